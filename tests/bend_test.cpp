// Numerical experiments on the bend (deformers/bend.h): round trips of the analytic inverse off
// the fold, the analytic Jacobian against central differences, continuity as phi -> 0, the
// direction convention, the identity faces and the folded volume against its closed form.
#include "deformers/bend.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "base/error.h"

namespace raywarp {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr Axis kAxes[] = {Axis::X, Axis::Y, Axis::Z};
// Uneven, and thick enough along every b that the +-300 degree bends fold somewhere.
const Eigen::Vector3d kHalf(0.6, 0.35, 0.9);
constexpr double kAngles[] = {300.0, -300.0, 90.0, -90.0, 1e-6, 0.0};

// The bend's axes and pivot, restated from bend.h (Blender's simpleDeform_bend).
struct Frame {
  int d, a, b;
  Eigen::Vector3d pivot;
  double length, k;
};
Frame frame_of(Axis axis, const Eigen::Vector3d& h, double angle_deg) {
  Frame f;
  f.d = static_cast<int>(axis);
  f.a = axis == Axis::Z ? 0 : 2;
  f.b = axis == Axis::Y ? 0 : 1;
  f.pivot = Eigen::Vector3d::Zero();
  f.pivot[f.a] = -h[f.a];
  f.length = 2.0 * h[f.a];
  f.k = angle_deg * kDeg / f.length;
  return f;
}

// Uniform in [-scale h, scale h].
Eigen::Vector3d random_point(std::mt19937_64& rng, const Eigen::Vector3d& h, double scale = 1.0) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  return scale * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(h);
}

// A point of the box with 1 - k q_b > 0.05: off the fold, where the inverse is one-to-one and
// its conditioning is at worst 1 / 0.05.
Eigen::Vector3d random_unfolded_point(std::mt19937_64& rng, const Frame& f,
                                      const Eigen::Vector3d& h, double scale = 1.0) {
  for (;;) {
    const Eigen::Vector3d p = random_point(rng, h, scale);
    if (1.0 - f.k * p[f.b] > 0.05) return p;
  }
}

// inverse(F(p)) solves for the polar angle and radius about the centre of curvature: atan2 and
// hypot are correct to ~1 ulp, the angle then divides by k (q_a = theta / k) and the radius
// loses at most a factor 1 / (1 - k q_b) <= 20 in conditioning, so the error is ~20 * few eps *
// |q|, ~1e-14 of the box. 1e-9 * diagonal is the bar every analytic inverse must meet.
TEST(Bend, RoundTripInverseOfForwardOffTheFold) {
  const double tol = 1e-9 * 2.0 * kHalf.norm();
  std::mt19937_64 rng(1);
  for (Axis axis : kAxes)
    for (double angle : kAngles) {
      const auto bend = make_bend(kHalf, axis, angle);
      const Frame f = frame_of(axis, kHalf, angle);
      double worst = 0.0;
      for (int n = 0; n < 10000; ++n) {
        const Eigen::Vector3d p = random_unfolded_point(rng, f, kHalf);
        worst = std::max(worst, (bend->inverse(bend->forward(p)) - p).norm());
      }
      EXPECT_LE(worst, tol) << bend->describe();
    }
}

// Below 180 degrees the rigid continuations beyond +-a do not overlap the image of the slab
// 1 - k q_b > 0, so the round trip holds there too.
TEST(Bend, RoundTripBeyondTheLimits) {
  const double tol = 1e-9 * 2.0 * kHalf.norm();
  std::mt19937_64 rng(2);
  for (Axis axis : kAxes)
    for (double angle : {90.0, -90.0, 170.0}) {
      const auto bend = make_bend(kHalf, axis, angle);
      const Frame f = frame_of(axis, kHalf, angle);
      double worst = 0.0;
      for (int n = 0; n < 10000; ++n) {
        Eigen::Vector3d p = random_unfolded_point(rng, f, kHalf);
        p[f.a] *= 3.0;  // q_a in [-L, 2 L]
        worst = std::max(worst, (bend->inverse(bend->forward(p)) - p).norm());
      }
      EXPECT_LE(worst, tol) << bend->describe();
    }
}

