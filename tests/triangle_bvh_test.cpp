// The double-precision triangle BVH (library/triangle_bvh.h) against brute force: the nearest
// triangle to a point (with and without a bound) and the triangles along a ray, on random
// triangles and on the icosphere fixture.
#include "library/triangle_bvh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "tests/mesh_fixtures.h"

namespace raywarp {
namespace {

using Vec3 = Eigen::Vector3d;
constexpr double kInf = std::numeric_limits<double>::infinity();

std::vector<Triangle3d> random_triangles(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> centre(-1.0, 1.0), size(0.01, 0.3);
  std::normal_distribution<double> offset(0.0, 1.0);
  std::vector<Triangle3d> out(n);
  for (Triangle3d& t : out) {
    const Vec3 c(centre(rng), centre(rng), centre(rng));
    const double s = size(rng);
    for (Vec3& v : t) v = c + s * Vec3(offset(rng), offset(rng), offset(rng));
  }
  return out;
}

std::vector<Triangle3d> triangles_of(const Mesh& mesh) {
  std::vector<Triangle3d> out(mesh.F.rows());
  for (int f = 0; f < mesh.F.rows(); ++f)
    out[f] = {mesh.vertex(f, 0), mesh.vertex(f, 1), mesh.vertex(f, 2)};
  return out;
}

double distance_to(const Triangle3d& t, const Vec3& p) {
  return (p - closest_point_on_triangle(p, t[0], t[1], t[2])).norm();
}

// The nearest triangle by trying all.
std::pair<int, double> brute_nearest(const std::vector<Triangle3d>& tris, const Vec3& p) {
  std::pair<int, double> best{-1, kInf};
  for (int k = 0; k < static_cast<int>(tris.size()); ++k) {
    const double d = distance_to(tris[k], p);
    if (d < best.second) best = {k, d};
  }
  return best;
}

// The nearest hit with t in [t_min, t_max], and the number of hits beyond t_from, by trying all.
std::optional<TriangleBvh::Hit> brute_hit(const std::vector<Triangle3d>& tris, const Vec3& o,
                                          const Vec3& d, double t_min, double t_max) {
  std::optional<TriangleBvh::Hit> best;
  for (int k = 0; k < static_cast<int>(tris.size()); ++k) {
    auto h = intersect_triangle(o, d, tris[k][0], tris[k][1], tris[k][2]);
    if (h && h->t >= t_min && h->t <= t_max && (!best || h->t < best->hit.t))
      best = TriangleBvh::Hit{k, *h};
  }
  return best;
}

int brute_count_after(const std::vector<Triangle3d>& tris, const Vec3& o, const Vec3& d,
                      double t_from) {
  int count = 0;
  for (const Triangle3d& t : tris) {
    auto h = intersect_triangle(o, d, t[0], t[1], t[2]);
    count += h && h->t > t_from;
  }
  return count;
}

Vec3 random_direction(std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  return Vec3(g(rng), g(rng), g(rng)).normalized();
}

TEST(ClosestPoint, Regions) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_EQ(closest_point_on_triangle(Vec3(-1, -1, 2), a, b, c), a);   // vertex a
  EXPECT_EQ(closest_point_on_triangle(Vec3(2, -0.5, 1), a, b, c), b);  // vertex b
  EXPECT_EQ(closest_point_on_triangle(Vec3(-0.5, 3, 0), a, b, c), c);  // vertex c
  EXPECT_TRUE(closest_point_on_triangle(Vec3(0.5, -2, 1), a, b, c).isApprox(Vec3(0.5, 0, 0)));
  EXPECT_TRUE(closest_point_on_triangle(Vec3(-2, 0.25, 0), a, b, c).isApprox(Vec3(0, 0.25, 0)));
  EXPECT_TRUE(closest_point_on_triangle(Vec3(1, 1, 0), a, b, c).isApprox(Vec3(0.5, 0.5, 0)));
  EXPECT_TRUE(closest_point_on_triangle(Vec3(0.2, 0.3, -4), a, b, c).isApprox(Vec3(0.2, 0.3, 0)));
  // Degenerate: a point, and a segment.
  EXPECT_EQ(closest_point_on_triangle(Vec3(3, 3, 3), b, b, b), b);
  EXPECT_TRUE(closest_point_on_triangle(Vec3(0.5, 2, 0), a, a, b).isApprox(Vec3(0.5, 0, 0)));
  EXPECT_TRUE(closest_point_on_triangle(Vec3(0.5, 2, 0), a, b, b).isApprox(Vec3(0.5, 0, 0)));
}

TEST(TriangleBvh, NearestMatchesBruteForceOnRandomTriangles) {
  std::mt19937 rng(7);
  const std::vector<Triangle3d> tris = random_triangles(600, rng);
  const TriangleBvh bvh(tris);
  EXPECT_EQ(bvh.size(), 600);
  std::uniform_real_distribution<double> u(-1.6, 1.6);
  for (int q = 0; q < 2000; ++q) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const auto [k, d] = brute_nearest(tris, p);
    const TriangleBvh::Nearest n = bvh.nearest(p);
    ASSERT_GE(n.triangle, 0);
    EXPECT_NEAR(n.distance, d, 1e-12) << q;
    // The triangle it names is that near, and its point lies on it.
    EXPECT_NEAR(distance_to(tris[n.triangle], p), d, 1e-12) << q;
    EXPECT_NEAR((n.point - p).norm(), n.distance, 1e-12) << q;
    if (n.triangle != k) {
      EXPECT_NEAR(distance_to(tris[k], p), distance_to(tris[n.triangle], p), 1e-12);
    }
    // Within a bound: the distance when nearer, else the bound and no triangle.
    const double bound = 0.5 * d + 0.05 * (q % 3);
    const TriangleBvh::Nearest b = bvh.nearest(p, bound);
    if (d < bound * (1 - 1e-9)) {
      EXPECT_NEAR(b.distance, d, 1e-12);
      EXPECT_GE(b.triangle, 0);
    } else if (d > bound * (1 + 1e-9)) {
      EXPECT_DOUBLE_EQ(b.distance, bound);
      EXPECT_EQ(b.triangle, -1);
    }
    EXPECT_EQ(bvh.nearest_distance(p, bound), b.distance);
  }
}

