// Numerical experiments on bake_deformation (library/deformation_bake.h): the baked inverse
// displacement against the analytic inverse within the trilinear interpolation bound, and
// finite, well-flagged textures for extreme twists and bends.
//
// The interpolation bound. Grid3::sample is trilinear between the 8 texel centres around p', a
// cube of side s. In 1D, linear interpolation of f between nodes s apart errs by
// |f''(xi)| x (s - x) / 2 <= s^2 / 8 max|f''|. Trilinear interpolation is I = Ix Iy Iz, each a
// convex combination (max norm 1), and f - I f = (f - Iz f) + Iz (f - Iy f) + Iz Iy (f - Ix f),
// so per component c of D
//   |D_c - I D_c| <= s^2 / 8 (max|d^2 D_c/dx^2| + max|d^2 D_c/dy^2| + max|d^2 D_c/dz^2|)     (1)
// over the cube: (3/8) s^2 max|d^2 D| in general, sharper below. Only pure second derivatives
// along the grid axes (the box axes) enter; D and F^-1 = D + identity have the same ones. (1)
// needs D smooth on the cube: it is if the 8 corners all have w = 1 and the region the inverse
// treats with one formula is convex (the slab |p'_a| <= h_a for a twist; the wedge
// 0 <= theta <= phi for a bend of at most 180 degrees). The test takes points p' = F(p) whose
// 4x4x4 texel block (the stencil and one texel around it) all have w = 1.
//
// Twist about a, g = phi / L: F^-1(p') = R_a(-g (p'_a + h_a)) p' inside the slab. At fixed p'_a it
// is linear in the other two coordinates, so only d^2/dp'_a^2 = g^2 R_a''(-theta) p' is non-zero:
// a vector orthogonal to a of length g^2 r, r = distance from the axis. r is convex, so on the
// cube it is largest at a corner, and corners lie in F(box): r <= r_max = hypot(h_u, h_v). So
//   |error_c| <= s^2 / 8 g^2 r_max for c != a, and D_a = 0 exactly.
// Bend about d (axes a, b, curvature k, centre of curvature at distance rho): on the sector
// q_a = theta / k with theta the polar angle about the centre, and q_b = R - sign(k) rho. For a
// polar angle, |d^2 theta/dx^2| + |d^2 theta/dy^2| = 4 |x y| / rho^4 <= 2 / rho^2; for the radius,
// d^2 rho/dx^2 + d^2 rho/dy^2 = 1 / rho. So
//   |error_a| <= s^2 / 8 * 2 / (|k| rho_lo^2),   |error_b| <= s^2 / 8 / rho_lo,   error_d = 0,
// with rho_lo the least rho on the cube: corners lie in F(box), rho >= |R| - h_b there, and rho is
// 1-Lipschitz, so rho_lo >= |R| - h_b - s / sqrt(2) (the cube's (a, b) face is a square).
// Float storage adds at most 2^-24 |D_c| per component (round to nearest; the interpolation is a
// convex combination), and the double arithmetic of the test ~1e-15.
#include "library/deformation_bake.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include "base/error.h"
#include "deformers/bend.h"
#include "deformers/box_cut.h"
#include "deformers/deformer.h"
#include "deformers/incision.h"
#include "deformers/twist.h"
#include "library/scene.h"

namespace raywarp {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kFloatRounding = 0x1p-24;

// Uniform in [-h, h].
Eigen::Vector3d random_point(std::mt19937_64& rng, const Eigen::Vector3d& h) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  return Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(h);
}

// Whether the trilinear stencil of p' and one texel around it (4x4x4 texels) exist and all have
// w = 1.
bool well_inside(const Grid3<Eigen::Vector4f>& grid, const Eigen::Vector3d& p_def) {
  const Eigen::Vector3d u =
      (p_def - grid.origin).cwiseQuotient(grid.spacing) - Eigen::Vector3d::Constant(0.5);
  Eigen::Vector3i base;
  for (int a = 0; a < 3; ++a) {
    base[a] = static_cast<int>(std::floor(u[a]));
    if (base[a] - 1 < 0 || base[a] + 2 >= grid.dims[a]) return false;
  }
  for (int k = -1; k <= 2; ++k)
    for (int j = -1; j <= 2; ++j)
      for (int i = -1; i <= 2; ++i)
        if (grid.at(base.x() + i, base.y() + j, base.z() + k).w() != 1.0f) return false;
  return true;
}

