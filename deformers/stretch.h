// Stretch along a box axis, as Blender's Simple Deform modifier (mode Stretch) with the box as
// its limits.
//
// Blender (source/blender/modifiers/intern/MOD_simpledeform.cc, simpleDeform_stretch and
// SimpleDeformModifier_do) works in the frame of its origin, clamps the coordinate along the
// axis to the limits [l0, l1] (axis_limit, the clamped-off amount kept as dcut), divides the
// factor by the limit range (k = smd_factor = factor / (l1 - l0)), remaps the axis to z
// (axis_map_table) and maps
//   (x, y, z) -> (x s, y s, z (1 + k)) + dcut,   s = z z k - k + 1.
// raywarp's box is the limits and the pivot (Blender's origin) is the box centre across the axis
// and its lower face -h_a along it, so l0 = 0 and l1 = L = 2 h_a: in Blender, an origin empty at
// the centre of the lower face and a mesh whose bounds along the axis are the box, limits [0, 1].
// (Blender floors the limit range at FLT_EPSILON; a box is never that thin, so raywarp does not.)
//
// Blender's quirk, kept: z is in object units while k is divided by L once, so z^2 k is not
// scale-free. The shape depends on the size of the box, not only on its proportions: the
// cross-section scale runs from 1 - f / L on face -a to 1 + f (L - 1 / L) on face +a (for the
// bunny's 10.1-unit box and f = 0.05, from 0.995 to 1.5). The formula was made for Blender's
// default: the origin at the centre of a 2-unit cube, where s = 1 at both ends and 1 - f / 2 in
// the middle; with the pivot on the lower face the stretch is neither symmetric nor the identity
// on any face.
//
// In the box's local frame (box [-h, h]), for the stretch axis a (the two others, u and v, are
// treated alike), factor f, k = f / L, pivot o = -h_a e_a, q = p - o (q_a = p_a + h_a,
// q_u = p_u, q_v = p_v) and the clamped axis coordinate z = clamp(q_a, 0, L):
//   s(z)  = 1 + k (z^2 - 1)
//   q'_u  = s(z) q_u,  q'_v = s(z) q_v,
//   q'_a  = z (1 + k) + (q_a - z) = q_a + k z,   F(p) = o + q'.
// Inside the limits the axis is scaled by 1 + k (the box grows by f object units along a: face
// +a moves to q'_a = L + f); beyond them F continues as Blender's clamp makes it: below face -a
// a uniform scale across the axis by 1 - k with q'_a = q_a, above face +a a scale by
// 1 + k (L^2 - 1) across and a shift by f along the axis.
//
// Jacobian (analytic). For 0 <= q_a <= L (the faces included):
//   dq'_u/dq_u = dq'_v/dq_v = s,  dq'_a/dq_a = 1 + k,
//   dq'_u/dq_a = 2 k q_a q_u,     dq'_v/dq_a = 2 k q_a q_v,   all other entries 0,
// det = s^2 (1 + k); outside, diag(s, s, 1) with s at its end value, det = s^2. F is continuous
// across the limit planes, its Jacobian jumps there (as Blender's).
//
// Inverse (exact). q'_a = q_a + k z is increasing in q_a when 1 + k > 0, and z is recovered from
// q'_a alone: z = clamp(q'_a / (1 + k), 0, L) (q'_a < 0 below the limits, q'_a > L + f above).
// Then q_a = q'_a - k z and q_u = q'_u / s(z), q_v = q'_v / s(z). For every accepted f, s > 0
// and 1 + k > 0 on all of space, so F is a bijection of space with this inverse;
// inverse(F(p)) = p and F(inverse(p')) = p' everywhere (to rounding; see Known issues for huge
// inputs). Past the ends of the range the scale would reach 0 at a slice of the box (a plane
// collapsing onto the axis, no preimage off it, the slices past it turned by 180 degrees), or at
// f <= -L the axis itself would fold (1 + k <= 0): make_stretch refuses those factors, so there
// is no non-invertible case and no branch to choose.
//
// identity_faces(): all six iff f == 0, none otherwise (s(0) = 1 - f / L != 1 on face -a).
//
// Inputs:
//   half_extents  h, the box half sizes along x, y, z (object units), each > 0 and finite
//   axis          the stretch axis a
//   factor        f, finite, with s > 0 at both ends (s is monotonic in z^2, so its least value
//                 over [0, L] is at an end) and 1 + k > 0, which for L = 2 h_a is the open range
//                   lo < f < L,  lo = -L if L <= sqrt(2), else -L / (L^2 - 1)
//                 (f < L keeps s(0) = 1 - f / L > 0, lo keeps 1 + k and s(L) > 0), and at most
//                 10 in size, Blender's slider range (-10, 10): for the bunny's 10.1-unit box
//                 the range is (-0.09999, 10], and f = 10 widens face +a 101-fold
// Output: the deformer; describe() reads e.g. "stretch along y by 0.5".
// Throws raywarp::Error "stretch factor = X: must be in (LO, HI) for a box L long along a ..."
// otherwise (the scene layer prefixes the file and field), and on a non-positive or non-finite
// half extent.
//
// Known issues: forward(), jacobian() and inverse() clamp each input coordinate to
// +-min(1e30 * max(h), 1e300) before evaluating and each result to +-DBL_MAX (s reaches 10 L on
// face +a and the inverse divides by s, which may be ~1e-16 next to the ends of the range), so
// that they are finite for every finite input; beyond that radius F(inverse(p')) != p' and the
// Jacobian is that of the clamped point (such points are never inside a baked texture). Boxes
// with a half extent over 1e300 are not supported.
#pragma once
#include <Eigen/Core>
#include <memory>

#include "deformers/deformer.h"

namespace raywarp {

std::unique_ptr<Deformer> make_stretch(const Eigen::Vector3d& half_extents, Axis axis,
                                       double factor);

}  // namespace raywarp
