// Named after no one source: an image test across the bake, the renderer and the references.
// Composition: several deformers in one box (F = F_n o ... o F_1, D baked from the composed
// inverse) and several boxes in one scene (each its own textures and ray-cast pass), checked
// against the exact ground truth: the mesh subdivided, split at each box's faces, mapped by the
// box's composed forward map and rasterised (thresholds of the foundation: IoU >= 0.98, at most
// 2 % of the common pixels off by more than 1 % of the diagonal).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "base/error.h"
#include "deformers/bend.h"
#include "deformers/box_cut.h"
#include "deformers/composed.h"
#include "deformers/twist.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "verify/reference.h"

using namespace raywarp;

namespace {

constexpr int kSize = 256;
const std::string kRoot = RAYWARP_SOURCE_DIR;

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

TEST(Composed, ChainRuleAndInverse) {
  const Eigen::Vector3d h(1.0, 1.5, 0.8);
  std::shared_ptr<const Deformer> twist = make_twist(h, Axis::Y, 120);
  std::shared_ptr<const Deformer> bend = make_bend(h, Axis::Z, 70);
  auto f = make_composed({twist, bend});
  EXPECT_EQ(f->describe(), twist->describe() + ", then " + bend->describe());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst_jacobian = 0, worst_inverse = 0;
  for (int i = 0; i < 200; ++i) {
    Eigen::Vector3d p(u(rng) * h.x(), u(rng) * h.y(), u(rng) * h.z());
    EXPECT_LT((f->forward(p) - bend->forward(twist->forward(p))).norm(), 1e-12);
    Eigen::Matrix3d numeric;
    const double e = 1e-6;
    for (int a = 0; a < 3; ++a) {
      Eigen::Vector3d d = Eigen::Vector3d::Unit(a) * e;
      numeric.col(a) = (f->forward(p + d) - f->forward(p - d)) / (2 * e);
    }
    worst_jacobian = std::max(worst_jacobian, (numeric - f->jacobian(p)).norm());
    worst_inverse =
        std::max(worst_inverse, (f->forward(f->inverse(f->forward(p))) - f->forward(p)).norm());
  }
  std::printf(
      "[figures] twist 120 then bend 70: |J - central difference| max %.3g, "
      "|F(F^-1(p')) - p'| max %.3g\n",
      worst_jacobian, worst_inverse);
  EXPECT_LT(worst_jacobian, 1e-6);
  EXPECT_LT(worst_inverse, 1e-9);
  // A face stays in place when it does under both: the bend about z moves -y (its limit axis is
  // x), so no face does here; two twists about y both keep -y.
  auto faces = f->identity_faces();
  for (int i = 0; i < 6; ++i)
    EXPECT_EQ(faces[i], twist->identity_faces()[i] && bend->identity_faces()[i]) << i;
  EXPECT_FALSE(faces[2]);
  std::shared_ptr<const Deformer> twist2 = make_twist(h, Axis::Y, -30);
  auto faces2 = make_composed({twist, twist2})->identity_faces();
  EXPECT_TRUE(faces2[2]);
  EXPECT_FALSE(faces2[3]);
}

TEST(Composed, RejectsCuts) {
  const Eigen::Vector3d h(1, 1, 1);
  std::shared_ptr<const Deformer> twist = make_twist(h, Axis::Y, 90);
  std::shared_ptr<const Deformer> cut = make_box_cut(h, BoxCutParams{});
  EXPECT_THROW(make_composed({twist, cut}), Error);
  EXPECT_THROW(make_composed({}), Error);
}

std::filesystem::path write_scene(const std::string& name, const std::string& deformer) {
  std::filesystem::path dir = std::filesystem::temp_directory_path() / "raywarp_composition_test";
  std::filesystem::create_directories(dir);
  std::filesystem::path path = dir / name;
  std::ofstream(path) << "{\"mesh\": \"" << kRoot
                      << "/examples/meshes/bunny.ply\", \"boxes\": [{\"min\": [-1, -1, -1], "
                         "\"max\": [1, 1, 1], \"deformer\": "
                      << deformer << "}]}";
  return path;
}

std::string load_error(const std::filesystem::path& path) {
  try {
    load_scene(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Composed, SceneLists) {
  Scene s = load_scene(
      write_scene("list.json",
                  "[{\"type\": \"twist\", \"axis\": \"y\", \"angle_deg\": 90}, {\"type\": "
                  "\"bend\", \"axis\": \"z\", \"angle_deg\": 30}]"));
  ASSERT_EQ(s.boxes.size(), 1u);
  EXPECT_EQ(s.boxes[0].deformer.type, "twist");
  ASSERT_EQ(s.boxes[0].then.size(), 1u);
  EXPECT_EQ(s.boxes[0].then[0].type, "bend");
  EXPECT_NE(make_deformer(s, 0)->describe().find(", then bend"), std::string::npos);

  std::string e = load_error(
      write_scene("cut.json",
                  "[{\"type\": \"twist\", \"axis\": \"y\", \"angle_deg\": 90}, {\"type\": "
                  "\"box_cut\"}]"));
  EXPECT_NE(e.find("boxes[0].deformer[1].type"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot be composed"), std::string::npos) << e;
  e = load_error(write_scene("empty.json", "[]"));
  EXPECT_NE(e.find("boxes[0].deformer"), std::string::npos) << e;
  e = load_error(write_scene("bad.json", "[{\"type\": \"twist\", \"axis\": \"w\"}]"));
  EXPECT_NE(e.find("boxes[0].deformer[0].axis"), std::string::npos) << e;
}

// Renders a scene with GL and compares it with its ground truth: each box's part of the mesh
// mapped by the box's exact (composed) forward map.
void check_against_truth(const std::string& scene_file, const std::string& name) {
  Scene scene = load_scene(kRoot + "/examples/" + scene_file);
  Camera camera = load_camera(kRoot + "/examples/cameras/front.json");
  std::ostringstream log;
  PreparedScene prepared = prepare_scene(scene, log);
  for (const auto& b : prepared.boxes) EXPECT_TRUE(b.report.warnings.empty()) << log.str();

  context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  Image image = renderer.render(camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);

  Mesh truth_mesh = prepared.mesh();
  for (const auto& b : prepared.boxes) {
    auto F = [&](const Eigen::Vector3d& p) { return b.deformer->forward(p); };
    truth_mesh =
        ground_truth_mesh(truth_mesh, b.textures.box, F, 0.25 * b.textures.sdf.grid.voxel());
  }
  Image truth = rasterize(truth_mesh, camera, kSize, kSize, scene.render);
  const double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  ImageComparison vs_truth = compare_images(image, truth, 0.01 * diagonal);
  Image cpu =
      reference_render(prepared.mesh(), prepared.textures(), camera, kSize, kSize, scene.render);
  ImageComparison vs_cpu = compare_images(image, cpu, 0.01 * diagonal);
  std::printf(
      "[figures] %s: %zu boxes; GL vs ground truth: IoU %.4f, over 1%% of diag %.2f%%, mean "
      "depth err %.4g; GL vs CPU reference: IoU %.4f, over %.2f%%\n",
      name.c_str(), prepared.boxes.size(), vs_truth.iou, 100 * vs_truth.fraction_over,
      vs_truth.mean_depth_error, vs_cpu.iou, 100 * vs_cpu.fraction_over);
  std::filesystem::create_directories("composition_test_images");
  write_png("composition_test_images/" + name + "_gl.png", image);
  write_png("composition_test_images/" + name + "_truth.png", truth);
  EXPECT_GE(vs_truth.iou, 0.98);
  EXPECT_LE(vs_truth.fraction_over, 0.02);
  EXPECT_GE(vs_cpu.iou, 0.99);
  EXPECT_LE(vs_cpu.fraction_over, 0.01);
}

TEST(CompositionRender, TwistThenBendMatchesComposedForwardMap) {
  check_against_truth("bunny_twist_bend.json", "twist_then_bend");
}

TEST(CompositionRender, TwoBoxesInOneScene) {
  check_against_truth("bunny_two_boxes.json", "two_boxes");
}

// The shipped control-point scene against its own forward map (the inverse is Newton's).
TEST(CompositionRender, ControlPointsExampleMatchesItsForwardMap) {
  check_against_truth("bunny_control_points.json", "control_points");
}

}  // namespace