// Every branch of the inverse (sector, identity before -a, rigid motion beyond +a) inverts F on
// its region exactly, so F(inverse(p')) = p' for any p', folded images and the neighbourhood of
// the centre of curvature included: there theta is ill-conditioned (error ~eps / sqrt(S)) but F
// moves along the arc by only sqrt(S) per unit of q_a, and the two cancel.
TEST(Bend, RoundTripForwardOfInverse) {
  const double tol = 1e-9 * 2.0 * kHalf.norm();
  std::mt19937_64 rng(3);
  for (Axis axis : kAxes)
    for (double angle : kAngles) {
      const auto bend = make_bend(kHalf, axis, angle);
      double worst = 0.0;
      for (int n = 0; n < 10000; ++n) {
        const Eigen::Vector3d in_image = bend->forward(random_point(rng, kHalf));
        worst = std::max(worst, (bend->forward(bend->inverse(in_image)) - in_image).norm());
        const Eigen::Vector3d anywhere = random_point(rng, kHalf, 4.0);
        worst = std::max(worst, (bend->forward(bend->inverse(anywhere)) - anywhere).norm());
      }
      EXPECT_LE(worst, 4.0 * tol) << bend->describe();
    }
}

// Central differences with step d along axis j: error <= d^2 / 6 |d^3 F / dp_j^3| + 2 * 4 eps
// |F| / (2 d). F is affine along d and b, so only j = a truncates, and there
// d^3 q' / dq_a^3 = k^3 (R - q_b) (-cos, -sin)(theta): size k^2 |1 - k q_b|. The points stay 2d
// away from q_a = 0 and q_a = L, where the map turns rigid and the a-column jumps.
TEST(Bend, JacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(4);
  const double d = 1e-6 * 2.0 * kHalf.norm();
  const double scale = 2.0;  // the box and the rigid continuations beyond it
  for (Axis axis : kAxes)
    for (double angle : kAngles) {
      const auto bend = make_bend(kHalf, axis, angle);
      const Frame f = frame_of(axis, kHalf, angle);
      const double k = std::abs(f.k);
      const double third = k * k * (1.0 + k * scale * kHalf[f.b]);
      const double f_max = 4.0 * scale * kHalf.norm();
      const double tol = 2.0 * (d * d / 6.0 * third + 4.0 * kEps * f_max / d);
      double worst = 0.0;
      for (int n = 0; n < 2000; ++n) {
        const Eigen::Vector3d p = random_point(rng, kHalf, scale);
        const double qa = p[f.a] - f.pivot[f.a];
        if (std::abs(qa) < 2.0 * d || std::abs(qa - f.length) < 2.0 * d) continue;
        Eigen::Matrix3d numeric;
        for (int j = 0; j < 3; ++j) {
          const Eigen::Vector3d step = d * Eigen::Vector3d::Unit(j);
          numeric.col(j) = (bend->forward(p + step) - bend->forward(p - step)) / (2.0 * d);
        }
        worst = std::max(worst, (numeric - bend->jacobian(p)).cwiseAbs().maxCoeff());
      }
      EXPECT_LE(worst, tol) << bend->describe();
    }
}

TEST(Bend, JacobianDeterminantIsOneMinusKQb) {
  std::mt19937_64 rng(5);
  for (Axis axis : kAxes) {
    const auto bend = make_bend(kHalf, axis, 300.0);
    const Frame f = frame_of(axis, kHalf, 300.0);
    for (int n = 0; n < 1000; ++n) {
      const Eigen::Vector3d p = random_point(rng, kHalf);
      EXPECT_NEAR(bend->jacobian(p).determinant(), 1.0 - f.k * p[f.b], 1e-14 * (1.0 + f.k));
    }
  }
}

