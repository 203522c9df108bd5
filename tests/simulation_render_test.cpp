// Named after no one source: an image test across the bake, the renderer and the references.
// Image tests of the simulation deformer (docs/simulation.md): the GL render (raster pass and
// ray-cast pass through OSMesa) against the exact ground truth of the same F (the mesh subdivided
// to a quarter voxel, the part in the box mapped by F, rasterised on the CPU), with the image
// thresholds of tests/render_test.cpp: silhouette IoU >= 0.98 and at most 2 % of the commonly
// covered pixels off by more than 1 % of the deformed mesh's bounding-box diagonal.
//   SimulatedState  examples/bunny_simulation.json: the drag's last state (folds included).
//   TwistedNodes    a lattice whose every sample is placed on a 180-degree twist about y of the
//                   box of examples/bunny_head_twist.json: F is the trilinear (grid) or
//                   piecewise-linear (tets) interpolant of the twist, baked (automatic layout)
//                   and rendered like a simulation's.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "deformers/registry.h"
#include "deformers/simulation.h"
#include "deformers/twist.h"
#include "gl/tet_scene.h"
#include "library/deformation_bake.h"
#include "library/tet_body.h"
#include "tests/ground_truth_render.h"
#include "verify/ground_truth.h"

using namespace raywarp;

