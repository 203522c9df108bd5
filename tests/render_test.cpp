// Image tests: the GL render (raster pass + ray-cast pass through OSMesa) against
//  - the exact ground truth: the mesh subdivided to a quarter voxel, split at the box faces, the
//    inside part mapped by the deformer's exact forward map, rasterised on the CPU with no box
//    logic; thresholds from the foundation issue: silhouette IoU >= 0.98 and at most 2 % of the
//    commonly covered pixels off by more than 1 % of the deformed mesh's bounding-box diagonal;
//  - the CPU reference of the same ray cast in double (checks the shader against its
//    specification; the two read the same textures, so they agree far more tightly).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "cli/pipeline.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "verify/reference.h"
#include "library/scene.h"

using namespace raywarp;

namespace {

constexpr int kSize = 256;

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

struct Case {
  std::string scene, camera;
};

class RenderTest : public ::testing::TestWithParam<Case> {};

TEST_P(RenderTest, MatchesGroundTruthAndReference) {
  const std::string root = RAYWARP_SOURCE_DIR;
  Scene scene = load_scene(root + "/examples/" + GetParam().scene);
  Camera camera = load_camera(root + "/examples/cameras/" + GetParam().camera);
  std::ostringstream log;
  PreparedScene prepared = prepare_scene(scene, log);
  ASSERT_EQ(prepared.boxes.size(), 1u);
  const BakedBox& box = prepared.boxes[0];
  EXPECT_TRUE(box.report.warnings.empty()) << log.str();

  context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh);
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  Image gl_image = renderer.render(camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);

  double quarter_voxel = 0.25 * box.textures.sdf.grid.spacing;
  auto F = [&](const Eigen::Vector3d& p) { return box.deformer->forward(p); };
  Mesh truth_mesh = ground_truth_mesh(prepared.mesh, box.textures.box, F, quarter_voxel);
  Image truth = rasterize(truth_mesh, camera, kSize, kSize, scene.render);
  double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  ImageComparison vs_truth = compare_images(gl_image, truth, 0.01 * diagonal);

  Image cpu =
      reference_render(prepared.mesh, prepared.textures(), camera, kSize, kSize, scene.render);
  ImageComparison vs_cpu = compare_images(gl_image, cpu, 0.01 * diagonal);

  std::string name = GetParam().scene.substr(0, GetParam().scene.size() - 5) + "_" +
                     GetParam().camera.substr(0, GetParam().camera.size() - 5);
  std::printf(
      "[figures] %s: %zu ground-truth triangles; GL vs ground truth: IoU %.4f, over 1%% of diag "
      "%.2f%%, mean depth err %.4g, max %.4g (diag %.3g); GL vs CPU reference: IoU %.4f, over "
      "%.2f%%, mean %.4g; frame %.1f ms\n",
      name.c_str(), static_cast<size_t>(truth_mesh.F.rows()), vs_truth.iou,
      100 * vs_truth.fraction_over, vs_truth.mean_depth_error, vs_truth.max_depth_error, diagonal,
      vs_cpu.iou, 100 * vs_cpu.fraction_over, vs_cpu.mean_depth_error, stats.milliseconds);
  std::filesystem::create_directories("render_test_images");
  write_png("render_test_images/" + name + "_gl.png", gl_image);
  write_png("render_test_images/" + name + "_truth.png", truth);
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
                           std::string s = info.param.scene + "_" + info.param.camera;
                           for (char& c : s)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return s;
                         });

}  // namespace
