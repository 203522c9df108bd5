// Numerical experiments on the twist (deformers/twist.h): round trips of the analytic inverse,
// the analytic Jacobian against central differences, the identity faces and the fold measure.
#include "deformers/twist.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "base/error.h"

namespace raywarp {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr Axis kAxes[] = {Axis::X, Axis::Y, Axis::Z};
// A box of uneven aspect ratio, so that a mixed-up axis shows.
const Eigen::Vector3d kHalf(0.7, 1.3, 0.4);
constexpr double kAngles[] = {720.0, -720.0, 1e-6, 0.0, 90.0, -200.0};

// Uniform in [-scale h, scale h].
Eigen::Vector3d random_point(std::mt19937_64& rng, const Eigen::Vector3d& h, double scale = 1.0) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  return scale * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(h);
}

// The twist is a rotation at every point, and the inverse uses the very same angle (p'_a = p_a
// bit for bit), so a round trip costs a few rotations' rounding, ~1e-15 of the box; the
// 1e-9 * diagonal asked of every analytic inverse leaves room for any reordering of the algebra.
TEST(Twist, RoundTripInverseOfForward) {
  const double tol = 1e-9 * 2.0 * kHalf.norm();
  std::mt19937_64 rng(1);
  for (Axis axis : kAxes)
    for (double angle : kAngles) {
      const auto twist = make_twist(kHalf, axis, angle);
      double worst = 0.0;
      for (int n = 0; n < 10000; ++n) {
        const Eigen::Vector3d p = random_point(rng, kHalf);
        worst = std::max(worst, (twist->inverse(twist->forward(p)) - p).norm());
      }
      EXPECT_LE(worst, tol) << twist->describe();
    }
}

TEST(Twist, RoundTripForwardOfInverse) {
  const double tol = 1e-9 * 2.0 * kHalf.norm();
  std::mt19937_64 rng(2);
  for (Axis axis : kAxes)
    for (double angle : kAngles) {
      const auto twist = make_twist(kHalf, axis, angle);
      double worst = 0.0;
      for (int n = 0; n < 10000; ++n) {
        const Eigen::Vector3d p_def = twist->forward(random_point(rng, kHalf));  // in F(box)
        worst = std::max(worst, (twist->forward(twist->inverse(p_def)) - p_def).norm());
        // Also beyond the box, where the twist continues rigidly: F is a bijection of space.
        const Eigen::Vector3d far = random_point(rng, kHalf, 3.0);
        worst = std::max(worst, (twist->forward(twist->inverse(far)) - far).norm());
      }
      EXPECT_LE(worst, 3.0 * tol) << twist->describe();
    }
}

// Central differences with step d along axis j: error <= d^2 / 6 * |d^3 F / dp_j^3| (truncation)
// + 2 * 4 eps |F| / (2 d) (each F carries ~4 eps |F| of rounding). F is linear along the two axes
// orthogonal to a (a rotation at fixed p_a), so only j = a truncates: with g = phi / L,
// d^3 F / dp_a^3 = g^3 R'''(theta) p, of size g^3 r (r = distance from the axis). The points
// stay 2d away from the planes p_a = +-h_a where grad(theta) jumps.
TEST(Twist, JacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(3);
  const double d = 1e-6 * 2.0 * kHalf.norm();
  for (Axis axis : kAxes)
    for (double angle : kAngles) {
      const auto twist = make_twist(kHalf, axis, angle);
      const int a = static_cast<int>(axis);
      const double g = std::abs(angle) * std::numbers::pi / 180.0 / (2.0 * kHalf[a]);
      const double scale = 2.0;  // inside the box and the rigid continuations beyond it
      const double r_max = scale * std::hypot(kHalf[(a + 1) % 3], kHalf[(a + 2) % 3]);
      const double f_max = scale * kHalf.norm();
      const double tol = 2.0 * (d * d / 6.0 * g * g * g * r_max + 4.0 * kEps * f_max / d);
      double worst = 0.0;
      for (int n = 0; n < 2000; ++n) {
        const Eigen::Vector3d p = random_point(rng, kHalf, scale);
        if (std::abs(std::abs(p[a]) - kHalf[a]) < 2.0 * d) continue;
        Eigen::Matrix3d numeric;
        for (int j = 0; j < 3; ++j) {
          const Eigen::Vector3d step = d * Eigen::Vector3d::Unit(j);
          numeric.col(j) = (twist->forward(p + step) - twist->forward(p - step)) / (2.0 * d);
        }
        worst = std::max(worst, (numeric - twist->jacobian(p)).cwiseAbs().maxCoeff());
      }
      EXPECT_LE(worst, tol) << twist->describe();
    }
}

