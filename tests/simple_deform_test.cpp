// Named after no one source: two types (taper, stretch) against one restated algorithm.
// Numerical experiments on Blender's Simple Deform modes taper and stretch (deformers/taper.h,
// deformers/stretch.h): the forward map against Blender's algorithm restated independently, round
// trips of the analytic inverse, the analytic Jacobian against central differences, the identity
// faces, finite results for huge and odd inputs, the parameter ranges and their messages.
#include <gtest/gtest.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "base/error.h"
#include "deformers/stretch.h"
#include "deformers/taper.h"

namespace raywarp {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr Axis kAxes[] = {Axis::X, Axis::Y, Axis::Z};
// Uneven boxes, so that a mixed-up axis shows. kHalf has lengths 1.4 (<= sqrt 2, where the
// stretch's lower bound is -L), 2.6 and 0.8 (< 1, where z^2 < z); kLong has 12 and 16 (> 10,
// where the stretch's upper bound is the cap 10, closed) and 1.
const Eigen::Vector3d kHalf(0.7, 1.3, 0.4);
const Eigen::Vector3d kLong(6.0, 0.5, 8.0);
const Eigen::Vector3d kBoxes[] = {kHalf, kLong};

enum class Mode { Taper, Stretch };

std::unique_ptr<Deformer> make(Mode m, const Eigen::Vector3d& h, Axis axis, double factor) {
  return m == Mode::Taper ? make_taper(h, axis, factor) : make_stretch(h, axis, factor);
}

// The stretch's range, restated from stretch.h: lo < f < min(L, 10) (f <= 10 when L > 10),
// lo = -L for L <= sqrt(2), else -L / (L^2 - 1) (written -1 / (L - 1 / L) for huge L).
struct Range {
  double lo, hi;
  bool hi_closed;
};
Range stretch_range(double L) {
  return {L <= std::sqrt(2.0) ? -L : -1.0 / (L - 1.0 / L), std::min(L, 10.0), L > 10.0};
}

// The factors tried for a box of length L along the axis: both extremes of the range (1e-3 of
// its size inside an open end, the closed end itself), moderate values of both signs, tiny ones
// and zero.
std::vector<double> factors(Mode m, double L) {
  if (m == Mode::Taper) return {-0.999, -0.5, -1e-6, 0.0, 1e-6, 0.8, 3.0, 10.0};
  const Range r = stretch_range(L);
  const double top = r.hi_closed ? r.hi : r.hi * (1.0 - 1e-3);
  const double tiny = 1e-6 * std::min(-r.lo, r.hi);
  return {r.lo * (1.0 - 1e-3), 0.3 * r.lo, -tiny, 0.0, tiny, 0.3 * r.hi, top};
}

// Uniform in [-scale h, scale h].
Eigen::Vector3d random_point(std::mt19937_64& rng, const Eigen::Vector3d& h, double scale = 1.0) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  return scale * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(h);
}

