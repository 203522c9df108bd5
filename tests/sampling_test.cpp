// Sampling methods of the linear search (render.sampling): each one's GL render against the CPU
// reference of the same ray cast and against the exact ground truth, and eq. 4's step against a
// finite-difference computation from the exact inverse.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <sstream>

#include "deformers/twist.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/deformation_bake.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "verify/reference.h"

using namespace raywarp;

namespace {

constexpr int kSize = 256;

class SamplingTest : public ::testing::TestWithParam<std::string> {};

TEST_P(SamplingTest, MatchesReferenceAndGroundTruth) {
  static auto context = gl::create_osmesa_context();
  const std::string root = RAYWARP_SOURCE_DIR;
  Scene scene = load_scene(root + "/examples/bunny_twist.json");
  scene.render.sampling = parse_sampling(GetParam()).value();
  if (GetParam() != "threshold") scene.render.step_voxels = kFineStepVoxels;
  std::ostringstream log;
  PreparedScene prepared = prepare_scene(scene, log);
  const BakedBox& box = prepared.boxes[0];
  const Camera& camera = *scene.camera;
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  renderer.render(camera, kSize, kSize, scene.render, &stats);  // warm-up
  Image gl = renderer.render(camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);
  Image cpu =
      reference_render(prepared.mesh(), prepared.textures(), camera, kSize, kSize, scene.render);
  auto F = [&](const Eigen::Vector3d& p) { return box.deformer->forward(p); };
  Mesh truth_mesh =
      ground_truth_mesh(prepared.mesh(), box.textures.box, F, 0.25 * box.textures.sdf.grid.voxel());
  Image truth = rasterize(truth_mesh, camera, kSize, kSize, scene.render);
  const double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  ImageComparison vs_cpu = compare_images(gl, cpu, 0.01 * diagonal);
  ImageComparison vs_truth = compare_images(gl, truth, 0.01 * diagonal);
  std::printf(
      "[figures] sampling %s: GL vs ground truth IoU %.4f, over 1%% of diag %.2f%%, mean depth "
      "err %.4g; vs CPU IoU %.4f, over %.2f%%; frame %.1f ms at %d^2\n",
      GetParam().c_str(), vs_truth.iou, 100 * vs_truth.fraction_over, vs_truth.mean_depth_error,
      vs_cpu.iou, 100 * vs_cpu.fraction_over, stats.milliseconds, kSize);
  EXPECT_GE(vs_cpu.iou, 0.99);
  EXPECT_LE(vs_cpu.fraction_over, 0.01);
  EXPECT_GE(vs_truth.iou, 0.98);
  EXPECT_LE(vs_truth.fraction_over, 0.02);
}

INSTANTIATE_TEST_SUITE_P(BunnyTwist, SamplingTest,
                         ::testing::Values("linear", "threshold", "jacobian", "bounded"),
                         [](const auto& info) { return info.param; });

// Eq. 4: |(I + J_D) v| is how fast the preimage moves along the ray. From the exact inverse,
// by a central difference of F^-1 along v with a small step, it must match the texture's.
TEST(JacobianStep, MatchesFiniteDifferenceOfExactInverse) {
  const Eigen::Vector3d h(1.0, 0.6, 0.8);
  auto twist = make_twist(h, Axis::Y, 270.0);
  BoxTextures tex;
  tex.box.half_extents = h;
  tex.deformation = bake_deformation(*twist, h, 128);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  double worst = 0.0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p =
        0.9 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(h);
    const Eigen::Vector3d v = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
    const double e = 1e-6;
    const Eigen::Vector3d moved = (twist->inverse(p + e * v) - twist->inverse(p - e * v)) / (2 * e);
    const double expected = 1.0 / std::clamp(moved.norm(), 0.25, 16.0);
    const double got = jacobian_step(tex, p, v, 1.0);
    worst = std::max(worst, std::abs(got - expected) / expected);
  }
  std::printf(
      "[figures] eq. 4 step from the 128^3 texture vs the exact inverse: worst relative "
      "error %.3g\n",
      worst);
  // The texture's central difference spans 2 texels: its error is O(h^2 |D'''|) plus the
  // trilinear interpolation's O(h^2 |D''|); a few percent at 128 texels for 270 degrees.
  EXPECT_LT(worst, 0.05);
}

}  // namespace
