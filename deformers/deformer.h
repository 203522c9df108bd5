// Deformers: closed-form forward maps over a box, with analytic Jacobians and inverses, and the
// bake of the inverse displacement into a DeformationTexture.
//
// Every map works in the box's local frame (origin at the box centre, object units), where the
// box is [-h, h] with h = half_extents. Axis conventions follow Blender's Simple Deform modifier
// (see twist.h and bend.h), so artists can check a result against Blender.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <functional>
#include <memory>
#include <string>

#include "library/textures.h"

namespace raywarp {

enum class Axis { X = 0, Y = 1, Z = 2 };
char axis_name(Axis a);

class Deformer {
 public:
  virtual ~Deformer() = default;
  virtual std::string describe() const = 0;
  // Forward map F: undeformed -> deformed.
  virtual Eigen::Vector3d forward(const Eigen::Vector3d& p) const = 0;
  // dF/dp, analytic.
  virtual Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const = 0;
  // Analytic inverse: a p with F(p) = p_def. Where F folds (several preimages) it returns the
  // branch the deformer documents. Finite for every finite input.
  virtual Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const = 0;
  // Whether F is the identity on each face of the box, in the order -x, +x, -y, +y, -z, +z.
  // Where the mesh crosses a face that is not, the surface tears (DESIGN "Seams").
  virtual std::array<bool, 6> identity_faces() const = 0;
};

// Shortest decimal text that reads back as x ("360", "1e-06"), for messages.
std::string shortest_text(double x);
// Throws Error "<what> half_extents[i] = v: must be > 0 and finite" for a bad box.
void check_half_extents(const char* what, const Eigen::Vector3d& half_extents);

// Volume of the box where det(dF/dp) <= 0, estimated on a regular lattice of samples per axis.
struct FoldReport {
  double folded_volume = 0.0;  // object units cubed
  double box_volume = 0.0;
  bool folds() const { return folded_volume > 0.0; }
};
FoldReport measure_folds(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                         int samples_per_axis = 64);

// Bounds of F(box), from F on a fine lattice over the box faces, padded by `pad` (object units).
Eigen::AlignedBox3d deformed_bounds(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    double pad = 0.0);

// Bakes D(p') = F^-1(p') - p' at the texel centres of a grid over the bounds of F(box) (padded by
// one texel), `resolution` texels along its longest side. w = 1 where F^-1(p') lies in the box.
DeformationTexture bake_deformation(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    int resolution);

}  // namespace raywarp
