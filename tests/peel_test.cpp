// Numerical experiments on the peel (deformers/peel.h): round trips of the analytic inverse off
// the folds, the analytic Jacobian against central differences, the curl's direction, the alpha
// map against the cut (sign, Lipschitz bound, distance by brute force), the folded volume against
// its closed form, the bake, the identity faces and the input checks, for every curl axis and
// face.
#include "deformers/peel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include "base/error.h"
#include "library/deformation_bake.h"
#include "tests/sanitizer.h"

namespace raywarp {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr Axis kAxes[] = {Axis::X, Axis::Y, Axis::Z};
// Uneven, so that a mixed-up axis shows.
const Eigen::Vector3d kHalf(0.6, 0.9, 0.45);

// thickness as a fraction of 2 h_e, radius as a multiple of the thickness, hinge as a fraction
// of h_a. The last two fold (radius < thickness).
struct Params {
  double angle_deg, thickness_frac, radius_over_t, hinge_frac;
};
constexpr Params kParams[] = {{90.0, 0.3, 2.0, 0.0},   {120.0, 0.2, 1.5, -0.3},
                              {180.0, 0.25, 1.2, 0.5}, {30.0, 0.4, 3.0, -1.0},
                              {150.0, 0.4, 0.5, -0.5}, {60.0, 0.15, 0.8, 0.2}};

// The peel's axes and curl, restated from peel.h.
struct Frame {
  int d, e, a;
  double side, theta_max, t, radius, hinge, cut;
  bool folds() const { return radius <= t; }
  double s(const Eigen::Vector3d& p) const { return p[a] - hinge; }
  double v(const Eigen::Vector3d& p) const { return side * p[e] - cut; }
  double length() const { return radius * theta_max; }
  // The flap's underside at the end of the curved part, and its centre of curvature, in (s, v).
  Eigen::Vector2d end() const {
    return radius * Eigen::Vector2d(std::sin(theta_max), 1.0 - std::cos(theta_max));
  }
  Eigen::Vector2d centre() const { return {0.0, radius}; }
  // The cut region in the (s, v) plane: above the body's cut plane and beyond the flap's
  // underside, which is the arc of radius R about the centre for polar angles (from the centre,
  // 0 towards the hinge, growing towards +s) in [0, Theta], its tangent ray beyond Theta, and the
  // hinge plane's continuation s = 0 below 0; the angles are split between the last two at the
  // angle opposite Theta / 2. For s > 0 this is the gap the flap vacated.
  bool in_cut(double s, double v) const {
    if (!(v > 0.0)) return false;
    double angle = std::atan2(s, radius - v);  // in [-pi, pi]
    if (angle < 0.5 * theta_max - std::numbers::pi) angle += 2.0 * std::numbers::pi;
    if (angle < 0.0) return false;  // beyond the identity side's face v = v'
    if (angle <= theta_max) return std::hypot(s, v - radius) > radius;
    const Eigen::Vector2d normal(-std::sin(theta_max), std::cos(theta_max));
    return normal.dot(Eigen::Vector2d(s, v) - end()) < 0.0;
  }
  bool in_cut(const Eigen::Vector3d& p) const { return in_cut(s(p), v(p)); }
  bool in_flap(const Eigen::Vector3d& p) const { return s(p) >= 0.0 && v(p) >= 0.0; }
};

struct Case {
  Frame f;
  std::unique_ptr<Deformer> deformer;
};

Case make_case(const Eigen::Vector3d& h, Axis curl, Axis entry, int side, const Params& params) {
  Frame f;
  f.d = static_cast<int>(curl);
  f.e = static_cast<int>(entry);
  f.a = 3 - f.d - f.e;
  f.side = side;
  f.theta_max = params.angle_deg * kDeg;
  f.t = params.thickness_frac * 2.0 * h[f.e];
  f.radius = params.radius_over_t * f.t;
  f.hinge = params.hinge_frac * h[f.a];
  f.cut = h[f.e] - f.t;
  return {f, make_peel(h, curl, Face{entry, side}, params.angle_deg, f.t, f.radius, f.hinge)};
}

// Every curl axis, face and parameter set.
std::vector<Case> all_cases(const Eigen::Vector3d& h = kHalf) {
  std::vector<Case> cases;
  for (Axis curl : kAxes)
    for (Axis entry : kAxes)
      for (int side : {1, -1})
        for (const Params& params : kParams)
          if (curl != entry) cases.push_back(make_case(h, curl, entry, side, params));
  return cases;
}

// Uniform in [-scale h, scale h].
Eigen::Vector3d random_point(std::mt19937_64& rng, const Eigen::Vector3d& h, double scale = 1.0) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  return scale * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(h);
}