// Blender's SimpleDeformModifier_do and simple_helper (MOD_simpledeform.cc) for one vertex, in
// double, with raywarp's box as the limits and the origin object at the centre of the box's lower
// face along `axis`: into the origin's frame; the limits [lower, upper] of the axis coordinate
// are the box, [0, 2 h_a] in that frame, and the factor is divided by their distance (at least
// FLT_EPSILON); the axis coordinate is clamped to them (axis_limit), the clamped-off part kept
// in dcut; the coordinates are remapped so that the axis is the third (axis_map_table); the mode's
// formula; dcut added; remapped back; out of the origin's frame.
Eigen::Vector3d blender_simple_deform(Mode mode, const Eigen::Vector3d& h, Axis axis, double factor,
                                      const Eigen::Vector3d& p) {
  const int a = static_cast<int>(axis);
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  origin[a] = -h[a];
  double co[3] = {p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]};
  const double lower = 0.0, upper = 2.0 * h[a];
  const double smd_factor = factor / std::max(double(FLT_EPSILON), upper - lower);
  double dcut[3] = {0.0, 0.0, 0.0};
  const double limited = std::min(upper, std::max(lower, co[a]));
  dcut[a] = co[a] - limited;
  co[a] = limited;
  // Blender's table: for the x axis (x, y, z) <- (y, z, x), for y <- (z, x, y), for z unchanged.
  static const int remap[3][3] = {{1, 2, 0}, {2, 0, 1}, {0, 1, 2}};
  const int* m = remap[a];
  double x = co[m[0]], y = co[m[1]], z = co[m[2]];
  if (mode == Mode::Taper) {
    const double scale = z * smd_factor;
    x = x + x * scale;
    y = y + y * scale;
  } else {
    const double scale = z * z * smd_factor - smd_factor + 1.0;
    x = x * scale;
    y = y * scale;
    z = z * (1.0 + smd_factor);
  }
  double out[3];
  out[m[0]] = x + dcut[m[0]];
  out[m[1]] = y + dcut[m[1]];
  out[m[2]] = z + dcut[m[2]];
  return Eigen::Vector3d(out[0], out[1], out[2]) + origin;
}

// For every mode, box, axis and factor.
template <typename Body>
void for_each_case(Body body) {
  for (Mode mode : {Mode::Taper, Mode::Stretch})
    for (const Eigen::Vector3d& h : kBoxes)
      for (Axis axis : kAxes)
        for (double f : factors(mode, 2.0 * h[static_cast<int>(axis)]))
          body(mode, h, axis, f, *make(mode, h, axis, f));
}

// Both compute the same few products and sums in a different order, in double: they agree to a
// few eps of the largest term, |s| |p| <= (1 + |f| L) |p| on a slice (s reaches 1 + f (L - 1/L)
// for the stretch, 1 + f for the taper).
TEST(SimpleDeform, ForwardMatchesBlender) {
  std::mt19937_64 rng(1);
  double worst = 0.0;
  for_each_case([&](Mode mode, const Eigen::Vector3d& h, Axis axis, double f, const Deformer& d) {
    const double L = 2.0 * h[static_cast<int>(axis)];
    const double s_max = 1.0 + std::abs(f) * (1.0 + L);
    for (int n = 0; n < 4000; ++n) {
      // Inside the box, then beyond it on every side, where Blender's clamp holds the scale.
      const Eigen::Vector3d p = random_point(rng, h, n % 2 ? 3.0 : 1.0);
      const Eigen::Vector3d expected = blender_simple_deform(mode, h, axis, f, p);
      const double err = (d.forward(p) - expected).norm() / (s_max * (p.norm() + h.norm()));
      worst = std::max(worst, err);
      ASSERT_LE(err, 1e-14) << d.describe() << " at " << p.transpose();
    }
  });
  std::printf("forward against Blender: worst relative error %.3g\n", worst);
}