TEST(Twist, IdentityFaces) {
  std::mt19937_64 rng(4);
  for (Axis axis : kAxes) {
    const int a = static_cast<int>(axis);
    for (double angle : {360.0, -720.0, 3600.0}) {
      const auto twist = make_twist(kHalf, axis, angle);
      const auto faces = twist->identity_faces();
      for (int f = 0; f < 6; ++f) EXPECT_EQ(faces[f], f / 2 == a) << twist->describe() << f;
      // Numerically: cos(2 pi n) and sin(2 pi n) are 1 and 0 to a few eps (times n).
      for (int n = 0; n < 100; ++n) {
        Eigen::Vector3d p = random_point(rng, kHalf);
        p[a] = (n % 2 ? 1.0 : -1.0) * kHalf[a];
        EXPECT_LE((twist->forward(p) - p).norm(), 1e-12 * kHalf.norm()) << twist->describe();
      }
    }
    const auto partial = make_twist(kHalf, axis, 359.5)->identity_faces();
    for (int f = 0; f < 6; ++f) EXPECT_EQ(partial[f], f == 2 * a) << f;
    const auto none = make_twist(kHalf, axis, 0.0)->identity_faces();
    for (int f = 0; f < 6; ++f) EXPECT_TRUE(none[f]) << f;
  }
}

TEST(Twist, DirectionIsRightHanded) {
  // A quarter turn at the +a face takes e_{a+1} to e_{a+2} (x -> y about z).
  for (Axis axis : kAxes) {
    const int a = static_cast<int>(axis);
    const Eigen::Vector3d h = Eigen::Vector3d::Ones();
    const auto twist = make_twist(h, axis, 90.0);
    const Eigen::Vector3d p = Eigen::Vector3d::Unit(a) + Eigen::Vector3d::Unit((a + 1) % 3);
    const Eigen::Vector3d expected = Eigen::Vector3d::Unit(a) + Eigen::Vector3d::Unit((a + 2) % 3);
    EXPECT_LE((twist->forward(p) - expected).norm(), 1e-15) << twist->describe();
  }
}

TEST(Twist, NeverFolds) {
  // det(dF/dp) = 1 exactly in exact arithmetic; no lattice sample may come out <= 0.
  for (Axis axis : kAxes) {
    const FoldReport report = measure_folds(*make_twist(kHalf, axis, 3600.0), kHalf, 32);
    EXPECT_EQ(report.folded_volume, 0.0);
    EXPECT_NEAR(report.box_volume, 8.0 * kHalf.prod(), 1e-15);
  }
}

TEST(Twist, InverseIsFiniteForAnyFiniteInput) {
  const double big = std::numeric_limits<double>::max();
  const double tiny = std::numeric_limits<double>::denorm_min();
  for (Axis axis : kAxes)
    for (double angle : {3600.0, -1e-300, 0.0})
      for (const Eigen::Vector3d& p :
           {Eigen::Vector3d(big, -big, big), Eigen::Vector3d(tiny, 0.0, -tiny),
            Eigen::Vector3d(1e200, 1e-200, -1e100)})
        EXPECT_TRUE(make_twist(kHalf, axis, angle)->inverse(p).allFinite());
}

TEST(Twist, DescribeAndErrors) {
  EXPECT_EQ(make_twist(kHalf, Axis::Y, 360.0)->describe(), "twist about y by 360\u00b0");
  EXPECT_EQ(make_twist(kHalf, Axis::X, -12.5)->describe(), "twist about x by -12.5\u00b0");
  EXPECT_THROW(make_twist(kHalf, Axis::X, NAN), Error);
  EXPECT_THROW(make_twist(Eigen::Vector3d(1, 0, 1), Axis::X, 10.0), Error);
}

}  // namespace
}  // namespace raywarp
