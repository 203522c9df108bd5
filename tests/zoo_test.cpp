// Named after no one source: meshes nobody tuned for, end to end.
// Image tests on meshes nobody tuned for (examples/zoo, written by scripts/make_zoo.py): a twist,
// a bend, a box cut and an incision on each of seven public meshes (closed and open, thin legs,
// fingers, ears, horns, a range scan of 222K triangles), at raywarp's default settings, each at
// 512 x 512 (four also at 1920 x 1080) against its exact ground truth:
//  - twist and bend: the mesh subdivided to a quarter of the default 128 grid's voxel, split at
//    the box faces, the inside part mapped by the exact forward map, rasterised
//    (verify/reference.h);
//  - box cut: exact_cut_render (every triangle along each ray, the region removed analytically);
//  - incision (hollow): as the twist, also split at the cut plane.
// The figures, with the frame times of bench/, are in docs/meshes.md. A case whose figures miss
// the marks (IoU >= 0.99, <= 1 % of the pixels off by more than 1 % of the diagonal) names the
// reason and the setting that fixes it in kKnownShort below, and is held to what it reaches.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <ostream>
#include <sstream>
#include <string>

#include "deformers/box_cut.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "tests/seam_check.h"
#include "verify/reference.h"

namespace raywarp {
namespace {

// The seams and the samplers' figures are taken at this size.
constexpr int kSize = 192;

struct Known {
  const char* scene;
  double iou, over;  // what the case reaches at defaults
  const char* why;
};
// Cases below the marks at the defaults, with the reason.
const Known kKnownShort[] = {
    {"horse_legs_bend", 0.980, 0.01,
     "the bend folds 17 % of the box (det J <= 0; raywarp warns and renders one branch, the "
     "ground truth shows both); a smaller angle_deg or a longer box does not fold"},
    {"card_twist", 0.99, 0.02,
     "the card is drawn as a shell 1.2 voxels (0.018 units) thick around the exact sheet: where "
     "the twist turns it edge-on, a ray grazing the shell meets it up to sqrt(2 R s) before the "
     "sheet (R the card's radius of curvature along the ray), more than 1 % of the card's "
     "4.5-unit diagonal on a band along the turn"},
};

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

// A scene of examples/zoo and the image size its comparison is made at.
struct ZooCase {
  std::string scene;
  int width, height;
};

// As GoogleTest names the case in its listing (and so ctest's name).
void PrintTo(const ZooCase& c, std::ostream* os) {
  *os << c.scene << " at " << c.width << "x" << c.height;
}

class ZooTest : public ::testing::TestWithParam<ZooCase> {};

TEST_P(ZooTest, MatchesExactGroundTruthAtDefaults) {
  const std::string name = GetParam().scene;
  const int width = GetParam().width, height = GetParam().height;
  // The seams and the samplers' figures are taken once, with the square images.
  const bool square = width == height;
  const std::string tag = name + "_" + std::to_string(width) + "x" + std::to_string(height);
  const Scene scene =
      load_scene(std::string(RAYWARP_SOURCE_DIR) + "/examples/zoo/" + name + ".json");
  std::ostringstream log;
  // One session for both bakes below: the bounded one reads the distance grid and D from memory
  // and bakes only its step bounds.
  BakeSession session;
  const PreparedScene prepared = prepare_scene(scene, log, session);
  ASSERT_EQ(prepared.boxes.size(), 1u);
  const BakedBox& box = prepared.boxes[0];
  ASSERT_TRUE(scene.camera.has_value());
  const Camera& camera = *scene.camera;

  context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  const Image image = renderer.render(camera, width, height, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);

  // The exact ground truth at any size.
  const BoxSpec& spec = scene.boxes[0];
  const auto* cut = dynamic_cast<const BoxCut*>(box.deformer.get());
  Mesh truth_mesh;
  double diagonal = mesh_bounds(prepared.mesh()).diagonal().norm();
  if (spec.deformer.type == "box_cut") {
    ASSERT_NE(cut, nullptr);
  } else {
    auto F = [&](const Eigen::Vector3d& q) { return box.deformer->forward(q); };
    const int split = spec.deformer.type == "incision" ? spec.deformer.axis : -1;
    // Edges of a quarter of the default grid's voxel follow the map's curvature closely enough
    // (the mesh's own triangles are exact); a finer automatic grid does not need finer ones.
    const double edge =
        0.25 * 2.0 * box.textures.box.half_extents.maxCoeff() / kAutoImplicitFloorResolution;
    truth_mesh = ground_truth_mesh(prepared.mesh(), box.textures.box, F, edge, split);
    diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  }
  auto truth_at = [&](int w, int h) {
    if (spec.deformer.type == "box_cut")
      return exact_cut_render(prepared.mesh(), box.textures.box, cut->region(), spec.cut_mode,
                              camera, w, h, scene.render);
    return rasterize(truth_mesh, camera, w, h, scene.render);
  };
  const Image truth = truth_at(width, height);
  const ImageComparison c = compare_images(image, truth, 0.01 * diagonal);
  std::filesystem::create_directories("zoo_test_images");
  write_png("zoo_test_images/" + tag + "_gl.png", image);
  write_png("zoo_test_images/" + tag + "_truth.png", truth);
  write_png("zoo_test_images/" + tag + "_difference.png",
            difference_image(image, truth, 0.01 * diagonal));
  std::printf(
      "[figures] zoo %s at %d x %d: IoU %.4f, over 1%% of diag %.2f%%, outline bias %.3f pixel, "
      "%.1f MiB of textures\n",
      name.c_str(), width, height, c.iou, 100 * c.fraction_over, c.outline_bias(),
      renderer.texture_bytes() / 1048576.0);
  double iou = 0.99, over = 0.01;
  for (const Known& k : kKnownShort)
    if (name == k.scene) {
      iou = k.iou;
      over = k.over;
      std::printf("[figures] zoo %s is below the marks at defaults: %s\n", name.c_str(), k.why);
    }
  EXPECT_GE(c.iou, iou);
  EXPECT_LE(c.fraction_over, over);
  if (!square) return;

  const Image small = renderer.render(camera, kSize, kSize, scene.render);
  static_assert(kSize == testing::kSeamImageSize);
  const testing::SeamFigures seams =
      testing::check_seams("zoo/" + name + ".json", prepared, camera, small, scene.render);
  EXPECT_LE(seams.cracked, seams.allowed);

  // Continuous deformations: the pixels that sphere tracing with Lipschitz bounds (`bounded`,
  // which never steps over a surface) covers and the default sampler misses. A figure, not a
  // mark: docs/meshes.md.
  if (!box.deformer->has_cut()) {
    Scene traced = scene;
    traced.render.sampling = Sampling::Bounded;
    std::ostringstream traced_log;
    const PreparedScene bounded = prepare_scene(traced, traced_log, session);
    gl::Renderer bounded_renderer;
    bounded_renderer.set_mesh(bounded.mesh());
    bounded_renderer.set_boxes(bounded.textures());
    const Image reference = bounded_renderer.render(camera, kSize, kSize, traced.render);
    // The same textures sampled linearly at the fine step: what the default's misses owe to its
    // coarse steps, and what to the hit rules (bounded counts a sample within its epsilon of the
    // surface as the hit; a linear search needs a sample inside).
    RenderSettings fine = scene.render;
    fine.sampling = Sampling::Linear;
    fine.step_voxels = kFineStepVoxels;
    fine.max_steps = 16 * scene.render.max_steps;
    const Image linear = renderer.render(camera, kSize, kSize, fine);
    const Image small_truth = truth_at(kSize, kSize);
    long covered = 0, missed = 0, missed_linear = 0, missed_truth = 0;
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x)
        if (reference.covered(x, y)) {
          ++covered;
          missed += !small.covered(x, y);
          missed_linear += !linear.covered(x, y);
          missed_truth += !small_truth.covered(x, y);
        }
    // Against linear at the fine step, which steps over nothing thicker than it: what the
    // default steps over.
    long linear_covered = 0, stepped_over = 0;
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x)
        if (linear.covered(x, y)) {
          ++linear_covered;
          stepped_over += !small.covered(x, y);
        }
    std::printf(
        "[figures] zoo %s: the default misses %ld of the %ld pixels linear at %g voxel "
        "covers (%.3f %%)\n",
        name.c_str(), stepped_over, linear_covered, kFineStepVoxels,
        linear_covered ? 100.0 * stepped_over / linear_covered : 0.0);
    auto percent = [&](long n) { return covered ? 100.0 * n / covered : 0.0; };
    std::printf(
        "[figures] zoo %s: of the %ld pixels bounded covers, the default sampler misses %ld "
        "(%.3f %%), linear at %g voxel %ld (%.3f %%), the ground truth %ld (%.3f %%)\n",
        name.c_str(), covered, missed, percent(missed), kFineStepVoxels, missed_linear,
        percent(missed_linear), missed_truth, percent(missed_truth));
  }
}

