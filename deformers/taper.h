// Taper along a box axis, as Blender's Simple Deform modifier (mode Taper) with the box as its
// limits.
//
// Blender (source/blender/modifiers/intern/MOD_simpledeform.cc, simpleDeform_taper and
// SimpleDeformModifier_do) works in the frame of its origin, clamps the coordinate along the
// axis to the limits [l0, l1] (axis_limit, the clamped-off amount kept as dcut), divides the
// factor by the limit range (smd_factor = factor / (l1 - l0)), remaps the axis to z
// (axis_map_table) and maps (x, y, z) -> (x + x z smd_factor, y + y z smd_factor, z) + dcut.
// raywarp's box is the limits and the pivot (Blender's origin) is the box centre across the axis
// and its lower face -h_a along it, so l0 = 0 and l1 = L = 2 h_a: in Blender, an origin empty at
// the centre of the lower face and a mesh whose bounds along the axis are the box, limits [0, 1].
// (Blender floors the limit range at FLT_EPSILON; a box is never that thin, so raywarp does not.)
//
// In the box's local frame (box [-h, h]), for the taper axis a (the two others, u and v, are
// treated alike), factor f, pivot o = -h_a e_a, q = p - o (q_a = p_a + h_a, q_u = p_u, q_v = p_v)
// and the clamped axis coordinate z = clamp(q_a, 0, L):
//   s(z)  = 1 + f z / L                    (1 on face -a, 1 + f on face +a)
//   q'_u  = s(z) q_u,  q'_v = s(z) q_v,  q'_a = q_a,   F(p) = o + q'.
// Each slice q_a = const is scaled about the axis by s; beyond the limits the scale stays at its
// end value (1 below face -a: the identity; 1 + f above face +a: a uniform scale across the
// axis), as Blender's clamp does. f is Blender's "factor": the relative change of the width over
// the limits (f = -0.5 halves the +a face, f = 1 doubles it).
//
// Jacobian (analytic). For 0 <= q_a <= L (the faces included):
//   dq'_u/dq_u = dq'_v/dq_v = s,  dq'_a/dq_a = 1,
//   dq'_u/dq_a = (f / L) q_u,     dq'_v/dq_a = (f / L) q_v,   all other entries 0;
// outside, the (f / L) column vanishes and s is its end value: diag(1, 1, 1) for q_a < 0 and
// (1 + f) on u and v for q_a > L. det(dF/dp) = s^2 > 0 for every accepted f. F is continuous
// across the limit planes, its Jacobian jumps there (as Blender's).
//
// Inverse (exact). The taper keeps the axis coordinate, q'_a = q_a, so z = clamp(q'_a, 0, L)
// and F^-1: q_a = q'_a, q_u = q'_u / s(z), q_v = q'_v / s(z). For f > -1, s >= min(1, 1 + f) > 0
// on all of space and F is a bijection of space with this inverse; inverse(F(p)) = p and
// F(inverse(p')) = p' everywhere (to rounding; see Known issues for huge inputs). For f <= -1 the
// scale would reach 0 at the slice z = -L / f (face +a at f = -1, inside the box below -1): that
// slice collapses onto the axis (no preimage off the axis, the inverse unbounded next to it) and
// the slices past it come out turned by 180 degrees about the axis (s < 0). make_taper refuses
// those factors, so there is no non-invertible case and no branch to choose.
//
// identity_faces(): face -a always (s = 1, q' = q); the other five iff f == 0.
//
// Inputs:
//   half_extents  h, the box half sizes along x, y, z (object units), each > 0 and finite
//   axis          the taper axis a
//   factor        f, in (-1, 10]: above -1 so that the +a face keeps a positive width (at -1 it
//                 shrinks to a point, below it the taper pinches inside the box); at most 10,
//                 the top of Blender's slider range (-10, 10), where the +a face is already 11x
//                 as wide and F(box), over which the deformation texture is baked, 11x the box
// Output: the deformer; describe() reads e.g. "taper along y by 0.8".
// Throws raywarp::Error "taper factor = X: must be in (-1, 10]" otherwise (the scene layer
// prefixes the file and field), and on a non-positive or non-finite half extent.
//
// Known issues: forward(), jacobian() and inverse() clamp each input coordinate to
// +-min(1e30 * max(h), 1e300) before evaluating and each result to +-DBL_MAX (the inverse next
// to f = -1 divides by s ~ 1e-16), so that they are finite for every finite input; beyond that
// radius F(inverse(p')) != p' and the Jacobian is that of the clamped point (such points are
// never inside a baked texture). Boxes with a half extent over 1e300 are not supported.
#pragma once
#include <Eigen/Core>
#include <memory>

#include "deformers/deformer.h"

namespace raywarp {

std::unique_ptr<Deformer> make_taper(const Eigen::Vector3d& half_extents, Axis axis, double factor);

}  // namespace raywarp
