// Control-point deformer: a smooth displacement field through user-placed source -> target pairs
// (hand-made deformations: a user moves mesh points), interpolated with radial basis functions.
//
// In the box's local frame (box [-h, h], object units), with n pairs (s_i, t_i), d_i = t_i - s_i
// and L = 2 |h| (the box diagonal), inside the box
//   F(p) = p + u(p),   u(p) = m(p) v(p).
// m is the pin mask, a product over the axes a with a pinned face of
//   m_a = (1 + p_a / h_a) / 2   (face -a pinned)    m_a = (1 - p_a / h_a) / 2   (face +a pinned)
//   m_a = 1 - (p_a / h_a)^2     (both pinned)
// (m = 1 with no pinned face), so m = 0, hence u = 0 and F = identity, on the pinned faces
// exactly, and 0 < m <= 1 elsewhere in the box. v is the RBF interpolant of v(s_i) = d_i / m(s_i)
// over the pairs with m(s_i) > 0 (a source on a pinned face must have t_i = s_i, and F(s_i) = t_i
// holds there through m = 0), so F(s_i) = t_i for every pair, to rounding:
//  - radius == 0 (global): polyharmonic spline phi(r) = (r / L)^3 plus an affine part,
//      v(p) = sum_j w_j phi(|p - s_j|) + c_0 + C E^T (p - mu) / L,
//    with mu the mean of the sources and E the k <= 3 principal directions along which the
//    sources spread by at least 1e-3 L (RMS): all three for 4 or more sources in general
//    position, fewer for 1 to 3 sources or coplanar/collinear ones, so the system stays
//    non-singular (along a dropped direction v is constant instead of affine). The saddle-point
//    system
//      [A P; P^T 0] [w; c] = [v_i; 0],  A_ij = phi(|s_i - s_j|),  P_i = [1, E^T (s_i - mu) / L]
//    is solved by LU with partial pivoting (Eigen) plus one step of iterative refinement. Being
//    affine-exact, the global spline reproduces an affine map (rigid motion, scale, shear) exactly
//    when no face is pinned, and is the interpolant of least bending energy.
//  - radius R > 0 (local): Wendland's C2 function phi(r) = (1 - r/R)^4 (4 r/R + 1) for r < R, 0
//    beyond, with no polynomial part: v(p) = sum_j w_j phi(|p - s_j|), so a point farther than R
//    from every source does not move. A is symmetric positive definite (Wendland's phi is positive
//    definite in 3D), solved by LDLT plus one step of refinement. Without a polynomial part it
//    reproduces no global field exactly (a twist sampled on a 6^3 lattice: 11 % of L off with
//    R = 2 lattice spacings, against 0.25 % for the global spline): it is for local edits.
// Either system is checked: its reciprocal condition number (Eigen's estimate) must be at least
// 1e-15 and the solved weights must reproduce the right-hand side to 1e-9 of its largest entry,
// else make_control_points throws naming the closest pair of sources (near-coincident sources
// with different displacements are the usual cause: the global system's condition grows as the
// inverse cube of their distance: two sources 2e-6 L apart that move apart can already fail).
//
// Beyond the box F continues by its first-order Taylor expansion at the nearest box point
// q = clamp(p, -h, h):
//   F(p) = F(q) + dF/dp(q) (p - q) = p + u(q) + J_u(q) (p - q),
// so F and dF/dp are continuous across the faces, edges and corners (F is C1 everywhere, C2 inside
// the box) and finite for every finite p (p is first clamped to +-1e30 L). Just beyond a face
// dF/dp is close to its value on the face, so F stays locally invertible there where it is on the
// face, and the texels just outside F(box), which trilinear interpolation blends with those inside,
// get a D that continues smoothly. Beyond a pinned face this is not the identity (u = 0
// on the face but its normal derivative is not): only the face itself is held.
//
// Jacobian (analytic): inside, dF/dp = I + J_u with J_u = v grad(m)^T + m J_v,
// J_v = sum_j w_j g(r_j) (p - s_j)^T + C E^T / L, g = phi'(r) / r = 3 r / L^3 (global) or
// -20 (1 - r/R)^3 / R^2 (local), both smooth at r = 0. Beyond the box, with w = p - q (non-zero
// only along the axes a where p lies beyond a face, which hold q_a fixed), dF/dp = I + J_u(q) plus,
// in each column b with w_b = 0, sum_c d^2 u / dq_b dq_c w_c
//   = (H_m w)_b v + (grad m)_b J_v w + (grad m . w) J_v e_b + m sum_j w_j g2(r_j) (d_j . w) d_jb,
// d_j = q - s_j, H_m the mask's Hessian and g2 = g'(r) / r = 3 / (L^3 r) or 60 (1 - r/R)^2 /
// (R^3 r) (its d d^T term vanishes at r = 0).
//
// Inverse (numerical): damped Newton on F(p) - p' = 0 with the analytic Jacobian. Starts, tried in
// turn until one converges to a point where det(dF/dp) > 0: (1) the linear inverse about the
// nearest image of a 9 x 9 x 9 lattice of nodes over the box, node + (dF/dp(node))^-1 (p' -
// F(node)) (F and the inverse Jacobians of the nodes are tabulated when the deformer is made), (2)
// p' - u(clamp(p')), (3) p'. Each start runs at most 50 iterations and is given up when 5 of them
// do not halve its residual; each step is halved up to 10 times until |F(p) - p'| decreases, and
// a singular Jacobian takes a steepest-descent step instead. Converged means
// |F(p) - p'| <= 1e-13 L + 4 eps |p'|_inf. The answer is the first converged root with det > 0,
// else a converged root in the box (a fold's other branch), else any converged root. If no start
// converges, p' is taken to have no preimage in the box (true wherever it lies outside F(box)): the
// least-residual iterate is returned, moved just beyond the nearest box face if it lies inside,
// so that the texel is empty rather than a wrong surface. Always finite, never NaN, bounded work:
// about 3.5 evaluations of F and dF/dp per texel when baking a smooth field (the 90-degree twist
// by 6^3 points of the tests; 0.7 us per evaluation with 180 sources), several times more for a
// folding one. Where F is a bijection the root is unique and F(inverse(p')) = p' to about 1e-13 L.
// Where F folds (det(dF/dp) <= 0 somewhere: targets that cross, a displacement larger than the
// distance to a pinned face, or a field too twisted for its sources, which folds first at the box
// edges) a p' may have several preimages or none, and Newton may miss one: inverse() returns what
// the rules above give, and measure_folds reports the folded volume.
//
// identity_faces(): face f iff pinned[f], or every displacement is zero (F is the identity).
//
// Inputs:
//   half_extents  h, the box half sizes (object units), each > 0 and finite
//   points        the pairs, 1 to kMaxControlPoints = 2048 (the systems are dense: 2048 pairs take
//                 about 64 MiB (the matrix and its LU) and about a second to solve, and every
//                 evaluation of F costs O(n); the local kernel skips blocks of 16 sources farther
//                 than R)
//   radius        R: 0 = global, > 0 = radius of influence of each source (object units)
//   pinned        faces held fixed, in the order -x, +x, -y, +y, -z, +z
//   warnings      optional: receives what the user should know but is no error (see below)
// Output: the deformer; describe() reads e.g. "control points (12 pairs, radius 0.5, pinned -y +y)"
// or "control points (20 pairs, global)".
// Throws raywarp::Error, the message beginning with the field so that the scene layer can prefix
// it ("scene.json: boxes[0].deformer." + message):
//   "points: none given: ..."  /  "points: 3000 pairs: at most 2048 are allowed"
//   "points[3].source = [x, y, z]: coordinates must be finite"  (also .target)
//   "points[3].source = [x, y, z]: must lie in the box [...]"   beyond it by more than 1e-9 L (a
//                                   source within that tolerance is moved onto the face)
//   "points[2] and points[5] have coincident sources (...)"    closer than 1e-6 L
//   "points[4] lies on pinned face -y (...) but its target ... differs from it by ...: a point
//    cannot be both pinned and moved"   a source within 1e-9 L of a pinned face, target moved by
//                                       more than 1e-9 L
//   "radius = -1: must be >= 0 and finite (...)"
//   "the control points' interpolation system is ill-conditioned (...)"   (see above)
//   and check_half_extents' errors ("control points half_extents[1] = 0: ...").
// Warnings (not errors), only computed when `warnings` is given: targets outside the box (the
// deformed part leaves the box, as a twist's corners do; rays are cast over F(box) anyway), a
// source that moves by more than its distance to a pinned face (F must stretch steeply or fold
// between them), a poorly conditioned system (reciprocal condition below 1e-10), and folds:
// det(dF/dp) <= 0 at any point of a 17^3 lattice over the box with its faces, edges and corners
// (where an under-sampled field folds first, between measure_folds' cell-centre samples; 4913
// evaluations of dF/dp).
//
// Known issues: a local radius smaller than the spacing of the sources gives isolated bumps, and
// a target far from its source relative to R folds space (both are what the input asks for;
// measure_folds says so). A source very close to a pinned face with a non-zero displacement gives
// a large v = d / m and a steep field there. Too few sources for a strong deformation (a 360-degree
// twist by 6^3 or 9^3 points) fold at the box edges and corners, between measure_folds' samples
// (which lie at cell centres), and there the first-order continuation beyond the box can fold far
// regions back onto F(box): the baked D then has holes near those edges and large jumps outside
// F(box) (displacement_lipschitz of 1e4 to 1e5 against 12 for the analytic twist); the fold
// warning and the pipeline's texture-error warning fire. The start table's 729 nodes cost as many
// evaluations of dF/dp when the deformer is made.
#pragma once
#include <Eigen/Core>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "deformers/deformer.h"

namespace raywarp {

// A source -> target pair, in the box's local frame (object units).
struct ControlPoint {
  Eigen::Vector3d source, target;
};

// The most pairs make_control_points accepts.
constexpr int kMaxControlPoints = 2048;

std::unique_ptr<Deformer> make_control_points(const Eigen::Vector3d& half_extents,
                                              std::vector<ControlPoint> points, double radius,
                                              std::array<bool, 6> pinned,
                                              std::vector<std::string>* warnings = nullptr);

}  // namespace raywarp