std::vector<std::string> zoo_scenes() {
  std::vector<std::string> names;
  for (const auto& e :
       std::filesystem::directory_iterator(std::string(RAYWARP_SOURCE_DIR) + "/examples/zoo"))
    if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::vector<ZooCase> zoo_cases(int width, int height, const std::vector<std::string>& only = {}) {
  std::vector<ZooCase> cases;
  for (const std::string& name : zoo_scenes())
    if (only.empty() || std::find(only.begin(), only.end(), name) != only.end())
      cases.push_back({name, width, height});
  return cases;
}

// Every scene at 512 x 512 (a voxel of the 128 grid spans 1.6 pixels or more: a one-voxel error
// shows); a subset at 1920 x 1080, one of each kind on the meshes with thin parts.
INSTANTIATE_TEST_SUITE_P(Zoo, ZooTest, ::testing::ValuesIn(zoo_cases(512, 512)),
                         [](const auto& info) { return info.param.scene; });
INSTANTIATE_TEST_SUITE_P(Zoo1080, ZooTest,
                         ::testing::ValuesIn(zoo_cases(1920, 1080,
                                                       {"armadillo_hand_twist", "devil_bend",
                                                        "devil_hair_twist", "man_hand_cut",
                                                        "scan_trex_incision"})),
                         [](const auto& info) { return info.param.scene; });

}  // namespace
}  // namespace raywarp