namespace {

constexpr int kSize = 256;

void expect_thresholds(const std::string& name, const ImageComparison& c, const Image& gl,
                       const Image& truth) {
  std::printf(
      "[figures] simulation render %s: IoU %.4f, over 1%% of diag %.2f%%, mean depth err %.4g, "
      "max %.4g\n",
      name.c_str(), c.iou, 100 * c.fraction_over, c.mean_depth_error, c.max_depth_error);
  std::filesystem::create_directories("simulation_render_test_images");
  write_png("simulation_render_test_images/" + name + "_gl.png", gl);
  write_png("simulation_render_test_images/" + name + "_truth.png", truth);
  EXPECT_GE(c.iou, 0.98) << name;
  EXPECT_LE(c.fraction_over, 0.02) << name;
}

TEST(SimulationRender, SimulatedStateMatchesGroundTruth) {
  const raywarp::testing::GroundTruthRun run =
      raywarp::testing::render_against_ground_truth("bunny_simulation.json", "front.json", kSize);
  ASSERT_EQ(run.prepared.boxes.size(), 1u);
  ASSERT_TRUE(run.prepared.boxes[0].report.simulation.has_value()) << run.log;
  EXPECT_EQ(run.stats.nonfinite_pixels, 0);
  expect_thresholds("bunny_simulation", run.vs_truth, run.gl_image, run.truth);
}

TEST(SimulationRender, TwistedNodesMatchGroundTruth) {
  const std::string root = RAYWARP_SOURCE_DIR;
  const Scene scene = load_scene(root + "/examples/bunny_head_twist.json");
  const Camera camera = load_camera(root + "/examples/cameras/front.json");
  std::ostringstream log;
  PreparedScene prepared = prepare_scene(scene, log);
  ASSERT_EQ(prepared.boxes.size(), 1u);
  const Eigen::Vector3d h = scene.boxes[0].box.half_extents;
  const auto twist = make_twist(h, Axis::Y, 180.0);
  for (SimModel model : {SimModel::grid, SimModel::tets}) {
    // Every sample of a 32-cell lattice is a node, placed on the twist.
    const double target = 2.0 * h.maxCoeff() / 32;
    Eigen::Vector3i cells;
    for (int a = 0; a < 3; ++a)
      cells[a] = std::max(1, static_cast<int>(std::lround(2 * h[a] / target)));
    const Eigen::Vector3d spacing = (2.0 * h).cwiseQuotient(cells.cast<double>());
    std::vector<int> node_of_sample;
    std::vector<Eigen::Vector3d> nodes;
    for (int k = 0; k <= cells.z(); ++k)
      for (int j = 0; j <= cells.y(); ++j)
        for (int i = 0; i <= cells.x(); ++i) {
          node_of_sample.push_back(static_cast<int>(nodes.size()));
          nodes.push_back(twist->forward(-h + spacing.cwiseProduct(Eigen::Vector3d(i, j, k))));
        }
    std::shared_ptr<const Deformer> f =
        make_lattice_deformer(model, h, cells, node_of_sample, nodes);
    BakedBox& box = prepared.boxes[0];
    box.deformer = f;
    // The automatic layout a bake picks (scene.h), as for any deformer.
    box.textures.deformation =
        bake_deformation_auto(*f, h, kAutoErrorVoxels * box.textures.sdf.grid.voxel(),
                              std::uint64_t(64) << 20, kAutoFloorResolution, false)
            .texture;
    box.textures.region = Eigen::AlignedBox3d(box.textures.deformation.grid.origin,
                                              box.textures.deformation.grid.upper());
    box.textures.lipschitz = displacement_lipschitz(*f, box.textures.deformation);

    raywarp::testing::osmesa_context();
    gl::Renderer renderer;
    renderer.set_mesh(prepared.mesh());
    renderer.set_boxes(prepared.textures());
    gl::FrameStats stats;
    const Image image = renderer.render(camera, kSize, kSize, scene.render, &stats);
    EXPECT_EQ(stats.nonfinite_pixels, 0);
    const double quarter_voxel = 0.25 * box.textures.sdf.grid.voxel();
    const Mesh truth_mesh = ground_truth_mesh(
        prepared.mesh(), box.textures.box, [&](const Eigen::Vector3d& p) { return f->forward(p); },
        quarter_voxel);
    const Image truth = rasterize(truth_mesh, camera, kSize, kSize, scene.render);
    const double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
    expect_thresholds(std::string("twisted_nodes_") + sim_model_names()[static_cast<int>(model)],
                      compare_images(image, truth, 0.01 * diagonal), image, truth);
  }
}

// The tetrahedral route (render.route "tets") on the simulated state: the body's tetrahedra
// mapped by the same F, f's zero set walked in surface mode and composited with the rasterised
// mesh outside the box, within the thresholds against the exact ground truth and against the
// deformation-texture route; for the grid model (the example) and the tets model.
TEST(SimulationRender, TetRouteMatchesTruthAndTextureRoute) {
  const std::string root = RAYWARP_SOURCE_DIR;
  for (const char* model : {"grid", "tets"}) {
    nlohmann::json doc = read_scene_document(root + "/examples/bunny_simulation.json");
    doc["boxes"][0]["deformer"]["model"] = model;
    const Scene scene = load_scene_json(doc, root + "/examples/bunny_simulation.json");
    const Camera camera = load_camera(root + "/examples/cameras/front.json");
    std::ostringstream log;
    const PreparedScene prepared = prepare_scene(scene, log);
    ASSERT_EQ(prepared.boxes.size(), 1u);
    const BakedBox& box = prepared.boxes[0];
    raywarp::testing::osmesa_context();
    gl::Renderer texture_route;
    texture_route.set_mesh(prepared.mesh());
    texture_route.set_boxes(prepared.textures());
    const Image texture_image = texture_route.render(camera, kSize, kSize, scene.render);

    const TetBody body = build_tet_body(box, prepared.mesh(), scene.render.tets);
    gl::TetSceneRenderer tets(prepared.mesh(), {&box.textures}, {&body}, scene.render.tets);
    gl::TetSceneStats stats;
    const Image image = tets.render(camera, kSize, kSize, scene.render, &stats);
    EXPECT_EQ(stats.walk.capped, 0);
    EXPECT_FALSE(stats.walk.pass_cap_reached);

    const Truth truth = ground_truth(scene, prepared, camera, kSize, kSize);
    const double threshold = 0.01 * truth.diagonal;
    const ImageComparison vs_truth = compare_images(image, truth.image, threshold);
    const ImageComparison vs_texture = compare_images(image, texture_image, threshold);
    std::printf(
        "[figures] tet route %s: %zu tets (cells split %d^3), %d passes; vs truth IoU "
        "%.4f, %.2f%% over; vs texture route IoU %.4f, %.2f%% over\n",
        model, body.tets.size(), body.refine, stats.walk.passes, vs_truth.iou,
        100 * vs_truth.fraction_over, vs_texture.iou, 100 * vs_texture.fraction_over);
    expect_thresholds(std::string("tet_route_") + model, vs_truth, image, truth.image);
    EXPECT_GE(vs_texture.iou, 0.98) << model;
    EXPECT_LE(vs_texture.fraction_over, 0.02) << model;
  }
}

// At rest (every refined node at its rest position), the route's surface against the mesh
// itself, rasterised with no box: f's zero set, linear per tetrahedron, within the thresholds.
TEST(SimulationRender, TetRouteAtRestMatchesTheMesh) {
  const std::string root = RAYWARP_SOURCE_DIR;
  const Scene scene = load_scene(root + "/examples/bunny_simulation.json");
  const Camera camera = load_camera(root + "/examples/cameras/front.json");
  std::ostringstream log;
  const PreparedScene prepared = prepare_scene(scene, log);
  const BakedBox& box = prepared.boxes[0];
  raywarp::testing::osmesa_context();
  TetBody body = build_tet_body(box, prepared.mesh(), scene.render.tets);
  for (size_t i = 0; i < body.rest.size(); ++i)
    body.positions[i] = box.textures.box.to_object(body.rest[i]);
  gl::TetSceneRenderer tets(prepared.mesh(), {&box.textures}, {&body}, scene.render.tets);
  const Image image = tets.render(camera, kSize, kSize, scene.render);
  gl::Renderer plain;
  plain.set_mesh(prepared.mesh());
  const Image mesh = plain.render(camera, kSize, kSize, scene.render);
  const double diagonal = mesh_bounds(prepared.mesh()).diagonal().norm();
  const ImageComparison c = compare_images(image, mesh, 0.01 * diagonal);
  std::printf("[figures] tet route at rest: %zu tets, IoU %.4f, %.2f%% over 1%% of the diagonal\n",
              body.tets.size(), c.iou, 100 * c.fraction_over);
  expect_thresholds("tet_route_rest", c, image, mesh);
}

// The volume mode of the route reads the scene's transfer function: with no extinction the body
// adds nothing (its pixels show the background), with an opaque red one every pixel it covers is
// red (up to the background the early termination at an opacity of 0.99 leaves: green and blue
// below 64 of 255 on white); the default function over f puts colour inside the part only.
TEST(SimulationRender, TetRouteVolumeReadsTheTransferFunction) {
  const std::string root = RAYWARP_SOURCE_DIR;
  const Scene base = load_scene(root + "/examples/bunny_simulation.json");
  const Camera camera = load_camera(root + "/examples/cameras/front.json");
  std::ostringstream log;
  const PreparedScene prepared = prepare_scene(base, log);
  const BakedBox& box = prepared.boxes[0];
  raywarp::testing::osmesa_context();
  TetDisplaySpec spec;
  spec.mode = "volume";
  spec.refine = 2;
  spec.scalar_samples = 32;
  spec.length_samples = 16;
  const TetBody body = build_tet_body(box, prepared.mesh(), spec);
  auto red_pixels = [&](const TransferFunction& tf) {
    TetDisplaySpec s = spec;
    s.transfer = tf;
    gl::TetSceneRenderer r(prepared.mesh(), {&box.textures}, {&body}, s);
    const Image image = r.render(camera, 128, 128, base.render);
    long red = 0;
    for (size_t i = 0; i < image.depth.size(); ++i)
      red += image.rgba[4 * i] == 255 && image.rgba[4 * i + 1] < 64 && image.rgba[4 * i + 2] < 64;
    return red;
  };
  TransferFunction clear;
  clear.points.push_back({0.0, Eigen::Vector3d(1, 0, 0), 0.0});
  TransferFunction opaque;
  opaque.points.push_back({0.0, Eigen::Vector3d(1, 0, 0), 1e6});
  EXPECT_EQ(red_pixels(clear), 0);
  const long covered = red_pixels(opaque);
  EXPECT_GT(covered, 500);
  std::printf("[figures] tet route volume: %zu tets, opaque red body covers %ld of 128^2 pixels\n",
              body.tets.size(), covered);
  const TransferFunction def = default_transfer_function(body.f, "f", 10.0);
  EXPECT_EQ(def.points.front().tau, 0.0);
  EXPECT_GT(def.points.back().s, 0.0);
}

}  // namespace