// At phi = 1e-9 degrees, k ~ 1e-11 / L: F(p) - p = k (-q_a q_b, q_a^2 / 2) + O(k^2 L^3) in (a, b)
// (the first-order terms of the stable forms), so F is the identity to 1e-9 of the box, and the
// first-order term itself is reproduced to rounding: no cancellation from a 1 / k anywhere.
TEST(Bend, ContinuousAsAngleGoesToZero) {
  std::mt19937_64 rng(6);
  const double size = 2.0 * kHalf.norm();
  for (Axis axis : kAxes) {
    const double angle = 1e-9;
    const auto bend = make_bend(kHalf, axis, angle);
    const Frame f = frame_of(axis, kHalf, angle);
    for (int n = 0; n < 1000; ++n) {
      const Eigen::Vector3d p = random_point(rng, kHalf);
      const Eigen::Vector3d q = p - f.pivot;
      Eigen::Vector3d first_order = Eigen::Vector3d::Zero();
      first_order[f.a] = -f.k * q[f.a] * q[f.b];
      first_order[f.b] = 0.5 * f.k * q[f.a] * q[f.a];
      const Eigen::Vector3d moved = bend->forward(p) - p;
      EXPECT_LE(moved.norm(), 1e-9 * size);
      EXPECT_LE((moved - first_order).norm(), 8.0 * kEps * size);
    }
  }
}

// Blender leaves the mesh alone below |k| = 1e-6 (BEND_EPS), a jump of ~k L^2 / 2 at the
// threshold. Here F is smooth in k: across k = 1e-6 (1 -+ 1e-6) it moves by at most
// |dF/dk| dk <= (|q_a q_b| + q_a^2 / 2) dk, plus rounding.
TEST(Bend, NoJumpAtBlendersThreshold) {
  std::mt19937_64 rng(7);
  const double size = 2.0 * kHalf.norm();
  for (Axis axis : kAxes) {
    const Frame f = frame_of(axis, kHalf, 0.0);
    const double k_lo = 1e-6 * (1.0 - 1e-6), k_hi = 1e-6 * (1.0 + 1e-6);
    const auto below = make_bend(kHalf, axis, k_lo * f.length / kDeg);
    const auto above = make_bend(kHalf, axis, k_hi * f.length / kDeg);
    const double dF_dk = f.length * (f.length / 2.0 + kHalf[f.b]);
    const double blender_jump = 1e-6 * f.length * f.length / 2.0;
    double worst = 0.0;
    for (int n = 0; n < 1000; ++n) {
      Eigen::Vector3d p = random_point(rng, kHalf);
      p[f.a] = kHalf[f.a];  // face +a, where the bend moves points most
      worst = std::max(worst, (above->forward(p) - below->forward(p)).norm());
      EXPECT_GT((below->forward(p) - p).norm(), 0.1 * blender_jump);  // bent below it too
    }
    EXPECT_LE(worst, dF_dk * (k_hi - k_lo) + 8.0 * kEps * size);
    EXPECT_LE(worst, 1e-5 * blender_jump);
  }
}

// +phi curls +a towards +b: at 90 degrees the centre of face +a (q = L e_a) lands on
// (2L / pi)(e_a + e_b); at -90 degrees on (2L / pi)(e_a - e_b).
TEST(Bend, PositiveAngleCurlsAToB) {
  for (Axis axis : kAxes)
    for (double sign : {1.0, -1.0}) {
      const auto bend = make_bend(kHalf, axis, sign * 90.0);
      const Frame f = frame_of(axis, kHalf, 90.0);
      const Eigen::Vector3d p = f.pivot + f.length * Eigen::Vector3d::Unit(f.a);
      const Eigen::Vector3d expected =
          f.pivot + 2.0 * f.length / std::numbers::pi *
                        (Eigen::Vector3d::Unit(f.a) + sign * Eigen::Vector3d::Unit(f.b));
      EXPECT_LE((bend->forward(p) - expected).norm(), 1e-14) << bend->describe();
      // The bend axis d is untouched.
      Eigen::Vector3d lifted = p;
      lifted[f.d] += 0.25;
      EXPECT_NEAR(bend->forward(lifted)[f.d], 0.25, 1e-15);
    }
}

