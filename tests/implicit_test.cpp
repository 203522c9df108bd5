// The distance grid against shapes whose signed distance is known: a sphere (up to its
// tessellation) and a cube (exactly), in axis-aligned and rotated boxes; the narrow band and its
// background, the sign of open meshes, the memory budget, progress and cancelling.
#include "library/implicit.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "base/error.h"
#include "library/winding.h"
#include "tests/mesh_fixtures.h"

namespace raywarp {
namespace {

// Calls fn(texel centre in the box's local frame, value) for every texel.
void for_each_texel(const DistanceGrid& sdf,
                    const std::function<void(const Eigen::Vector3d&, float)>& fn) {
  const Grid3<float>& g = sdf.grid;
  for (int k = 0; k < g.dims.z(); ++k) {
    for (int j = 0; j < g.dims.y(); ++j) {
      for (int i = 0; i < g.dims.x(); ++i) fn(g.texel_centre(i, j, k), g.at(i, j, k));
    }
  }
}

ImplicitSpec spec_with(int resolution, double band_voxels = 3.0, double margin_voxels = 2.0) {
  ImplicitSpec spec;
  spec.resolution = resolution;
  spec.band_voxels = band_voxels;
  spec.margin_voxels = margin_voxels;
  return spec;
}

Box cube_box(double half) {
  Box box;
  box.half_extents = Eigen::Vector3d::Constant(half);
  return box;
}

// Signed distance to the cube [-h, h]^3, positive inside.
double cube_sdf(const Eigen::Vector3d& p, double h) {
  const Eigen::Vector3d q = p.cwiseAbs() - Eigen::Vector3d::Constant(h);
  const double outside = q.cwiseMax(0.0).norm();
  return outside > 0 ? -outside : -q.maxCoeff();
}

// Checks a bake against a known signed distance `exact` (positive inside) that the mesh
// follows within [exact - low, exact + high] (the mesh's own tessellation error) and float
// rounding `eps`:
//  - in the band, f is within that interval;
//  - a texel surely nearer than the background is in the band, one surely farther reads exactly
//    +-background with the sign of `exact`;
//  - |f| <= background everywhere.
void expect_signed_distance(const DistanceGrid& sdf, const Box& box,
                            const std::function<double(const Eigen::Vector3d&)>& exact, double low,
                            double high, double eps) {
  const double background = sdf.background;
  long band = 0, failures = 0;
  for_each_texel(sdf, [&](const Eigen::Vector3d& q, float f) {
    const double d = exact(box.to_object(q));
    ASSERT_TRUE(std::isfinite(f));
    ASSERT_LE(std::abs(f), background);
    if (std::abs(d) < background - std::max(low, high) - eps) {
      ++band;
      // f is a distance here, not the background.
      if (!(std::abs(f) < background) || f < d - low - eps || f > d + high + eps) {
        if (++failures <= 5)
          ADD_FAILURE() << "at " << q.transpose() << ": f = " << f << ", exact " << d;
      }
    } else if (std::abs(d) > background + std::max(low, high) + eps) {
      const float expected = d > 0 ? sdf.background : -sdf.background;
      if (f != expected && ++failures <= 5) {
        ADD_FAILURE() << "beyond the band at " << q.transpose() << ": f = " << f << ", exact " << d;
      }
    }
  });
  EXPECT_EQ(failures, 0);
  EXPECT_GT(band, 0);
  EXPECT_GE(sdf.active_voxels, band);  // the band also holds the texels of the tolerance shell
  EXPECT_EQ(sdf.active_voxels, std::count_if(sdf.grid.data.begin(), sdf.grid.data.end(),
                                             [&](float f) { return std::abs(f) < background; }));
}

// Distance from p to triangle abc, by cases (an independent reference for the bake): inside
// the prism over the triangle, the distance to its plane; else the nearest of its three edges.
double triangle_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                         const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  auto segment = [&](const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
    const double t =
        std::clamp((p - u).dot(v - u) / std::max((v - u).squaredNorm(), 1e-300), 0.0, 1.0);
    return (p - (u + t * (v - u))).norm();
  };
  const Eigen::Vector3d n = (b - a).cross(c - a);
  if (n.squaredNorm() > 0) {
    const bool inside = n.dot((b - a).cross(p - a)) >= 0 && n.dot((c - b).cross(p - b)) >= 0 &&
                        n.dot((a - c).cross(p - c)) >= 0;
    if (inside) return std::abs((p - a).dot(n)) / n.norm();
  }
  return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

double mesh_distance(const Mesh& mesh, const Eigen::Vector3d& p) {
  double d = std::numeric_limits<double>::infinity();
  for (int f = 0; f < mesh.F.rows(); ++f) {
    d = std::min(d, triangle_distance(p, mesh.vertex(f, 0), mesh.vertex(f, 1), mesh.vertex(f, 2)));
  }
  return d;
}

TEST(Implicit, GridCoversTheBoxPlusMargin) {
  const Box box = [] {
    Box b;
    b.half_extents = Eigen::Vector3d(1.0, 0.5, 0.25);
    return b;
  }();
  const DistanceGrid sdf = bake_distance_grid(fixtures::cube(0.2), box, spec_with(32, 3, 2));
  // 32 voxels along the longest side (2 units), 2 voxels of margin on every side.
  EXPECT_DOUBLE_EQ(sdf.grid.voxel(), 2.0 / 32);
  EXPECT_EQ(sdf.grid.dims, Eigen::Vector3i(36, 20, 12));
  EXPECT_TRUE(sdf.grid.origin.isApprox(-0.5 * sdf.grid.extent()));
  EXPECT_FLOAT_EQ(sdf.background, 3 * 2.0 / 32);
  EXPECT_EQ(sdf.band_voxels, 3.0);
  EXPECT_EQ(sdf.sign_method, "generalised winding number (Barill et al. 2018)");
  EXPECT_GT(sdf.active_voxels, 0);
  EXPECT_GE(sdf.bake_seconds, 0.0);
}

TEST(Implicit, CubeDistancesAreExactInTheBand) {
  // The cube mesh is the cube: the only error is OpenVDB's float arithmetic on coordinates of
  // size ~1, a few 1e-7; 1e-5 leaves a margin and is 1e-3 of a voxel.
  const double h = 0.6;
  const Box box = cube_box(1.0);
  const DistanceGrid sdf = bake_distance_grid(fixtures::cube(h), box, spec_with(40));
  expect_signed_distance(
      sdf, box, [&](const Eigen::Vector3d& p) { return cube_sdf(p, h); }, 0, 0, 1e-5);
}

TEST(Implicit, SphereDistancesMatchWithinTheTessellation) {
  // The icosphere is inscribed: its surface lies between radius r - s and r (s the largest
  // sagitta), so the distance to it is within [r - |p| - s, r - |p|] inside and out (sign f > 0
  // inside). OpenVDB computes exact point-triangle distances in the band; float rounding of
  // coordinates ~1 adds a few 1e-7.
  const double r = 1.0;
  const Mesh sphere = fixtures::icosphere(r, 5);
  const double sag = fixtures::max_sagitta(sphere, r);
  ASSERT_LT(sag, 2e-3);  // a tolerance much finer than the voxel (0.05)
  const Box box = cube_box(1.25);
  const DistanceGrid sdf = bake_distance_grid(sphere, box, spec_with(40));
  expect_signed_distance(
      sdf, box, [&](const Eigen::Vector3d& p) { return r - p.norm(); }, sag, 0, 1e-5);
}

TEST(Implicit, RotatedBoxReadsTheMeshInItsLocalFrame) {
  // A non-cubic, rotated, off-centre box over part of a sphere: texel centres are local, the
  // sphere is in object space.
  Box box;
  box.centre = Eigen::Vector3d(0.3, -0.2, 0.1);
  box.half_extents = Eigen::Vector3d(0.9, 0.7, 0.5);
  box.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const double r = 0.8;
  const Eigen::Vector3d c(0.2, 0.0, 0.0);
  const Mesh sphere = fixtures::icosphere(r, 4, c);
  const double sag = fixtures::max_sagitta(sphere, r);
  const DistanceGrid sdf = bake_distance_grid(sphere, box, spec_with(32));
  EXPECT_DOUBLE_EQ(sdf.grid.voxel(), 2 * 0.9 / 32);
  expect_signed_distance(
      sdf, box, [&](const Eigen::Vector3d& p) { return r - (p - c).norm(); }, sag, 0, 1e-5);
}

TEST(Implicit, BunnyMatchesBruteForceDistanceAndExactWindingNumber) {
  // A real scan in a rotated box over its head: 300 texels against the distance to all
  // 3674 triangles (double, by cases) and the sign of the exact winding number (the bunny is
  // closed: w is 0 or 1 up to rounding). Band values are the same distance computed in double
  // and stored as float: 1e-6 relative to the coordinates (~5) is 5e-6.
  const Mesh bunny = load_mesh(RAYWARP_SOURCE_DIR "/examples/meshes/bunny.ply");
  ASSERT_TRUE(mesh_stats(bunny).closed());
  Box box;
  box.centre = Eigen::Vector3d(-1.5, 7.0, 0.5);
  box.half_extents = Eigen::Vector3d(2.5, 2.0, 1.5);
  box.rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  const DistanceGrid sdf = bake_distance_grid(bunny, box, spec_with(32));
  const WindingNumber winding(bunny);
  long band = 0, beyond = 0;
  const size_t stride = sdf.grid.size() / 300 | 1;  // odd: no alignment with the rows
  for (size_t t = 0; t < sdf.grid.size(); t += stride) {
    const int i = int(t % sdf.grid.dims.x()), j = int(t / sdf.grid.dims.x() % sdf.grid.dims.y()),
              k = int(t / sdf.grid.dims.x() / sdf.grid.dims.y());
    const Eigen::Vector3d p = box.to_object(sdf.grid.texel_centre(i, j, k));
    const float f = sdf.grid.data[t];
    const double d = mesh_distance(bunny, p);
    const bool inside = winding.exact(p) > 0.5;
    if (d < sdf.background - 5e-6) {
      ++band;
      EXPECT_NEAR(std::abs(f), d, 5e-6) << p.transpose();
    } else if (d > sdf.background + 5e-6) {
      ++beyond;
      EXPECT_EQ(std::abs(f), sdf.background) << p.transpose();  // a lower bound of d
    }
    if (d > 1e-6) {
      EXPECT_EQ(f > 0, inside) << "f = " << f << " at " << p.transpose();
    }
  }
  EXPECT_GT(band, 25);
  EXPECT_GT(beyond, 25);
}

TEST(Implicit, OpenMeshKeepsItsInsidePositive) {
  // A hole of angular radius ~0.25 in a sphere of radius 1. OpenVDB's own flood fill would leak
  // through it; the winding number still sees ~97% of the sphere from the inside.
  const double r = 1.0;
  const Mesh closed = fixtures::icosphere(r, 4);
  const Eigen::Vector3d hole(0, 0, r);
  const double hole_radius = 0.25;
  const Mesh open = fixtures::with_hole(closed, hole, hole_radius);
  ASSERT_FALSE(mesh_stats(open).closed());
  const Box box = cube_box(1.25);
  const DistanceGrid a = bake_distance_grid(closed, box, spec_with(32));
  const DistanceGrid b = bake_distance_grid(open, box, spec_with(32));
  const double voxel = b.grid.voxel();
  long checked = 0;
  for (size_t t = 0; t < b.grid.size(); ++t) {
    const int i = int(t % b.grid.dims.x()), j = int(t / b.grid.dims.x() % b.grid.dims.y()),
              k = int(t / b.grid.dims.x() / b.grid.dims.y());
    const Eigen::Vector3d p = b.grid.texel_centre(i, j, k);
    const float f = b.grid.data[t];
    // Two voxels off the sphere, the sign is the sphere's also next to the hole.
    if (std::abs(p.norm() - r) > 2 * voxel) {
      EXPECT_EQ(f > 0, p.norm() < r) << "f = " << f << " at " << p.transpose();
    }
    // Farther from the hole than its radius plus the band, the triangles nearest to a texel are
    // all still there: the same distance, the same sign.
    if ((p - hole).norm() > hole_radius + 2 * b.background) {
      EXPECT_NEAR(f, a.grid.data[t], 1e-6) << p.transpose();
      ++checked;
    }
  }
  EXPECT_GT(checked, long(b.grid.size() / 2));
}

TEST(Implicit, MeshOutsideOrAroundTheBoxGivesTheBackground) {
  const Box box = cube_box(0.5);
  // Far outside: no triangle near the grid, one region, outside.
  const DistanceGrid outside = bake_distance_grid(
      fixtures::icosphere(1.0, 2, Eigen::Vector3d(10, 0, 0)), box, spec_with(16));
  EXPECT_EQ(outside.active_voxels, 0);
  for (float f : outside.grid.data) EXPECT_EQ(f, -outside.background);
  // The box deep inside a large sphere: one region, inside.
  const DistanceGrid inside = bake_distance_grid(fixtures::icosphere(5.0, 2), box, spec_with(16));
  EXPECT_EQ(inside.active_voxels, 0);
  for (float f : inside.grid.data) EXPECT_EQ(f, inside.background);
}

TEST(Implicit, MemoryBudgetIsChecked) {
  // 128 + 2 * 2 = 132 texels a side: 132^3 * 4 bytes = 8.77 MiB.
  try {
    bake_distance_grid(fixtures::cube(0.5), cube_box(1.0), spec_with(128), size_t(8) << 20);
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("implicit.resolution = 128"), std::string::npos) << message;
    EXPECT_NE(message.find("8.77"), std::string::npos) << message;
    EXPECT_NE(message.find("budget of 8 MiB"), std::string::npos) << message;
  }
}

TEST(Implicit, ProgressReportsBothStagesAndCancels) {
  const Mesh sphere = fixtures::icosphere(1.0, 3);
  const Box box = cube_box(1.25);
  std::vector<std::string> stages;
  double last = -1;
  std::string last_stage;
  Interrupter progress(
      [&](const std::string& stage, double fraction) {
        EXPECT_GE(fraction, 0.0);
        EXPECT_LE(fraction, 1.0);
        if (stage != last_stage) {
          stages.push_back(stage);
          last = -1;
        }
        EXPECT_GE(fraction, last) << stage;
        last = fraction;
        last_stage = stage;
      },
      0.0);
  bake_distance_grid(sphere, box, spec_with(32), size_t(1) << 30, &progress);
  EXPECT_EQ(stages, (std::vector<std::string>{"distance", "sign", "sheets"}));
  EXPECT_GT(progress.polls(), 10);

  // Cancelled at the start, inside OpenVDB (its interrupter), and in the sign stage.
  const std::vector<std::pair<std::string, double>> cancel_points = {
      {"distance", 0.0}, {"distance", 0.2}, {"sign", 0.0}};
  for (const auto& point : cancel_points) {
    const std::string& cancel_stage = point.first;
    const double cancel_after = point.second;
    Interrupter* self = nullptr;
    Interrupter cancelling(
        [&](const std::string& stage, double fraction) {
          if (stage == cancel_stage && fraction >= cancel_after) self->cancel();
        },
        0.0);
    self = &cancelling;
    EXPECT_THROW(bake_distance_grid(sphere, box, spec_with(32), size_t(1) << 30, &cancelling),
                 Cancelled)
        << cancel_stage << " " << cancel_after;
  }
}

}  // namespace
}  // namespace raywarp