// Uniform in a box.
Eigen::Vector3d random_in(std::mt19937_64& rng, const Eigen::AlignedBox3d& box) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  return box.min() + Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(box.sizes());
}

// A point of the box where the inverse is one-to-one: not on a flap point with 1 - v / R < 0.05
// (the fold and its neighbourhood, where the conditioning passes 1 / 0.05), and, where the flap
// folds, not in the body, which the folded flap may overlap (peel.h, Folds).
Eigen::Vector3d random_unfolded_point(std::mt19937_64& rng, const Frame& f,
                                      const Eigen::Vector3d& h) {
  for (;;) {
    const Eigen::Vector3d p = random_point(rng, h);
    if (f.in_flap(p) ? 1.0 - f.v(p) / f.radius > 0.05 : !f.folds()) return p;
  }
}

// Every branch of the inverse inverts F exactly on its region (the bend's sector, rigid motion
// and identity, as in bend_test), so F(inverse(p')) = p' wherever p' has a preimage, folded
// configurations included: on the flap's side the preimage q, elsewhere p' itself. The
// ill-conditioned angle near the centre of curvature cancels as in the bend. The points fill the
// deformed bounds padded by half the box, and skip the cut (A >= 0).
TEST(Peel, RoundTripForwardOfInverse) {
  const double tol = 1e-9 * 2.0 * kHalf.norm();
  std::mt19937_64 rng(1);
  double worst_all = 0.0;
  for (const Case& c : all_cases()) {
    const Eigen::AlignedBox3d bounds = deformed_bounds(*c.deformer, kHalf, 0.5 * kHalf.norm());
    double worst = 0.0;
    int used = 0;
    for (int k = 0; k < testing::samples(5000); ++k) {
      const Eigen::Vector3d p_def = random_in(rng, bounds);
      if (!(c.deformer->alpha(p_def) < 0.0)) continue;
      ++used;
      worst = std::max(worst, (c.deformer->forward(c.deformer->inverse(p_def)) - p_def).norm());
    }
    EXPECT_GT(used, testing::samples(5000) / 2) << c.deformer->describe();
    EXPECT_LE(worst, tol) << c.deformer->describe();
    worst_all = std::max(worst_all, worst);
  }
  std::printf("[figures] peel F(inverse(p')) - p': worst %.3g (tolerance %.3g)\n", worst_all, tol);
}

// On the flap the inverse solves for the polar angle and radius about the centre of curvature
// (bend_test's argument: conditioning 1 / (1 - v / R) <= 20, so ~1e-14 of the box); the body is
// its own preimage. Where the flap does not fold (R > t) its image keeps off the body's side
// (peel.h), so the round trip holds on the whole box.
TEST(Peel, RoundTripInverseOfForward) {
  const double tol = 1e-9 * 2.0 * kHalf.norm();
  std::mt19937_64 rng(2);
  double worst_all = 0.0;
  for (const Case& c : all_cases()) {
    double worst = 0.0;
    for (int k = 0; k < testing::samples(5000); ++k) {
      const Eigen::Vector3d p = random_unfolded_point(rng, c.f, kHalf);
      worst = std::max(worst, (c.deformer->inverse(c.deformer->forward(p)) - p).norm());
    }
    EXPECT_LE(worst, tol) << c.deformer->describe();
    worst_all = std::max(worst_all, worst);
  }
  std::printf("[figures] peel inverse(F(p)) - p: worst %.3g (tolerance %.3g)\n", worst_all, tol);
}