// Every accepted factor keeps the scale > 0 (and the stretch's 1 + k > 0), so F is a bijection
// of space: both round trips hold inside the box and beyond it. F(p) carries a few eps of
// |F(p)| + |h| of rounding (the box-centred coordinates), which the inverse amplifies by
// |J^-1|: 1e3 and more next to the ends of the ranges (the stretch with 1 + k = 1e-3 squeezes the
// axis 1000-fold), ~1 elsewhere. The bar: 1e-12 of |p| + |h|, times max(1, |J^-1|) for
// inverse(F(p)) and max(1, cond(J)) for F(inverse(p')); the worst raw figures are printed.
TEST(SimpleDeform, RoundTrips) {
  std::mt19937_64 rng(2);
  double raw_ifp = 0.0, raw_fip = 0.0, scaled_ifp = 0.0, scaled_fip = 0.0, worst_kappa = 0.0;
  for_each_case([&](Mode, const Eigen::Vector3d& h, Axis, double, const Deformer& d) {
    for (int n = 0; n < 4000; ++n) {
      const Eigen::Vector3d p = random_point(rng, h, n % 2 ? 3.0 : 1.0);
      const Eigen::Matrix3d J = d.jacobian(p), J_inv = J.inverse();
      const double kappa = J_inv.cwiseAbs().rowwise().sum().maxCoeff();  // |J^-1|, infinity norm
      const double ifp = (d.inverse(d.forward(p)) - p).norm() / (p.norm() + h.norm());
      // p' in F(box) and its surroundings, and p' anywhere near the box.
      const Eigen::Vector3d p_def = n % 4 < 2 ? d.forward(p) : random_point(rng, h, 3.0);
      const Eigen::Vector3d back = d.inverse(p_def);
      const Eigen::Matrix3d Jb = d.jacobian(back);
      const double cond = Jb.cwiseAbs().rowwise().sum().maxCoeff() *
                          Jb.inverse().cwiseAbs().rowwise().sum().maxCoeff();
      const double fip = (d.forward(back) - p_def).norm() / (p_def.norm() + h.norm());
      raw_ifp = std::max(raw_ifp, ifp);
      raw_fip = std::max(raw_fip, fip);
      scaled_ifp = std::max(scaled_ifp, ifp / std::max(1.0, kappa));
      scaled_fip = std::max(scaled_fip, fip / std::max(1.0, cond));
      worst_kappa = std::max(worst_kappa, kappa);
      ASSERT_LE(ifp, 1e-12 * std::max(1.0, kappa)) << d.describe() << " at " << p.transpose();
      ASSERT_LE(fip, 1e-12 * std::max(1.0, cond)) << d.describe() << " at " << p_def.transpose();
    }
  });
  std::printf(
      "inverse(F(p)) - p: %.3g (%.3g / max(1, |J^-1|)), F(inverse(p')) - p': %.3g (%.3g / "
      "max(1, cond J)), relative; |J^-1| up to %.3g\n",
      raw_ifp, scaled_ifp, raw_fip, scaled_fip, worst_kappa);
}

// Central differences with step d: F is at most quadratic along any one coordinate on each side
// of the limit planes (the stretch's s(q_a) q_u), so their truncation error is 0 and what is left
// is rounding: ~4 eps |F| in each F and eps |p| in each p +- d e_j (times |J|), over 2 d. The
// points stay 2 d away from the planes q_a = 0, L, where the Jacobian jumps.
TEST(SimpleDeform, JacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(3);
  double worst_ratio = 0.0, worst_abs = 0.0;
  for_each_case([&](Mode, const Eigen::Vector3d& h, Axis axis, double, const Deformer& def) {
    const int a = static_cast<int>(axis);
    const double d = 1e-6 * h.norm();
    for (int n = 0; n < 1000; ++n) {
      const Eigen::Vector3d p = random_point(rng, h, n % 2 ? 2.5 : 1.0);
      if (std::abs(std::abs(p[a]) - h[a]) < 2.0 * d) continue;
      Eigen::Matrix3d numeric;
      double f_max = 0.0;
      for (int j = 0; j < 3; ++j) {
        const Eigen::Vector3d step = d * Eigen::Vector3d::Unit(j);
        const Eigen::Vector3d plus = def.forward(p + step), minus = def.forward(p - step);
        numeric.col(j) = (plus - minus) / (2.0 * d);
        f_max = std::max({f_max, plus.cwiseAbs().maxCoeff(), minus.cwiseAbs().maxCoeff()});
      }
      const Eigen::Matrix3d J = def.jacobian(p);
      const double err = (numeric - J).cwiseAbs().maxCoeff();
      const double tol =
          2.0 * 4.0 * kEps * (f_max + J.cwiseAbs().maxCoeff() * p.norm() + h.norm()) / d;
      worst_ratio = std::max(worst_ratio, err / tol);
      worst_abs = std::max(worst_abs, err);
      ASSERT_LE(err, tol) << def.describe() << " at " << p.transpose();
    }
  });
  std::printf("Jacobian against central differences: worst %.3g, %.3g of the rounding bound\n",
              worst_abs, worst_ratio);
}