// Largest |sampled D_c - analytic D_c| / bound_c over points p' = F(p) well inside the valid
// region; prints the errors and bounds.
double worst_error_ratio(const Deformer& deformer, const Eigen::Vector3d& h,
                         const DeformationTexture& texture, const Eigen::Vector3d& bound) {
  std::mt19937_64 rng(11);
  Eigen::Vector3d worst = Eigen::Vector3d::Zero();
  int used = 0;
  for (int n = 0; n < 20000; ++n) {
    const Eigen::Vector3d p_def = deformer.forward(random_point(rng, h));
    if (!well_inside(texture.grid, p_def)) continue;
    ++used;
    const Eigen::Vector3d analytic = deformer.inverse(p_def) - p_def;
    const Eigen::Vector3d sampled = texture.grid.sample(p_def).head<3>();
    worst = worst.cwiseMax((sampled - analytic).cwiseAbs());
  }
  std::printf(
      "%s: texel %.4g, %d points; max error (%.3g, %.3g, %.3g) <= bound (%.3g, %.3g, %.3g)\n",
      deformer.describe().c_str(), texture.grid.voxel(), used, worst.x(), worst.y(), worst.z(),
      bound.x(), bound.y(), bound.z());
  EXPECT_GT(used, 5000) << deformer.describe();
  return worst.cwiseQuotient(bound).maxCoeff();
}

TEST(Bake, TwistWithinInterpolationBound) {
  struct Case {
    Eigen::Vector3d h;
    Axis axis;
    double angle_deg;
  };
  for (const Case& c :
       {Case{{0.5, 0.8, 0.35}, Axis::Y, 360.0}, Case{{0.45, 0.3, 0.9}, Axis::Z, -270.0}}) {
    const auto twist = make_twist(c.h, c.axis, c.angle_deg);
    const DeformationTexture texture = bake_deformation(*twist, c.h, 64);
    const int a = static_cast<int>(c.axis);
    const double s = texture.grid.voxel();
    const double g = c.angle_deg * kDeg / (2.0 * c.h[a]);
    const double r_max = std::hypot(c.h[(a + 1) % 3], c.h[(a + 2) % 3]);
    const double slack = kFloatRounding * 2.0 * r_max + 1e-14;  // |D| <= 2 r for a rotation
    Eigen::Vector3d bound = Eigen::Vector3d::Constant(s * s / 8.0 * g * g * r_max + slack);
    bound[a] = slack;
    EXPECT_LE(worst_error_ratio(*twist, c.h, texture, bound), 1.0) << twist->describe();
  }
}

TEST(Bake, BendWithinInterpolationBound) {
  struct Case {
    Eigen::Vector3d h;
    Axis axis;
    double angle_deg;
    int a, b;  // limit axis and bend direction of `axis` (bend.h)
  };
  for (const Case& c :
       {Case{{0.8, 0.3, 0.4}, Axis::Z, 120.0, 0, 1}, Case{{0.3, 0.25, 0.7}, Axis::X, -150.0, 2, 1},
        Case{{0.2, 0.5, 0.6}, Axis::Y, 180.0, 2, 0}}) {
    const auto bend = make_bend(c.h, c.axis, c.angle_deg);
    const DeformationTexture texture = bake_deformation(*bend, c.h, 64);
    const double s = texture.grid.voxel();
    const double k = std::abs(c.angle_deg * kDeg / (2.0 * c.h[c.a]));
    const double rho_lo = 1.0 / k - c.h[c.b] - s / std::sqrt(2.0);
    ASSERT_GT(rho_lo, 0.0) << "the case must not fold";
    // |D(F(p))| = |p - F(p)| <= |q| + |q'|, each at most L + |h| from the pivot.
    const double slack = kFloatRounding * 2.0 * (2.0 * c.h[c.a] + c.h.norm()) + 1e-14;
    Eigen::Vector3d bound = Eigen::Vector3d::Constant(slack);
    bound[c.a] += s * s / 8.0 * 2.0 / (k * rho_lo * rho_lo);
    bound[c.b] += s * s / 8.0 / rho_lo;
    EXPECT_LE(worst_error_ratio(*bend, c.h, texture, bound), 1.0) << bend->describe();
  }
}

