// Peel: a layer under a box face is cut free and curls away from the body about an axis, like a
// strip of bark (a cut deformer, Correa & Silver 2007, section 5 and Fig. 4).
//
// Axes. The layer lies under face `from` (axis e, side s_e = +-1); it curls about an axis parallel
// to d = `curl_axis` (d != e); the third axis a is the peel direction. In the box's local frame
// (box [-h, h]), with thickness t, radius R, angle Theta (radians) and hinge position x_a = hinge:
//   e'  = s_e x_e              (outward along e; the face `from` is e' = h_e)
//   e_c = h_e - t              (the cut plane, e' = e_c)
//   v   = e' - e_c             (height above the cut plane; the layer is 0 <= v <= t)
//   s   = x_a - hinge          (arc length from the hinge)
// The flap region is s >= 0 and v >= 0 (the layer beyond the hinge, extended to all of space
// beyond the box's faces). Outside it F is the identity. On it F is Blender's bend (bend.h) in
// the (s, v) plane with q_a = s, q_b = v, curvature k = 1 / R and limit length L = R Theta:
// theta = k clamp(s, 0, L) and, for 0 <= s <= L,
//   s' = (R - v) sin(theta)            (evaluated as s sinc(theta) - v sin(theta))
//   v' = R - (R - v) cos(theta)        (evaluated as s sinc(theta / 2) sin(theta / 2) + v
//   cos(theta))
// and beyond s > L the point at s = L plus (s - L)(cos Theta, sin Theta) (rigid); then
// x'_a = hinge + s', x'_e = s_e (e_c + v'), x'_d = x_d. The flap curls outward, away from the
// body: at 90 degrees the end of the curl, s = L = pi R / 2, v = 0, goes to s' = R, v' = R. At s =
// 0 F is the identity, so the flap stays attached along the hinge; F is discontinuous across the
// cut half-plane {v = 0, s > 0} only.
//
// Jacobian (analytic), in the (a, e) block (d is untouched), for s >= 0, v >= 0, s <= L:
//   dx'_a/dx_a = (1 - k v) cos(theta)   dx'_a/dx_e = -s_e sin(theta)
//   dx'_e/dx_a = s_e (1 - k v) sin(theta)   dx'_e/dx_e = cos(theta)
// beyond s > L the rotation by Theta (det 1); the identity outside the flap region. So
// det(dF/dp) = 1 - v / R on the curved part: F folds where v >= R, which lies in the layer when
// R <= t. That is allowed (measure_folds reports it); see Folds below.
//
// Inverse (analytic). With q = the bend's inverse of p' in the (s, v) plane (bend.h: theta =
// atan2(k s', 1 - k v') unwrapped into [Theta / 2 - pi, Theta / 2 + pi], the non-folded branch
// 1 - k v > 0, the identity for theta < 0 and the inverse rigid motion for theta > Theta):
//   (1) if p' lies in the flap region (s' >= 0, v' >= 0) or in the cut (A(p') > 0, below): return
//       q if -v(q) <= v(p'), else p'. Where v(q) >= 0 (q in the flap region) q is p''s
//       preimage: the flap's own points, and above or beside the flap (v(q) > t, |x_d| > h_d,
//       x_a > h_a) a point outside the box, so those read as empty space. Where v(q) < 0, p' is
//       in the cut, between the body's cut face v' = 0 and the flap's underside v(q) = 0, and
//       this is the continuation of the nearer cut face's inverse: the jump of D lies on the
//       bisector -v(q) = v(p') between the two cut faces, inside the cut, as Deformer's contract
//       asks, and D is continuous across both cut faces.
//   (2) otherwise return q if q lies in the flap's layer (s >= 0, 0 <= v <= t, |x_d| <= h_d,
//       x_a <= h_a): the flap's image outside the flap region, where past 90 degrees its rigid
//       part overhangs the body's side (s' < 0; in the air above the body when R > t, over the
//       body itself only where the flap folds: see Folds); else p' (the identity).
// So F(inverse(p')) = p' wherever A(p') <= 0, and inverse(F(p)) = p for p in the box with v < R
// off the cut plane, except where F(p) lies in a folded flap's image.
//
// Alpha (deformer.h): A(p') = min(v(p'), -v(q)): above the body's cut plane and beyond the flap's
// underside. -v(q) is continuous (the branches of q agree on their borders, the bisector between
// the identity and the rigid motion included) and 1-Lipschitz: |p' - centre| - R on the curved
// sector (centre of curvature (s, v) = (0, R)), the signed distance to the underside's rigid
// tangent line beyond it, -v' on the identity side. So A, a CSG intersection of two 1-Lipschitz
// functions, is 1-Lipschitz, and |A| is at most the distance to the boundary of the cut region
// {A > 0}, equal to it near the two cut faces. The cut region is the gap the flap vacated
// (s' >= 0: no preimage off the fold) and, past 90 degrees, the space beyond the underside of the
// flap's overhanging part (s' < 0), which lies at v' > 2 R, outside the box for R >= t / 2: its
// points' only preimage is themselves, outside the box, and counting them in the cut keeps the
// whole underside a cut face (the renderer's A = 0, eq. 6) with D continuous across it.
// has_cut() = true.
//
// identity_faces(): face -a (s <= 0 there: a hinge at -h_a gives s = 0, theta = 0), and the face
// opposite `from` (v = t - 2 h_e < 0); not +a, +-d or `from`.
//
// Folds. Where R <= t the part v >= R of the curved flap turns inside out; inverse() returns the
// non-folded branch, so that part's material is not rendered, and (2) lets the folded flap's
// image win over the body's where they overlap.
//
// Inputs:
//   half_extents  h, the box half sizes along x, y, z (object units), each > 0 and finite
//   curl_axis     d, the axis the flap curls about, != from.axis
//   from          the face whose layer peels (axis e, side +1 or -1)
//   angle_deg     Theta in degrees, in (0, 180]
//   thickness     t, the layer's thickness, in (0, 2 h_e) (object units)
//   radius        R, the curl's radius at the cut plane, > 0 and finite (object units)
//   hinge         where the flap starts along a, in [-h_a, h_a) (object units, from the centre)
// Output: the deformer; describe() reads e.g. "peel of +y layer 0.8 thick about z by 120°,
// radius 1.5, hinge 0".
// Throws raywarp::Error (the scene layer prefixes the file and field), h_e and h_a named by
// their axes:
//   "peel axis = y: must differ from the axis of `from` (+y)"
//   "peel from.side = 0: must be +1 or -1"
//   "peel angle_deg = X: must be in (0, 180]"
//   "peel thickness = X: must be in (0, 2 h_e = Y)"
//   "peel radius = X: must be > 0 and finite"
//   "peel hinge = X: must be in [-h_a, h_a) = [-Y, Y)"
// and on a non-positive or non-finite half extent.
//
// Known issues: forward(), jacobian(), inverse() and alpha() clamp each input coordinate to
// +-1e30 * max(h), and the radius to [1e-100, 1e100] * max(h) (a crease, or no curl at all: the
// difference is far below rounding), so that they are finite for every finite input while max(h)
// lies in [1e-200, 1e200]; beyond that radius F(inverse(p')) != p' (such points are never inside
// a baked texture). Past 90 degrees, where the flap overhangs the body's side (s' < 0), D jumps
// from the flap's preimage to the identity across the flap's faces there other than its
// underside (its face `from`, its +-d sides and its +a end), outside the cut: the validity w
// jumps with it, but a Lipschitz bound of D taken over cells outside the cut sees the jump.
// A flap of angle 1e-300 degrees and radius 1e-100 max(h) has L = 0 and inverts as the identity.
#pragma once
#include <Eigen/Core>
#include <memory>

#include "deformers/deformer.h"

namespace raywarp {

std::unique_ptr<Deformer> make_peel(const Eigen::Vector3d& half_extents, Axis curl_axis, Face from,
                                    double angle_deg, double thickness, double radius,
                                    double hinge);

}  // namespace raywarp
