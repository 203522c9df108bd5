// The shape-diameter probe of the automatic distance grid (library/thickness.h) and the rule that
// turns it into a resolution (choose_implicit_resolution, library/implicit.h).
#include "library/thickness.h"

#include <gtest/gtest.h>

#include "library/implicit.h"
#include "tests/mesh_fixtures.h"

namespace raywarp {
namespace {

// A cuboid of the given half extents about the origin.
Mesh cuboid(const Eigen::Vector3d& half) {
  Mesh mesh = fixtures::cube(1.0);
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
    mesh.V.row(v) = mesh.V.row(v).cwiseProduct(half.transpose());
  return mesh;
}

Box unit_box() {
  Box box;
  box.half_extents = Eigen::Vector3d(0.8, 0.8, 0.8);
  return box;
}

TEST(Thickness, ARodIsALimbAsThickAsItIs) {
  // A rod 0.04 thick along x: most of its area is its four long sides, 0.04 across.
  const ThicknessProbe p = probe_thickness(cuboid({1.0, 0.02, 0.02}), unit_box());
  EXPECT_EQ(p.samples, 2048);
  EXPECT_GT(p.hits, 2000);
  EXPECT_GT(p.limbs, p.hits * 9 / 10);
  EXPECT_NEAR(p.quantile(0.05), 0.04, 1e-6);
  EXPECT_NEAR(p.quantile(0.5), 0.04, 1e-6);
}

TEST(Thickness, ASlabIsASheetCountedTwice) {
  // A slab 0.04 thick: its chords are 0.04, its width across them the box's, so a sheet.
  const ThicknessProbe p = probe_thickness(cuboid({1.0, 0.02, 1.0}), unit_box());
  EXPECT_GT(p.hits, 2000);
  EXPECT_LT(p.limbs, p.hits / 10);
  EXPECT_NEAR(p.quantile(0.5), 0.08, 1e-6);
}

TEST(Thickness, NoMeshInTheBoxGivesNoFeature) {
  Box far = unit_box();
  far.centre = Eigen::Vector3d(10, 0, 0);
  const ThicknessProbe p = probe_thickness(cuboid({1.0, 0.02, 0.02}), far);
  EXPECT_EQ(p.samples, 0);
  EXPECT_EQ(p.quantile(0.05), 0.0);
}

TEST(Thickness, TheResolutionPutsFiveVoxelsAcrossALimbWithinTheBudget) {
  const Mesh rod = cuboid({1.0, 0.02, 0.02});
  ImplicitSpec spec;  // "auto", 48 MiB
  const ImplicitChoice c = choose_implicit_resolution(rod, unit_box(), spec);
  EXPECT_TRUE(c.automatic);
  // 5 voxels across 0.04 in a box 1.6 long: 200, rounded up to a multiple of 8.
  EXPECT_EQ(c.wanted, 200);
  EXPECT_EQ(c.resolution, 200);
  EXPECT_FALSE(c.budget_bound);
  spec.max_mib = 4;
  const ImplicitChoice held = choose_implicit_resolution(rod, unit_box(), spec);
  EXPECT_TRUE(held.budget_bound);
  EXPECT_LT(held.resolution, 200);
  ImplicitSpec fitted = spec;
  fitted.resolution = held.resolution;
  EXPECT_LE(distance_grid_bytes(unit_box(), fitted), std::uint64_t(4) << 20);
  // A thick part keeps the floor; an explicit resolution is kept as it is.
  EXPECT_EQ(
      choose_implicit_resolution(cuboid({0.5, 0.5, 0.5}), unit_box(), ImplicitSpec{}).resolution,
      kAutoImplicitFloorResolution);
  spec.resolution = 64;
  EXPECT_EQ(choose_implicit_resolution(rod, unit_box(), spec).resolution, 64);
}

}  // namespace
}  // namespace raywarp