// Textures of extreme deformations stay finite (bake_deformation throws otherwise, and this
// checks every texel again), are valid at F(centre) and invalid beyond the padding, and cover
// F(box) with at least half a texel to spare.
TEST(Bake, ExtremeCasesAreFiniteAndFlagged) {
  struct Case {
    Eigen::Vector3d h;
    std::unique_ptr<Deformer> deformer;
  };
  Case cases[] = {
      {{0.3, 1.0, 0.3}, make_twist({0.3, 1.0, 0.3}, Axis::Y, 3600.0)},  // ten turns
      {{1.0, 0.2, 0.3}, make_bend({1.0, 0.2, 0.3}, Axis::Z, 359.0)},
      {{0.5, 0.4, 0.6}, make_bend({0.5, 0.4, 0.6}, Axis::X, 1e-4)},
      {{1.0, 1.0, 0.5}, make_bend({1.0, 1.0, 0.5}, Axis::Z, 180.0)},  // folds: R = 2 / pi < 1
  };
  std::mt19937_64 rng(12);
  for (const Case& c : cases) {
    const Deformer& deformer = *c.deformer;
    const DeformationTexture texture = bake_deformation(deformer, c.h, 32);
    const Grid3<Eigen::Vector4f>& grid = texture.grid;
    for (const Eigen::Vector4f& texel : grid.data)
      ASSERT_TRUE(texel.allFinite()) << deformer.describe();
    EXPECT_EQ(grid.sample(deformer.forward(Eigen::Vector3d::Zero())).w(), 1.0)
        << deformer.describe();
    const Eigen::Vector3d far = grid.upper() + 10.0 * grid.extent();
    EXPECT_EQ(grid.sample(far).w(), 0.0) << deformer.describe();
    EXPECT_EQ(grid.sample(grid.origin - grid.extent()).w(), 0.0) << deformer.describe();
    for (int n = 0; n < 2000; ++n) {
      const Eigen::Vector3d p_def = deformer.forward(random_point(rng, c.h));
      const Eigen::Vector3d margin = 0.5 * grid.spacing;
      EXPECT_TRUE(((p_def - grid.origin).array() >= margin.array()).all() &&
                  ((grid.upper() - p_def).array() >= margin.array()).all())
          << deformer.describe() << ": F(p) = " << p_def.transpose() << " is not covered";
    }
    EXPECT_GT(texture.bake_seconds, 0.0);
  }
}

