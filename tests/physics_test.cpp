// Named after no one source: physics/ as a whole; its sources share these fixtures.
// The physics core (physics/): the spring law and its Jacobians, the integrators' exact behaviour
// on a linear spring, their stability and conservation on a tetrahedral bar, local/global against
// implicit Euler, the tetrahedralisation and the grid model (docs/physics.md).
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <numbers>
#include <random>
#include <vector>

#include "base/error.h"
#include "physics/integrators.h"
#include "physics/mass_spring.h"
#include "physics/models.h"
#include "physics/spectrum.h"

namespace raywarp::physics {
namespace {

// One free node (index 1, mass m) on a spring of rest length L to a pinned node at the origin,
// displaced by u0 along x: its motion stays on the x axis and the spring is exactly linear there.
MassSpring single_spring(double m, double ks, double L, double u0) {
  MassSpring s;
  s.add_node(Eigen::Vector3d::Zero(), 1.0);
  s.add_node(Eigen::Vector3d(L + u0, 0, 0), m);
  s.add_spring(0, 1, ks, 0, L);
  s.pin(0);
  return s;
}

double spring_energy_1d(const MassSpring& s) { return s.energy().total(); }

// Deterministic values in [-0.5, 0.5) (std::mt19937's sequence is fixed by the standard).
struct Noise {
  std::mt19937 g{12345u};
  double operator()() { return g() / 4294967296.0 - 0.5; }
};

TEST(PhysicsSpring, ForcesMatchEnergyGradientAndJacobians) {
  MassSpring s;
  s.add_node(Eigen::Vector3d(0.1, -0.2, 0.3), 1.5);
  s.add_node(Eigen::Vector3d(1.2, 0.4, -0.1), 0.7);
  s.add_node(Eigen::Vector3d(0.3, 1.1, 0.5), 1.1);
  s.add_spring(0, 1, 40, 0, 0.8);  // stretched
  s.add_spring(1, 2, 25, 0, 2.0);  // compressed
  s.add_spring(0, 2, 10, 0);       // at rest
  s.v << 0.3, -0.1, 0.2, -0.4, 0.5, 0.1, 0.2, 0.2, -0.3;
  Vector f = s.forces();
  const double eps = 1e-6;
  SparseMatrix K = s.dfdx(s.x, false);
  for (int k = 0; k < 9; ++k) {
    Vector xp = s.x, xm = s.x;
    xp[k] += eps;
    xm[k] -= eps;
    double grad = (s.energy(xp, s.v).spring - s.energy(xm, s.v).spring) / (2 * eps);
    EXPECT_NEAR(f[k], -grad, 1e-7);  // f = -∂E/∂x (no gravity, no damping)
    Vector col = (s.forces(xp, s.v) - s.forces(xm, s.v)) / (2 * eps);
    for (int r = 0; r < 9; ++r) EXPECT_NEAR(K.coeff(r, k), col[r], 1e-6);
  }
  EXPECT_NEAR((Eigen::MatrixXd(K) - Eigen::MatrixXd(K).transpose()).norm(), 0, 0);
  // Damping: relative (Tejada & Ertl eq. 3) and along the spring; ∂f/∂v by differences.
  for (Damping d : {Damping::relative, Damping::along_spring}) {
    s.damping = d;
    for (auto& sp : s.springs) sp.kd = 0.7;
    SparseMatrix D = s.dfdv(s.x);
    for (int k = 0; k < 9; ++k) {
      Vector vp = s.v, vm = s.v;
      vp[k] += eps;
      vm[k] -= eps;
      Vector col = (s.forces(s.x, vp) - s.forces(s.x, vm)) / (2 * eps);
      for (int r = 0; r < 9; ++r) EXPECT_NEAR(D.coeff(r, k), col[r], 1e-7);
    }
  }
  // The clamp drops the negative transverse term of the compressed spring only: -K stays PSD.
  SparseMatrix Kc = s.dfdx(s.x, true);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(-Eigen::MatrixXd(Kc));
  EXPECT_GE(es.eigenvalues().minCoeff(), -1e-12);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eu(-Eigen::MatrixXd(K));
  EXPECT_LT(eu.eigenvalues().minCoeff(), -1e-3);
}

TEST(PhysicsSpring, MosegaardKIsTwiceKs) {
  // Mosegaard & Sørensen eq. 2 for one node with face (D1) and edge (D2) neighbours, grid units.
  double k = 30;
  MassSpring s;
  s.add_node(Eigen::Vector3d(0.1, -0.05, 0.07), 1);
  std::vector<Eigen::Vector3d> d1 = {{1, 0, 0}, {0, -1, 0}}, d2 = {{1, 1, 0}, {0, -1, 1}};
  for (auto& p : d1) s.add_spring(0, s.add_node(p, 1), ks_from_mosegaard_k(k), 0, 1.0);
  for (auto& p : d2) s.add_spring(0, s.add_node(p, 1), ks_from_mosegaard_k(k), 0, std::sqrt(2.0));
  Eigen::Vector3d pi = s.position(0), g = Eigen::Vector3d::Zero();
  for (auto& p : d1) g += (pi - p).normalized() - (pi - p);
  for (auto& p : d2) g += std::sqrt(2.0) * (pi - p).normalized() - (pi - p);
  g *= 0.5 * k;
  EXPECT_LT((s.forces().segment<3>(0) - g).norm(), 1e-12);
}

TEST(PhysicsIntegrators, EulerEnergyRatiosOnALinearSpring) {
  const double m = 2, ks = 200, h = 0.01;  // ω = 10, ωh = 0.1
  const double w2h2 = ks / m * h * h;
  ExplicitEuler ee;
  ImplicitEuler ie;
  MassSpring a = single_spring(m, ks, 1.0, 0.1), b = a;
  double worst_e = 0, worst_i = 0;
  int cg = 0;
  for (int n = 0; n < 50; ++n) {
    double ea = spring_energy_1d(a), eb = spring_energy_1d(b);
    ASSERT_TRUE(ee.step(a, h).ok());
    StepResult r = ie.step(b, h);
    ASSERT_TRUE(r.ok());
    EXPECT_FALSE(r.hit_cap);
    cg = std::max(cg, r.iterations);
    worst_e = std::max(worst_e, std::abs(spring_energy_1d(a) / ea / (1 + w2h2) - 1));
    worst_i = std::max(worst_i, std::abs(spring_energy_1d(b) / eb * (1 + w2h2) - 1));
    // The motion stays on the axis.
    EXPECT_EQ(a.position(1).tail<2>().norm(), 0);
    EXPECT_EQ(b.position(1).tail<2>().norm(), 0);
  }
  EXPECT_LT(worst_e, 1e-9);
  EXPECT_LT(worst_i, 1e-9);
  std::printf("energy ratio error: explicit %.2e, implicit %.2e (1 + w2h2 = %.4f), CG its <= %d\n",
              worst_e, worst_i, 1 + w2h2, cg);
}

// The period of velocity Verlet's oscillation, from the zero crossings of x - L (interpolated
// linearly) over `steps` steps.
double measured_period(double omega_h, int steps) {
  const double m = 1, ks = 1, L = 1;  // ω = 1, h = ωh
  const double h = omega_h;
  MassSpring s = single_spring(m, ks, L, 0.01);
  VelocityVerlet vv;
  double prev = s.position(1).x() - L, first = -1, last = -1;
  int crossings = 0;
  for (int n = 1; n <= steps; ++n) {
    EXPECT_TRUE(vv.step(s, h).ok());
    double u = s.position(1).x() - L;
    if ((prev < 0) != (u < 0)) {
      double t = (n - 1 + prev / (prev - u)) * h;
      if (crossings == 0) first = t;
      last = t;
      ++crossings;
    }
    prev = u;
  }
  return 2 * (last - first) / (crossings - 1);
}

TEST(PhysicsIntegrators, VelocityVerletPeriod) {
  for (double wh : {0.1, 0.2}) {
    double expected = 2 * std::numbers::pi / ((2 / wh) * std::asin(wh / 2));  // ω = 1
    double period = measured_period(wh, wh < 0.15 ? 20000 : 40000);
    double err = std::abs(period / expected - 1);
    EXPECT_LT(err, 1e-6) << "wh " << wh;
    // The discrete period is measurably not the exact 2π/ω.
    EXPECT_GT(std::abs(period / (2 * std::numbers::pi) - 1), 100 * err);
    std::printf(
        "velocity Verlet wh = %.2f: period %.9f, expected %.9f (rel. error %.1e; "
        "2pi/w off by %.1e)\n",
        wh, period, expected, err, period / (2 * std::numbers::pi) - 1);
  }
}

TEST(PhysicsIntegrators, VelocityVerletStabilityLimit) {
  const double u0 = 0.01;
  {
    MassSpring s = single_spring(1, 1, 1, u0);
    VelocityVerlet vv;
    vv.energy_bound = 1e6 * s.energy().total();
    double worst = 0;
    for (int n = 0; n < 5000; ++n) {
      ASSERT_TRUE(vv.step(s, 1.99).ok());
      worst = std::max(worst, std::abs(s.position(1).x() - 1));
    }
    EXPECT_LE(worst, u0 * (1 + 1e-9));  // x_n - L = u0 cos(n θ), cos θ = 1 - (ωh)²/2
    std::printf("velocity Verlet wh = 1.99: max |x - L| / u0 = %.9f over 5000 steps\n", worst / u0);
  }
  {
    MassSpring s = single_spring(1, 1, 1, u0);
    VelocityVerlet vv;
    double e0 = s.energy().total();
    vv.energy_bound = 1e6 * e0;
    StepResult r;
    int n = 0;
    for (; n < 1000; ++n) {
      r = vv.step(s, 2.01);
      if (!r.ok()) break;
    }
    ASSERT_EQ(r.status, StepStatus::energy_above_bound);
    EXPECT_EQ(r.step, n);
    EXPECT_NE(r.message.find("step " + std::to_string(n)), std::string::npos) << r.message;
    EXPECT_EQ(s.steps, n);  // the failed step left the state as it was
    EXPECT_LE(s.energy().total(), 1e6 * e0);
    std::printf("velocity Verlet wh = 2.01: %s\n", r.message.c_str());
  }
}

TEST(PhysicsIntegrators, ImplicitEulerMatchesRecurrenceUnderGravity) {
  const double m = 0.5, ks = 80, kd = 0.3, L = 1, h = 0.02, g = -9.81;
  MassSpring s;
  s.add_node(Eigen::Vector3d::Zero(), 1);
  s.add_node(Eigen::Vector3d(0, -L, 0), m);
  s.add_spring(0, 1, ks, kd);
  s.pin(0);
  s.gravity = Eigen::Vector3d(0, g, 0);
  ImplicitEuler ie;
  // By hand: y < 0 is the free node's height, length -y; f = ks (-y - L) - kd v + m g,
  // ∂f/∂y = -ks, ∂f/∂v = -kd; (m + h kd + h² ks) Δv = h (f - h ks v).
  double y = -L, v = 0, worst = 0;
  for (int n = 0; n < 300; ++n) {
    double f = ks * (-y - L) - kd * v + m * g;
    double dv = h * (f - h * ks * v) / (m + h * kd + h * h * ks);
    v += dv;
    y += h * v;
    ASSERT_TRUE(ie.step(s, h).ok());
    worst =
        std::max(worst, std::max(std::abs(s.position(1).y() - y), std::abs(s.velocity(1).y() - v)));
    EXPECT_EQ(s.position(1).x(), 0);
  }
  EXPECT_LT(worst, 1e-12);
  std::printf("implicit Euler vs recurrence: max difference %.1e over 300 steps\n", worst);
}

// The bar of 2 x 2 x 5 unit cubes (120 tets, 54 nodes).
MassSpring bar_system(double ks, double kd) { return mass_spring(bar(), 1.0, ks, kd); }

void pin_end(MassSpring& s) {
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.position(i).z() == 0) s.pin(i);
  }
}

