// Bend about a box axis, as Blender's Simple Deform modifier (mode Bend) with the box as its
// limits.
//
// Axes. The bend axis d is the axis the box curls about; the limit axis a runs along the box and
// the bend direction b is where +a curls to:
//   d = x: a = z, b = y      d = y: a = z, b = x      d = z: a = x, b = y
// (Blender's simpleDeform_bend). In the box's local frame (box [-h, h]), with angle phi
// (radians), L = 2 h_a, k = phi / L (curvature; radius R = 1 / k), pivot o = box centre on d and b
// and -h_a on a, q = p - o and theta = k q_a:
//   q'_b = (q_b - R) cos(theta) + R = 2 sin^2(theta / 2) / k + q_b cos(theta)
//   q'_a = -(q_b - R) sin(theta)    = sin(theta) / k        - q_b sin(theta)
//   q'_d = q_d,  F(p) = o + q'.
// The right-hand forms are the ones evaluated: sin(theta) / k = q_a sinc(theta) and
// 2 sin^2(theta / 2) / k = q_a sinc(theta / 2) sin(theta / 2) never divide by k, so F is smooth
// in phi through phi = 0 (no threshold: Blender switches to the identity below |k| = 1e-6, this
// does not, and F(phi -> 0) -> identity). Positive phi curls +a towards +b: the point q = L e_a
// goes to (2L / pi)(e_a + e_b) at phi = 90 degrees.
// Beyond the limits F continues rigidly, as in Blender: for q_a < 0 it is the identity; for
// q_a > L it maps the point with q_a = L and adds the overshoot (q_a - L) along the tangent
// cos(phi) e_a + sin(phi) e_b (dq'/dq_a at q_b = 0, theta = phi).
//
// Jacobian (analytic), for 0 <= q_a <= L, in the (a, b) block (d is untouched):
//   dq'_a/dq_a = (1 - k q_b) cos(theta)   dq'_a/dq_b = -sin(theta)
//   dq'_b/dq_a = (1 - k q_b) sin(theta)   dq'_b/dq_b =  cos(theta)
// so det(dF/dp) = 1 - k q_b: F folds where k q_b >= 1, i.e. on the far side of the centre of
// curvature (q_b >= R for phi > 0), which lies in the box when |R| <= h_b. Beyond the limits the
// block is a rotation by theta = 0 or phi (det 1).
//
// Inverse (analytic). In the (a, b) plane F maps lines q_a = const to rays from the centre of
// curvature (0, R) and lines q_b = const to circles about it. With u = k q'_a, w = 1 - k q'_b and
// sqrt(S) = hypot(u, w) = |1 - k q_b|:
//   theta = atan2(u, w), unwrapped into [phi / 2 - pi, phi / 2 + pi] (so bends past 180 degrees
//           invert right), and q_a = theta / k;
//   q_b = (2 q'_b - k (q'_a^2 + q'_b^2)) / (1 + sqrt(S))       (= (1 - sqrt(S)) / k, no division
//                                                                 by k: exact as phi -> 0)
// Where F folds a point has two preimages; inverse() returns the one with 1 - k q_b > 0 (the
// non-folded side, det > 0). A theta outside [0, phi] is the rigid continuation: on the side of
// theta = 0 (theta phi < 0) the identity, on the side of theta = phi the inverse of the rigid
// motion beyond q_a = L. k == 0 exactly (phi = 0) is the identity. F(inverse(p')) = p' for every
// p' (each branch inverts F on its region exactly; see Known issues for huge p'), but inverse(F(p))
// = p only where 1 - k q_b > 0 and the rigid continuations do not overlap the image (they do past
// 180 degrees).
//
// identity_faces(): face -a (q_a = 0) always; the others iff phi == 0.
//
// Inputs:
//   half_extents  h, the box half sizes along x, y, z (object units), each > 0 and finite
//   axis          the bend axis d
//   angle_deg     phi in degrees, in (-360, 360)
// Output: the deformer; describe() reads e.g. "bend about z by 90°".
// Throws raywarp::Error "bend angle_deg = X: must be in (-360, 360)" otherwise (the scene layer
// prefixes the file and field), and on a non-positive or non-finite half extent.
//
// Known issues: inverse() clamps each input coordinate to +-1e30 * max(h) before evaluating, so
// that it is finite for every finite input; beyond that radius F(inverse(p')) != p' (such points
// are never inside a baked texture). The centre of curvature itself (S = 0, the image of the whole
// fold line q_b = R) inverts to theta = phi / 2.
#pragma once
#include <Eigen/Core>
#include <memory>

#include "deformers/deformer.h"

namespace raywarp {

std::unique_ptr<Deformer> make_bend(const Eigen::Vector3d& half_extents, Axis axis,
                                    double angle_deg);

}  // namespace raywarp
