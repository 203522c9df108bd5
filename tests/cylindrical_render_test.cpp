// Named after no one source: an image test across the bake, the renderer and the references.
// Image tests of cylindrical textures (library/cylindrical.h): the GL render (raster pass +
// ray-cast pass through OSMesa) of a box whose D and A are stored over (angle, radius, height),
//   - a twist of 720 degrees (examples/bunny_twist720_cylindrical.json) against the exact ground
//     truth (the mesh mapped by the twist's forward map) with the foundation's thresholds (IoU >=
//     0.98, at most 2 % of the common pixels off by more than 1 % of the diagonal), against the
//     CPU reference ray cast of the same textures (IoU >= 0.99, at most 1 %), and against the
//     Cartesian texture's render of the same scene;
//   - a groove (examples/bunny_groove.json), solid and hollow, against the exact render of its
//     removed ring (verify/reference.h's exact_removed_render with the ring's intervals solved
//     from its cylinder and slab) and against the CPU reference;
//   - the variant: RAYWARP_CYLINDRICAL is in the shader of a cylindrical box only;
//   - the command line: `raywarp bake` exports a cylindrical box, its sidecar saying the mapping
//     (tests/export_test.cpp renders what it wrote, read back).
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "deformers/deformer.h"
#include "tests/ground_truth_render.h"
#include "tests/run_raywarp.h"

using namespace raywarp;

