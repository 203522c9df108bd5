// Composition of deformers in one box: F = F_n o ... o F_2 o F_1 (F_1 applied first), as a scene
// box's "deformer": [first, second, ...] list asks.
//
// Each F_i is defined on all of space, not only its box: twist and bend continue rigidly beyond
// their limits along their axis (as Blender's Simple Deform does), control points as their
// header states. So F_2 sees the points F_1 moved out of the box (a twist's corners) and maps
// them by its own continuation.
//
//   forward:   F(p)     = F_n(... F_1(p))
//   jacobian:  dF/dp    = J_n(p_{n-1}) ... J_2(p_1) J_1(p),  p_i = F_i(... F_1(p))  (chain rule)
//   inverse:   F^-1(p') = F_1^-1(... F_n^-1(p'))   (the inverse of F_2 o F_1 is F_1^-1 o F_2^-1)
// identity_faces(): a face is the identity under F when it is under every F_i (F_1 leaves its
// points in place, so F_2 sees the same face), a sufficient condition; where it does not hold the
// pipeline reports a torn face.
// Where some F_i folds, F folds (det dF/dp is the product of the dets); measure_folds sees it.
//
// Cuts (peel, incision, box_cut) do not compose: their alpha map is a distance field in the
// frame of their own deformed box, which a later deformer would distort. make_composed rejects
// them, and a list of one deformer is that deformer itself.
//
// Added detail (Correa & Silver 2007, section 4: "deformation textures can be added to add
// detail"). Detail deformers (deformers/detail.h) at the end of a list, F_d1 ... F_dm after the
// rest R = F_k o ... o F_1 (possibly none), are added, not composed: the baked texture is the sum
// of the inverse displacements,
//   D(p') = D_R(p') + sum_j D_dj(p'),   D_R(p') = R^-1(p') - p',  D_dj(p') = F_dj^-1(p') - p',
// while the list means the composition F = F_dm o ... o F_d1 o R (detail applied after the
// rest). make_composed then returns an AddedDetail whose forward() and jacobian() are that exact
// composition and whose inverse() is the sum p' + D(p'), so that measure_inverse_residual's
// |F(p' + D(p')) - p'| measures what adding instead of composing costs; exact_inverse() is the
// exact composed inverse R^-1(F_d1^-1(... F_dm^-1(p'))). To first order the two differ by
// (dR^-1/dp' - I) D_d: a twist by 90 degrees turns the detail's displacement by up to 90
// degrees at its upper face, so the residual is of the order of the detail itself there (and 0
// where R is a translation). A detail entry before a deformer that is not one is refused.
#pragma once
#include <memory>
#include <vector>

#include "deformers/deformer.h"

namespace raywarp {

// The deformer of a list that ends in detail entries (above). inverse() is the sum of the inverse
// displacements, an approximation: F(inverse(p')) != p' in general.
class AddedDetail : public Deformer {
 public:
  // F^-1 exactly, the composed inverse.
  virtual Eigen::Vector3d exact_inverse(const Eigen::Vector3d& p_def) const = 0;
  // The parts before the detail (the rest R, maybe none) and the detail entries.
  virtual size_t rest_count() const = 0;
  virtual size_t detail_count() const = 0;
};

// Throws raywarp::Error when `parts` is empty or holds a null pointer or a cut deformer, or a
// detail before a deformer that is not one (naming its index, "[1]", and what it is).
std::unique_ptr<Deformer> make_composed(std::vector<std::shared_ptr<const Deformer>> parts);

}  // namespace raywarp
