// Groove: a round cut about one of the box's axes through its centre, a ring of material removed
// all around (a groove around a limb); moves nothing (Correa & Silver 2007, section 5's removal of
// parts, with a region that follows a cylinder: section 3.2's round cuts).
//
// With a the axis and (u, v) the next two axes cyclically (a = y: u = z, v = x), r the distance
// from the axis, r = sqrt(p_u^2 + p_v^2), the removed region C, in the box's local frame, is
//   C = { r >= radius and |p_a| <= width / 2 }:
// everything farther than `radius` from the axis within a slab of `width` about the box centre.
// alpha(p) = min(r - radius, width / 2 - |p_a|): the minimum of two 1-Lipschitz signed distances
// (r is 1-Lipschitz), the CSG intersection as in box_cut.h: 1-Lipschitz, exact near each face,
// a lower bound of the distance outside (deformer.h's contract), its gradient the face normal.
// alpha depends on r and p_a only: stored over (angle, radius, height) (library/cylindrical.h) a
// few texels of angle hold it.
//
// identity_faces(): all six; moves_nothing() is true (the caps the removed ring leaves on the
// box faces come from the distance grid, as for a box cut).
//
// Inputs: half_extents > 0 and finite; axis; radius > 0 and finite (object units); width in
// (0, 2 h_a] (object units). Throws raywarp::Error naming the bad input otherwise:
//   "groove radius = X: must be > 0 and finite"
//   "groove width = X: must be in (0, 2 h_y = Y]"
#pragma once
#include <Eigen/Core>
#include <memory>

#include "deformers/deformer.h"

namespace raywarp {

std::unique_ptr<Deformer> make_groove(const Eigen::Vector3d& half_extents, Axis axis, double radius,
                                      double width);

}  // namespace raywarp