// ω_max² = the largest eigenvalue of M⁻¹ K, K = -∂f/∂x at rest (free nodes).
double dense_omega_max(const MassSpring& s) {
  Eigen::MatrixXd K = -Eigen::MatrixXd(s.dfdx(s.x, false));
  Vector msqrt = s.mass_diagonal().cwiseSqrt().cwiseInverse();
  Eigen::MatrixXd A = msqrt.asDiagonal() * K * msqrt.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(A, Eigen::EigenvaluesOnly);
  return std::sqrt(es.eigenvalues().maxCoeff());
}

bool verlet_stable(const MassSpring& rest, double h) {
  MassSpring s = rest;
  Noise noise;
  for (Eigen::Index k = 0; k < s.x.size(); ++k) s.x[k] += 1e-4 * noise();
  Verlet vv;
  vv.energy_bound = 1e4 * s.energy().total();
  for (int n = 0; n < 300; ++n) {
    if (!vv.step(s, h).ok()) return false;
  }
  return true;
}

TEST(PhysicsBar, VerletStableStepIsTwoOverOmegaMax) {
  MassSpring s = bar_system(1000, 0);
  double wmax = dense_omega_max(s);
  double lo = 1e-4, hi = lo;
  ASSERT_TRUE(verlet_stable(s, lo));
  while (verlet_stable(s, hi)) {
    lo = hi;
    hi *= 2;
  }
  while (hi / lo > 1.01) {
    double mid = 0.5 * (lo + hi);
    (verlet_stable(s, mid) ? lo : hi) = mid;
  }
  double ratio = lo / (2 / wmax);
  EXPECT_NEAR(ratio, 1, 0.05);
  std::printf(
      "Verlet on the bar: w_max %.3f rad/s, 2/w_max %.6f s, largest stable step %.6f s "
      "(ratio %.4f)\n",
      wmax, 2 / wmax, lo, ratio);
}

