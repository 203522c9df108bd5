// Cylindrical texture coordinates (library/cylindrical.h): the change of coordinates and its
// inverse, the periodic read that mirrors GL_REPEAT along the angle, the bakes of D and A over
// (angle, radius, height) measured against the deformers' exact inverse and alpha, a twist of any
// number of turns held by a texture two texels around, the groove's ring in a cylindrical alpha
// map, and the scene reader's "mapping" field with its refusals.
#include "library/cylindrical.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "base/error.h"
#include "deformers/groove.h"
#include "deformers/twist.h"
#include "library/deformation_bake.h"
#include "library/scene.h"
#include "library/texture_map.h"

using namespace raywarp;

namespace {

const Eigen::Vector3d kHalf(1.0, 1.5, 1.0);

CylindricalDomain box_domain(int axis) {
  return cylindrical_domain(Eigen::AlignedBox3d(-kHalf, kHalf), axis);
}

TEST(Cylindrical, CoordinatesRoundTripAboutEveryAxis) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (int axis = 0; axis < 3; ++axis)
    for (int n = 0; n < 1000; ++n) {
      const Eigen::Vector3d p(u(rng), u(rng), u(rng));
      const Eigen::Vector3d c = to_cylindrical(p, axis);
      EXPECT_GT(c[0], -M_PI - 1e-12);
      EXPECT_LE(c[0], M_PI);
      EXPECT_NEAR(c[1], std::hypot(p[(axis + 1) % 3], p[(axis + 2) % 3]), 1e-12);
      EXPECT_EQ(c[2], p[axis]);
      EXPECT_LT((from_cylindrical(c, axis) - p).norm(), 1e-12);
      // An angle off by whole turns names the same point.
      EXPECT_LT((from_cylindrical(c + Eigen::Vector3d(4 * M_PI, 0, 0), axis) - p).norm(), 1e-12);
    }
  // The right-handed order: about y, the angle runs from z (u) towards x (v).
  EXPECT_NEAR(to_cylindrical(Eigen::Vector3d(0, 0, 1), 1)[0], 0.0, 1e-15);
  EXPECT_NEAR(to_cylindrical(Eigen::Vector3d(1, 0, 0), 1)[0], 0.5 * M_PI, 1e-15);
}

TEST(Cylindrical, DomainHoldsTheRegion) {
  const CylindricalDomain d = cylindrical_domain(
      Eigen::AlignedBox3d(Eigen::Vector3d(-1, -2, -0.5), Eigen::Vector3d(3, 4, 2)), 1);
  EXPECT_DOUBLE_EQ(d.radius, std::hypot(3.0, 2.0));
  EXPECT_EQ(d.low, -2.0);
  EXPECT_EQ(d.high, 4.0);
}

TEST(Cylindrical, LayoutPutsTexelCentresOnTheAxisAndTheEnds) {
  const CylindricalDomain d{2.0, -1.0, 3.0};
  const Grid3<float> g = cylindrical_layout(d, Eigen::Vector3i(8, 5, 9), 0.0f);
  EXPECT_NEAR(g.texel_centre(0, 0, 0)[1], 0.0, 1e-15);
  EXPECT_NEAR(g.texel_centre(0, 4, 0)[1], 2.0, 1e-15);
  EXPECT_NEAR(g.texel_centre(0, 0, 0)[2], -1.0, 1e-15);
  EXPECT_NEAR(g.texel_centre(0, 0, 8)[2], 3.0, 1e-15);
  // Angle texels cover (-pi, pi] once: GL_REPEAT's period is the texture's width.
  EXPECT_NEAR(g.extent()[0], 2 * M_PI, 1e-15);
}