// Central differences with step d along axis j: error <= d^2 / 6 |d^3 F / dp_j^3| + 2 * 4 eps
// |F| / (2 d). F is affine along d and e (v), so only j = a truncates, where (bend_test)
// d^3 F / ds^3 has size k^2 |1 - k v|. The points (in the box and beyond it) stay 2 d away from
// the kinks: the hinge s = 0, the end of the curl s = L and the cut plane v = 0, where F jumps.
TEST(Peel, JacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(3);
  const double d = 1e-6 * 2.0 * kHalf.norm();
  const double scale = 2.0;
  double worst_all = 0.0, tol_max = 0.0;
  for (const Case& c : all_cases()) {
    const Frame& f = c.f;
    const double k = 1.0 / f.radius;
    const double third = k * k * (1.0 + k * 2.0 * scale * kHalf.maxCoeff());
    const double f_max = 4.0 * scale * kHalf.norm();
    const double tol = 2.0 * (d * d / 6.0 * third + 4.0 * kEps * f_max / d);
    tol_max = std::max(tol_max, tol);
    double worst = 0.0;
    for (int n = 0; n < testing::samples(2000); ++n) {
      const Eigen::Vector3d p = random_point(rng, kHalf, scale);
      const double s = f.s(p), v = f.v(p);
      if (std::abs(s) < 2.0 * d || std::abs(s - f.length()) < 2.0 * d || std::abs(v) < 2.0 * d)
        continue;
      Eigen::Matrix3d numeric;
      for (int j = 0; j < 3; ++j) {
        const Eigen::Vector3d step = d * Eigen::Vector3d::Unit(j);
        numeric.col(j) =
            (c.deformer->forward(p + step) - c.deformer->forward(p - step)) / (2.0 * d);
      }
      worst = std::max(worst, (numeric - c.deformer->jacobian(p)).cwiseAbs().maxCoeff());
    }
    EXPECT_LE(worst, tol) << c.deformer->describe();
    worst_all = std::max(worst_all, worst);
  }
  std::printf("[figures] peel Jacobian vs central differences: worst %.3g (tolerance <= %.3g)\n",
              worst_all, tol_max);
}

// det(dF/dp) = 1 - v / R on the curved part of the flap (0 <= s <= L), 1 elsewhere.
TEST(Peel, JacobianDeterminantIsOneMinusVOverR) {
  std::mt19937_64 rng(4);
  for (const Case& c : all_cases()) {
    const Frame& f = c.f;
    for (int n = 0; n < testing::samples(1000); ++n) {
      const Eigen::Vector3d p = random_point(rng, kHalf, 1.5);
      const bool curved = f.in_flap(p) && f.s(p) <= f.length();
      const double expected = curved ? 1.0 - f.v(p) / f.radius : 1.0;
      EXPECT_NEAR(c.deformer->jacobian(p).determinant(), expected, 1e-13 * (1.0 + 1.0 / f.radius))
          << c.deformer->describe();
    }
  }
}

// The flap curls outward, away from the body: at 90 degrees the underside's point at the end of
// the curl, s = L = pi R / 2, goes to s' = R, v' = R; x_d is kept; the hinge line and the body
// stay put.
TEST(Peel, CurlsTheFlapOutward) {
  for (Axis curl : kAxes)
    for (Axis entry : kAxes)
      for (int side : {1, -1}) {
        if (curl == entry) continue;
        const Case c = make_case(kHalf, curl, entry, side, Params{90.0, 0.3, 0.8, -0.5});
        const Frame& f = c.f;
        Eigen::Vector3d p = Eigen::Vector3d::Zero();
        p[f.d] = 0.25 * kHalf[f.d];
        p[f.a] = f.hinge + f.length();
        p[f.e] = f.side * f.cut;
        Eigen::Vector3d expected = p;
        expected[f.a] = f.hinge + f.radius;
        expected[f.e] = f.side * (f.cut + f.radius);
        EXPECT_LE((c.deformer->forward(p) - expected).norm(), 1e-14) << c.deformer->describe();
        p[f.e] -= f.side * 1e-9;  // just under the cut: the body
        EXPECT_EQ(c.deformer->forward(p), p) << c.deformer->describe();
        p[f.a] = f.hinge;  // the hinge line
        p[f.e] = f.side * (f.cut + 0.5 * f.t);
        EXPECT_LE((c.deformer->forward(p) - p).norm(), 1e-14) << c.deformer->describe();
        EXPECT_TRUE(c.deformer->has_cut());
      }
}