MassSpring moving_free_bar() {
  MassSpring s = bar_system(1000, 0.5);
  Noise noise;
  for (Eigen::Index k = 0; k < s.x.size(); ++k) {
    s.x[k] += 0.02 * noise();
    s.v[k] = (k % 3 == 0 ? 0.5 : 0.0) + noise();
  }
  return s;
}

TEST(PhysicsBar, FreeBodyConservesMomentum) {
  const double h = 0.003;  // about half Verlet's stable step
  ExplicitEuler ee;
  Verlet vl;
  VelocityVerlet vv;
  ImplicitEuler ie;
  LocalGlobal lg;
  std::vector<std::pair<Integrator*, double>> cases = {
      {&ee, 1e-12}, {&vl, 1e-12}, {&vv, 1e-12}, {&ie, 1e-6}, {&lg, 1e-9}};
  for (auto [integ, tol] : cases) {
    MassSpring s = moving_free_bar();
    Eigen::Vector3d p0 = s.momentum();
    double drift = 0;
    int cg = 0;
    int steps = integ == &ee ? 50 : 200;  // explicit Euler gains energy: fewer steps
    for (int n = 0; n < steps; ++n) {
      StepResult r = integ->step(s, h);
      ASSERT_TRUE(r.ok()) << integ->name() << ": " << r.message;
      cg = std::max(cg, r.iterations);
      drift = std::max(drift, (s.momentum() - p0).norm() / p0.norm());
    }
    EXPECT_LT(drift, tol) << integ->name();
    std::printf("free bar, %s: momentum drift %.1e relative over %d steps (iterations <= %d)\n",
                integ->name(), drift, steps, cg);
  }
}