// The determinants of taper.h and stretch.h: s^2 (taper), s^2 (1 + k) (stretch) inside the
// limits, positive for every accepted factor, so no lattice sample may fold.
TEST(SimpleDeform, NeverFolds) {
  for_each_case([&](Mode, const Eigen::Vector3d& h, Axis, double, const Deformer& d) {
    const FoldReport report = measure_folds(d, h, 16);
    EXPECT_EQ(report.folded_volume, 0.0) << d.describe();
  });
}

TEST(SimpleDeform, IdentityFaces) {
  std::mt19937_64 rng(4);
  for_each_case([&](Mode mode, const Eigen::Vector3d& h, Axis axis, double f, const Deformer& d) {
    const int a = static_cast<int>(axis);
    const auto faces = d.identity_faces();
    for (int i = 0; i < 6; ++i) {
      // taper.h: face -a always, the others iff f == 0; stretch.h: all iff f == 0, else none.
      const bool expected = f == 0.0 || (mode == Mode::Taper && i == 2 * a);
      EXPECT_EQ(faces[i], expected) << d.describe() << " face " << i;
      // Numerically: exactly the identity where claimed, visibly not elsewhere.
      double moved = 0.0;
      for (int n = 0; n < 200; ++n) {
        Eigen::Vector3d p = random_point(rng, h);
        p[i / 2] = (i % 2 ? 1.0 : -1.0) * h[i / 2];
        moved = std::max(moved, (d.forward(p) - p).norm());
        if (faces[i]) {
          EXPECT_LE((d.forward(p) - p).norm(), 1e-15 * h.norm()) << d.describe() << " " << i;
          EXPECT_LE((d.inverse(p) - p).norm(), 1e-15 * h.norm()) << d.describe() << " " << i;
        }
      }
      if (!faces[i]) {
        EXPECT_GT(moved, 1e-9 * std::abs(f) * h.norm()) << d.describe() << " face " << i;
      }
    }
  });
}

// Blender's sense of the factor, on a 2-unit cube (L = 2): a taper by 1 doubles the +a face; a
// stretch by 1 (k = 1/2) scales the -a face by 1 - k = 1/2 and the +a face by 1 + k (L^2 - 1) =
// 5/2 across, and moves the +a face by f = 1 along a.
TEST(SimpleDeform, FactorMeansWhatBlendersDoes) {
  const Eigen::Vector3d h = Eigen::Vector3d::Ones();
  for (Axis axis : kAxes) {
    const int a = static_cast<int>(axis);
    const Eigen::Vector3d e_a = Eigen::Vector3d::Unit(a);
    const Eigen::Vector3d across = Eigen::Vector3d::Ones() - e_a;  // (1, 1) across the axis
    const auto taper = make_taper(h, axis, 1.0);
    EXPECT_LE((taper->forward(e_a + across) - (e_a + 2.0 * across)).norm(), 1e-15);
    EXPECT_LE((taper->forward(-e_a + across) - (-e_a + across)).norm(), 1e-15);
    const auto stretch = make_stretch(h, axis, 1.0);
    EXPECT_LE((stretch->forward(e_a + across) - (2.0 * e_a + 2.5 * across)).norm(), 1e-15);
    EXPECT_LE((stretch->forward(-e_a + across) - (-e_a + 0.5 * across)).norm(), 1e-15);
    // Half way, z = 1: s = 1 + k (1 - 1) = 1 and the axis scaled by 1 + k about the pivot.
    EXPECT_LE((stretch->forward(across) - (0.5 * e_a + across)).norm(), 1e-15);
  }
}

