// Named after no one source: an image test across the bake, the renderer and the references.
// Image tests of Blender's Simple Deform modes taper and stretch (deformers/taper.h,
// deformers/stretch.h): the GL render (raster pass + ray-cast pass through OSMesa) of
// examples/bunny_taper.json and examples/bunny_stretch.json against the exact ground truth
// (tests/ground_truth_render.h), with the thresholds of tests/render_test.cpp: silhouette IoU >=
// 0.98 and at most 2 % of the commonly covered pixels off by more than 1 % of the deformed mesh's
// bounding-box diagonal.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "tests/ground_truth_render.h"

using namespace raywarp;

namespace {

constexpr int kSize = 256;

struct Case {
  std::string scene, camera;
};

class SimpleDeformRenderTest : public ::testing::TestWithParam<Case> {};

TEST_P(SimpleDeformRenderTest, MatchesGroundTruth) {
  const raywarp::testing::GroundTruthRun run =
      raywarp::testing::render_against_ground_truth(GetParam().scene, GetParam().camera, kSize);
  ASSERT_EQ(run.prepared.boxes.size(), 1u);
  // No warnings: in particular no torn face (the box holds all the mesh the deformation moves).
  EXPECT_TRUE(run.prepared.boxes[0].report.warnings.empty()) << run.log;
  EXPECT_EQ(run.stats.nonfinite_pixels, 0);
  const ImageComparison& vs_truth = run.vs_truth;
  std::printf(
      "[figures] %s: %zu ground-truth triangles; GL vs ground truth: IoU %.4f, over 1%% of diag "
      "%.2f%%, mean depth err %.4g, max %.4g (diag %.3g); frame %.1f ms\n",
      run.name.c_str(), run.truth_triangles, vs_truth.iou, 100 * vs_truth.fraction_over,
      vs_truth.mean_depth_error, vs_truth.max_depth_error, run.diagonal, run.stats.milliseconds);
  std::filesystem::create_directories("simple_deform_render_test_images");
  write_png("simple_deform_render_test_images/" + run.name + "_gl.png", run.gl_image);
  write_png("simple_deform_render_test_images/" + run.name + "_truth.png", run.truth);

  EXPECT_GE(vs_truth.iou, 0.98);
  EXPECT_LE(vs_truth.fraction_over, 0.02);
}

INSTANTIATE_TEST_SUITE_P(Bunny, SimpleDeformRenderTest,
                         ::testing::Values(Case{"bunny_taper.json", "front.json"},
                                           Case{"bunny_taper.json", "side_ortho.json"},
                                           Case{"bunny_stretch.json", "front.json"},
                                           Case{"bunny_stretch.json", "side_ortho.json"}),
                         [](const auto& info) {
                           return raywarp::testing::case_name(info.param.scene, info.param.camera);
                         });

}  // namespace
