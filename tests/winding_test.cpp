// Generalised winding number: the exact sum against the known inside/outside of closed meshes,
// the hierarchical evaluation against the exact one, open meshes, and concurrent queries.
#include "library/winding.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <thread>
#include <vector>

#include "library/mesh.h"
#include "tests/mesh_fixtures.h"

namespace raywarp {
namespace {

// Seeded uniform points in the box centre +- half.
std::vector<Eigen::Vector3d> random_points(int count, const Eigen::Vector3d& centre,
                                           const Eigen::Vector3d& half, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> points(count);
  for (auto& p : points) p = centre + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(half);
  return points;
}

// Signed distance from p to the surface of the cube [-h, h]^3, positive inside.
double cube_signed_distance(const Eigen::Vector3d& p, double h) {
  const Eigen::Vector3d q = p.cwiseAbs() - Eigen::Vector3d::Constant(h);
  const double outside = q.cwiseMax(0.0).norm();
  return outside > 0 ? -outside : -q.maxCoeff();
}

TEST(Winding, FixtureMeshesAreOutwardOriented) {
  EXPECT_NEAR(fixtures::signed_volume(fixtures::cube(1.0)), 8.0, 1e-12);
  // An inscribed icosphere has a little less than the sphere's volume.
  const double volume = fixtures::signed_volume(fixtures::icosphere(1.0, 3));
  EXPECT_GT(volume, 0.97 * 4.0 / 3.0 * M_PI);
  EXPECT_LT(volume, 4.0 / 3.0 * M_PI);
}

TEST(Winding, ExactIsOneInsideAndZeroOutsideClosedMeshes) {
  // For a closed mesh the solid angles sum to exactly 4 pi or 0; the float error of the sum of
  // n atan2 terms of size <= 1/2 is ~ n * 1e-16, so 1e-10 is generous for n = 1280.
  const Mesh sphere = fixtures::icosphere(1.0, 3);
  const Mesh cube = fixtures::cube(1.0);
  const WindingNumber ws(sphere), wc(cube);
  for (const Eigen::Vector3d& p :
       random_points(1000, Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(2.0), 1)) {
    const double r = p.norm();
    // The inscribed icosphere lies between radii cos(angle) and 1: skip that shell.
    if (r < 0.95 || r > 1.0) {
      EXPECT_NEAR(ws.exact(p), r < 1.0 ? 1.0 : 0.0, 1e-10) << p.transpose();
    }
    const double d = cube_signed_distance(p, 1.0);
    if (std::abs(d) > 1e-9) {
      EXPECT_NEAR(wc.exact(p), d > 0 ? 1.0 : 0.0, 1e-12) << p.transpose();
    }
  }
}

TEST(Winding, ReversedOrientationGivesMinusOne) {
  Mesh cube = fixtures::cube(1.0);
  cube.F.col(1).swap(cube.F.col(2));
  const WindingNumber w(cube);
  EXPECT_NEAR(w.exact(Eigen::Vector3d(0.1, 0.2, 0.3)), -1.0, 1e-12);
  EXPECT_NEAR(w(Eigen::Vector3d(0.1, 0.2, 0.3)), -1.0, 1e-12);
}

TEST(Winding, FarFieldErrorFallsAsTheFourthPowerOfDistance) {
  // Eight random triangles: one leaf, which the tree takes by its expansion whenever
  // |q - p~| > beta r. Through second order (dipole + quadrupole) the remainder falls as
  // |q - p~|^-4, against |q - p~|^-2 for the expansion's leading term: doubling the distance
  // must divide the error by ~16 (> 10 allows for the next order at the nearest distance).
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Mesh soup;
  soup.V.resize(24, 3);
  soup.F.resize(8, 3);
  for (int v = 0; v < 24; ++v) soup.V.row(v) << u(rng), u(rng), 0.3 * u(rng);
  for (int f = 0; f < 8; ++f) soup.F.row(f) << 3 * f, 3 * f + 1, 3 * f + 2;
  const WindingNumber w(soup, 1e-9);
  std::vector<Eigen::Vector3d> directions =
      random_points(100, Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones(), 8);
  double previous = 0;
  for (double distance : {4.0, 8.0, 16.0, 32.0}) {
    double error = 0;
    for (const Eigen::Vector3d& d : directions) {
      const Eigen::Vector3d q = distance * d.normalized();
      error = std::max(error, std::abs(w(q) - w.exact(q)));
    }
    if (previous > 0) {
      EXPECT_GT(previous / error, 10.0) << "at distance " << distance;
    }
    previous = error;
  }
}

TEST(Winding, HierarchicalMatchesExactAwayFromTheSurface) {
  // The truncated expansion of a node at distance beta r errs by a fraction of its
  // contribution that shrinks with beta. The worst case is the inside of a sphere, where every
  // node is curved the same way and the errors add up: measured 0.073 at beta = 2 and 0.0065
  // at beta = 5 (sphere, 1280 triangles). So: 1e-2 at beta = 5, and at the default beta = 2 a
  // bound of 0.1, which still leaves 0.4 between a closed mesh's 0 or 1 and the threshold 1/2.
  const Mesh sphere = fixtures::icosphere(1.0, 3);
  const Mesh cube = fixtures::cube(1.0);
  const WindingNumber sphere_default(sphere), sphere_fine(sphere, 5.0), cube_default(cube);
  for (const Eigen::Vector3d& p :
       random_points(1000, Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(2.0), 2)) {
    if (std::abs(p.norm() - 1.0) < 0.05) continue;  // away from the surface
    const double exact = sphere_default.exact(p);
    EXPECT_NEAR(sphere_fine(p), exact, 1e-2) << p.transpose();
    EXPECT_NEAR(sphere_default(p), exact, 0.1) << p.transpose();
    if (std::abs(cube_signed_distance(p, 1.0)) > 0.05) {
      // 12 triangles in two leaves of 6: near queries are exact, far ones expanded.
      EXPECT_NEAR(cube_default(p), cube_default.exact(p), 0.1) << p.transpose();
    }
  }
}

TEST(Winding, BunnySignsAgreeWithTheExactSum) {
  const Mesh bunny = load_mesh(RAYWARP_SOURCE_DIR "/examples/meshes/bunny.ply");
  const MeshStats stats = mesh_stats(bunny);
  const WindingNumber w(bunny);
  const std::vector<Eigen::Vector3d> points =
      random_points(1000, stats.bounds.center(), 0.6 * stats.bounds.sizes(), 3);
  int agree = 0, inside = 0;
  for (const Eigen::Vector3d& p : points) {
    const bool exact_inside = w.exact(p) > 0.5;
    agree += (w(p) > 0.5) == exact_inside;
    inside += exact_inside;
  }
  EXPECT_GT(agree, 0.995 * points.size());
  EXPECT_GT(inside, 0.05 * points.size());  // the experiment has points on both sides
  EXPECT_LT(inside, 0.95 * points.size());
}

TEST(Winding, OpenSphereStillHasAnInside) {
  // A hole of ~1% of the area (cap of angular radius 0.2): the centre sees 99% of the sphere.
  const Mesh sphere = fixtures::icosphere(1.0, 3);
  const Mesh open = fixtures::with_hole(sphere, Eigen::Vector3d(0, 0, 1), 0.2);
  ASSERT_LT(open.F.rows(), sphere.F.rows());
  EXPECT_FALSE(mesh_stats(open).closed());
  const WindingNumber w(open);
  EXPECT_GT(w(Eigen::Vector3d::Zero()), 0.9);
  EXPECT_GT(w.exact(Eigen::Vector3d::Zero()), 0.9);
  EXPECT_LT(w(Eigen::Vector3d(0, 0, 5)), 0.1);  // in front of the hole
  EXPECT_LT(w(Eigen::Vector3d(3, -4, 2)), 0.1);
  EXPECT_GT(w(Eigen::Vector3d(0, 0, 0.7)), 0.5);  // inside, facing the hole
}

TEST(Winding, ConcurrentQueriesEqualSerialOnes) {
  const Mesh sphere = fixtures::icosphere(1.0, 4);
  const WindingNumber w(sphere);
  const std::vector<Eigen::Vector3d> points =
      random_points(5000, Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(1.5), 4);
  std::vector<double> serial(points.size()), parallel(points.size());
  for (size_t i = 0; i < points.size(); ++i) serial[i] = w(points[i]);
  std::vector<std::thread> threads;
  const int count = 4;
  for (int t = 0; t < count; ++t) {
    threads.emplace_back([&, t] {
      for (size_t i = t; i < points.size(); i += count) parallel[i] = w(points[i]);
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(serial, parallel);
}

TEST(Winding, EmptyAndDegenerateMeshesGiveZero) {
  const WindingNumber empty{Mesh{}};
  EXPECT_EQ(empty(Eigen::Vector3d(1, 2, 3)), 0.0);
  Mesh flat;
  flat.V.resize(3, 3);
  flat.V << 0, 0, 0, 1, 0, 0, 2, 0, 0;  // collinear
  flat.F.resize(1, 3);
  flat.F << 0, 1, 2;
  const WindingNumber degenerate(flat);
  EXPECT_EQ(degenerate(Eigen::Vector3d(0.5, 0, 0)), 0.0);  // on it
  EXPECT_EQ(degenerate(Eigen::Vector3d(0.5, 1, 0)), 0.0);
}

}  // namespace
}  // namespace raywarp