TEST(PhysicsBar, ImplicitEulerNeverGainsEnergy) {
  // h = 0.02 s is about twice Verlet's stable step on this bar, 0.1 s ten times it.
  for (auto [h, steps] : {std::pair{0.02, 1000}, std::pair{0.1, 200}}) {
    MassSpring s = bar_system(1000, 0);
    pin_end(s);
    s.gravity = Eigen::Vector3d(0, -9.81, 0);
    ImplicitEuler ie;
    double e0 = s.energy().total(), worst = -1e300, tip_rest = s.position(s.nodes() - 1).y();
    int cg = 0, cg_total = 0;
    for (int n = 0; n < steps; ++n) {
      StepResult r = ie.step(s, h);
      ASSERT_TRUE(r.ok()) << r.message;
      ASSERT_FALSE(r.hit_cap);
      cg = std::max(cg, r.iterations);
      cg_total += r.iterations;
      worst = std::max(worst, s.energy().total() - e0);
    }
    EXPECT_LE(worst, 0);
    std::printf(
        "pinned bar under gravity, implicit Euler h = %.2f, %d steps: E0 %.4f, max E - E0 %.3e, "
        "CG its max %d mean %.1f, tip displacement %.4f\n",
        h, steps, e0, worst, cg, cg_total / double(steps),
        s.position(s.nodes() - 1).y() - tip_rest);
  }
}

// A pinned bar under gravity after a few implicit steps, so that it moves.
MassSpring sagging_bar(double kd) {
  MassSpring s = bar_system(1000, kd);
  pin_end(s);
  s.gravity = Eigen::Vector3d(0, -9.81, 0);
  ImplicitEuler ie;
  for (int n = 0; n < 5; ++n) ie.step(s, 0.02);
  return s;
}

