// The from-mesh deformer: a smooth map F over the box fitted to vertex pairs, a mesh's vertices
// (sources s_i) and where a deformed copy of it puts them (targets t_i): a sculpted copy with the
// same vertex order, a glTF morph target (docs/from_mesh.md).
//
// In the box's local frame (box [-h, h], object units), F(p) = p + u(p), u the trilinear
// interpolation of displacements on a lattice over the box: `resolution` cells along the box's
// longest side and a whole number of cells along the others (the lattice of simulation.h). The
// displacements minimise, with u = 0 on the lattice nodes of the pinned faces,
//   E(u) = (1/n) sum_i |u(s_i) - d_i|^2 + lambda R(u),   d_i = t_i - s_i,
// with R a smoothness energy made dimensionless by the box diagonal L and volume V:
//   thin_plate (default)  R = (L^4 / V) int |Hessian of u|^2: over the nodes, the squared second
//                         differences along each axis, and over the lattice squares the squared
//                         mixed differences (twice), each times its volume. It is zero exactly on
//                         affine fields, so with no pinned face an affine map is reproduced
//                         whatever lambda; away from the pairs u continues smoothly (linearly far
//                         from them).
//   membrane              R = (L^2 / V) int |grad u|^2, over the lattice edges: the harmonic
//                         extension of the pairs' displacements. Kept for comparison: it pulls u
//                         towards a constant between the pairs, so its error inside the solid is
//                         3 to 6 times the thin plate's and it folds where the thin plate does not.
// The normal equations (B^T B + n lambda R + eps I) u = B^T d + eps a (B: the trilinear weights
// of the sources; a: the pairs' least-squares affine fit, with the least gradient along the
// directions the sources do not spread in; eps: 1e-10 of R's largest diagonal entry, which holds
// what neither the pairs nor R hold, such as the affine fields a single pair or pairs on a plane
// leave free) are solved, the three components at once and matrix-free, by conjugate gradients
// in double preconditioned by a multigrid W-cycle: lattices of half the cells (rounded up) down
// to at most 4 a side, R rediscretised on each, two Chebyshev steps of Jacobi smoothing before
// and after, trilinear prolongation and its transpose, a dense Cholesky solve on the coarsest.
// The cycle runs in float, or in double when the sources barely spread along some direction. It
// stops at a relative residual of `tolerance` (or after 200 iterations).
//
// Turns: where the pairs turn more than 100 degrees about the line they turn about
// (deformers/turn_paths.h: a twist's axis, a line near a bend's centre), one smooth u would
// average the turns and fold (a full turn averages to a collapse). The pairs then follow paths
// that turn at most 43 degrees a step; each step's pairs (with the pinned faces' samples, which
// turn whole turns and come back) are fitted as above on a lattice of cells of the same size over
// a box grown to hold every pose, the steps are composed at the box lattice's samples, and what
// the composition leaves of the displacements is fitted on the box's lattice and added, with
// u = 0 on the pinned faces. The result is one lattice, as for a fit in one go.
//
// The map is make_lattice_deformer's (deformers/simulation.h, model grid) with every lattice
// sample a node at its rest position plus u: trilinear in each cell (continuous, its Jacobian
// analytic per cell and discontinuous across cell faces); the identity beyond the box (so F jumps
// across an unpinned face where u is not zero there, as the simulation's does); exactly the
// identity on the pinned faces. Its inverse is the lattice's: per cell by damped Newton to 1e-9
// of the cell diagonal; of several preimages (F folds) the one nearest to p'; outside F(box) a
// point beyond the box (an invalid texel).
//
// identity_faces(): the faces on which every node keeps its rest position: the pinned faces (all
// six when every d_i is 0).
//
// Inputs:
//   half_extents  h, each > 0 and finite
//   pairs         one or more; every coordinate finite; every source in the box (a source within
//                 1e-9 L of it is moved onto the face)
//   params        see FromMeshParams
//   fit           optional: receives the fit's figures
//   interrupter   optional: polled throughout (stage "from mesh fit"); cancel() throws Cancelled
// Throws Error naming the parameter and what is allowed on a bad input, and when the fit would
// take more than kFromMeshMaxBytes: checked before the solver's memory is allocated (about 180
// bytes per lattice node: a cubic box reaches the cap near resolution 175) and again, with the
// fitted positions, before the lattice deformer's (its search buckets grow with how far the
// cells move).
//
// Figures (docs/from_mesh.md, tests/from_mesh_test.cpp): the bunny's head (847 vertices) under an
// exact twist of 90 degrees, of 360, of 720, a bend of 90 and one of 180, at the defaults:
// |F(s_i) - t_i| at most 0.03 %, 0.11 %, 0.35 %, 0.012 % and 0.06 % of the box diagonal, F inside
// the solid within 1.7 %, 1.6 %, 2.4 %, 1.4 % and 2.4 % of the exact map, no fold inside the
// solid, in 0.3 s (one go) to 5 s (17 steps); 300,000 pairs on a 128-cell lattice in about 9 s
// and 440 MiB on two cores.
//
// Limits: a source on a pinned face whose target moves cannot be met (u = 0 there): the fit's
// error says so. Where the targets fold or tear the surface (nearby sources sent far apart), no
// smooth u meets them all: the least-squares fit averages them. Turns are followed about one
// line: pairs that turn far about several lines at once (two twists on different axes in one
// box) take paths about the line that fits them best, and may fold where those paths cross
// (measure_folds reports the folded volume).
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <memory>
#include <vector>

