// Detail: a small seeded vector noise displacement inside the box, the identity on its faces and
// beyond. Correa & Silver (2007, section 4) add deformation textures to add detail; in a box's
// list a "detail" entry is added that way (deformers/composed.h, make_composed): its inverse
// displacement is added to the list's, an approximation whose residual the bake measures.
//
// In the box's local frame (box [-h, h]), for scale s, wavelength lambda and seed:
//   F(p)  = p + s w(p) N(p)
//   N(p)  = sum_k b_k sin(c_k . p + phi_k),  k = 1..8,  |N| <= 1
//   w(p)  = prod_i g_i(p_i),  g_i(x) = S((h_i - |x|) / m_i) for |x| < h_i, else 0,
//           S(u) = u^2 (3 - 2 u) for u < 1, else 1 (a smoothstep), m_i = min(lambda, h_i)
// (w = 1 deeper than a wavelength inside the box, falling to 0 over the last wavelength before
// each face: a window such as prod (1 - (x_i / h_i)^2) would leave little of the noise where a
// mesh's surface usually lies, near the box's sides.)
// The eight plane waves are drawn from the seed (splitmix64, the same on every platform): a
// direction u_k and an amplitude direction a_k uniform on the sphere, a wavelength
// lambda / m_k with m_k uniform in [0.75, 1.25], a phase phi_k uniform in [0, 2 pi);
// c_k = (2 pi m_k / lambda) u_k and b_k = a_k / A, A = max over signs e_k in {-1, 1} of
// |sum_k e_k a_k|, so that |N| <= 1 (|sum_k a_k sin_k| is convex in the sines, so its largest
// value over [-1, 1]^8 is at a corner). s is thus a bound of the displacement |F(p) - p|.
// w is C^1 (S(0) = S'(0) = 0 at the faces, S'(1) = 0), so F is C^1 on all of space, and
// F = identity outside the open box: identity_faces() is all true.
//
// Jacobian (analytic): dF/dp = I + s (N grad(w)^T + w dN/dp), dN/dp = sum_k b_k cos(...) c_k^T,
// dw/dp_i = g_i'(p_i) prod_{j != i} g_j(p_j), g_i'(x) = -sign(x) 6 u (1 - u) / m_i.
//
// Lipschitz bound (stated; computed by detail_lipschitz()): |N grad(w)^T + w dN/dp| <=
//   L = G + L_N,  G = 1.5 |(1/m_x, 1/m_y, 1/m_z)|   (max |S'| = 1.5, and |N| <= 1, w <= 1),
//   L_N = max over signs e_k of || sum_k e_k b_k c_k^T ||_2  (convexity in the cosines, as for A).
// make_detail refuses s L > 1/2 (kMaxDetailContraction): then |dF/dp - I| <= 1/2, so F is a
// bijection of space with det(dF/dp) > 0 (it never folds) and its inverse is a contraction
// fixed point.
//
// Inverse (exact, to rounding): outside the open box F^-1(p') = p' (F is a bijection that is the
// identity there, so it maps the box onto itself). Inside, six fixed-point steps
// p <- p' - s w(p) N(p) (each at least halves the error), then Newton steps on F(p) = p' (at most
// 8, stopping at |F(p) - p'| <= 1e-14 |h|), then, should Newton not have got there (it does on
// every input we have tried), up to 100 more fixed-point steps; the iterate with the smallest
// |F(p) - p'| is returned. Bounded work, finite for every finite input.
//
// Inputs:
//   half_extents  h, each > 0 and finite
//   scale         s >= 0, finite, with s L <= 1/2 (the message gives the largest s)
//   wavelength    lambda > 0 and finite (object units), at most 1e6 |h|
//   seed          any integer in [0, 2^32)
// Output: the deformer; describe() reads e.g. "detail noise of scale 0.1, wavelength 1.5, seed 7".
// Throws raywarp::Error naming the parameter, its value and what is allowed, without a field
// prefix ("scale = 0.5: must be in [0, 0.112] for wavelength 1.5, seed 7 and this box: ..."); the
// scene layer prefixes the file and field.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <memory>

#include "deformers/deformer.h"

namespace raywarp {

// The most s L may be (see above).
constexpr double kMaxDetailContraction = 0.5;
constexpr int kDetailWaves = 8;

// L of the windowed noise for this box, wavelength and seed (scale-free: F - I is s times it).
double detail_lipschitz(const Eigen::Vector3d& half_extents, double wavelength, std::uint64_t seed);
// The largest accepted scale, kMaxDetailContraction / L.
double detail_max_scale(const Eigen::Vector3d& half_extents, double wavelength, std::uint64_t seed);

std::unique_ptr<Deformer> make_detail(const Eigen::Vector3d& half_extents, double scale,
                                      double wavelength, std::uint64_t seed);

// Whether d is a detail deformer (make_detail): make_composed adds it instead of composing it.
bool is_detail(const Deformer& d);

}  // namespace raywarp