// A > 0 exactly on the cut region, restated in polar form (Frame::in_cut). On the flap's side
// (s' >= 0) that is the gap, with no preimage off the fold: not p' itself (F moves the flap
// region) nor a flap point (the non-folded preimage q has v(q) < 0). Past 90 degrees it also holds
// the space beyond the overhanging flap's underside (s' < 0), which lies outside the box when
// R >= t / 2 (all cases here), so no point of the cut region is the box's material. At F(p) for p
// in the box (off the folded part) A <= 0.
TEST(Peel, AlphaPositiveExactlyOnTheCut) {
  std::mt19937_64 rng(5);
  int overhang = 0;
  for (const Case& c : all_cases()) {
    const Frame& f = c.f;
    ASSERT_GE(2.0 * f.radius, f.t);
    const Eigen::AlignedBox3d bounds = deformed_bounds(*c.deformer, kHalf, 0.3);
    int in_cut = 0;
    for (int k = 0; k < testing::samples(4000); ++k) {
      const Eigen::Vector3d p_def = random_in(rng, bounds);
      const double a = c.deformer->alpha(p_def);
      if (std::abs(a) < 1e-12) continue;  // on the boundary, to rounding
      const bool cut = f.in_cut(p_def);
      in_cut += cut;
      EXPECT_EQ(a > 0.0, cut) << c.deformer->describe() << " at " << p_def.transpose();
      if (cut && f.s(p_def) < 0.0) {
        ++overhang;
        EXPECT_GT(f.theta_max, std::numbers::pi / 2.0) << c.deformer->describe();
        EXPECT_FALSE((p_def.cwiseAbs().array() <= kHalf.array()).all()) << c.deformer->describe();
      }
      Eigen::Vector3d p = random_point(rng, kHalf);
      if (f.in_flap(p) && f.v(p) >= f.radius) continue;  // folded
      EXPECT_LE(c.deformer->alpha(c.deformer->forward(p)), 0.0) << c.deformer->describe();
    }
    EXPECT_GT(in_cut, 0) << c.deformer->describe();
  }
  EXPECT_GT(overhang, 0);
  std::printf("[figures] peel: %d sampled cut points beyond the overhang's underside (s' < 0)\n",
              overhang);
}

// |A(p) - A(q)| <= |p - q|, for pairs far apart and pairs 1e-3 of the box apart.
TEST(Peel, AlphaIsOneLipschitz) {
  std::mt19937_64 rng(6);
  double worst_all = 0.0;
  for (const Case& c : all_cases()) {
    const Eigen::AlignedBox3d bounds = deformed_bounds(*c.deformer, kHalf, 0.3);
    double worst = 0.0;
    for (int k = 0; k < testing::samples(4000); ++k) {
      const Eigen::Vector3d p = random_in(rng, bounds);
      const Eigen::Vector3d q =
          k % 2 ? random_in(rng, bounds) : (p + random_point(rng, kHalf, 1e-3)).eval();
      const double ratio = std::abs(c.deformer->alpha(p) - c.deformer->alpha(q)) / (p - q).norm();
      worst = std::max(worst, ratio);
    }
    EXPECT_LE(worst, 1.0 + 1e-9) << c.deformer->describe();
    worst_all = std::max(worst_all, worst);
  }
  std::printf("[figures] peel alpha: largest |dA| / |dp| %.6f\n", worst_all);
}

