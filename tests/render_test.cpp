// Named after no one source: the renderer end to end against the references.
// Image tests: the GL render (raster pass + ray-cast pass through OSMesa) against
//  - the exact ground truth (tests/ground_truth_render.h): the mesh subdivided to a quarter voxel,
//  split at the box faces, the
//    inside part mapped by the deformer's exact forward map, rasterised on the CPU with no box
//    logic; thresholds from the foundation issue: silhouette IoU >= 0.98 and at most 2 % of the
//    commonly covered pixels off by more than 1 % of the deformed mesh's bounding-box diagonal;
//  - the CPU reference of the same ray cast in double (checks the shader against its
//    specification; the two read the same textures, so they agree far more tightly).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "tests/ground_truth_render.h"

using namespace raywarp;

namespace {

constexpr int kSize = 256;

struct Case {
  std::string scene, camera;
};

class RenderTest : public ::testing::TestWithParam<Case> {};

TEST_P(RenderTest, MatchesGroundTruthAndReference) {
  const raywarp::testing::GroundTruthRun run =
      raywarp::testing::render_against_ground_truth(GetParam().scene, GetParam().camera, kSize);
  ASSERT_EQ(run.prepared.boxes.size(), 1u);
  EXPECT_TRUE(run.prepared.boxes[0].report.warnings.empty()) << run.log;
  EXPECT_EQ(run.stats.nonfinite_pixels, 0);
  const ImageComparison& vs_truth = run.vs_truth;

  Image cpu = reference_render(run.prepared.mesh(), run.prepared.textures(), run.camera, kSize,
                               kSize, run.scene.render);
  ImageComparison vs_cpu = compare_images(run.gl_image, cpu, 0.01 * run.diagonal);

  const std::string& name = run.name;
  std::printf(
      "[figures] %s: %zu ground-truth triangles; GL vs ground truth: IoU %.4f, over 1%% of diag "
      "%.2f%%, mean depth err %.4g, max %.4g (diag %.3g); GL vs CPU reference: IoU %.4f, over "
      "%.2f%%, mean %.4g; frame %.1f ms\n",
      name.c_str(), run.truth_triangles, vs_truth.iou, 100 * vs_truth.fraction_over,
      vs_truth.mean_depth_error, vs_truth.max_depth_error, run.diagonal, vs_cpu.iou,
      100 * vs_cpu.fraction_over, vs_cpu.mean_depth_error, run.stats.milliseconds);
  std::filesystem::create_directories("render_test_images");
  write_png("render_test_images/" + name + "_gl.png", run.gl_image);
  write_png("render_test_images/" + name + "_truth.png", run.truth);
  write_png("render_test_images/" + name + "_cpu.png", cpu);

  EXPECT_GE(vs_truth.iou, 0.98);
  EXPECT_LE(vs_truth.fraction_over, 0.02);
  EXPECT_GE(vs_cpu.iou, 0.99);
  EXPECT_LE(vs_cpu.fraction_over, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Bunny, RenderTest,
                         ::testing::Values(Case{"bunny_twist.json", "front.json"},
                                           Case{"bunny_twist.json", "side_ortho.json"},
                                           Case{"bunny_bend.json", "front.json"},
                                           Case{"bunny_bend.json", "side_ortho.json"}),
                         [](const auto& info) {
                           return raywarp::testing::case_name(info.param.scene, info.param.camera);
                         });

}  // namespace