// For twists and bends F is affine along the two box axes other than a at fixed p_a (a rotation,
// resp. q_b -> q' linear), so the extremes of F(box) lie on the four box edges along a. A dense
// sampling of those edges must fall within deformed_bounds up to its refinement tolerance:
// deformed_bounds stops when a halving of the lattice grows the bounds by <= 1e-4 of the
// diagonal and leaves ~1/3 of that unseen, or stops at 1024 intervals, where the worst case
// here, a 16-turn twist, has node angles repeating every 64 nodes: a sagitta of
// r (1 - cos(pi / 64)) ~ 1.2e-3 r ~ 2e-4 of the diagonal. 1e-3 of the diagonal holds both. The
// 16 turns alias with the first lattice (the nodes of an edge take only 4 angles, missing 30% of
// r): the refinement must find it.
TEST(Bake, DeformedBoundsHoldTheDeformedBox) {
  struct Case {
    Eigen::Vector3d h;
    std::unique_ptr<Deformer> deformer;
    int a;
  };
  Case cases[] = {
      {{0.3, 1.0, 0.2}, make_twist({0.3, 1.0, 0.2}, Axis::Y, 3570.0), 1},
      {{0.3, 1.0, 0.3}, make_twist({0.3, 1.0, 0.3}, Axis::Y, 16 * 360.0), 1},
      {{1.0, 0.2, 0.3}, make_bend({1.0, 0.2, 0.3}, Axis::Z, 331.0), 0},
      {{0.4, 0.5, 0.9}, make_bend({0.4, 0.5, 0.9}, Axis::X, -250.0), 2},
  };
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const Case& c : cases) {
    const Eigen::AlignedBox3d bounds = deformed_bounds(*c.deformer, c.h);
    const double tol = 1e-3 * bounds.diagonal().norm();
    Eigen::AlignedBox3d edges;
    for (int n = 0; n < 100000; ++n) {
      Eigen::Vector3d p;
      for (int i = 0; i < 3; ++i) p[i] = c.h[i] * (unit(rng) < 0.0 ? -1.0 : 1.0);
      p[c.a] = c.h[c.a] * unit(rng);
      edges.extend(c.deformer->forward(p));
    }
    EXPECT_LE((bounds.min() - edges.min()).maxCoeff(), tol) << c.deformer->describe();
    EXPECT_LE((edges.max() - bounds.max()).maxCoeff(), tol) << c.deformer->describe();
    const Eigen::AlignedBox3d padded = deformed_bounds(*c.deformer, c.h, 0.25);
    EXPECT_LE((padded.min() - (bounds.min().array() - 0.25).matrix()).norm(), 1e-15);
    EXPECT_LE((padded.max() - (bounds.max().array() + 0.25).matrix()).norm(), 1e-15);
  }
}

TEST(Bake, GridIsResolutionTexelsAlongTheLongestSide) {
  const Eigen::Vector3d h(0.5, 0.8, 0.35);
  const auto twist = make_twist(h, Axis::Y, 90.0);
  const DeformationTexture texture = bake_deformation(*twist, h, 40);
  EXPECT_EQ(texture.grid.dims.maxCoeff(), 40);
  EXPECT_EQ(texture.grid.size(), static_cast<size_t>(texture.grid.dims.prod()));
}

TEST(Bake, CountsPerAxisPadOneTexelEachSide) {
  const Eigen::Vector3d h(0.5, 0.8, 0.35);
  const auto twist = make_twist(h, Axis::Y, 90.0);
  const Eigen::Vector3i counts(20, 7, 33);
  const DeformationTexture texture = bake_deformation(*twist, h, counts, false);
  EXPECT_EQ(texture.grid.dims, counts);
  const Eigen::AlignedBox3d bounds = deformed_bounds(*twist, h);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(texture.grid.spacing[a], bounds.sizes()[a] / (counts[a] - 2), 1e-12);
    EXPECT_NEAR(texture.grid.origin[a], bounds.min()[a] - texture.grid.spacing[a], 1e-12);
    EXPECT_NEAR(texture.grid.upper()[a], bounds.max()[a] + texture.grid.spacing[a], 1e-12);
  }
  EXPECT_THROW(bake_deformation(*twist, h, Eigen::Vector3i(2, 8, 8), false), Error);
}

