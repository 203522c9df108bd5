// Named after no one source: an image test across the bake, the renderer and the references.
// 16-bit against 32-bit float textures (render.texture_bits): half rounding itself, and what
// each precision gives in error against the exact ground truth, with its texture memory.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>

#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "verify/reference.h"

using namespace raywarp;

namespace {

TEST(RoundToHalf, NearestHalfTiesToEven) {
  EXPECT_EQ(round_to_half(1.0f), 1.0f);
  EXPECT_EQ(round_to_half(1.0f + std::ldexp(1.0f, -11)), 1.0f);  // tie: to the even 1
  EXPECT_EQ(round_to_half(1.0f + 3 * std::ldexp(1.0f, -11)), 1.0f + std::ldexp(1.0f, -9));
  EXPECT_EQ(round_to_half(-1.0f - std::ldexp(1.0f, -10)), -1.0f - std::ldexp(1.0f, -10));
  EXPECT_EQ(round_to_half(0.1f), 0.0999755859375f);
  EXPECT_EQ(round_to_half(std::ldexp(1.0f, -24)), std::ldexp(1.0f, -24));  // smallest subnormal
  EXPECT_EQ(round_to_half(std::ldexp(1.0f, -26)), 0.0f);
  EXPECT_EQ(round_to_half(65504.0f), 65504.0f);
  EXPECT_EQ(round_to_half(1e6f), 65504.0f);  // clamped, finite
  EXPECT_EQ(round_to_half(-1e30f), -65504.0f);
  for (float x = -3.0f; x < 3.0f; x += 0.0137f)
    EXPECT_LE(std::abs(round_to_half(x) - x), std::ldexp(std::abs(x), -11) + 1e-12f) << x;
}

struct Case {
  std::string scene;
  int bits;
};

class PrecisionTest : public ::testing::TestWithParam<Case> {};

TEST_P(PrecisionTest, ErrorAgainstGroundTruth) {
  static auto context = gl::create_osmesa_context();
  constexpr int kSize = 256;
  const std::string root = RAYWARP_SOURCE_DIR;
  Scene scene = load_scene(root + "/examples/" + GetParam().scene);
  scene.render.texture_bits = GetParam().bits;
  std::ostringstream log;
  PreparedScene prepared = prepare_scene(scene, log);
  const BakedBox& box = prepared.boxes[0];
  EXPECT_EQ(box.textures.half_precision, GetParam().bits == 16);
  const Camera& camera = *scene.camera;
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  Image gl = renderer.render(camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);
  auto F = [&](const Eigen::Vector3d& p) { return box.deformer->forward(p); };
  Mesh truth_mesh =
      ground_truth_mesh(prepared.mesh(), box.textures.box, F, 0.25 * box.textures.sdf.grid.voxel());
  Image truth = rasterize(truth_mesh, camera, kSize, kSize, scene.render);
  Image cpu =
      reference_render(prepared.mesh(), prepared.textures(), camera, kSize, kSize, scene.render);
  const double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  ImageComparison vs_truth = compare_images(gl, truth, 0.01 * diagonal);
  ImageComparison vs_cpu = compare_images(gl, cpu, 0.01 * diagonal);
  std::printf(
      "[figures] %s %d-bit: %.2f MiB of textures; GL vs ground truth IoU %.4f, over 1%% of diag "
      "%.2f%%, mean depth err %.4g; vs CPU (same rounded texels) IoU %.4f\n",
      GetParam().scene.c_str(), GetParam().bits, renderer.texture_bytes() / double(1 << 20),
      vs_truth.iou, 100 * vs_truth.fraction_over, vs_truth.mean_depth_error, vs_cpu.iou);
  EXPECT_GE(vs_truth.iou, 0.98);
  EXPECT_LE(vs_truth.fraction_over, 0.02);
  EXPECT_GE(vs_cpu.iou, 0.99);
}

INSTANTIATE_TEST_SUITE_P(Bunny, PrecisionTest,
                         ::testing::Values(Case{"bunny_twist.json", 32},
                                           Case{"bunny_twist.json", 16},
                                           Case{"bunny_bend.json", 32},
                                           Case{"bunny_bend.json", 16}),
                         [](const auto& info) {
                           std::string s = info.param.scene.substr(0, info.param.scene.find('.')) +
                                           "_" + std::to_string(info.param.bits);
                           return s;
                         });

}  // namespace
