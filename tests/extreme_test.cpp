// Named after no one source: the shipped extreme scenes end to end.
// The extreme and stiff cases of examples/extreme/: each scene bakes and renders with no NaN or
// infinity in any texture or image; prints its error against the exact ground truth (the mesh
// subdivided, split at the box faces and mapped by the exact forward map), its frame time and
// what raywarp warns. Bends that are nearly the identity must render as the unbent mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "verify/reference.h"

using namespace raywarp;

namespace {

constexpr int kSize = 128;

class ExtremeTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ExtremeTest, FiniteEverywhereAndMeasured) {
  static auto context = gl::create_osmesa_context();
  const std::string path =
      std::string(RAYWARP_SOURCE_DIR) + "/examples/extreme/" + GetParam() + ".json";
  Scene scene = load_scene(path);
  scene.render.width = scene.render.height = kSize;
  std::ostringstream log;
  PreparedScene prepared = prepare_scene(scene, log);
  for (const BakedBox& box : prepared.boxes) {
    for (float v : box.textures.sdf.grid.data) ASSERT_TRUE(std::isfinite(v));
    for (const Eigen::Vector4f& v : box.textures.deformation.grid.data) ASSERT_TRUE(v.allFinite());
    for (float v : box.textures.alpha.grid.data) ASSERT_TRUE(std::isfinite(v));
  }
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  Image gl = renderer.render(*scene.camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);
  for (float z : gl.depth) ASSERT_FALSE(std::isnan(z));
  std::filesystem::create_directories("extreme_test_images");
  write_png("extreme_test_images/" + GetParam() + ".png", gl);

  std::string warnings;
  for (const BakedBox& box : prepared.boxes)
    for (const std::string& w : box.report.warning_messages())
      warnings += (warnings.empty() ? "" : "; ") + w;
  std::string error = "no exact ground truth (a cut)";
  const BakedBox& box = prepared.boxes[0];
  if (!box.deformer->has_cut()) {
    auto F = [&](const Eigen::Vector3d& p) { return box.deformer->forward(p); };
    Mesh truth_mesh = ground_truth_mesh(prepared.mesh(), box.textures.box, F,
                                        0.5 * box.textures.sdf.grid.voxel());
    Image truth = rasterize(truth_mesh, *scene.camera, kSize, kSize, scene.render);
    ImageComparison c = compare_images(gl, truth, 0.01 * mesh_bounds(truth_mesh).diagonal().norm());
    char buf[160];
    std::snprintf(buf, sizeof buf, "IoU %.4f, %.2f %% over 1 %% of diag", c.iou,
                  100 * c.fraction_over);
    error = buf;
    if (GetParam() == "bend_1e-4" || GetParam() == "angle_0" || GetParam() == "mesh_scaled_1e4") {
      EXPECT_GE(c.iou, 0.98) << GetParam();
      EXPECT_LE(c.fraction_over, 0.02) << GetParam();
    }
  }
  if (GetParam() == "degenerate_triangles") {  // its fin and repeated-vertex faces
    EXPECT_NE(warnings.find("open or non-manifold inside the box (2 boundary and 2 non-manifold"),
              std::string::npos)
        << warnings;
  }
  std::printf("[figures] %s: %s; frame %.1f ms at %d^2; warnings: %s\n", GetParam().c_str(),
              error.c_str(), stats.milliseconds, kSize,
              warnings.empty() ? "none" : warnings.c_str());
}

// A lone triangle has three boundary edges; a closed tetrahedron none; edges outside the box
// do not count.
TEST(OpenEdges, CountsBoundaryAndNonManifoldEdgesInTheBox) {
  Mesh tet;
  tet.V.resize(5, 3);
  tet.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0.3, 0.3, -1;
  tet.F.resize(4, 3);
  tet.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  Box box;
  box.centre = Eigen::Vector3d(0.5, 0.5, 0.5);
  box.half_extents = Eigen::Vector3d::Constant(0.6);
  EXPECT_FALSE(open_edges_in_box(tet, box).any());
  Mesh fin = tet;  // a fourth face on edge 0-1, and its two new edges
  fin.F.conservativeResize(5, 3);
  fin.F.row(4) << 0, 1, 4;
  const OpenEdges open = open_edges_in_box(fin, box);
  EXPECT_EQ(open.nonmanifold, 1);
  EXPECT_EQ(open.boundary, 0);  // edges 1-4 and 4-0 have midpoints below the box
  box.half_extents = Eigen::Vector3d::Constant(2.0);
  EXPECT_EQ(open_edges_in_box(fin, box).boundary, 2);
}

INSTANTIATE_TEST_SUITE_P(Extreme, ExtremeTest,
                         ::testing::Values("twist_10_turns_thin", "bend_359", "bend_1e-4",
                                           "bend_folds", "angle_0", "box_thinner_than_voxel",
                                           "box_partly_outside", "box_contains_mesh",
                                           "camera_inside_box", "grazing_box_face",
                                           "mesh_scaled_1e-3", "mesh_scaled_1e4",
                                           "degenerate_triangles", "peel_folds"),
                         [](const auto& info) {
                           std::string s = info.param;
                           for (char& c : s)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return s;
                         });

}  // namespace