#include "base/interrupt.h"
#include "deformers/deformer.h"

namespace raywarp {

struct PointPair;  // deformers/registry.h: a source and its target, box frame

enum class FromMeshSmoothing { thin_plate = 0, membrane = 1 };

constexpr int kFromMeshMinResolution = 4;
constexpr int kFromMeshMaxResolution = 256;
// The most memory a fit may take (the solver's, then the lattice deformer's; the pairs given
// are not counted).
constexpr std::size_t kFromMeshMaxBytes = std::size_t(1) << 30;

struct FromMeshParams {
  int resolution = 48;           // lattice cells along the box's longest side, [4, 256]
  std::array<bool, 6> pinned{};  // faces held at the identity, in the order -x, +x, -y, +y, -z, +z
  FromMeshSmoothing smoothing = FromMeshSmoothing::thin_plate;
  double smoothness = 1e-8;  // lambda, [1e-10, 1]: smaller fits closer and takes more iterations
  double tolerance = 1e-6;   // relative residual of the normal equations, [1e-10, 1e-2]
};

// Figures of a fit.
struct FromMeshFit {
  long pairs = 0;                                   // pairs used
  Eigen::Vector3i cells = Eigen::Vector3i::Zero();  // lattice cells per axis
  double max_error = 0, rms_error = 0;              // |F(s_i) - t_i| over the pairs, object units
  int iterations = 0;                               // conjugate gradient iterations (all fits)
  double largest_turn_deg = 0;   // the largest turn of a pair about the line the pairs turn about
  int steps = 1;                 // the turn's steps (1: fitted in one go)
  double relative_residual = 0;  // of the normal equations, when the solver stopped
  double seconds = 0;            // the whole of make_from_mesh
  std::size_t bytes = 0;         // peak memory estimate (the larger of the two phases)
};

// `positions`, optional, receives the fitted lattice (every sample at rest + u, x fastest over
// cells + 1 samples per axis), which from_mesh_fitted turns back into this deformer without the
// fit (a bake cache keeps it).
std::unique_ptr<Deformer> make_from_mesh(const Eigen::Vector3d& half_extents,
                                         const std::vector<PointPair>& pairs,
                                         const FromMeshParams& params, FromMeshFit* fit = nullptr,
                                         Interrupter* interrupter = nullptr,
                                         std::vector<Eigen::Vector3d>* positions = nullptr);

// The deformer make_from_mesh built with these half extents and params from the `pairs` pairs
// whose fitted lattice is `positions`. Throws Error when the positions are not finite or their
// count is not the lattice's, or past kFromMeshMaxBytes.
std::unique_ptr<Deformer> from_mesh_fitted(const Eigen::Vector3d& half_extents,
                                           const FromMeshParams& params,
                                           const std::vector<Eigen::Vector3d>& positions,
                                           long pairs, Interrupter* interrupter = nullptr);

}  // namespace raywarp