TEST(PhysicsBar, LocalGlobalObjectiveDecreasesAndReachesImplicitEuler) {
  const double h = 0.02;
  for (double kd : {0.0, 2.0}) {
    MassSpring start = sagging_bar(kd);
    MassSpring a = start, b = start;
    LocalGlobal lg;
    lg.iterations = 3000;
    lg.record_objective = true;
    StepResult r = lg.step(a, h);
    ASSERT_TRUE(r.ok());
    ASSERT_EQ(r.objective.size(), 3001u);
    double worst_rise = 0;
    for (size_t k = 1; k < r.objective.size(); ++k) {
      worst_rise = std::max(worst_rise,
                            (r.objective[k] - r.objective[k - 1]) / std::abs(r.objective[k - 1]));
    }
    // Strictly non-increasing while it still moves; within roundoff (1e-13 relative) once it
    // has converged.
    for (size_t k = 1; k <= 20; ++k) EXPECT_LE(r.objective[k], r.objective[k - 1]) << k;
    EXPECT_LE(worst_rise, 1e-13);
    EXPECT_LT(r.objective.back(), r.objective.front());
    ImplicitEuler ie;
    ie.tolerance = 1e-13;
    ie.max_iterations = 20000;
    ie.newton_iterations = 50;
    ie.newton_tolerance = 1e-14;
    StepResult q = ie.step(b, h);
    ASSERT_TRUE(q.ok());
    double diff = (a.x - b.x).cwiseAbs().maxCoeff();
    EXPECT_LT(diff, 1e-6);
    // The objective's minimiser is implicit Euler's: the converged IE state scores no higher.
    EXPECT_LE(lg.objective(start, start.x, start.v, b.x, h), r.objective.back() + 1e-12);
    std::printf(
        "local/global kd = %.1f, h = %.2f: objective %.9f -> %.9f (largest rise %.1e), "
        "after 10 its %.9f; vs implicit Euler (%d Newton its, %d CG its, residual "
        "%.1e): max |dx| %.2e\n",
        kd, h, r.objective.front(), r.objective.back(), worst_rise, r.objective[10],
        q.newton_iterations, q.iterations, q.residual, diff);
  }
}

TEST(PhysicsBar, LocalGlobalFactorisesOncePerSetting) {
  MassSpring s = sagging_bar(0);
  LocalGlobal lg;
  for (int n = 0; n < 20; ++n) ASSERT_TRUE(lg.step(s, 0.02).ok());
  EXPECT_EQ(lg.factorizations(), 1);
  ASSERT_TRUE(lg.step(s, 0.01).ok());
  EXPECT_EQ(lg.factorizations(), 2);
  s.springs[0].ks *= 2;
  ASSERT_TRUE(lg.step(s, 0.01).ok());
  EXPECT_EQ(lg.factorizations(), 3);
  s.pin(s.nodes() - 1);
  ASSERT_TRUE(lg.step(s, 0.01).ok());
  EXPECT_EQ(lg.factorizations(), 4);
}

TEST(PhysicsBar, PinsHoldAndDragsMove) {
  MassSpring s = sagging_bar(0.5);
  std::vector<int> pins;
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.is_pinned(i)) pins.push_back(i);
  }
  ExplicitEuler ee;
  Verlet vl;
  VelocityVerlet vv;
  ImplicitEuler ie;
  LocalGlobal lg;
  for (Integrator* integ : std::vector<Integrator*>{&ee, &vl, &vv, &ie, &lg}) {
    MassSpring t = s;
    for (int n = 0; n < 20; ++n) {
      std::vector<Eigen::Vector3d> to;
      for (int i : pins) to.push_back(s.position(i) + Eigen::Vector3d(0.001 * n, 0, 0));
      t.move_pinned(pins, to);
      ASSERT_TRUE(integ->step(t, 0.001).ok());
      for (size_t k = 0; k < pins.size(); ++k) {
        EXPECT_EQ(t.position(pins[k]), to[k]) << integ->name();
        EXPECT_EQ(t.velocity(pins[k]).norm(), 0) << integ->name();
      }
    }
  }
  EXPECT_THROW(s.move_pinned({s.nodes() - 1}, {Eigen::Vector3d::Zero()}), Error);
}

TEST(PhysicsBar, BlowUpIsReportedNotWritten) {
  MassSpring s = bar_system(1000, 0);
  Noise noise;
  for (Eigen::Index k = 0; k < s.x.size(); ++k) s.x[k] += 1e-3 * noise();
  ExplicitEuler ee;  // no energy bound: runs until a value is not finite
  StepResult r;
  int n = 0;
  for (; n < 2000; ++n) {
    r = ee.step(s, 0.5);
    if (!r.ok()) break;
  }
  ASSERT_EQ(r.status, StepStatus::non_finite);
  EXPECT_EQ(r.step, n);
  EXPECT_TRUE(s.x.allFinite());
  EXPECT_TRUE(s.v.allFinite());
  std::printf("explicit Euler h = 0.5 on the bar: %s\n", r.message.c_str());
}

