// Incision: a straight knife cut through a box face whose two sides are pushed apart (a cut
// deformer, Correa & Silver 2007, section 5).
//
// Axes. The cut is a piece of the plane x_n = 0 (n = `normal`); it enters through face `from`
// (axis e != n, side s_e = +-1) and reaches `depth` into the box; l is the third axis, along the
// cut's length. In the box's local frame (box [-h, h]), with u = s_e x_e (so the entry face is
// u = h_e) and the cut's end at u_end = h_e - depth:
//   ramp     r(u)   = clamp((u - u_end) / depth, 0, 1)     0 at the cut's end, 1 at the entry face
//   profile  m(x_l) = 1 - (min(|x_l|, h_l) / h_l)^2       0 at the +-l faces, so they do not tear
//   opening  c(p)   = (opening / 2) r(u) m(x_l)          depends only on coordinates F keeps
//   F(p)_n   = x_n + sgn(x_n) c (1 - min(|x_n| / h_n, 1)),  sgn(0) = +1;  other coordinates kept.
// Each side 0 <= +-x_n <= h_n is squeezed affinely onto c <= +-x'_n <= h_n (towards its side face,
// which stays fixed), so the slit opens into the gap |x'_n| < c: an open lens across l, widest
// (c = opening / 2) at the entry face's centre line, closing at the cut's end and at the +-l faces.
// Beyond the box the same formula holds with |x_n| / h_n, r and m clamped as written: the
// identity beyond the +-n faces (|x_n| >= h_n), the +-l faces (m = 0) and the face opposite
// `from` (r = 0); beyond the entry face (u > h_e, r = 1) the slit goes on opening outward with
// c = (opening / 2) m(x_l), so there is a gap beyond that face too (it is where the surface tears).
// F is discontinuous across the cut x_n = 0 only (it jumps by 2c there).
//
// Jacobian (analytic), for |x_n| < h_n, with g = sgn(x_n) (1 - |x_n| / h_n):
//   dx'_n/dx_n = 1 - c / h_n
//   dx'_n/dx_e = g (opening / 2) m s_e / depth     for u_end < u < h_e, else 0
//   dx'_n/dx_l = -g (opening / 2) r 2 x_l / h_l^2  for |x_l| < h_l, else 0
// and the identity elsewhere (at the kinks u = u_end, u = h_e, |x_l| = h_l it takes the side
// where the derivative is 0). det(dF/dp) = 1 - c / h_n >= 1 - opening / (2 h_n) > 0: an incision
// never folds.
//
// Inverse (exact). F keeps x_e and x_l, so c' = c(p') = c(p). For |x'_n| >= h_n it is the identity;
// otherwise x_n = (x'_n - c') / (1 - c' / h_n) if x'_n >= 0, (x'_n + c') / (1 - c' / h_n) if not.
// F(inverse(p')) = p' for every p' outside the gap (|x'_n| >= c'), and inverse(F(p)) = p for every
// p (x_n = 0 goes to the + side). In the gap, which has no preimage, this is the continuation of
// the nearer side's inverse, so D is smooth up to the gap's mid-plane x'_n = 0, where it jumps
// (by 2 c' / (1 - c' / h_n)) inside the cut region, as Deformer's contract asks.
//
// Alpha (deformer.h): A(p') = (c(p') - |x'_n|) / Lip with
//   Lip = sqrt(1 + (opening / 2 / depth)^2 + (opening / h_l)^2),
// a global bound of |grad(c - |x_n|)| (|dc/du| <= opening / (2 depth), |dc/dx_l| <= opening / h_l).
// So A is 1-Lipschitz, A > 0 exactly on the gap, and |A| is at most the distance to the gap's
// boundary (where A = 0), and at least that distance / Lip wherever c(p') > 0 (the boundary lies
// along n within |c - |x'_n||). has_cut() = true.
//
// identity_faces(): the +-n faces (|x_n| = h_n), the +-l faces (m = 0) and the face opposite
// `from` (r(-h_e) = 0 since depth <= 2 h_e); not the entry face `from`.
//
// Inputs:
//   half_extents  h, the box half sizes along x, y, z (object units), each > 0 and finite
//   normal        n, the axis normal to the cut plane
//   from          the entry face (axis e != n, side +1 or -1)
//   depth         how far the cut reaches into the box from `from`, in (0, 2 h_e] (object units)
//   opening       the gap's width at the entry face's centre line, in (0, 2 h_n) (object units)
// Output: the deformer; describe() reads e.g. "incision normal x from +y, depth 3, opening 1.2".
// Throws raywarp::Error (the scene layer prefixes the file and field):
//   "incision normal = y: must differ from the axis of `from` (+y)"
//   "incision from.side = 0: must be +1 or -1"
//   "incision depth = X: must be in (0, 2 h_e = Y]"      (h_e named by its axis: "2 h_y = 4")
//   "incision opening = X: must be in (0, 2 h_n = Y)"
// and on a non-positive or non-finite half extent.
//
// Known issues: as opening approaches 2 h_n the squeezed sides get thin and the inverse divides by
// 1 - c / h_n -> 0 (conditioning 1 / (1 - opening / (2 h_n))). A baked D interpolates across its
// jump on the gap's mid-plane; that is inside the cut (A > 0), but a gap narrower than two texels
// (near the cut's end and the +-l faces) leaves the jump's blur just outside it.
#pragma once
#include <Eigen/Core>
#include <memory>

#include "deformers/deformer.h"

namespace raywarp {

std::unique_ptr<Deformer> make_incision(const Eigen::Vector3d& half_extents, Axis normal, Face from,
                                        double depth, double opening);

}  // namespace raywarp