TEST(Cylindrical, PeriodicSampleWrapsLikeGlRepeat) {
  // A texture linear in the angle's index inside, wrapping from the last texel to the first.
  const CylindricalDomain d{1.0, 0.0, 1.0};
  Grid3<float> g = cylindrical_layout(d, Eigen::Vector3i(8, 2, 2), 0.0f);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 8; ++i) g.at(i, j, k) = float(i);
  // At a texel centre: its value; halfway between the last and the first texel: their mean.
  for (int i = 0; i < 8; ++i)
    EXPECT_NEAR(sample_periodic(g, g.texel_centre(i, 0, 0)).value(), i, 1e-6);
  const double seam = g.texel_centre(7, 0, 0)[0] + 0.5 * g.spacing[0];  // = +pi
  EXPECT_NEAR(seam, M_PI, 1e-12);
  EXPECT_NEAR(sample_periodic(g, Eigen::Vector3d(seam, 0.5, 0.5)).value(), 3.5, 1e-6);
  EXPECT_NEAR(sample_periodic(g, Eigen::Vector3d(-M_PI, 0.5, 0.5)).value(), 3.5, 1e-6);
  // A quarter past the seam either way round reads the same.
  const double q = 0.25 * g.spacing[0];
  EXPECT_NEAR(sample_periodic(g, Eigen::Vector3d(M_PI + q, 0.5, 0.5)).value(),
              sample_periodic(g, Eigen::Vector3d(-M_PI + q, 0.5, 0.5)).value(), 1e-6);
  EXPECT_NEAR(sample_periodic(g, Eigen::Vector3d(M_PI + q, 0.5, 0.5)).value(), 0.25 * 7, 1e-6);
  // Clamped along r and h, as GL_CLAMP_TO_EDGE.
  EXPECT_NEAR(sample_periodic(g, Eigen::Vector3d(g.texel_centre(2, 0, 0)[0], 5.0, -5.0)).value(),
              2.0, 1e-6);
}

// A twist of 720 degrees about the cylinder's axis: D over (angle, radius, height) is (-angle(h),
// 0, 0), linear in h, so two texels of angle and radius hold it to rounding; the Cartesian texture
// of the same twist needs many texels on every axis.
TEST(Cylindrical, TwistOfTwoTurnsIsHeldByAFewTexels) {
  const auto twist = make_twist(kHalf, Axis::Y, 720.0);
  const CylindricalDomain domain = box_domain(1);
  const DeformationTexture cyl =
      bake_cylindrical_deformation(*twist, 1, domain, Eigen::Vector3i(4, 4, 8), nullptr);
  const double e_cyl = cylindrical_deformation_error(*twist, kHalf, cyl, 1);
  const DeformationTexture cart = bake_deformation(*twist, kHalf, 64);
  const double e_cart = deformation_texture_error(*twist, cart);
  const double cyl_kib = cyl.grid.data.size() * 16 / 1024.0;
  const double cart_kib = cart.grid.data.size() * 16 / 1024.0;
  std::printf(
      "[figures] twist 720 deg in a box of half extents (1, 1.5, 1): cylindrical 4x4x8 texels "
      "(%.2f KiB) error %.3g units; Cartesian %dx%dx%d (%.0f KiB) error %.3g units\n",
      cyl_kib, e_cyl, cart.grid.dims.x(), cart.grid.dims.y(), cart.grid.dims.z(), cart_kib, e_cart);
  EXPECT_LT(e_cyl, 1e-5);
  EXPECT_GT(e_cart, 100 * e_cyl);
  EXPECT_LT(cyl_kib * 100, cart_kib);
  // The angle's difference unwraps along h: it runs monotonically through two turns.
  const Grid3<Eigen::Vector4f>& g = cyl.grid;
  const double top = g.at(0, 2, g.dims.z() - 1)[0], bottom = g.at(0, 2, 0)[0];
  EXPECT_NEAR(std::abs(top - bottom), 4 * M_PI, 1e-4);
  // Read back at random points of the box as the shader does: the exact preimage.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int n = 0; n < 500; ++n) {
    const Eigen::Vector3d p(0.7 * u(rng), 1.5 * u(rng), 0.7 * u(rng));
    const Eigen::Vector4d d = cylindrical_displacement(g, 1, p);
    EXPECT_EQ(d[3], 1.0);
    EXPECT_LT((p + d.head<3>() - twist->inverse(p)).norm(), 1e-5) << p.transpose();
  }
  // Beyond the domain's height or radius: no preimage.
  EXPECT_EQ(cylindrical_displacement(g, 1, Eigen::Vector3d(0, 1.8, 0))[3], 0.0);
  EXPECT_EQ(cylindrical_displacement(g, 1, Eigen::Vector3d(1.5, 0, 1.5))[3], 0.0);
  // The residual the bake reports: |F(p' + D(p')) - p'| at the texel centres.
  const InverseResidual r = measure_cylindrical_residual(*twist, kHalf, cyl, 1, 1e-4);
  EXPECT_GT(r.texels, 0);
  EXPECT_LT(r.max, 1e-5);
  EXPECT_EQ(r.over_tolerance, 0);
}