TEST(PhysicsModels, BarTetrahedra) {
  TetMesh m = bar();
  EXPECT_EQ(m.tets.size(), 120u);
  EXPECT_EQ(m.nodes.size(), 54u);
  TetQuality q = tet_quality(m);
  EXPECT_NEAR(q.min_volume, 1.0 / 6, 1e-15);
  EXPECT_NEAR(q.max_volume, 1.0 / 6, 1e-15);
  // The Kuhn tetrahedron (corners 0, e_a, e_a + e_b, 1): dihedral angles 45°, 60°, 90° (two
  // each); faces 1/2, 1/2, √2/2, √2/2 so inradius r = 3V / area = 1 / (2 (1 + √2)), and aspect
  // ratio √3 / (2√6 r) = (1 + √2) / √2 = 1 + 1/√2.
  EXPECT_NEAR(q.min_dihedral_deg, 45, 1e-9);
  EXPECT_NEAR(q.max_dihedral_deg, 90, 1e-9);
  double aspect = 1 + 1 / std::sqrt(2.0);
  EXPECT_NEAR(q.max_aspect_ratio, aspect, 1e-12);
  MassSpring s = mass_spring(m, 2.0, 10);
  EXPECT_NEAR(s.mass.sum(), 2.0 * 20, 1e-12);
  EXPECT_LT(s.forces().norm(), 1e-12);  // at rest
  std::printf(
      "bar: %zu tets, %d nodes, %zu springs; min dihedral %.6f deg, max %.6f, "
      "max aspect %.6f\n",
      m.tets.size(), s.nodes(), s.springs.size(), q.min_dihedral_deg, q.max_dihedral_deg,
      q.max_aspect_ratio);
}

Grid3<std::uint8_t> sphere_mask(int n, double radius) {
  Grid3<std::uint8_t> mask(Eigen::Vector3d(-1, -1, -1), 2.0 / n, Eigen::Vector3i(n, n, n), 0);
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) mask.at(i, j, k) = mask.texel_centre(i, j, k).norm() < radius;
    }
  }
  return mask;
}

TEST(PhysicsModels, SphereMaskIsConforming) {
  Grid3<std::uint8_t> mask = sphere_mask(14, 0.9);
  TetMesh m = tetrahedralize(mask);
  ASSERT_GT(m.tets.size(), 0u);
  std::map<std::array<int, 3>, int> faces;
  int cells = 0;
  for (int k = 0; k + 1 < 14; ++k) {
    for (int j = 0; j + 1 < 14; ++j) {
      for (int i = 0; i + 1 < 14; ++i) {
        bool all = true;
        for (int c = 0; c < 8; ++c) {
          all = all && mask.at(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
        }
        cells += all;
      }
    }
  }
  EXPECT_EQ(m.tets.size(), 6u * cells);
  double volume = 0;
  for (int t = 0; t < static_cast<int>(m.tets.size()); ++t) {
    double v = tet_volume(m, t);
    EXPECT_GT(v, 0);
    volume += v;
    const auto& n = m.tets[t];
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int, 3> f;
      int w = 0;
      for (int a = 0; a < 4; ++a) {
        if (a != skip) f[w++] = n[a];
      }
      std::sort(f.begin(), f.end());
      faces[f] += 1;
    }
  }
  EXPECT_NEAR(volume, cells * std::pow(mask.spacing.x(), 3), 1e-12);
  // Every face belongs to one tet (boundary) or two (interior); the boundary faces close up:
  // each of their edges is used an even number of times (a hanging face would leave an odd one).
  std::map<std::array<int, 2>, int> boundary_edges;
  int interior = 0, boundary = 0;
  for (const auto& [f, count] : faces) {
    ASSERT_LE(count, 2);
    if (count == 2) {
      ++interior;
      continue;
    }
    ++boundary;
    boundary_edges[{f[0], f[1]}] += 1;
    boundary_edges[{f[1], f[2]}] += 1;
    boundary_edges[{f[0], f[2]}] += 1;
  }
  for (const auto& [e, count] : boundary_edges) EXPECT_EQ(count % 2, 0);
  TetQuality q = tet_quality(m);
  EXPECT_NEAR(q.min_dihedral_deg, 45, 1e-9);
  std::printf(
      "sphere mask 14^3: %d cells, %zu tets, %zu nodes, %d interior and %d boundary "
      "faces\n",
      cells, m.tets.size(), m.nodes.size(), interior, boundary);
  // Deterministic.
  TetMesh again = tetrahedralize(mask);
  EXPECT_EQ(again.tets, m.tets);
}