TEST(TriangleBvh, RayQueriesMatchBruteForceOnRandomTriangles) {
  std::mt19937 rng(11);
  const std::vector<Triangle3d> tris = random_triangles(600, rng);
  const TriangleBvh bvh(tris);
  std::uniform_real_distribution<double> u(-1.5, 1.5), t(-1.0, 1.0);
  int hits = 0;
  for (int q = 0; q < 3000; ++q) {
    const Vec3 o(u(rng), u(rng), u(rng));
    // Towards a point near the triangles, so that most rays meet some.
    const Vec3 d = (Vec3(t(rng), t(rng), t(rng)) - o).normalized();
    const double t_min = q % 4 == 0 ? -kInf : 0.1 * (q % 5), t_max = q % 7 == 0 ? 1.5 : kInf;
    const auto expected = brute_hit(tris, o, d, t_min, t_max);
    const auto got = bvh.nearest_hit(o, d, t_min, t_max);
    ASSERT_EQ(got.has_value(), expected.has_value()) << q;
    if (got) {
      ++hits;
      EXPECT_NEAR(got->hit.t, expected->hit.t, 1e-12) << q;
      auto h = intersect_triangle(o, d, tris[got->triangle][0], tris[got->triangle][1],
                                  tris[got->triangle][2]);
      ASSERT_TRUE(h);
      EXPECT_EQ(h->t, got->hit.t);
      EXPECT_EQ(h->u, got->hit.u);
      EXPECT_EQ(h->v, got->hit.v);
    }
    // A filter: only hits beyond the nearest one.
    if (expected) {
      const double first = expected->hit.t;
      const auto second = bvh.nearest_hit(o, d, t_min, t_max, [&](double x) { return x > first; });
      std::optional<double> brute_second;
      for (const Triangle3d& tri : tris) {
        auto h = intersect_triangle(o, d, tri[0], tri[1], tri[2]);
        if (h && h->t >= t_min && h->t <= t_max && h->t > first &&
            (!brute_second || h->t < *brute_second))
          brute_second = h->t;
      }
      ASSERT_EQ(second.has_value(), brute_second.has_value()) << q;
      if (second) {
        EXPECT_NEAR(second->hit.t, *brute_second, 1e-12) << q;
      }
    }
    const double from = q % 3 == 0 ? -kInf : t(rng);
    EXPECT_EQ(bvh.count_after(o, d, from), brute_count_after(tris, o, d, from)) << q;
  }
  EXPECT_GT(hits, 1000);  // the test meant something
}