// The twist's angle stops at the box's ends: a kink at y = +-h_y. Over a domain that reaches past
// them (the scene's, grown by two voxels) the layout puts texel centres on both faces, so that
// the points next to them read the exact preimage too.
TEST(Cylindrical, TexelCentresLieOnTheBoxFacesAcrossTheAxis) {
  const Eigen::AlignedBox3d grown(-kHalf - Eigen::Vector3d::Constant(0.05),
                                  kHalf + Eigen::Vector3d::Constant(0.05));
  const CylindricalDomain domain = cylindrical_domain(grown, 1, kHalf);
  ASSERT_TRUE(domain.faces);
  const auto twist = make_twist(kHalf, Axis::Y, 720.0);
  for (int n : {8, 9, 32, 33}) {
    const DeformationTexture t =
        bake_cylindrical_deformation(*twist, 1, domain, Eigen::Vector3i(4, 8, n));
    const Grid3<Eigen::Vector4f>& g = t.grid;
    int on_low = 0, on_high = 0;
    for (int k = 0; k < n; ++k) {
      on_low += std::abs(g.texel_centre(0, 0, k)[2] + kHalf.y()) < 1e-12;
      on_high += std::abs(g.texel_centre(0, 0, k)[2] - kHalf.y()) < 1e-12;
    }
    EXPECT_EQ(on_low, 1) << n;
    EXPECT_EQ(on_high, 1) << n;
    EXPECT_LE(g.texel_centre(0, 0, 0)[2], grown.min().y()) << n;
    EXPECT_GE(g.texel_centre(0, 0, n - 1)[2], grown.max().y()) << n;
    // Points within a hundredth of the ends read the exact preimage.
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0), e(0.0, 0.01);
    double worst = 0.0;
    for (int i = 0; i < 2000; ++i) {
      const double y = (i % 2 ? 1 : -1) * (kHalf.y() - e(rng));
      const Eigen::Vector3d p(0.7 * u(rng), y, 0.7 * u(rng));
      const Eigen::Vector4d d = cylindrical_displacement(g, 1, p);
      worst = std::max(worst, (p + d.head<3>() - twist->inverse(p)).norm());
    }
    EXPECT_LT(worst, 1e-5) << n;
  }
  // Without room for its padding (n = 2), the plain layout.
  double first = 0, dh = 0;
  cylindrical_heights(domain, 2, &first, &dh);
  EXPECT_DOUBLE_EQ(first, domain.low);
  EXPECT_DOUBLE_EQ(dh, domain.high - domain.low);
}

// About another axis than the twist's, the texture is no simpler than a Cartesian one: the error
// measure must see it.
TEST(Cylindrical, ErrorSeesAMismatchedAxis) {
  const auto twist = make_twist(kHalf, Axis::Y, 90.0);
  const DeformationTexture cyl =
      bake_cylindrical_deformation(*twist, 0, box_domain(0), Eigen::Vector3i(4, 4, 8), nullptr);
  EXPECT_GT(cylindrical_deformation_error(*twist, kHalf, cyl, 0), 0.05);
}

