// Twist about a box axis, as Blender's Simple Deform modifier (mode Twist) with the box as its
// limits.
//
// In the box's local frame (box [-h, h], centre c = 0), for the twist axis a, angle phi (radians)
// and L = 2 h_a:
//   t(p)     = (p_a + h_a) / L                    (0 on face -a, 1 on face +a)
//   theta(p) = phi * clamp(t, 0, 1)
//   F(p)     = c + R_a(theta) (p - c)
// with R_a(theta) the right-handed rotation about +a (x -> y about z, y -> z about x, z -> x about
// y). Beyond the box along a the twist continues rigidly (theta clamped), as in Blender.
//
// Jacobian (analytic): dF/dp = R_a(theta) + (dR_a/dtheta (p - c)) grad(theta)^T, with
// grad(theta) = (phi / L) e_a for t in [0, 1] and 0 outside; det(dF/dp) = 1 everywhere (the
// added term lies in the plane orthogonal to a while grad(theta) is along a), so a twist never
// folds.
//
// Inverse (exact): a twist keeps the axis coordinate, p'_a = p_a, so theta = theta(p') and
// F^-1(p') = c + R_a(-theta) (p' - c). F is a bijection of space.
//
// identity_faces(): face -a always (theta = 0); face +a iff phi is a multiple of 2 pi (to 1e-9
// relative); the four side faces iff phi == 0.
//
// Inputs:
//   half_extents  h, the box half sizes along x, y, z (object units), each > 0 and finite
//   axis          the twist axis a
//   angle_deg     phi in degrees, any finite value (several turns are fine)
// Output: the deformer; describe() reads e.g. "twist about y by 360°".
// Throws raywarp::Error on a non-positive or non-finite half extent or a non-finite angle.
//
// Known issues: inverse() clamps each input coordinate to +-1e30 * max(h) before evaluating, so
// that it is finite for every finite input; beyond that radius F(inverse(p')) != p' (such points
// are never inside a baked texture).
#pragma once
#include <Eigen/Core>
#include <memory>

#include "deformers/deformer.h"

namespace raywarp {

std::unique_ptr<Deformer> make_twist(const Eigen::Vector3d& half_extents, Axis axis,
                                     double angle_deg);

}  // namespace raywarp