TEST(TriangleBvh, SphereFixture) {
  const Mesh sphere = fixtures::icosphere(1.0, 3, Vec3(0.2, -0.1, 0.3));  // 1280 triangles
  const std::vector<Triangle3d> tris = triangles_of(sphere);
  const TriangleBvh bvh(sphere);
  ASSERT_EQ(bvh.size(), 1280);
  // The largest gap between the sphere and its inscribed mesh (a face centre's depth).
  double sagitta = 0.0;
  for (const Triangle3d& t : tris)
    sagitta = std::max(sagitta, 1.0 - ((t[0] + t[1] + t[2]) / 3.0 - Vec3(0.2, -0.1, 0.3)).norm());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> radius(0.2, 2.5);
  for (int q = 0; q < 500; ++q) {
    const Vec3 dir = random_direction(rng);
    const double r = radius(rng);
    const Vec3 p = Vec3(0.2, -0.1, 0.3) + r * dir;
    const double brute = brute_nearest(tris, p).second;
    const TriangleBvh::Nearest n = bvh.nearest(p);
    EXPECT_NEAR(n.distance, brute, 1e-12) << q;
    EXPECT_NEAR(n.distance, std::abs(r - 1.0), sagitta + 1e-12) << q;
    // Face indices are the mesh's.
    EXPECT_NEAR(distance_to(tris[n.triangle], p), n.distance, 1e-12) << q;

    // A ray from p: one hit beyond an inside point, none or two beyond an outside one.
    const Vec3 d = random_direction(rng);
    const int beyond = bvh.count_after(p, d, 0.0);
    EXPECT_EQ(beyond, brute_count_after(tris, p, d, 0.0)) << q;
    if (r < 1.0 - sagitta - 1e-9) {
      EXPECT_EQ(beyond, 1) << q;
    } else if (r > 1.0 + 1e-9) {
      EXPECT_TRUE(beyond == 0 || beyond == 2) << q;
    }
    // Through the centre from outside: the first hit is the near side.
    if (r > 1.0) {
      const Vec3 in = -dir;
      const auto h = bvh.nearest_hit(p, in, 0.0, kInf);
      ASSERT_TRUE(h) << q;
      EXPECT_NEAR(h->hit.t, r - 1.0, sagitta + 1e-12) << q;
      const auto b = brute_hit(tris, p, in, 0.0, kInf);
      ASSERT_TRUE(b);
      EXPECT_NEAR(h->hit.t, b->hit.t, 1e-12) << q;
      EXPECT_EQ(bvh.count_after(p, in, -kInf), 2) << q;
      const Vec3 at = p + h->hit.t * in;
      const Vec3 on = (1 - h->hit.u - h->hit.v) * sphere.vertex(h->triangle, 0) +
                      h->hit.u * sphere.vertex(h->triangle, 1) +
                      h->hit.v * sphere.vertex(h->triangle, 2);
      EXPECT_LT((at - on).norm(), 1e-12) << q;
    }
  }
}

TEST(TriangleBvh, Empty) {
  const TriangleBvh bvh{std::vector<Triangle3d>{}};
  EXPECT_TRUE(bvh.empty());
  EXPECT_EQ(bvh.nearest(Vec3::Zero(), 2.0).triangle, -1);
  EXPECT_EQ(bvh.nearest_distance(Vec3::Zero(), 2.0), 2.0);
  EXPECT_FALSE(bvh.nearest_hit(Vec3::Zero(), Vec3::UnitX(), -kInf, kInf));
  EXPECT_EQ(bvh.count_after(Vec3::Zero(), Vec3::UnitX(), -kInf), 0);
}

}  // namespace
}  // namespace raywarp