TEST(Cylindrical, AutoLayoutsMeetTheirTargets) {
  // D: about the twist's own axis the floor meets a tight target with one bake.
  const auto twist = make_twist(kHalf, Axis::Z, 200.0);
  const Eigen::Vector3i floor(8, 8, 8);
  const AutoDeformation d =
      bake_cylindrical_deformation_auto(*twist, kHalf, 2, box_domain(2), 1e-4, 64u << 20, floor);
  EXPECT_LE(d.error, 1e-4);
  EXPECT_EQ(d.texture.grid.dims, floor);
  EXPECT_NEAR(d.error, cylindrical_deformation_error(*twist, kHalf, d.texture, 2), 1e-12);
  // A: the groove's corners (where its cylinder meets its slab) need texels along radius and
  // height; the refinement adds them there and not around.
  const auto groove = make_groove(kHalf, Axis::Y, 0.6, 0.5);
  const double band = 0.1, target = 0.04;
  const Eigen::Vector3i coarse(8, 12, 12);
  const AlphaMap at_floor = bake_cylindrical_alpha(*groove, 1, box_domain(1), coarse);
  const double floor_error = cylindrical_alpha_error(*groove, at_floor, 1, band);
  const AutoAlpha a =
      bake_cylindrical_alpha_auto(*groove, 1, box_domain(1), target, band, 16u << 20, coarse);
  std::printf(
      "[figures] groove alpha, auto for %.3g: %dx%dx%d texels, error %.3g (floor 8x12x12: "
      "%.3g)\n",
      target, a.map.grid.dims.x(), a.map.grid.dims.y(), a.map.grid.dims.z(), a.error, floor_error);
  EXPECT_GT(floor_error, target);
  EXPECT_LE(a.error, target);
  EXPECT_EQ(a.map.grid.dims.x(), coarse.x());
  EXPECT_NEAR(a.error, cylindrical_alpha_error(*groove, a.map, 1, band), 1e-12);
}

// The groove's alpha depends on radius and height only: a cylindrical alpha map two texels around
// holds it as well as a Cartesian map of many more texels.
TEST(Groove, CylindricalAlphaHoldsTheRingWithAFewTexels) {
  const auto g = make_groove(kHalf, Axis::Y, 0.6, 0.5);
  const double band = 0.1;
  const CylindricalDomain domain = box_domain(1);
  const AlphaMap cyl = bake_cylindrical_alpha(*g, 1, domain, Eigen::Vector3i(2, 64, 64));
  const double e_cyl = cylindrical_alpha_error(*g, cyl, 1, band);
  const AlphaMap cart = bake_alpha(*g, Eigen::AlignedBox3d(-kHalf, kHalf), 64);
  const double e_cart = alpha_map_error(*g, cart, band);
  std::printf(
      "[figures] groove radius 0.6 width 0.5: cylindrical alpha 2x64x64 (%.0f KiB) error %.3g; "
      "Cartesian %dx%dx%d (%.0f KiB) error %.3g (band %.2g)\n",
      cyl.grid.data.size() * 4 / 1024.0, e_cyl, cart.grid.dims.x(), cart.grid.dims.y(),
      cart.grid.dims.z(), cart.grid.data.size() * 4 / 1024.0, e_cart, band);
  EXPECT_LT(e_cyl, e_cart);
  EXPECT_LT(cyl.grid.data.size() * 10, cart.grid.data.size());
  // Read at random points as the shader does: within a texel's reach of the exact alpha.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double reach = std::hypot(cyl.grid.spacing[1], cyl.grid.spacing[2]);
  for (int n = 0; n < 500; ++n) {
    const Eigen::Vector3d p(u(rng), 1.5 * u(rng), u(rng));
    EXPECT_NEAR(cylindrical_alpha(cyl.grid, 1, p), g->alpha(p), reach) << p.transpose();
  }
}

TEST(Cylindrical, BakesRefuseBadCounts) {
  const auto twist = make_twist(kHalf, Axis::Y, 90.0);
  EXPECT_THROW(bake_cylindrical_deformation(*twist, 1, box_domain(1), Eigen::Vector3i(1, 8, 8)),
               Error);
  EXPECT_THROW(
      bake_cylindrical_deformation(*twist, 1, CylindricalDomain{}, Eigen::Vector3i(8, 8, 8)),
      Error);
  EXPECT_THROW(bake_cylindrical_alpha(*twist, 1, box_domain(1), Eigen::Vector3i(8, 8, 8)), Error);
}

