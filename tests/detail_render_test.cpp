// Named after no one source: an image test across the bake, the renderer and the references.
// Image tests of added detail (deformers/detail.h, deformers/composed.h): the GL render (raster
// pass + ray-cast pass through OSMesa) of examples/bunny_twist_detail.json, a twist by 360
// degrees with detail added to its texture,
//   - against the CPU reference ray cast of the same textures (verify/reference.h), with
//     composition_test's thresholds: IoU >= 0.99, at most 1 % of the common pixels off by more
//     than 1 % of the diagonal;
//   - against the exact ground truth of the list's meaning, the composition detail o twist
//     (the mesh mapped by the list's forward map), with the thresholds of the other image tests:
//     IoU >= 0.98, at most 2 % over 1 % of the diagonal; the texture holds the sum of the inverse
//     displacements, whose residual (reported by the bake) is well under that;
//   - against the twist alone: the detail must show (pixels whose shade or depth changes).
// And the command line refuses a scale that could fold with exit status 2 and the field named.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/ground_truth_render.h"
#include "tests/run_raywarp.h"

using namespace raywarp;

namespace {

constexpr int kSize = 256;
const std::string kRoot = RAYWARP_SOURCE_DIR;

TEST(DetailRender, TwistWithDetailMatchesReferenceAndComposition) {
  const raywarp::testing::GroundTruthRun run =
      raywarp::testing::render_against_ground_truth("bunny_twist_detail.json", "front.json", kSize);
  ASSERT_EQ(run.prepared.boxes.size(), 1u);
  const BakedBox& box = run.prepared.boxes[0];
  EXPECT_TRUE(box.report.warnings.empty()) << run.log;
  EXPECT_EQ(run.stats.nonfinite_pixels, 0);
  ASSERT_TRUE(box.report.added_detail) << run.log;
  const AddedDetailFigures& added = *box.report.added_detail;
  const InverseResidual& residual = box.report.residual;

  const Image cpu = reference_render(run.prepared.mesh(), run.prepared.textures(), run.camera,
                                     kSize, kSize, run.scene.render);
  const ImageComparison vs_cpu = compare_images(run.gl_image, cpu, 0.01 * run.diagonal);

  // The twist alone, same camera and settings.
  Scene plain = run.scene;
  plain.boxes[0].then.clear();
  std::ostringstream log;
  const PreparedScene twist = prepare_scene(plain, log);
  gl::Renderer renderer;
  renderer.set_mesh(twist.mesh());
  renderer.set_boxes(twist.textures());
  const Image without = renderer.render(run.camera, kSize, kSize, plain.render);
  long covered = 0, shaded = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      if (!run.gl_image.covered(x, y) || !without.covered(x, y)) continue;
      ++covered;
      const size_t i = 4 * (size_t(y) * kSize + x);
      int most = 0;
      for (int c = 0; c < 3; ++c)
        most = std::max(most, std::abs(int(run.gl_image.rgba[i + c]) - int(without.rgba[i + c])));
      shaded += most > 4;
    }
  const ImageComparison vs_twist = compare_images(run.gl_image, without, 0.001 * run.diagonal);

  std::printf(
      "[figures] %s: residual of the summed texture |F(p' + D) - p'| max %.3g, mean %.3g; "
      "|D - D_exact| max %.3g, mean %.3g (box diagonal %.3g); GL vs CPU reference: IoU %.4f, "
      "over 1%% of diag %.2f%%; GL vs ground truth of the composition: IoU %.4f, over %.2f%%, "
      "mean depth err %.4g; against the twist alone: %.1f%% of common pixels shaded > 4/255 "
      "apart, %.1f%% with depth > 0.1%% of diag apart\n",
      run.name.c_str(), residual.max, residual.mean, added.difference_max, added.difference_mean,
      added.box_diagonal, vs_cpu.iou, 100 * vs_cpu.fraction_over, run.vs_truth.iou,
      100 * run.vs_truth.fraction_over, run.vs_truth.mean_depth_error,
      100.0 * shaded / std::max(covered, 1L), 100 * vs_twist.fraction_over);
  std::filesystem::create_directories("detail_render_test_images");
  write_png("detail_render_test_images/" + run.name + "_gl.png", run.gl_image);
  write_png("detail_render_test_images/" + run.name + "_cpu.png", cpu);
  write_png("detail_render_test_images/" + run.name + "_truth.png", run.truth);
  write_png("detail_render_test_images/" + run.name + "_twist_only.png", without);

  EXPECT_GE(vs_cpu.iou, 0.99);
  EXPECT_LE(vs_cpu.fraction_over, 0.01);
  EXPECT_GE(run.vs_truth.iou, 0.98);
  EXPECT_LE(run.vs_truth.fraction_over, 0.02);
  // The summation's residual, measured, within its bound (tests/detail_test.cpp): 1.5 max
  // |J_R - I| s, |J_R - I| <= 2 + r_max phi / L for the twist R by phi = 2 pi over the box's
  // L = 5.79 units along y, r_max = |(h_x, h_z)| + 2 s; s = 0.058 the example's scale.
  const Eigen::Vector3d h = run.scene.boxes[0].box.half_extents;
  const double s = run.scene.boxes[0].then.at(0).scale;
  const double j_bound = 2.0 + (std::hypot(h.x(), h.z()) + 2 * s) * 2 * M_PI / (2 * h.y());
  EXPECT_GT(residual.max, 0.0);
  EXPECT_LE(residual.max, 1.5 * j_bound * s);
  EXPECT_LE(added.difference_max, j_bound * s);
  // The detail shows: at least 5 % of the pixels change shade, and as many move in depth.
  EXPECT_GT(shaded, covered / 20);
  EXPECT_GT(vs_twist.fraction_over, 0.05);
}

TEST(DetailRender, CommandRefusesAFoldingScale) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "raywarp_detail_render_test";
  std::filesystem::create_directories(dir);
  const std::filesystem::path scene = dir / "folds.json";
  std::ofstream(scene) << R"({"mesh": ")" << kRoot << R"(/examples/meshes/bunny.ply",
    "boxes": [{"min": [-5.2, 1.93, -4.0], "max": [5.2, 7.72, 4.0],
      "deformer": [{"type": "twist", "axis": "y", "angle_deg": 90},
                   {"type": "detail", "scale": 0.5, "wavelength": 0.8}],
      "implicit": {"type": "sdf", "resolution": 32}}],
    "camera": ")" << kRoot
                       << R"(/examples/cameras/front.json"})";
  const std::filesystem::path out = dir / "folds.png";
  std::filesystem::remove(out);
  std::string output;
  EXPECT_EQ(raywarp::testing::run_raywarp(
                "render " + scene.string() + " -o " + out.string() + " --no-cache", &output),
            2)
      << output;
  EXPECT_NE(output.find("folds.json: boxes[0].deformer[1].scale = 0.5: must be in [0, "),
            std::string::npos)
      << output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