TEST(PhysicsModels, GridModelHasEighteenNeighbours) {
  Grid3<std::uint8_t> mask(Eigen::Vector3d::Zero(), 0.5, Eigen::Vector3i(3, 3, 3), 1);
  GridModel g = grid_model(mask, 4.0, 7.0);
  EXPECT_EQ(g.system.nodes(), 27);
  EXPECT_EQ(g.system.springs.size(), 54u + 72u);
  std::vector<int> degree(27, 0);
  int short_ones = 0, long_ones = 0;
  for (const Spring& s : g.system.springs) {
    ++degree[s.i];
    ++degree[s.j];
    if (std::abs(s.rest - 0.5) < 1e-15) ++short_ones;
    if (std::abs(s.rest - 0.5 * std::sqrt(2.0)) < 1e-15) ++long_ones;
  }
  EXPECT_EQ(short_ones, 54);
  EXPECT_EQ(long_ones, 72);
  EXPECT_EQ(degree[13], 18);  // the centre node
  EXPECT_NEAR(g.system.mass[0], 4.0 * 0.125, 1e-15);
  EXPECT_LT(g.system.forces().norm(), 1e-12);
  // A sphere: no node on an outside sample.
  Grid3<std::uint8_t> sphere = sphere_mask(10, 0.8);
  GridModel gs = grid_model(sphere, 1.0, 1.0);
  for (const auto& p : gs.sample) EXPECT_TRUE(sphere.at(p.x(), p.y(), p.z()));
}

template <class I>
std::vector<char> run_bytes(int steps) {
  MassSpring s = sagging_bar(0.5);
  I integ;
  for (int n = 0; n < steps; ++n) integ.step(s, 0.01);
  std::vector<char> bytes(sizeof(double) * (s.x.size() + s.v.size()));
  std::memcpy(bytes.data(), s.x.data(), sizeof(double) * s.x.size());
  std::memcpy(bytes.data() + sizeof(double) * s.x.size(), s.v.data(), sizeof(double) * s.v.size());
  return bytes;
}

TEST(PhysicsDeterminism, TwoRunsGiveIdenticalBytes) {
  EXPECT_EQ(run_bytes<ImplicitEuler>(50), run_bytes<ImplicitEuler>(50));
  EXPECT_EQ(run_bytes<LocalGlobal>(50), run_bytes<LocalGlobal>(50));
  EXPECT_EQ(run_bytes<Verlet>(100), run_bytes<Verlet>(100));
  EXPECT_EQ(run_bytes<VelocityVerlet>(100), run_bytes<VelocityVerlet>(100));
}