// A scene file's path beside the shipped meshes: the reader resolves "mesh" against it.
const std::string kScene = std::string(RAYWARP_SOURCE_DIR) + "/examples/scene.json";

nlohmann::json twist_scene() {
  return nlohmann::json::parse(R"({
    "mesh": "meshes/bunny.ply",
    "boxes": [{"min": [-1, -1, -1], "max": [1, 1, 1],
               "deformer": {"type": "twist", "axis": "y", "angle_deg": 720}}]})");
}

std::string refusal(const nlohmann::json& j) {
  try {
    load_scene_json(j, kScene);
  } catch (const Error& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(CylindricalScene, ReadsTheMappingField) {
  nlohmann::json j = twist_scene();
  EXPECT_FALSE(load_scene_json(j, kScene).boxes[0].mapping.cylindrical);
  j["boxes"][0]["mapping"] = {{"type", "cylindrical"}, {"axis", "z"}, {"angle_texels", 4}};
  const MappingSpec m = load_scene_json(j, kScene).boxes[0].mapping;
  EXPECT_TRUE(m.cylindrical);
  EXPECT_EQ(m.axis, 2);
  EXPECT_EQ(m.angle_texels, 4);
  j["boxes"][0]["mapping"] = {{"type", "cartesian"}};
  EXPECT_FALSE(load_scene_json(j, kScene).boxes[0].mapping.cylindrical);
}

TEST(CylindricalScene, RefusalsNameTheFieldAndWhatIsAllowed) {
  struct Case {
    nlohmann::json mapping;
    std::string want;
  };
  const Case cases[] = {
      {{{"type", "polar"}}, "boxes[0].mapping.type = \"polar\": must be one of cartesian"},
      {{{"type", "cylindrical"}}, "boxes[0].mapping.axis: missing"},
      {{{"type", "cylindrical"}, {"axis", "w"}}, "boxes[0].mapping.axis = \"w\": must be one of"},
      {{{"type", "cylindrical"}, {"axis", "y"}, {"angle_texels", 1}},
       "boxes[0].mapping.angle_texels = 1: must be"},
      {{{"type", "cartesian"}, {"axis", "y"}},
       "boxes[0].mapping.axis = \"y\": applies to \"type\": \"cylindrical\" only"},
      {{{"type", "cylindrical"}, {"axis", "y"}, {"radius", 2}},
       "boxes[0].mapping.radius = 2: unknown field; allowed: type, axis, angle_texels"},
      {"cylindrical", "boxes[0].mapping = \"cylindrical\""},
  };
  for (const Case& c : cases) {
    nlohmann::json j = twist_scene();
    j["boxes"][0]["mapping"] = c.mapping;
    const std::string message = refusal(j);
    EXPECT_NE(message.find(c.want), std::string::npos) << message << "\nwanted: " << c.want;
  }
  // The bounded tracer's step bounds hold for Cartesian textures only.
  nlohmann::json j = twist_scene();
  j["boxes"][0]["mapping"] = {{"type", "cylindrical"}, {"axis", "y"}};
  j["render"] = {{"sampling", "bounded"}};
  EXPECT_NE(refusal(j).find("render.sampling = \"bounded\": boxes[0].mapping.type is "
                            "\"cylindrical\""),
            std::string::npos)
      << refusal(j);
}

// A twist's angle is animated through M on Cartesian textures only (cli/animate.cpp and the
// editor then re-bake a cylindrical box).
TEST(CylindricalScene, TwistAngleMappingRefusesCylindricalTextures) {
  nlohmann::json j = twist_scene();
  j["boxes"][0]["mapping"] = {{"type", "cylindrical"}, {"axis", "y"}};
  const BoxSpec spec = load_scene_json(j, kScene).boxes[0];
  BoxTextures baked;
  baked.cylindrical_axis = 1;
  EXPECT_THROW(twist_angle_mapping(spec, baked, 720.0), Error);
  baked.cylindrical_axis = -1;
  EXPECT_NO_THROW(twist_angle_mapping(spec, baked, 720.0));
}

}  // namespace
