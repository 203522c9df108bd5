// The map M that shows a twist's smaller angle through the texture baked for a larger one
// (library/texture_map.h): it is the identity at the baked angle, a scale about the lower face
// along the axis below it, refused beyond the baked angle or across a change of sign, and the
// region it gives lies within the texture's.
#include "library/texture_map.h"

#include <gtest/gtest.h>

#include "base/error.h"
#include "deformers/twist.h"
#include "library/deformation_bake.h"

namespace raywarp {
namespace {

TEST(TextureMap, ATwistsSmallerAngleIsAScaleAboutTheLowerFace) {
  BoxSpec spec;
  spec.box.half_extents = Eigen::Vector3d(0.5, 1.0, 0.5);
  spec.deformer.type = "twist";
  spec.deformer.axis = 1;
  spec.deformer.angle_deg = 120;
  BoxTextures baked;
  baked.box = spec.box;
  const auto twist = make_twist(spec.box.half_extents, Axis::Y, 120);
  baked.deformation = bake_deformation(*twist, spec.box.half_extents, 24, true);
  baked.lipschitz = 2.0;

  const TextureMapping same = twist_angle_mapping(spec, baked, 120);
  EXPECT_TRUE(same.map.isApprox(Eigen::Matrix4d::Identity()));
  EXPECT_DOUBLE_EQ(same.lipschitz, 2.0);

  spec.deformer.angle_deg = 30;  // s = 1/4
  const TextureMapping quarter = twist_angle_mapping(spec, baked, 120);
  EXPECT_DOUBLE_EQ(quarter.map(1, 1), 0.25);
  EXPECT_DOUBLE_EQ(quarter.map(1, 3), 1.0 * (0.25 - 1.0));
  // The lower face stays; the upper face reads the texture a quarter of the way up.
  EXPECT_NEAR((quarter.map * Eigen::Vector4d(0, -1, 0, 1)).y(), -1.0, 1e-12);
  EXPECT_NEAR((quarter.map * Eigen::Vector4d(0, 1, 0, 1)).y(), -0.5, 1e-12);
  EXPECT_DOUBLE_EQ(quarter.lipschitz, 2.75);
  const Eigen::AlignedBox3d grid(baked.deformation.grid.origin, baked.deformation.grid.upper());
  EXPECT_TRUE(grid.contains(quarter.region));
  EXPECT_FALSE(quarter.region.isEmpty());

  spec.deformer.angle_deg = 150;
  EXPECT_THROW(twist_angle_mapping(spec, baked, 120), Error);
  spec.deformer.angle_deg = -10;
  EXPECT_THROW(twist_angle_mapping(spec, baked, 120), Error);
  spec.deformer.angle_deg = 10;
  spec.deformer.type = "bend";
  EXPECT_THROW(twist_angle_mapping(spec, baked, 120), Error);
}

}  // namespace
}  // namespace raywarp