TEST(Bend, IdentityFaces) {
  std::mt19937_64 rng(8);
  for (Axis axis : kAxes) {
    const Frame f = frame_of(axis, kHalf, 0.0);
    for (double angle : {300.0, -90.0, 1e-6}) {
      const auto bend = make_bend(kHalf, axis, angle);
      const auto faces = bend->identity_faces();
      for (int i = 0; i < 6; ++i) EXPECT_EQ(faces[i], i == 2 * f.a) << bend->describe() << i;
      for (int n = 0; n < 100; ++n) {
        Eigen::Vector3d p = random_point(rng, kHalf);
        p[f.a] = -kHalf[f.a];
        EXPECT_LE((bend->forward(p) - p).norm(), 4.0 * kEps * kHalf.norm());
      }
    }
    const auto flat = make_bend(kHalf, axis, 0.0)->identity_faces();
    for (int i = 0; i < 6; ++i) EXPECT_TRUE(flat[i]) << i;
  }
}

// det(dF/dp) = 1 - k q_b <= 0 exactly where k q_b >= 1, i.e. on the slab q_b >= R (phi > 0) or
// q_b <= R (phi < 0) of the box, whose volume is (h_b - |R|) L (2 h_d) when |R| < h_b. The
// lattice counts cell centres, so it misses at most one layer of cells across b:
// box volume / samples.
TEST(Bend, FoldedVolumeMatchesClosedForm) {
  const Eigen::Vector3d h(1.0, 1.2, 0.9);
  const int samples = 64;
  for (Axis axis : kAxes)
    for (double angle : {180.0, -250.0, 60.0}) {
      const auto bend = make_bend(h, axis, angle);
      const Frame f = frame_of(axis, h, angle);
      const double radius = 1.0 / std::abs(f.k);
      const double expected =
          std::max(0.0, h[f.b] - radius) * f.length * 2.0 * h[f.d];  // 0 when it does not fold
      const FoldReport report = measure_folds(*bend, h, samples);
      EXPECT_NEAR(report.box_volume, 8.0 * h.prod(), 1e-12);
      EXPECT_NEAR(report.folded_volume, expected, report.box_volume / samples) << bend->describe();
      EXPECT_EQ(report.folds(), expected > 0.0) << bend->describe();
    }
}

TEST(Bend, InverseIsFiniteForAnyFiniteInput) {
  const double big = std::numeric_limits<double>::max();
  const double tiny = std::numeric_limits<double>::denorm_min();
  for (Axis axis : kAxes)
    for (double angle : {359.999, -359.999, 90.0, 1e-300, -1e-12, 0.0}) {
      const auto bend = make_bend(kHalf, axis, angle);
      const Frame f = frame_of(axis, kHalf, angle);
      Eigen::Vector3d centre = f.pivot;  // the centre of curvature, where S = 0
      if (f.k != 0.0) centre[f.b] += 1.0 / f.k;
      for (const Eigen::Vector3d& p :
           {Eigen::Vector3d(big, -big, big), Eigen::Vector3d(-big, big, -big),
            Eigen::Vector3d(tiny, 0.0, -tiny), Eigen::Vector3d(1e200, 1e-200, -1e100), centre}) {
        EXPECT_TRUE(bend->inverse(p).allFinite()) << bend->describe() << " " << p.transpose();
      }
    }
}

TEST(Bend, DescribeAndErrors) {
  EXPECT_EQ(make_bend(kHalf, Axis::Z, 90.0)->describe(), "bend about z by 90\u00b0");
  for (double bad : {360.0, -360.0, 400.0}) {
    try {
      make_bend(kHalf, Axis::X, bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const Error& e) {
      const std::string value = bad == 400.0 ? "400" : bad > 0 ? "360" : "-360";
      EXPECT_EQ(std::string(e.what()), "bend angle_deg = " + value + ": must be in (-360, 360)");
    }
  }
  EXPECT_THROW(make_bend(kHalf, Axis::X, NAN), Error);
  EXPECT_NO_THROW(make_bend(kHalf, Axis::X, 359.999));
}

}  // namespace
}  // namespace raywarp