// |A(p')| against the distance to the cut region's boundary by brute force. The region is a prism
// along d, so its distance is the one in the (s, v) plane, where it is classified on a lattice of
// spacing sp over the deformed bounds and its boundary sampled at the midpoints of neighbouring
// nodes of opposite class: |A| <= distance + 1.5 sp (as in incision_test). Near the two cut faces
// A is the distance itself; the figure printed is the worst distance - |A| in the cut.
TEST(Peel, AlphaBoundsDistanceToTheCut) {
  std::mt19937_64 rng(7);
  const int nodes = 400;
  double worst_over = 0.0, worst_under = 0.0;
  for (const Case& c : all_cases()) {
    const Frame& f = c.f;
    if (f.d != 2 && f.e != 2) continue;  // one slice orientation per face is enough
    const Eigen::AlignedBox3d bounds = deformed_bounds(*c.deformer, kHalf, 0.2);
    // The bounds in (s, v), whichever way e points.
    const double v0 = f.side * bounds.min()[f.e] - f.cut, v1 = f.side * bounds.max()[f.e] - f.cut;
    const Eigen::Vector2d lo(bounds.min()[f.a] - f.hinge, std::min(v0, v1));
    const Eigen::Vector2d hi(bounds.max()[f.a] - f.hinge, std::max(v0, v1));
    const double sp = (hi - lo).maxCoeff() / nodes;
    const Eigen::Vector2i dims = ((hi - lo) / sp).array().ceil().cast<int>();
    auto node = [&](int i, int j) -> Eigen::Vector2d { return lo + sp * Eigen::Vector2d(i, j); };
    std::vector<char> gap(static_cast<size_t>(dims.prod()));
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) {
        const Eigen::Vector2d q = node(i, j);
        gap[i + dims.x() * j] = f.in_cut(q.x(), q.y());
      }
    std::vector<Eigen::Vector2d> boundary;
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) {
        if (i + 1 < dims.x() && gap[i + dims.x() * j] != gap[i + 1 + dims.x() * j])
          boundary.push_back(0.5 * (node(i, j) + node(i + 1, j)));
        if (j + 1 < dims.y() && gap[i + dims.x() * j] != gap[i + dims.x() * (j + 1)])
          boundary.push_back(0.5 * (node(i, j) + node(i, j + 1)));
      }
    ASSERT_FALSE(boundary.empty()) << c.deformer->describe();
    for (int t = 0; t < 300; ++t) {
      const Eigen::Vector3d p = random_in(rng, bounds);
      const Eigen::Vector2d q(f.s(p), f.v(p));
      double distance = std::numeric_limits<double>::infinity();
      for (const Eigen::Vector2d& b : boundary) distance = std::min(distance, (q - b).norm());
      const double a = c.deformer->alpha(p);
      worst_over = std::max(worst_over, std::abs(a) - distance);
      EXPECT_LE(std::abs(a), distance + 1.5 * sp) << c.deformer->describe() << " at " << q;
      if (a > 0.0) worst_under = std::max(worst_under, distance - a);
    }
  }
  std::printf(
      "[figures] peel |A| - brute-force distance: worst %.3g; in the cut, distance - A: "
      "worst %.3g\n",
      worst_over, worst_under);
}

// Deformer's contract: inside the cut the inverse continues the nearer side's, so D is continuous
// across the cut's faces and its jump lies inside the cut. Random segments from a point outside
// the cut (A < 0) to one inside are bisected on the sign of A down to 1e-10 of the box; where the
// outer end's preimage is material (in the box), D must agree on both ends to within its
// Lipschitz constant times the step (at most ~1e-8 here).
TEST(Peel, InverseContinuousAcrossTheCutFaces) {
  std::mt19937_64 rng(10);
  double worst_all = 0.0;
  int checked = 0;
  for (const Case& c : all_cases()) {
    const Eigen::AlignedBox3d bounds = deformed_bounds(*c.deformer, kHalf, 0.1);
    double worst = 0.0;
    for (int k = 0; k < testing::samples(400); ++k) {
      Eigen::Vector3d out = random_in(rng, bounds), in = random_in(rng, bounds);
      if (!(c.deformer->alpha(out) < 0.0)) std::swap(out, in);
      if (!(c.deformer->alpha(out) < 0.0 && c.deformer->alpha(in) > 0.0)) continue;
      while ((in - out).norm() > 1e-10 * kHalf.norm()) {
        const Eigen::Vector3d mid = 0.5 * (in + out);
        (c.deformer->alpha(mid) > 0.0 ? in : out) = mid;
      }
      const Eigen::Vector3d p_out = c.deformer->inverse(out);
      if (!(p_out.cwiseAbs().array() <= kHalf.array()).all()) continue;
      ++checked;
      const Eigen::Vector3d jump = (c.deformer->inverse(in) - in) - (p_out - out);
      worst = std::max(worst, jump.norm());
    }
    EXPECT_LE(worst, 1e-6 * kHalf.norm()) << c.deformer->describe();
    worst_all = std::max(worst_all, worst);
  }
  EXPECT_GT(checked, testing::samples(1000));
  std::printf("[figures] peel D across the cut faces: %d points, worst jump %.3g\n", checked,
              worst_all);
}