TEST(Bake, CountsForErrorShareTheTargetAmongTheAxesAboveTheirFloor) {
  // Only x errs: it alone is refined, by sqrt(4) for a quarter of the error.
  EXPECT_EQ(counts_for_error({10, 10, 10}, {0.4, 0, 0}, 0.1, {10, 10, 10}),
            Eigen::Vector3i(20, 10, 10));
  // Two equal errors: each takes half the target.
  EXPECT_EQ(counts_for_error({10, 10, 10}, {0.4, 0.4, 0}, 0.1, {10, 10, 10}),
            Eigen::Vector3i(29, 29, 10));
  // Already within: the floor.
  EXPECT_EQ(counts_for_error({10, 10, 10}, {0.01, 0.01, 0.01}, 0.1, {10, 10, 10}),
            Eigen::Vector3i(10, 10, 10));
  const Eigen::Vector3i n = counts_for_error({10, 10, 10}, {0.3, 0.2, 0.1}, 0.05, {4, 4, 4});
  double sum = 0;
  for (int a = 0; a < 3; ++a) sum += (a == 0 ? 0.3 : a == 1 ? 0.2 : 0.1) * 100.0 / (n[a] * n[a]);
  EXPECT_LE(sum, 0.05);
  EXPECT_GT(sum, 0.04);  // not wastefully fine
}

// A twist interpolates exactly across its axis (a rotation is linear in x, z at each y): its
// error lies along the axis, which the per-axis estimate sees and the automatic layout refines
// alone.
TEST(Bake, AutoLayoutRefinesOnlyTheAxisThatErrs) {
  const Eigen::Vector3d h(1.0, 0.2, 1.0);  // a slab: 720 degrees over 0.4
  const auto twist = make_twist(h, Axis::Y, 720.0);
  const double voxel = 2.0 / 128, target = kAutoErrorVoxels * voxel;
  const DeformationTexture fixed = bake_deformation(*twist, h, kAutoFloorResolution);
  const double fixed_error = deformation_texture_error(*twist, fixed);
  ASSERT_GT(fixed_error, 4 * target) << "the case must need the refinement";
  const Eigen::Vector3d per_axis = axis_interpolation_errors(*twist, fixed);
  EXPECT_LT(per_axis.x(), 1e-3 * per_axis.y());
  EXPECT_LT(per_axis.z(), 1e-3 * per_axis.y());
  EXPECT_GT(per_axis.sum(), 0.5 * fixed_error);
  EXPECT_LT(per_axis.sum(), 2.0 * fixed_error);

  const AutoDeformation a = bake_deformation_auto(*twist, h, target, std::uint64_t(64) << 20,
                                                  kAutoFloorResolution, false);
  std::printf(
      "720 degrees over 0.4: fixed %dx%dx%d, error %.3g; auto %dx%dx%d, error %.3g "
      "(target %.3g), %d bakes, %.2f s\n",
      fixed.grid.dims.x(), fixed.grid.dims.y(), fixed.grid.dims.z(), fixed_error,
      a.texture.grid.dims.x(), a.texture.grid.dims.y(), a.texture.grid.dims.z(), a.error, target,
      a.choice.bakes, a.texture.bake_seconds);
  EXPECT_LE(a.error, target);
  EXPECT_NEAR(a.error, deformation_texture_error(*twist, a.texture), 1e-15);
  EXPECT_FALSE(a.choice.budget_bound);
  EXPECT_EQ(a.texture.grid.dims.x(), fixed.grid.dims.x());
  EXPECT_EQ(a.texture.grid.dims.z(), fixed.grid.dims.z());
  EXPECT_GT(a.texture.grid.dims.y(), 3 * fixed.grid.dims.y());
  EXPECT_LE(a.texture.grid.size() * 16, std::uint64_t(16) << 20);
}

TEST(Bake, AutoLayoutKeepsTheFloorWhenItSuffices) {
  const Eigen::Vector3d h(0.5, 0.8, 0.35);
  const auto bend = make_bend(h, Axis::Y, 30.0);
  const AutoDeformation a =
      bake_deformation_auto(*bend, h, 0.01, std::uint64_t(64) << 20, kAutoFloorResolution, false);
  const DeformationTexture fixed = bake_deformation(*bend, h, kAutoFloorResolution);
  EXPECT_EQ(a.choice.bakes, 1);
  EXPECT_EQ(a.texture.grid.dims, fixed.grid.dims);
  EXPECT_EQ(a.texture.grid.spacing, fixed.grid.spacing);
  EXPECT_EQ(a.texture.grid.data, fixed.grid.data);
}

