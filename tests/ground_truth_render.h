// The GL render of an example scene against its exact ground truth, shared by the image tests
// (tests/render_test.cpp, tests/simple_deform_render_test.cpp): the scene prepared by
// prepare_scene, drawn by gl::Renderer through OSMesa, and the ground truth of
// verify/reference.h (the mesh subdivided to a quarter voxel, split at the box faces, the inside
// part mapped by the deformer's exact forward map, rasterised on the CPU with no box logic),
// compared with a depth threshold of 1 % of the deformed mesh's bounding-box diagonal.
#pragma once
#include <gtest/gtest.h>

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>

#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "verify/reference.h"

namespace raywarp::testing {

inline gl::Context& osmesa_context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

struct GroundTruthRun {
  std::string name;  // "<scene>_<camera>" without the .json
  Scene scene;
  Camera camera;
  PreparedScene prepared;
  std::string log;  // prepare_scene's report
  Image gl_image, truth;
  gl::FrameStats stats;
  size_t truth_triangles = 0;
  double diagonal = 0.0;  // of the ground-truth mesh's bounds
  ImageComparison vs_truth;
};

// examples/<scene_file> seen by examples/cameras/<camera_file>, size x size pixels. The scene must
// have one box.
inline GroundTruthRun render_against_ground_truth(const std::string& scene_file,
                                                  const std::string& camera_file, int size) {
  const std::string root = RAYWARP_SOURCE_DIR;
  GroundTruthRun run;
  run.name = scene_file.substr(0, scene_file.size() - 5) + "_" +
             camera_file.substr(0, camera_file.size() - 5);
  run.scene = load_scene(root + "/examples/" + scene_file);
  run.camera = load_camera(root + "/examples/cameras/" + camera_file);
  std::ostringstream log;
  run.prepared = prepare_scene(run.scene, log);
  run.log = log.str();
  EXPECT_EQ(run.prepared.boxes.size(), 1u);
  if (run.prepared.boxes.size() != 1) return run;
  const BakedBox& box = run.prepared.boxes[0];

  osmesa_context();
  gl::Renderer renderer;
  renderer.set_mesh(run.prepared.mesh());
  renderer.set_boxes(run.prepared.textures());
  run.gl_image = renderer.render(run.camera, size, size, run.scene.render, &run.stats);

  const double quarter_voxel = 0.25 * box.textures.sdf.grid.voxel();
  auto F = [&](const Eigen::Vector3d& p) { return box.deformer->forward(p); };
  const Mesh truth_mesh =
      ground_truth_mesh(run.prepared.mesh(), box.textures.box, F, quarter_voxel);
  run.truth_triangles = static_cast<size_t>(truth_mesh.F.rows());
  run.truth = rasterize(truth_mesh, run.camera, size, size, run.scene.render);
  run.diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  run.vs_truth = compare_images(run.gl_image, run.truth, 0.01 * run.diagonal);
  return run;
}

// "bunny_twist.json" + "front.json" -> "bunny_twist_json_front_json", a test name.
inline std::string case_name(const std::string& scene, const std::string& camera) {
  std::string s = scene + "_" + camera;
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return s;
}

}  // namespace raywarp::testing