// det <= 0 exactly on the curved part's slab v >= R of the layer, whose volume is
// (t - R) min(L, h_a - hinge) 2 h_d when R < t, and 0 otherwise. The lattice counts cell centres,
// so it misses at most one layer of cells across v and one across s: 2 box volume / samples.
TEST(Peel, FoldedVolumeMatchesClosedForm) {
  const int samples = 64;
  double worst = 0.0;
  for (const Case& c : all_cases()) {
    const Frame& f = c.f;
    const double expected = std::max(0.0, f.t - f.radius) *
                            std::min(f.length(), kHalf[f.a] - f.hinge) * 2.0 * kHalf[f.d];
    const FoldReport report = measure_folds(*c.deformer, kHalf, samples);
    EXPECT_NEAR(report.folded_volume, expected, 2.0 * report.box_volume / samples)
        << c.deformer->describe();
    EXPECT_EQ(report.folds(), f.folds()) << c.deformer->describe();
    worst = std::max(worst, std::abs(report.folded_volume - expected));
  }
  std::printf("[figures] peel folded volume vs closed form: worst error %.3g (box volume %.3g)\n",
              worst, 8.0 * kHalf.prod());
}

// The bake: finite everywhere, w = 1 exactly where the analytic preimage lies in the box, D the
// analytic one to float rounding, and outside the cut every valid texel a true image point:
// F(p' + D) = p'. The box points' images have w = 1 (round trip above).
TEST(Peel, BakeIsFiniteAndFlagsTheImage) {
  const std::vector<Case> cases = all_cases();
  for (size_t pick : {size_t{0}, size_t{7}, size_t{14}, size_t{27}, size_t{40}, size_t{71}}) {
    const Case& c = cases[pick % cases.size()];
    const DeformationTexture texture = bake_deformation(*c.deformer, kHalf, 48);
    const Grid3<Eigen::Vector4f>& grid = texture.grid;
    int valid = 0;
    for (int k = 0; k < grid.dims.z(); ++k)
      for (int j = 0; j < grid.dims.y(); ++j)
        for (int i = 0; i < grid.dims.x(); ++i) {
          const Eigen::Vector4f& texel = grid.at(i, j, k);
          ASSERT_TRUE(texel.allFinite());
          const Eigen::Vector3d p_def = grid.texel_centre(i, j, k);
          const Eigen::Vector3d p = c.deformer->inverse(p_def);
          const bool inside = (p.cwiseAbs().array() <= kHalf.array()).all();
          EXPECT_EQ(texel.w(), inside ? 1.0f : 0.0f);
          EXPECT_LE((texel.head<3>().cast<double>() - (p - p_def)).norm(), 1e-6);
          if (inside && c.deformer->alpha(p_def) < 0.0) {
            ++valid;
            EXPECT_LE((c.deformer->forward(p) - p_def).norm(), 1e-12) << c.deformer->describe();
          }
        }
    EXPECT_GT(valid, 1000) << c.deformer->describe();
    std::mt19937_64 rng(9);
    for (int n = 0; n < testing::samples(1000); ++n) {
      const Eigen::Vector3d p = random_unfolded_point(rng, c.f, kHalf);
      const Eigen::Vector3d back = c.deformer->inverse(c.deformer->forward(p));
      EXPECT_TRUE((back.cwiseAbs().array() <= kHalf.array() * (1.0 + 1e-12)).all());
    }
  }
}

// Faces -a (the flap starts at s = 0 at the earliest, where it does not move) and opposite `from`
// are the identity; +a, +-d and `from` carry the flap.
TEST(Peel, IdentityFaces) {
  std::mt19937_64 rng(8);
  for (const Case& c : all_cases()) {
    const Frame& f = c.f;
    const auto faces = c.deformer->identity_faces();
    const int opposite = 2 * f.e + (f.side > 0 ? 0 : 1);
    for (int i = 0; i < 6; ++i) {
      EXPECT_EQ(faces[i], i == 2 * f.a || i == opposite) << c.deformer->describe() << " " << i;
      double moved = 0.0;
      for (int k = 0; k < 400; ++k) {
        Eigen::Vector3d p = random_point(rng, kHalf);
        p[i / 2] = (i % 2 ? 1.0 : -1.0) * kHalf[i / 2];
        moved = std::max(moved, (c.deformer->forward(p) - p).norm());
      }
      if (faces[i])
        EXPECT_LE(moved, 4.0 * kEps * kHalf.norm()) << c.deformer->describe() << " face " << i;
      else
        EXPECT_GT(moved, 1e-3) << c.deformer->describe() << " face " << i;
    }
  }
}