TEST(SimpleDeform, FiniteForHugeAndOddInputs) {
  const double big = std::numeric_limits<double>::max();
  const double tiny = std::numeric_limits<double>::denorm_min();
  const std::vector<Eigen::Vector3d> inputs = {
      Eigen::Vector3d(big, -big, big),        Eigen::Vector3d(-big, big, -big),
      Eigen::Vector3d(big, 0.0, 0.0),         Eigen::Vector3d(0.0, big, 0.0),
      Eigen::Vector3d(0.0, 0.0, -big),        Eigen::Vector3d(tiny, -0.0, -tiny),
      Eigen::Vector3d(1e200, 1e-200, -1e100), Eigen::Vector3d(-1e300, 1e300, 1e-300),
      Eigen::Vector3d(0.0, 0.0, 0.0)};
  const std::vector<Eigen::Vector3d> boxes = {kHalf, Eigen::Vector3d(1e-300, 1.0, 1e-300),
                                              Eigen::Vector3d(1e250, 1e-5, 1e250),
                                              Eigen::Vector3d(1e299, 1e299, 1e299)};
  for (Mode mode : {Mode::Taper, Mode::Stretch})
    for (const Eigen::Vector3d& h : boxes)
      for (Axis axis : kAxes) {
        const double L = 2.0 * h[static_cast<int>(axis)];
        std::vector<double> fs = factors(mode, L);
        if (mode == Mode::Taper) {
          fs.push_back(std::nextafter(-1.0, 0.0));  // s = 1.1e-16 on face +a
        } else {
          const Range r = stretch_range(L);
          fs.push_back(r.lo * (1.0 - 1e-12));
          fs.push_back(r.hi_closed ? r.hi : r.hi * (1.0 - 1e-12));
        }
        for (double f : fs) {
          const auto d = make(mode, h, axis, f);
          for (const Eigen::Vector3d& p : inputs) {
            EXPECT_TRUE(d->forward(p).allFinite()) << d->describe() << " " << p.transpose();
            EXPECT_TRUE(d->jacobian(p).allFinite()) << d->describe() << " " << p.transpose();
            EXPECT_TRUE(d->inverse(p).allFinite()) << d->describe() << " " << p.transpose();
          }
        }
      }
}