TEST(PhysicsSpectrum, LanczosMatchesDenseOmegaMax) {
  // The bar free and pinned at z = 0, and a sphere network: Lanczos's ω_max against a dense
  // eigen-solve of M^{-1/2} K M^{-1/2} on the free nodes.
  std::vector<MassSpring> systems = {bar_system(1000, 0), bar_system(1000, 0),
                                     mass_spring(tetrahedralize(sphere_mask(8, 0.95)), 2.0, 50)};
  pin_end(systems[1]);
  for (MassSpring& s : systems) {
    std::vector<int> free;
    for (int i = 0; i < s.nodes(); ++i) {
      if (!s.is_pinned(i)) free.push_back(i);
    }
    Eigen::MatrixXd K = -Eigen::MatrixXd(s.dfdx(s.x, false));
    Eigen::MatrixXd A(3 * free.size(), 3 * free.size());
    for (size_t a = 0; a < free.size(); ++a) {
      for (size_t b = 0; b < free.size(); ++b) {
        A.block<3, 3>(3 * a, 3 * b) =
            K.block<3, 3>(3 * free[a], 3 * free[b]) / std::sqrt(s.mass[free[a]] * s.mass[free[b]]);
      }
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(A, Eigen::EigenvaluesOnly);
    const double dense = std::sqrt(es.eigenvalues().maxCoeff());
    OmegaMax w = omega_max(s);
    EXPECT_TRUE(w.converged);
    EXPECT_NEAR(w.omega / dense, 1, 1e-8);
    EXPECT_EQ(w.dimension, static_cast<int>(3 * free.size()));
    std::printf("omega_max: Lanczos %.10g rad/s (%d steps), dense %.10g, %zu free nodes\n", w.omega,
                w.iterations, dense, free.size());
  }
  MassSpring all_pinned = bar_system(10, 0);
  for (int i = 0; i < all_pinned.nodes(); ++i) all_pinned.pin(i);
  EXPECT_THROW(omega_max(all_pinned), Error);
}

TEST(PhysicsSpectrum, VerletStableStepIsTwoOverOmegaMaxOnANetwork) {
  // A sphere network pinned at its lowest layer: Verlet's largest stable step by bisection to
  // 1 % is within 5 % of 2/ω_max from Lanczos.
  MassSpring s = mass_spring(tetrahedralize(sphere_mask(12, 0.95)), 1.0, 3000);
  double zmin = 1e300;
  for (int i = 0; i < s.nodes(); ++i) zmin = std::min(zmin, s.position(i).z());
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.position(i).z() < zmin + 1e-9) s.pin(i);
  }
  const double limit = verlet_step_limit(omega_max(s));
  double lo = 0.6 * limit, hi = 1.7 * limit;
  ASSERT_TRUE(verlet_stable(s, lo));
  ASSERT_FALSE(verlet_stable(s, hi));
  while (hi / lo > 1.01) {
    double mid = std::sqrt(lo * hi);
    (verlet_stable(s, mid) ? lo : hi) = mid;
  }
  EXPECT_NEAR(lo / limit, 1, 0.05);
  std::printf("Verlet on a %d-node sphere network: 2/w_max %.6g s, largest stable %.6g s (%.4f)\n",
              s.nodes(), limit, lo, lo / limit);
}

// A network of more than 4096 nodes, so that forces, the implicit system and the local/global
// sweeps take their parallel paths.
template <class I>
std::vector<char> network_bytes(int threads) {
  tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
  MassSpring s =
      mass_spring(tetrahedralize(ellipsoid_mask(Eigen::Vector3d(13, 10, 10))), 1.0, 3e4, 0.5);
  double zmin = 1e300;
  for (int i = 0; i < s.nodes(); ++i) zmin = std::min(zmin, s.position(i).z());
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.position(i).z() < zmin + 1.5) s.pin(i);
  }
  s.gravity = Eigen::Vector3d(0, 0, -9.81);
  EXPECT_GT(s.nodes(), 4096);
  I integ;
  for (int n = 0; n < 4; ++n) EXPECT_TRUE(integ.step(s, 2e-3).ok());
  std::vector<char> bytes(sizeof(double) * (s.x.size() + s.v.size()));
  std::memcpy(bytes.data(), s.x.data(), sizeof(double) * s.x.size());
  std::memcpy(bytes.data() + sizeof(double) * s.x.size(), s.v.data(), sizeof(double) * s.v.size());
  return bytes;
}

TEST(PhysicsDeterminism, ThreadCountDoesNotChangeResults) {
  EXPECT_EQ(network_bytes<ExplicitEuler>(1), network_bytes<ExplicitEuler>(4));
  EXPECT_EQ(network_bytes<Verlet>(1), network_bytes<Verlet>(4));
  EXPECT_EQ(network_bytes<VelocityVerlet>(1), network_bytes<VelocityVerlet>(4));
  EXPECT_EQ(network_bytes<ImplicitEuler>(1), network_bytes<ImplicitEuler>(4));
  EXPECT_EQ(network_bytes<LocalGlobal>(1), network_bytes<LocalGlobal>(4));
}

TEST(PhysicsSpring, ForcesFollowChangedSprings) {
  // The kept adjacency is rebuilt when the springs' ends change.
  MassSpring s = bar_system(100, 0);
  Vector f0 = s.forces();
  s.x[3 * 5] += 0.1;
  Vector f1 = s.forces();
  ASSERT_EQ(s.springs[0].i, 0);
  s.springs[0].j = 5;  // now to the moved node, at another distance than its rest length
  Vector f2 = s.forces();
  MassSpring fresh;
  for (int i = 0; i < s.nodes(); ++i) fresh.add_node(s.position(i), s.mass[i]);
  fresh.springs = s.springs;
  EXPECT_EQ(f2, fresh.forces());
  EXPECT_NE(f1, f2);
  EXPECT_LT(f0.norm(), 1e-12);
}

}  // namespace
}  // namespace raywarp::physics