TEST(Peel, FiniteForAnyFiniteInput) {
  const double big = std::numeric_limits<double>::max();
  const double tiny = std::numeric_limits<double>::denorm_min();
  std::vector<std::unique_ptr<Deformer>> deformers;
  for (Case& c : all_cases()) deformers.push_back(std::move(c.deformer));
  for (double radius : {tiny, 1e-300, 1e-12, 1e300, big})
    for (double angle : {1e-300, 90.0, 180.0})
      deformers.push_back(make_peel(kHalf, Axis::Z, Face{Axis::Y, -1}, angle, 0.5, radius, -0.6));
  for (const auto& deformer : deformers) {
    // The hinge line on the cut plane of the last ones: their centre of curvature for a tiny R.
    const Eigen::Vector3d hinge_line(-0.6, -0.4, 0.0);
    for (const Eigen::Vector3d& p :
         {Eigen::Vector3d(big, -big, big), Eigen::Vector3d(-big, big, -big),
          Eigen::Vector3d(big, big, big), Eigen::Vector3d(tiny, 0.0, -tiny),
          Eigen::Vector3d(1e200, 1e-200, -1e100), Eigen::Vector3d(0.1, -big, 0.2), hinge_line}) {
      EXPECT_TRUE(deformer->forward(p).allFinite()) << deformer->describe() << " " << p;
      EXPECT_TRUE(deformer->inverse(p).allFinite()) << deformer->describe() << " " << p;
      EXPECT_TRUE(deformer->jacobian(p).allFinite()) << deformer->describe() << " " << p;
      EXPECT_TRUE(std::isfinite(deformer->alpha(p))) << deformer->describe() << " " << p;
    }
  }
}

// The message for a make_peel call that must throw.
std::string error_of(const std::function<void()>& make) {
  try {
    make();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Peel, DescribeAndErrors) {
  const Eigen::Vector3d h(1.0, 0.5, 1.5);
  EXPECT_EQ(make_peel(h, Axis::Z, Face{Axis::Y, 1}, 120.0, 0.8, 1.5, 0.0)->describe(),
            "peel of +y layer 0.8 thick about z by 120\u00b0, radius 1.5, hinge 0");
  EXPECT_EQ(make_peel(h, Axis::X, Face{Axis::Z, -1}, 45.0, 0.25, 0.5, -0.5)->describe(),
            "peel of -z layer 0.25 thick about x by 45\u00b0, radius 0.5, hinge -0.5");
  auto make = [&](Axis curl, Face from, double angle, double t, double radius, double hinge) {
    return [=]() { make_peel(h, curl, from, angle, t, radius, hinge); };
  };
  const Face top{Axis::Y, 1};  // a = x for a curl about z
  EXPECT_EQ(error_of(make(Axis::Y, top, 90, 0.5, 1, 0)),
            "peel axis = y: must differ from the axis of `from` (+y)");
  EXPECT_EQ(error_of(make(Axis::Z, Face{Axis::Y, 2}, 90, 0.5, 1, 0)),
            "peel from.side = 2: must be +1 or -1");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {0.0, -30.0, 180.5, nan})
    EXPECT_EQ(error_of(make(Axis::Z, top, bad, 0.5, 1, 0)),
              "peel angle_deg = " + shortest_text(bad) + ": must be in (0, 180]");
  for (double bad : {0.0, -0.5, 1.0, nan})
    EXPECT_EQ(error_of(make(Axis::Z, top, 90, bad, 1, 0)),
              "peel thickness = " + shortest_text(bad) + ": must be in (0, 2 h_y = 1)");
  for (double bad : {0.0, -1.0, inf, nan})
    EXPECT_EQ(error_of(make(Axis::Z, top, 90, 0.5, bad, 0)),
              "peel radius = " + shortest_text(bad) + ": must be > 0 and finite");
  for (double bad : {1.0, -1.0000001, 7.0, nan})
    EXPECT_EQ(error_of(make(Axis::Z, top, 90, 0.5, 1, bad)),
              "peel hinge = " + shortest_text(bad) + ": must be in [-h_x, h_x) = [-1, 1)");
  EXPECT_EQ(error_of(make(Axis::Y, Face{Axis::Z, -1}, 90, 0.5, 1, 1.2)),
            "peel hinge = 1.2: must be in [-h_x, h_x) = [-1, 1)");
  EXPECT_THROW(make_peel(Eigen::Vector3d(1, 1, -1), Axis::Z, top, 90, 0.5, 1, 0), Error);
  EXPECT_NO_THROW(make_peel(h, Axis::Z, top, 180.0, 0.999, 1e-9, -1.0));
}

}  // namespace
}  // namespace raywarp