namespace {

constexpr int kSize = 256;
const std::string kRoot = RAYWARP_SOURCE_DIR;

void save(const std::string& name, const Image& image) {
  std::filesystem::create_directories("cylindrical_render_test_images");
  write_png("cylindrical_render_test_images/" + name + ".png", image);
}

TEST(CylindricalRender, TwistOf720MatchesGroundTruthAndReference) {
  const raywarp::testing::GroundTruthRun run = raywarp::testing::render_against_ground_truth(
      "bunny_twist720_cylindrical.json", "front.json", kSize);
  ASSERT_EQ(run.prepared.boxes.size(), 1u);
  const BakedBox& box = run.prepared.boxes[0];
  const BoxTextures& tex = box.textures;
  ASSERT_TRUE(tex.cylindrical()) << run.log;
  EXPECT_EQ(tex.cylindrical_axis, 1);
  EXPECT_TRUE(box.report.warnings.empty()) << run.log;
  EXPECT_EQ(run.stats.nonfinite_pixels, 0);

  const Image cpu = reference_render(run.prepared.mesh(), run.prepared.textures(), run.camera,
                                     kSize, kSize, run.scene.render);
  const ImageComparison vs_cpu = compare_images(run.gl_image, cpu, 0.01 * run.diagonal);

  // The same scene with a Cartesian texture.
  Scene cartesian = run.scene;
  cartesian.boxes[0].mapping = MappingSpec{};
  std::ostringstream log;
  const PreparedScene cart = prepare_scene(cartesian, log);
  gl::Renderer renderer;
  renderer.set_mesh(cart.mesh());
  renderer.set_boxes(cart.textures());
  gl::FrameStats cart_stats;
  const Image cart_image = renderer.render(run.camera, kSize, kSize, cartesian.render, &cart_stats);
  const ImageComparison cart_vs_truth = compare_images(cart_image, run.truth, 0.01 * run.diagonal);
  const size_t cyl_bytes = tex.deformation.grid.data.size() * sizeof(Eigen::Vector4f);
  const size_t cart_bytes =
      cart.boxes[0].textures.deformation.grid.data.size() * sizeof(Eigen::Vector4f);

  std::printf(
      "[figures] %s: D %dx%dx%d (%.1f KiB), error %.3g units; GL vs ground truth: IoU %.4f, "
      "over 1%% of diag %.2f%%, mean depth err %.4g; GL vs CPU reference: IoU %.4f, over %.2f%%; "
      "Cartesian D %dx%dx%d (%.0f KiB), error %.3g: vs ground truth IoU %.4f, over %.2f%%\n",
      run.name.c_str(), tex.deformation.grid.dims.x(), tex.deformation.grid.dims.y(),
      tex.deformation.grid.dims.z(), cyl_bytes / 1024.0, box.report.texture_error, run.vs_truth.iou,
      100 * run.vs_truth.fraction_over, run.vs_truth.mean_depth_error, vs_cpu.iou,
      100 * vs_cpu.fraction_over, cart.boxes[0].textures.deformation.grid.dims.x(),
      cart.boxes[0].textures.deformation.grid.dims.y(),
      cart.boxes[0].textures.deformation.grid.dims.z(), cart_bytes / 1024.0,
      cart.boxes[0].report.texture_error, cart_vs_truth.iou, 100 * cart_vs_truth.fraction_over);
  save(run.name + "_gl", run.gl_image);
  save(run.name + "_cpu", cpu);
  save(run.name + "_truth", run.truth);
  save(run.name + "_cartesian", cart_image);

  EXPECT_GE(run.vs_truth.iou, 0.98);
  EXPECT_LE(run.vs_truth.fraction_over, 0.02);
  EXPECT_GE(vs_cpu.iou, 0.99);
  EXPECT_LE(vs_cpu.fraction_over, 0.01);
  // As close to the truth as the Cartesian texture, from a texture a tenth its size or less.
  EXPECT_GE(run.vs_truth.iou, cart_vs_truth.iou - 0.005);
  EXPECT_LE(10 * cyl_bytes, cart_bytes);

  // The variant: only the cylindrical box's shader reads cylindrical coordinates.
  EXPECT_NE(gl::raycast_defines(tex, run.scene.render).find("RAYWARP_CYLINDRICAL"),
            std::string::npos);
  EXPECT_EQ(
      gl::raycast_defines(cart.boxes[0].textures, cartesian.render).find("RAYWARP_CYLINDRICAL"),
      std::string::npos);
}

class GrooveRender : public ::testing::TestWithParam<CutMode> {};

TEST_P(GrooveRender, MatchesExactRingRemovedAndReference) {
  Scene scene = load_scene(kRoot + "/examples/bunny_groove.json");
  scene.boxes[0].cut_mode = GetParam();
  const Camera camera = load_camera(kRoot + "/examples/cameras/front.json");
  std::ostringstream log;
  const PreparedScene prepared = prepare_scene(scene, log);
  ASSERT_EQ(prepared.boxes.size(), 1u);
  const BoxTextures& tex = prepared.boxes[0].textures;
  ASSERT_TRUE(tex.cylindrical()) << log.str();
  ASSERT_TRUE(tex.has_cut);
  raywarp::testing::osmesa_context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  const Image gl_image = renderer.render(camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);

  const DeformerSpec& d = scene.boxes[0].deformer;
  const Image exact = exact_removed_render(
      prepared.mesh(), tex.box,
      [&](const Eigen::Vector3d& o, const Eigen::Vector3d& dir) {
        return groove_intervals(d.axis, d.radius, d.opening, o, dir);
      },
      GetParam(), camera, kSize, kSize, scene.render);
  const Image cpu =
      reference_render(prepared.mesh(), prepared.textures(), camera, kSize, kSize, scene.render);
  const double diagonal = mesh_bounds(prepared.mesh()).diagonal().norm();
  const ImageComparison vs_exact = compare_images(gl_image, exact, 0.01 * diagonal);
  const ImageComparison vs_cpu = compare_images(gl_image, cpu, 0.01 * diagonal);
  // The ring shows: the render differs from the whole mesh's.
  const Image whole = rasterize(prepared.mesh(), camera, kSize, kSize, scene.render);
  const ImageComparison vs_whole = compare_images(gl_image, whole, 0.01 * diagonal);
  const std::string name = std::string("bunny_groove_") + cut_mode_name(GetParam());
  std::printf(
      "[figures] %s: alpha %dx%dx%d (%.1f KiB); GL vs exact: IoU %.4f, over 1%% of diag %.2f%%, "
      "mean depth err %.4g; GL vs CPU reference: IoU %.4f, over %.2f%%; against the whole mesh: "
      "%.1f%% over\n",
      name.c_str(), tex.alpha.grid.dims.x(), tex.alpha.grid.dims.y(), tex.alpha.grid.dims.z(),
      tex.alpha.grid.data.size() * 4 / 1024.0, vs_exact.iou, 100 * vs_exact.fraction_over,
      vs_exact.mean_depth_error, vs_cpu.iou, 100 * vs_cpu.fraction_over,
      100 * vs_whole.fraction_over);
  save(name + "_gl", gl_image);
  save(name + "_exact", exact);
  save(name + "_cpu", cpu);
  EXPECT_GE(vs_exact.iou, 0.98);
  EXPECT_LE(vs_exact.fraction_over, 0.02);
  EXPECT_GE(vs_cpu.iou, 0.99);
  EXPECT_LE(vs_cpu.fraction_over, 0.01);
  EXPECT_GT(vs_whole.fraction_over, 0.05);
}

INSTANTIATE_TEST_SUITE_P(Modes, GrooveRender, ::testing::Values(CutMode::Solid, CutMode::Hollow),
                         [](const ::testing::TestParamInfo<CutMode>& i) {
                           return std::string(cut_mode_name(i.param));
                         });

TEST(CylindricalCommand, ExportWritesACylindricalBoxAndSaysItsMapping) {
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / "raywarp_cylindrical_render_test_export";
  std::filesystem::remove_all(out);
  std::string output;
  EXPECT_EQ(raywarp::testing::run_raywarp(
                "bake " + kRoot + "/examples/bunny_groove.json -o " + out.string(), &output),
            0)
      << output;
  std::ifstream in(out / "bunny_groove_box0.json");
  const nlohmann::json side = nlohmann::json::parse(in);
  EXPECT_EQ(side["mapping"]["type"], "cylindrical");
  EXPECT_EQ(side["mapping"]["axis"], "y");
  // A groove moves nothing: its D is the identity over the box, its A over the cylinder.
  EXPECT_EQ(side["textures"]["deformation"]["channels"][0], "dx");
  EXPECT_NEAR(side["textures"]["alpha"]["region"]["min"][0].get<double>(), -M_PI, 1e-9);
  std::filesystem::remove_all(out);
}

}  // namespace