std::string error_of(Mode mode, const Eigen::Vector3d& h, Axis axis, double f) {
  try {
    make(mode, h, axis, f);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(SimpleDeform, TaperErrors) {
  for (double f : {-1.0, -1.5, -1e300, 10.000001, 11.0, 1e300})
    EXPECT_EQ(error_of(Mode::Taper, kHalf, Axis::Y, f),
              "taper factor = " + shortest_text(f) + ": must be in (-1, 10]");
  EXPECT_EQ(error_of(Mode::Taper, kHalf, Axis::X, NAN), "taper factor = nan: must be in (-1, 10]");
  EXPECT_EQ(error_of(Mode::Taper, kHalf, Axis::X, INFINITY),
            "taper factor = inf: must be in (-1, 10]");
  EXPECT_EQ(error_of(Mode::Taper, kHalf, Axis::X, -INFINITY),
            "taper factor = -inf: must be in (-1, 10]");
  EXPECT_EQ(error_of(Mode::Taper, Eigen::Vector3d(1, 0, 1), Axis::X, 0.5),
            "taper half_extents[1] = 0: must be > 0 and finite");
  EXPECT_EQ(error_of(Mode::Taper, Eigen::Vector3d(1, 1, INFINITY), Axis::X, 0.5),
            "taper half_extents[2] = inf: must be > 0 and finite");
  // The extremes themselves are accepted.
  EXPECT_NO_THROW(make_taper(kHalf, Axis::Y, 10.0));
  EXPECT_NO_THROW(make_taper(kHalf, Axis::Y, std::nextafter(-1.0, 0.0)));
}

TEST(SimpleDeform, StretchErrors) {
  // x: L = 1.4 <= sqrt(2), the range (-1.4, 1.4).
  const std::string x_range =
      ": must be in (-1.4, 1.4) for a box 1.4 long along x (beyond, the "
      "cross-section scale 1 + (factor / L)(z^2 - 1) reaches 0 in the box)";
  for (double f : {1.4, -1.4, 2.0, -5.0, 11.0})
    EXPECT_EQ(error_of(Mode::Stretch, kHalf, Axis::X, f),
              "stretch factor = " + shortest_text(f) + x_range);
  EXPECT_EQ(error_of(Mode::Stretch, kHalf, Axis::X, NAN), "stretch factor = nan" + x_range);
  EXPECT_EQ(error_of(Mode::Stretch, kHalf, Axis::X, INFINITY), "stretch factor = inf" + x_range);
  // y: L = 2.6, lo = -L / (L^2 - 1) = -0.4514...; z: L = 0.8, (-0.8, 0.8); kLong x: L = 12 > 10,
  // the closed cap 10.
  struct Case {
    Eigen::Vector3d h;
    Axis axis;
    double bad;
  };
  for (const Case& c :
       {Case{kHalf, Axis::Y, -0.46}, Case{kHalf, Axis::Y, 2.6}, Case{kHalf, Axis::Z, 0.8},
        Case{kHalf, Axis::Z, -0.8}, Case{kLong, Axis::X, 10.5}, Case{kLong, Axis::X, -0.09},
        Case{kLong, Axis::Z, -1e300}}) {
    const double L = 2.0 * c.h[static_cast<int>(c.axis)];
    const Range r = stretch_range(L);
    const std::string message = error_of(Mode::Stretch, c.h, c.axis, c.bad);
    const std::string head = "stretch factor = " + shortest_text(c.bad) + ": must be in (";
    EXPECT_EQ(message.substr(0, head.size()), head) << message;
    // The bounds in the message are the documented ones, to a few eps.
    double lo = 0.0, hi = 0.0;
    char close = 0;
    ASSERT_EQ(std::sscanf(message.c_str() + head.size(), "%lf, %lf%c", &lo, &hi, &close), 3)
        << message;
    EXPECT_NEAR(lo, r.lo, 4.0 * kEps * std::abs(r.lo)) << message;
    EXPECT_EQ(hi, r.hi) << message;
    EXPECT_EQ(close, r.hi_closed ? ']' : ')') << message;
    EXPECT_NE(message.find("for a box " + shortest_text(L) + " long along " +
                           std::string(1, axis_name(c.axis))),
              std::string::npos)
        << message;
  }
  // Just inside both ends is accepted, and the closed cap itself.
  for (const Eigen::Vector3d& h : kBoxes)
    for (Axis axis : kAxes) {
      const Range r = stretch_range(2.0 * h[static_cast<int>(axis)]);
      EXPECT_NO_THROW(make_stretch(h, axis, r.lo * (1.0 - 1e-12)));
      EXPECT_NO_THROW(make_stretch(h, axis, r.hi_closed ? r.hi : r.hi * (1.0 - 1e-12)));
    }
  EXPECT_EQ(error_of(Mode::Stretch, Eigen::Vector3d(-1, 1, 1), Axis::Y, 0.5),
            "stretch half_extents[0] = -1: must be > 0 and finite");
}

TEST(SimpleDeform, Describe) {
  EXPECT_EQ(make_taper(kHalf, Axis::Y, 0.8)->describe(), "taper along y by 0.8");
  EXPECT_EQ(make_taper(kHalf, Axis::X, -0.25)->describe(), "taper along x by -0.25");
  EXPECT_EQ(make_taper(kHalf, Axis::Z, 10.0)->describe(), "taper along z by 10");
  EXPECT_EQ(make_stretch(kHalf, Axis::Y, 0.5)->describe(), "stretch along y by 0.5");
  EXPECT_EQ(make_stretch(kHalf, Axis::X, -0.05)->describe(), "stretch along x by -0.05");
  EXPECT_EQ(make_stretch(kHalf, Axis::Z, 0.0)->describe(), "stretch along z by 0");
}

}  // namespace
}  // namespace raywarp
