// Numerical experiments on the incision (deformers/incision.h): round trips of the analytic
// inverse, the analytic Jacobian against central differences, the alpha map against the gap
// (sign, Lipschitz bound, distance by brute force), folds, the bake, the identity faces and the
// input checks, for every normal axis and entry face.
#include "deformers/incision.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "base/error.h"
#include "library/deformation_bake.h"
#include "tests/sanitizer.h"

namespace raywarp {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr Axis kAxes[] = {Axis::X, Axis::Y, Axis::Z};
// Uneven, so that a mixed-up axis shows.
const Eigen::Vector3d kHalf(0.6, 0.9, 0.45);

// depth as a fraction of 2 h_e, opening as a fraction of 2 h_n.
struct Params {
  double depth_frac, opening_frac;
};
constexpr Params kParams[] = {{0.5, 0.3}, {1.0, 0.6}, {0.25, 0.9}, {0.8, 0.05}};

// The incision's axes and opening, restated from incision.h.
struct Frame {
  int n, e, l;
  double side, depth, opening, u_end;
  Eigen::Vector3d h;
  // c(p) = (opening / 2) r(u) m(x_l).
  double c(const Eigen::Vector3d& p) const {
    const double r = std::clamp((side * p[e] - u_end) / depth, 0.0, 1.0);
    const double t = std::min(std::abs(p[l]) / h[l], 1.0);
    return 0.5 * opening * r * (1.0 - t * t);
  }
  bool in_gap(const Eigen::Vector3d& p) const { return std::abs(p[n]) < c(p); }
  double lipschitz() const {
    return std::sqrt(1.0 + std::pow(0.5 * opening / depth, 2) + std::pow(opening / h[l], 2));
  }
};

struct Case {
  Frame f;
  std::unique_ptr<Deformer> deformer;
};

// Every normal axis, entry face and parameter set.
std::vector<Case> all_cases(const Eigen::Vector3d& h = kHalf) {
  std::vector<Case> cases;
  for (Axis normal : kAxes)
    for (Axis entry : kAxes)
      for (int side : {1, -1})
        for (const Params& params : kParams) {
          if (entry == normal) continue;
          Frame f;
          f.n = static_cast<int>(normal);
          f.e = static_cast<int>(entry);
          f.l = 3 - f.n - f.e;
          f.side = side;
          f.h = h;
          f.depth = params.depth_frac * 2.0 * h[f.e];
          f.opening = params.opening_frac * 2.0 * h[f.n];
          f.u_end = h[f.e] - f.depth;
          cases.push_back({f, make_incision(h, normal, Face{entry, side}, f.depth, f.opening)});
        }
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

// Each side maps affinely, x'_n = +-c + x_n (1 - c / h_n), so the inverse divides by
// 1 - c / h_n >= 1 - 0.9 = 0.1 (the widest opening here): a round trip costs ~10 * few eps of the
// box. Beyond the deformed bounds (padded by half the box) F is the identity or the slit's outward
// continuation, inverted just the same.
TEST(Incision, RoundTripForwardOfInverse) {
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
  std::printf("[figures] incision F(inverse(p')) - p': worst %.3g (tolerance %.3g)\n", worst_all,
              tol);
}

// F is one-to-one on all of space (each side maps into itself), so the round trip holds in the
// box and beyond it.
TEST(Incision, RoundTripInverseOfForward) {
  const double tol = 1e-9 * 2.0 * kHalf.norm();
  std::mt19937_64 rng(2);
  double worst_all = 0.0;
  for (const Case& c : all_cases()) {
    double worst = 0.0;
    for (int k = 0; k < testing::samples(5000); ++k) {
      const Eigen::Vector3d p = random_point(rng, kHalf, k % 2 ? 2.0 : 1.0);
      worst = std::max(worst, (c.deformer->inverse(c.deformer->forward(p)) - p).norm());
    }
    EXPECT_LE(worst, tol) << c.deformer->describe();
    worst_all = std::max(worst_all, worst);
  }
  std::printf("[figures] incision inverse(F(p)) - p: worst %.3g (tolerance %.3g)\n", worst_all,
              tol);
}

// x'_n is affine in x_n and in u, and quadratic in x_l, on each piece, so central differences
// with step d truncate nothing (the third derivatives vanish) and err only by rounding: each F
// carries ~4 eps |F|, so 2 * 4 eps |F| / (2 d). The points stay 2 d away from the kinks: the cut
// x_n = 0 (where F jumps), the side faces |x_n| = h_n, the ramp's ends u = u_end and u = h_e, and
// the +-l faces.
TEST(Incision, JacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(3);
  const double scale = 2.0;
  const double d = 1e-6 * 2.0 * kHalf.norm();
  const double f_max = scale * kHalf.norm();
  const double tol = 2.0 * (4.0 * kEps * f_max / d);
  double worst_all = 0.0;
  for (const Case& c : all_cases()) {
    const Frame& f = c.f;
    double worst = 0.0;
    for (int k = 0; k < testing::samples(2000); ++k) {
      const Eigen::Vector3d p = random_point(rng, kHalf, scale);
      const double u = f.side * p[f.e];
      if (std::abs(p[f.n]) < 2.0 * d || std::abs(std::abs(p[f.n]) - kHalf[f.n]) < 2.0 * d ||
          std::abs(u - f.u_end) < 2.0 * d || std::abs(u - kHalf[f.e]) < 2.0 * d ||
          std::abs(std::abs(p[f.l]) - kHalf[f.l]) < 2.0 * d)
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
  std::printf("[figures] incision Jacobian vs central differences: worst %.3g (tolerance %.3g)\n",
              worst_all, tol);
}

// det(dF/dp) = 1 - c / h_n > 0 inside the slab |x_n| < h_n and 1 beyond: no folds.
TEST(Incision, NeverFolds) {
  std::mt19937_64 rng(4);
  for (const Case& c : all_cases()) {
    for (int k = 0; k < testing::samples(1000); ++k) {
      const Eigen::Vector3d p = random_point(rng, kHalf);
      EXPECT_NEAR(c.deformer->jacobian(p).determinant(), 1.0 - c.f.c(p) / kHalf[c.f.n], 1e-14);
    }
    const FoldReport report = measure_folds(*c.deformer, kHalf, 32);
    EXPECT_EQ(report.folded_volume, 0.0) << c.deformer->describe();
    EXPECT_FALSE(report.folds());
  }
}

// Convention: at the entry face's centre the two sides of the cut part by the full opening, and
// the cut's end stays closed.
TEST(Incision, OpensAtTheEntryFace) {
  for (const Case& c : all_cases()) {
    const Frame& f = c.f;
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    p[f.e] = f.side * kHalf[f.e];
    EXPECT_EQ(c.deformer->forward(p)[f.n], 0.5 * f.opening) << c.deformer->describe();
    p[f.n] = -1e-300;
    EXPECT_NEAR(c.deformer->forward(p)[f.n], -0.5 * f.opening, 1e-15) << c.deformer->describe();
    EXPECT_NEAR(c.deformer->alpha(p), 0.5 * f.opening / f.lipschitz(), 1e-15);
    // The cut's end and the side faces do not move.
    p[f.e] = f.side * f.u_end;
    p[f.n] = 0.0;
    EXPECT_EQ(c.deformer->forward(p), p) << c.deformer->describe();
    EXPECT_TRUE(c.deformer->has_cut());
  }
}

// A > 0 exactly on the gap |x'_n| < c(p'), which has no preimage: F keeps x_e and x_l, so c, and
// maps each side onto c <= |x'_n|. At the images of box points A <= 0.
TEST(Incision, AlphaPositiveExactlyOnTheGap) {
  std::mt19937_64 rng(5);
  for (const Case& c : all_cases()) {
    const Eigen::AlignedBox3d bounds = deformed_bounds(*c.deformer, kHalf, 0.3);
    int in_gap = 0;
    for (int k = 0; k < testing::samples(4000); ++k) {
      const Eigen::Vector3d p_def = random_in(rng, bounds);
      const bool gap = c.f.in_gap(p_def);
      in_gap += gap;
      EXPECT_EQ(c.deformer->alpha(p_def) > 0.0, gap) << c.deformer->describe();
      const Eigen::Vector3d p = random_point(rng, kHalf);
      EXPECT_LE(c.deformer->alpha(c.deformer->forward(p)), 0.0) << c.deformer->describe();
    }
    EXPECT_GT(in_gap, 0) << c.deformer->describe();
  }
}

// |A(p) - A(q)| <= |p - q|, for pairs far apart and pairs 1e-3 of the box apart (which probe the
// gradient, largest where the ramp and the profile are steepest).
TEST(Incision, AlphaIsOneLipschitz) {
  std::mt19937_64 rng(6);
  double worst_all = 0.0;
  for (const Case& c : all_cases()) {
    double worst = 0.0;
    for (int k = 0; k < testing::samples(4000); ++k) {
      const Eigen::Vector3d p = random_point(rng, kHalf, 1.3);
      const Eigen::Vector3d q =
          k % 2 ? random_point(rng, kHalf, 1.3) : (p + random_point(rng, kHalf, 1e-3)).eval();
      const double ratio = std::abs(c.deformer->alpha(p) - c.deformer->alpha(q)) / (p - q).norm();
      worst = std::max(worst, ratio);
    }
    EXPECT_LE(worst, 1.0 + 1e-9) << c.deformer->describe();
    worst_all = std::max(worst_all, worst);
  }
  std::printf("[figures] incision alpha: largest |dA| / |dp| %.6f\n", worst_all);
}

// |A(p')| against the distance to the gap's boundary by brute force: the gap is classified on a
// lattice of spacing s over the box grown by a quarter, and the boundary sampled at the midpoints
// of neighbouring nodes of opposite class (each within s / 2 of the boundary, and every boundary
// point within s (sqrt(3) + 1) / 2 of one). So |A| <= distance + 1.5 s, and where c(p') > 0 (the
// boundary lies within |c - |x'_n|| along n) distance <= Lip |A| + 1.5 s.
TEST(Incision, AlphaBoundsDistanceToTheGap) {
  std::mt19937_64 rng(7);
  const int nodes = 72;
  const Eigen::Vector3d lo = -1.25 * kHalf, size = 2.5 * kHalf;
  const double s = size.maxCoeff() / nodes;
  const Eigen::Vector3i dims = (size / s).array().ceil().cast<int>();
  double worst_over = 0.0, worst_under = 0.0;
  for (const Case& c : all_cases()) {
    if (c.f.opening < 0.2 * kHalf[c.f.n]) continue;  // a gap thinner than the lattice
    auto node = [&](int i, int j, int k) -> Eigen::Vector3d {
      return lo + s * Eigen::Vector3d(i, j, k);
    };
    std::vector<char> gap(static_cast<size_t>(dims.prod()));
    auto index = [&](int i, int j, int k) { return i + dims.x() * (j + dims.y() * k); };
    for (int k = 0; k < dims.z(); ++k)
      for (int j = 0; j < dims.y(); ++j)
        for (int i = 0; i < dims.x(); ++i) gap[index(i, j, k)] = c.f.in_gap(node(i, j, k));
    std::vector<Eigen::Vector3d> boundary;
    for (int k = 0; k < dims.z(); ++k)
      for (int j = 0; j < dims.y(); ++j)
        for (int i = 0; i < dims.x(); ++i)
          for (const Eigen::Vector3i& step :
               {Eigen::Vector3i(1, 0, 0), Eigen::Vector3i(0, 1, 0), Eigen::Vector3i(0, 0, 1)}) {
            const Eigen::Vector3i m = Eigen::Vector3i(i, j, k) + step;
            if ((m.array() >= dims.array()).any()) continue;
            if (gap[index(i, j, k)] != gap[index(m.x(), m.y(), m.z())])
              boundary.push_back(0.5 * (node(i, j, k) + node(m.x(), m.y(), m.z())));
          }
    ASSERT_FALSE(boundary.empty()) << c.deformer->describe();
    for (int t = 0; t < 150; ++t) {
      const Eigen::Vector3d p = random_point(rng, kHalf);
      double distance = std::numeric_limits<double>::infinity();
      for (const Eigen::Vector3d& b : boundary) distance = std::min(distance, (p - b).norm());
      const double a = std::abs(c.deformer->alpha(p));
      worst_over = std::max(worst_over, a - distance);
      EXPECT_LE(a, distance + 1.5 * s) << c.deformer->describe() << " at " << p.transpose();
      if (c.f.c(p) > 0.0) {
        worst_under = std::max(worst_under, distance - c.f.lipschitz() * a);
        EXPECT_LE(distance, c.f.lipschitz() * a + 1.5 * s) << c.deformer->describe();
      }
    }
  }
  std::printf(
      "[figures] incision |A| - brute-force distance: worst %.3g; distance - Lip |A|: worst %.3g "
      "(lattice spacing %.3g)\n",
      worst_over, worst_under, s);
}

// Deformer's contract: inside the cut the inverse continues the nearer side's, so D is continuous
// across the cut's faces and its jump lies inside the cut. Random segments from a point outside
// the cut (A < 0) to one inside are bisected on the sign of A down to 1e-10 of the box; where the
// outer end's preimage is material (in the box), D must agree on both ends to within its
// Lipschitz constant times the step (at most ~1e-8 here).
TEST(Incision, InverseContinuousAcrossTheCutFaces) {
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
  std::printf("[figures] incision D across the cut faces: %d points, worst jump %.3g\n", checked,
              worst_all);
}

// The bake: finite everywhere, w = 1 exactly where the analytic preimage lies in the box, D the
// analytic one to float rounding, and outside the gap w = 1 exactly on the box (F maps the box
// onto the box minus the gap, and nothing outside it into it).
TEST(Incision, BakeIsFiniteAndFlagsTheImage) {
  const std::vector<Case> cases = all_cases();
  for (size_t pick : {size_t{0}, size_t{5}, size_t{18}, size_t{47}}) {
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
          if (c.deformer->alpha(p_def) < 0.0) {
            const bool in_box = (p_def.cwiseAbs().array() <= kHalf.array()).all();
            EXPECT_EQ(texel.w() == 1.0f, in_box) << c.deformer->describe() << " " << p_def;
            valid += in_box;
          }
        }
    EXPECT_GT(valid, 1000) << c.deformer->describe();
  }
}

TEST(Incision, IdentityFaces) {
  std::mt19937_64 rng(8);
  for (const Case& c : all_cases()) {
    const auto faces = c.deformer->identity_faces();
    for (int i = 0; i < 6; ++i) {
      const bool entry = i == 2 * c.f.e + (c.f.side > 0 ? 1 : 0);
      EXPECT_EQ(faces[i], !entry) << c.deformer->describe() << " face " << i;
      double moved = 0.0;
      for (int k = 0; k < 200; ++k) {
        Eigen::Vector3d p = random_point(rng, kHalf);
        p[i / 2] = (i % 2 ? 1.0 : -1.0) * kHalf[i / 2];
        moved = std::max(moved, (c.deformer->forward(p) - p).norm());
      }
      if (faces[i])
        EXPECT_EQ(moved, 0.0) << c.deformer->describe() << " face " << i;
      else
        EXPECT_GT(moved, 1e-3 * c.f.opening) << c.deformer->describe() << " face " << i;
    }
  }
}

TEST(Incision, FiniteForAnyFiniteInput) {
  const double big = std::numeric_limits<double>::max();
  const double tiny = std::numeric_limits<double>::denorm_min();
  std::vector<std::unique_ptr<Deformer>> deformers;
  for (const Case& c : all_cases())
    deformers.push_back(make_incision(kHalf, static_cast<Axis>(c.f.n),
                                      Face{static_cast<Axis>(c.f.e), static_cast<int>(c.f.side)},
                                      c.f.depth, c.f.opening));
  deformers.push_back(make_incision(kHalf, Axis::X, Face{Axis::Y, 1}, 1e-300, 1.2 * (1 - 1e-15)));
  deformers.push_back(make_incision(kHalf, Axis::Z, Face{Axis::X, -1}, 1.2, 1e-300));
  for (const auto& deformer : deformers)
    for (const Eigen::Vector3d& p :
         {Eigen::Vector3d(big, -big, big), Eigen::Vector3d(-big, big, -big),
          Eigen::Vector3d(tiny, 0.0, -tiny), Eigen::Vector3d(-0.0, 0.0, -0.0),
          Eigen::Vector3d(1e200, 1e-200, -1e100), Eigen::Vector3d(0.1, -big, 0.2)}) {
      EXPECT_TRUE(deformer->forward(p).allFinite()) << deformer->describe();
      EXPECT_TRUE(deformer->inverse(p).allFinite()) << deformer->describe();
      EXPECT_TRUE(deformer->jacobian(p).allFinite()) << deformer->describe();
      EXPECT_TRUE(std::isfinite(deformer->alpha(p))) << deformer->describe();
    }
}

// The message for a make_incision call that must throw.
std::string error_of(const std::function<void()>& make) {
  try {
    make();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Incision, DescribeAndErrors) {
  const Eigen::Vector3d h(0.6, 1.5, 0.45);
  EXPECT_EQ(make_incision(h, Axis::X, Face{Axis::Y, 1}, 3.0, 1.1)->describe(),
            "incision normal x from +y, depth 3, opening 1.1");
  EXPECT_EQ(make_incision(h, Axis::Z, Face{Axis::X, -1}, 0.5, 0.25)->describe(),
            "incision normal z from -x, depth 0.5, opening 0.25");
  auto make = [&](Axis normal, Face from, double depth, double opening) {
    return [=]() { make_incision(h, normal, from, depth, opening); };
  };
  EXPECT_EQ(error_of(make(Axis::Y, Face{Axis::Y, 1}, 1.0, 0.5)),
            "incision normal = y: must differ from the axis of `from` (+y)");
  EXPECT_EQ(error_of(make(Axis::X, Face{Axis::Y, 0}, 1.0, 0.5)),
            "incision from.side = 0: must be +1 or -1");
  for (double bad : {0.0, -1.0, 3.0000001, std::numeric_limits<double>::quiet_NaN()})
    EXPECT_EQ(error_of(make(Axis::X, Face{Axis::Y, -1}, bad, 0.5)),
              "incision depth = " + shortest_text(bad) + ": must be in (0, 2 h_y = 3]");
  for (double bad : {0.0, -0.5, 1.2, std::numeric_limits<double>::infinity()})
    EXPECT_EQ(error_of(make(Axis::X, Face{Axis::Y, 1}, 1.0, bad)),
              "incision opening = " + shortest_text(bad) + ": must be in (0, 2 h_x = 1.2)");
  EXPECT_THROW(make_incision(Eigen::Vector3d(1, 0, 1), Axis::X, Face{Axis::Y, 1}, 1, 0.5), Error);
  EXPECT_NO_THROW(make_incision(h, Axis::X, Face{Axis::Y, 1}, 3.0, 1.1999));
}

}  // namespace
}  // namespace raywarp