TEST(Bake, AutoLayoutStaysWithinItsBudget) {
  const Eigen::Vector3d h(1.0, 0.2, 1.0);
  const auto twist = make_twist(h, Axis::Y, 720.0);
  const std::uint64_t budget = std::uint64_t(1) << 20;
  const AutoDeformation a =
      bake_deformation_auto(*twist, h, 1e-4, budget, kAutoFloorResolution, false);
  EXPECT_TRUE(a.choice.budget_bound);
  EXPECT_LE(a.texture.grid.size() * 16, budget);
  EXPECT_GT(a.error, 1e-4);  // and says so: the error is measured, not the target's
  // With the lower-face shift the grown grid still fits.
  const AutoDeformation c =
      bake_deformation_auto(*twist, h, 1e-4, budget, kAutoFloorResolution, true);
  EXPECT_LE(c.texture.grid.size() * 16, budget);
}

// The alpha map's automatic layout: from the cubic floor up until A's error within the band
// around the cut face is at most the target, within its budget, for a box cut's wedge (kinks
// along its edge, where the error falls as 1 / n) and an incision; never worse than the floor
// (a refinement that does not help is not kept).
TEST(Bake, AutoAlphaMeetsItsTarget) {
  const Eigen::Vector3d h(0.5, 0.8, 0.35);
  BoxCutParams params;
  params.wedge_axis = Axis::Z;
  params.wedge_from_deg = 10.0;
  params.wedge_angle_deg = 90.0;
  const auto cut = make_box_cut(h, params);
  const auto incision = make_incision(h, Axis::X, Face{Axis::Y, 1}, 0.9, 0.2);
  const Eigen::AlignedBox3d region(-1.1 * h, 1.1 * h);
  const double voxel = 2.0 * h.maxCoeff() / 256, target = kAutoErrorVoxels * voxel;
  const double band = kAlphaBandVoxels * voxel;
  const std::vector<const Deformer*> deformers = {cut.get(), incision.get()};
  for (const Deformer* d : deformers) {
    const AlphaMap floor = bake_alpha(*d, region, 16);
    const double floor_error = alpha_map_error(*d, floor, band);
    const AutoAlpha a = bake_alpha_auto(*d, region, target, band, std::uint64_t(16) << 20, 16);
    std::printf(
        "%s: alpha at the floor (16) error %.3g; auto %dx%dx%d error %.3g (target %.3g), "
        "%d bakes\n",
        d->describe().c_str(), floor_error, a.map.grid.dims.x(), a.map.grid.dims.y(),
        a.map.grid.dims.z(), a.error, target, a.choice.bakes);
    EXPECT_TRUE(a.choice.automatic);
    EXPECT_LE(a.error, floor_error);
    EXPECT_NEAR(a.error, alpha_map_error(*d, a.map, band), 1e-12);
    EXPECT_LE(a.map.grid.size() * 4, std::uint64_t(16) << 20);
    ASSERT_GT(floor_error, target) << "the case must need the refinement";
    EXPECT_LE(a.error, target);
    for (int axis = 0; axis < 3; ++axis)  // the region exactly, texels per axis
      EXPECT_NEAR(a.map.grid.extent()[axis], region.sizes()[axis], 1e-12);
  }
}

// Not a check: the bake times the report quotes (96 texels along the longest side).
TEST(Bake, Times96) {
  const Eigen::Vector3d h(0.5, 0.8, 0.35);
  const auto twist = make_twist(h, Axis::Y, 360.0);
  const auto bend = make_bend(h, Axis::Y, 120.0);
  for (const Deformer* deformer : {twist.get(), bend.get()}) {
    const DeformationTexture texture = bake_deformation(*deformer, h, 96);
    std::printf("%s: %d x %d x %d texels baked in %.3f s\n", deformer->describe().c_str(),
                texture.grid.dims.x(), texture.grid.dims.y(), texture.grid.dims.z(),
                texture.bake_seconds);
  }
}

}  // namespace
}  // namespace raywarp
