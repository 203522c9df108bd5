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
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "base/interrupt.h"

namespace raywarp {

enum class Axis { X = 0, Y = 1, Z = 2 };
char axis_name(Axis a);

// A face of the box: the axis it is normal to and its side (+1 or -1), written "+y", "-x".
struct Face {
  Axis axis = Axis::Y;
  int side = 1;
};
std::string face_name(Face f);
// Face `index` of 0..5 in the order -x, +x, -y, +y, -z, +z (identity_faces, pinned faces).
Face face_of(int index);

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
  // Where the mesh crosses a face that is not, the surface tears (docs/conventions.md#seams).
  virtual std::array<bool, 6> identity_faces() const = 0;

  // Cuts (Correa & Silver 2007, section 5). A cut deformer separates material along a surface
  // (peel, incision) or removes it (box_cut). Its alpha map A(p'), in the deformed frame, is > 0
  // inside the cut region (the gap the cut opens, or the removed part) and <= 0 elsewhere, and
  // |A(p')| is a lower bound of the distance from p' to the boundary of the cut region, equal to
  // it (or to it divided by a stated constant) near that boundary: A is a signed distance field
  // of the cut geometry, so it doubles as the skipping distance (section 6.2) and its gradient
  // is the cut face's normal (eq. 6). A is 1-Lipschitz.
  // Inside the cut region p' has no preimage; there inverse() returns the continuation of the
  // inverse of the nearer side, so the baked D stays smooth up to the middle of the gap (its
  // jump lies where A > 0, masked by the cut). F(inverse(p')) = p' holds outside the cut.
  virtual bool has_cut() const { return false; }
  virtual double alpha(const Eigen::Vector3d& /*p_def*/) const {
    return -std::numeric_limits<double>::infinity();
  }
  // True when F is the identity on all of space (a box cut removes material and moves none), so
  // points outside the box are their own preimage and the ray caster may read the distance grid
  // beyond the box faces (where a removed part leaves a cap).
  virtual bool moves_nothing() const { return false; }
  // Grows `bounds` to hold F of the parts of the box that F may carry beyond the images of the
  // box faces (a simulated body's nodes); deformed_bounds calls it. Nothing by default.
  virtual void extend_image_bounds(Eigen::AlignedBox3d& /*bounds*/) const {}
};

// Each entry of a vector or matrix clamped to +-DBL_MAX: a result that overflowed to +-inf comes
// back finite (a NaN stays NaN).
template <typename M>
M clamp_finite(const M& m) {
  constexpr double big = std::numeric_limits<double>::max();
  return m.cwiseMax(-big).cwiseMin(big);
}

// Shortest decimal text that reads back as x ("360", "1e-06"), for messages.
std::string shortest_text(double x);
// "[x, y, z]" in shortest_text's form.
std::string vector_text(const Eigen::Vector3d& v);
// sin(y) / y, 1 at 0: the chord of an arc over its length (the bend's and the peel's arcs).
double sinc(double y);
// Throws Error "<what> half_extents[i] = v: must be > 0 and finite" for a bad box.
void check_half_extents(const char* what, const Eigen::Vector3d& half_extents);

// Volume of the box where det(dF/dp) <= 0, estimated on a regular lattice of samples per axis.
struct FoldReport {
  double folded_volume = 0.0;  // object units cubed
  double box_volume = 0.0;
  bool folds() const { return folded_volume > 0.0; }
};
FoldReport measure_folds(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                         int samples_per_axis = 64, Interrupter* interrupter = nullptr);

// Bounds of F(box), from F on a fine lattice over the box faces, padded by `pad` (object units).
Eigen::AlignedBox3d deformed_bounds(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    double pad = 0.0);

}  // namespace raywarp
