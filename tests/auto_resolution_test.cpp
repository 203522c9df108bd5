// Named after no one source: an image test across the bake, the renderer and the references.
// The automatic layout of the deformation texture (deformation.resolution "auto", the default):
// the extreme twist of 720 degrees in a slab a fifth of the bunny's height, at defaults, against
// the exact ground truth; the same scene at the cubic layout that was the fixed default
// (resolution 96) for comparison.
#include <gtest/gtest.h>

#include <cstdio>

#include "tests/ground_truth_render.h"

using namespace raywarp;

namespace {

constexpr int kSize = 256;

TEST(AutoResolution, ExtremeSlabTwistAtDefaults) {
  const raywarp::testing::GroundTruthRun run = raywarp::testing::render_against_ground_truth(
      "study/bunny_twist_720_slab.json", "front.json", kSize);
  ASSERT_EQ(run.prepared.boxes.size(), 1u);
  const BakeReport& r = run.prepared.boxes[0].report;
  const StageReport* def = r.stage(Stage::Deformation);
  ASSERT_NE(def, nullptr);
  EXPECT_TRUE(r.deformation_choice.automatic);
  EXPECT_TRUE(r.warnings.empty()) << run.log;
  EXPECT_LE(r.texture_error_voxels(), kAutoErrorVoxels);
  EXPECT_LE(def->bytes, std::uint64_t(16) << 20);
  std::printf(
      "[figures] 720 degrees in a slab, auto: D %dx%dx%d, %.1f MiB, error %.2f voxel, %d bakes "
      "in %.2f s; IoU %.4f, %.2f %% of pixels over 1 %% of the diagonal; frame %.1f ms\n",
      def->resolution.x(), def->resolution.y(), def->resolution.z(), def->bytes / 1048576.0,
      r.texture_error_voxels(), r.deformation_choice.bakes, def->seconds, run.vs_truth.iou,
      100 * run.vs_truth.fraction_over, run.stats.milliseconds);
  EXPECT_GE(run.vs_truth.iou, 0.99);
  EXPECT_LE(run.vs_truth.fraction_over, 0.01);

  // The former fixed default, the cubic layout of 96 texels: 16 along the twist axis.
  Scene fixed = run.scene;
  fixed.boxes[0].deformation_resolution = kAutoFloorResolution;
  std::ostringstream log;
  const PreparedScene prepared = prepare_scene(fixed, log);
  const BakeReport& f = prepared.boxes[0].report;
  raywarp::testing::osmesa_context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  const Image image = renderer.render(run.camera, kSize, kSize, fixed.render);
  const ImageComparison c = compare_images(image, run.truth, 0.01 * run.diagonal);
  std::printf(
      "[figures] 720 degrees in a slab, resolution 96: D %dx%dx%d, error %.2f voxels; IoU %.4f, "
      "%.2f %% over\n",
      f.stage(Stage::Deformation)->resolution.x(), f.stage(Stage::Deformation)->resolution.y(),
      f.stage(Stage::Deformation)->resolution.z(), f.texture_error_voxels(), c.iou,
      100 * c.fraction_over);
  EXPECT_GT(f.texture_error_voxels(), 1.0);  // what the automatic layout is for
  EXPECT_GT(c.fraction_over, run.vs_truth.fraction_over);
}

}  // namespace
