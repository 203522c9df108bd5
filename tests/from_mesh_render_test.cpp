// Named after no one source: an image test across the bake, the renderer and the references.
// Image tests of the from_mesh deformer (docs/from_mesh.md): a deformation authored elsewhere,
// brought in as a deformed copy of the mesh or as a glTF morph target, baked into a deformation
// texture and rendered by the GL renderer (OSMesa), against an independent reference, with the
// image thresholds of tests/render_test.cpp (IoU >= 0.98, at most 2 % of the common pixels off by
// more than 1 % of the deformed mesh's diagonal):
//   CopiesOfExactDeformations  the mesh's vertices in the box moved by raywarp's own exact twist
//                              (90 to 720 degrees) or bend (60 to 180), written out as a PLY, the
//                              faces the map holds pinned; the render at 512 x 512 against the
//                              analytic deformation's ground truth (the mesh subdivided to a
//                              quarter voxel and mapped by the exact F), on the bunny (3,674
//                              triangles) and the armadillo (52,000), within the zoo's marks:
//                              IoU >= 0.99, at most 1 % of the pixels over.
//   GltfMorphTargets           a glTF written here with two morph targets (the twist of the
//                              head and the bend of the whole bunny, as displacements); each
//                              target rendered against the target mesh itself, rasterised.
//   SequenceFrame              a folder of copies (a sequence), a fractional frame against the
//                              two copies it blends, rasterised.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <ostream>
#include <random>
#include <sstream>
#include <string>

#include "library/mesh_file.h"
#include "library/mesh_pairs.h"
#include "tests/ground_truth_render.h"
#include "tests/mesh_files.h"

using namespace raywarp;
namespace fs = std::filesystem;
using nlohmann::json;
using raywarp::testing::Folder;
using raywarp::testing::write_gltf;
using raywarp::testing::write_ply;

namespace {

constexpr int kSize = 256;
// The copies of exact deformations are drawn at the size people render.
constexpr int kCopySize = 512;

// The scene file's soup (the file's own vertex order) with the vertices inside `box` moved by
// the box's deformer F (box frame).
PolygonSoup moved_soup(const std::string& mesh_file, const Box& box, const Deformer& F) {
  PolygonSoup soup = read_ply(read_mesh_file(mesh_file).bytes, mesh_file);
  for (auto& v : soup.vertices) {
    const Eigen::Vector3d p(v[0], v[1], v[2]);
    const Eigen::Vector3d local = box.to_local(p);
    if (((local.cwiseAbs() - box.half_extents).array() > 0.0).any()) continue;
    const Eigen::Vector3d q = box.to_object(F.forward(local));
    v = {q.x(), q.y(), q.z()};
  }
  return soup;
}

// The faces F holds at the identity, as a scene's "pins" list.
json held_faces(const Deformer& F) {
  json pins = json::array();
  const std::array<bool, 6> held = F.identity_faces();
  for (int f = 0; f < 6; ++f)
    if (held[static_cast<size_t>(f)])
      pins.push_back(std::string(1, "-+"[f % 2]) + char('x' + f / 2));
  return pins;
}

void expect_thresholds(const std::string& name, const ImageComparison& c, const Image& gl,
                       const Image& truth, double min_iou = 0.98, double max_over = 0.02) {
  std::printf(
      "[figures] from_mesh %s: IoU %.4f, over 1%% of diag %.2f%%, mean depth err %.4g, max "
      "%.4g\n",
      name.c_str(), c.iou, 100 * c.fraction_over, c.mean_depth_error, c.max_depth_error);
  fs::create_directories("from_mesh_render_test_images");
  write_png("from_mesh_render_test_images/" + name + "_gl.png", gl);
  write_png("from_mesh_render_test_images/" + name + "_truth.png", truth);
  EXPECT_GE(c.iou, min_iou) << name;
  EXPECT_LE(c.fraction_over, max_over) << name;
}

Image render(const Scene& scene, const Camera& camera, PreparedScene& prepared, int size = kSize) {
  std::ostringstream log;
  prepared = prepare_scene(scene, log);
  raywarp::testing::osmesa_context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  const Image image = renderer.render(camera, size, size, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);
  const BakeReport& r = prepared.boxes.at(0).report;
  if (r.from_mesh)
    std::printf(
        "[figures] from_mesh pairs: %ld of %ld vertices, largest move %.4g, fit max %.3g rms %.3g, "
        "%.2f s (turns %.0f degrees, %d steps); folded %.3g of %.3g; D error %.3g voxels; %s\n",
        r.from_mesh->pairs, r.from_mesh->mesh_vertices, r.from_mesh->largest_move,
        r.from_mesh->fit_max_error, r.from_mesh->fit_rms_error, r.from_mesh->seconds,
        r.from_mesh->largest_turn_deg, r.from_mesh->turn_steps, r.folds.folded_volume,
        r.folds.box_volume, r.texture_error_voxels(), r.deformer.c_str());
  return image;
}

// A copy: the example and the angle its deformer is set to.
struct Copy {
  const char* scene;
  double angle_deg;
};

// As GoogleTest names the case in its listing (and so ctest's name).
void PrintTo(const Copy& c, std::ostream* os) { *os << c.scene << " at " << c.angle_deg; }

class CopiesOfExactDeformations : public ::testing::TestWithParam<Copy> {};

TEST_P(CopiesOfExactDeformations, RenderWithinTheThresholdsOfTheAnalyticMap) {
  const std::string root = RAYWARP_SOURCE_DIR;
  const fs::path scene_file = root + "/examples/" + GetParam().scene;
  Scene exact = load_scene(scene_file);
  ASSERT_EQ(exact.boxes.size(), 1u);
  exact.boxes[0].deformer.angle_deg = GetParam().angle_deg;
  const Camera camera = exact.camera ? *exact.camera : Camera{};
  const BoxSpec& spec = exact.boxes[0];
  const std::shared_ptr<const Deformer> F = make_box_deformer(spec, "boxes[0]");

  const Folder folder;
  const std::string target = (folder.path() / "target.ply").string();
  write_ply(target, moved_soup(exact.mesh.string(), spec.box, *F));

  // The faces the analytic map holds are the ones to pin (a bend moves a face the mesh crosses).
  const json pins = held_faces(*F);
  json doc = read_scene_document(scene_file);
  doc["boxes"][0]["deformer"] = {{"type", "from_mesh"}, {"target", target}, {"pins", pins}};
  // The reference: the analytic map of the same (possibly edited) deformer.
  const Scene scene = load_scene_json(doc, scene_file);
  PreparedScene prepared;
  const Image image = render(scene, camera, prepared, kCopySize);

  const BakedBox& box = prepared.boxes[0];
  const double quarter_voxel = 0.25 * box.textures.sdf.grid.voxel();
  const Mesh truth_mesh = ground_truth_mesh(
      prepared.mesh(), box.textures.box, [&](const Eigen::Vector3d& p) { return F->forward(p); },
      quarter_voxel);
  const Image truth = rasterize(truth_mesh, camera, kCopySize, kCopySize, scene.render);
  const double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  const std::string name = fs::path(GetParam().scene).stem().string() + "_" +
                           std::to_string(static_cast<int>(GetParam().angle_deg));
  expect_thresholds(name, compare_images(image, truth, 0.01 * diagonal), image, truth, 0.99, 0.01);
}

INSTANTIATE_TEST_SUITE_P(
    FromMesh, CopiesOfExactDeformations,
    // Turns fitted in one go (90, 60 degrees) and in steps (120 degrees and more, full turns;
    // docs/from_mesh.md "Full turns"). The 720-degree copy takes 30 to 75 s and the armadillo's
    // full turn 17 to 45 s (alone, or beside other tests): the fit follows the turn in steps of
    // at most 0.75 radian (17 for two turns), then the lattice is inverted over the box; a full
    // turn is the first thing a user tries.
    ::testing::Values(Copy{"bunny_head_twist.json", 90}, Copy{"bunny_bend.json", 90},
                      Copy{"zoo/armadillo_hand_twist.json", 120},
                      Copy{"zoo/armadillo_hand_bend.json", 60}, Copy{"bunny_head_twist.json", 360},
                      Copy{"bunny_head_twist.json", 720}, Copy{"bunny_bend.json", 180},
                      Copy{"zoo/armadillo_hand_twist.json", 360}),
    [](const auto& info) {
      std::string s = fs::path(info.param.scene).stem().string() + "_" +
                      std::to_string(static_cast<int>(info.param.angle_deg));
      for (char& c : s)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return s;
    });

TEST(FromMesh, GltfMorphTargetsRenderWithinTheThresholdsOfTheTargets) {
  const std::string root = RAYWARP_SOURCE_DIR;
  // Morph 0: the head twisted by 90 degrees in its box; morph 1: the whole bunny bent in
  // bunny_bend.json's box. Each scene is the example's, with the glTF as its mesh.
  const std::vector<fs::path> files = {root + "/examples/bunny_head_twist.json",
                                       root + "/examples/bunny_bend.json"};
  std::vector<Scene> scenes;
  for (const fs::path& f : files) scenes.push_back(load_scene(f));
  scenes[0].boxes[0].deformer.angle_deg = 90;  // as in CopiesOfExactDeformations
  const Camera camera = *scenes[0].camera;
  const std::string mesh_file = scenes[0].mesh.string();
  const PolygonSoup base = read_ply(read_mesh_file(mesh_file).bytes, mesh_file);
  std::vector<std::shared_ptr<const Deformer>> maps;
  std::vector<PolygonSoup> moved;
  for (const Scene& s : scenes) {
    maps.push_back(make_box_deformer(s.boxes[0], "boxes[0]"));
    moved.push_back(moved_soup(mesh_file, s.boxes[0].box, *maps.back()));
  }

  const Folder folder;
  const std::string gltf = (folder.path() / "bunny_morphs.gltf").string();
  write_gltf(gltf, base, moved);
  const FileVertices morph1 = load_file_vertices(gltf, 1);
  ASSERT_EQ(morph1.morph_targets, 2);
  ASSERT_EQ(morph1.positions.size(), base.vertices.size());
  for (int morph = 0; morph < 2; ++morph) {
    json doc = read_scene_document(files[static_cast<size_t>(morph)]);
    doc["mesh"] = gltf;
    const json pins = held_faces(*maps[static_cast<size_t>(morph)]);
    doc["boxes"][0]["deformer"] = {
        {"type", "from_mesh"}, {"target", gltf}, {"morph", morph}, {"pins", pins}};
    const Scene scene = load_scene_json(doc, files[static_cast<size_t>(morph)]);
    PreparedScene prepared;
    const Image image = render(scene, camera, prepared);
    // The reference: the target mesh itself (the morphed glTF), rasterised.
    const std::string target_ply = (folder.path() / "target.ply").string();
    write_ply(target_ply, moved[static_cast<size_t>(morph)]);
    const Mesh target = load_mesh(target_ply);
    const Image truth = rasterize(target, camera, kSize, kSize, scene.render);
    const double diagonal = mesh_bounds(target).diagonal().norm();
    expect_thresholds(std::string("gltf_morph_") + std::to_string(morph),
                      compare_images(image, truth, 0.01 * diagonal), image, truth);
  }
}

// A sequence: a folder of copies, the bunny's head twisted by 0, 45 and 90 degrees, named so that
// only natural order puts them right (copy_1, copy_2, copy_10). Frame 1.5 blends the 45- and
// 90-degree copies half and half; the reference is that blended mesh, rasterised.
TEST(FromMesh, SequenceFrameRendersWithinTheThresholdsOfTheBlendedCopies) {
  const std::string root = RAYWARP_SOURCE_DIR;
  const fs::path scene_file = root + "/examples/bunny_head_twist.json";
  Scene exact = load_scene(scene_file);
  const Camera camera = *exact.camera;
  const std::string mesh_file = exact.mesh.string();
  const Folder folder;
  const fs::path sequence = folder.path() / "twist";
  fs::create_directories(sequence);
  const char* names[3] = {"copy_1.ply", "copy_2.ply", "copy_10.ply"};
  std::vector<PolygonSoup> copies;
  std::shared_ptr<const Deformer> F;
  for (int k = 0; k < 3; ++k) {
    exact.boxes[0].deformer.angle_deg = 45.0 * k;
    F = make_box_deformer(exact.boxes[0], "boxes[0]");
    copies.push_back(moved_soup(mesh_file, exact.boxes[0].box, *F));
    write_ply((sequence / names[k]).string(), copies.back());
  }
  PolygonSoup blended = copies[1];
  for (size_t i = 0; i < blended.vertices.size(); ++i)
    for (int a = 0; a < 3; ++a)
      blended.vertices[i][a] = 0.5 * copies[1].vertices[i][a] + 0.5 * copies[2].vertices[i][a];
  json doc = read_scene_document(scene_file);
  doc["boxes"][0]["deformer"] = {{"type", "from_mesh"},
                                 {"target", sequence.string()},
                                 {"frame", 1.5},
                                 {"pins", held_faces(*F)}};
  const Scene scene = load_scene_json(doc, scene_file);
  PreparedScene prepared;
  const Image image = render(scene, camera, prepared);
  const BakeReport& r = prepared.boxes[0].report;
  ASSERT_TRUE(r.from_mesh);
  EXPECT_EQ(r.from_mesh->frames, 3);
  EXPECT_EQ(r.from_mesh->frame, 1.5);
  const std::string target_ply = (folder.path() / "blended.ply").string();
  write_ply(target_ply, blended);
  const Mesh target = load_mesh(target_ply);
  const Image truth = rasterize(target, camera, kSize, kSize, scene.render);
  expect_thresholds("sequence_frame_1_5",
                    compare_images(image, truth, 0.01 * mesh_bounds(target).diagonal().norm()),
                    image, truth);
}

// Bad targets are refused naming the field and both counts.
TEST(FromMesh, TargetWithOtherVerticesIsRefused) {
  const std::string root = RAYWARP_SOURCE_DIR;
  const fs::path scene_file = root + "/examples/bunny_head_twist.json";
  json doc = read_scene_document(scene_file);
  doc["boxes"][0]["deformer"] = {{"type", "from_mesh"},
                                 {"target", root + "/examples/meshes/probe.ply"}};
  const Scene scene = load_scene_json(doc, scene_file);
  std::ostringstream log;
  try {
    prepare_scene(scene, log);
    ADD_FAILURE() << "a target with other vertices was accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("boxes[0].deformer.target"), std::string::npos) << m;
    EXPECT_NE(m.find("1839"), std::string::npos) << m;
    EXPECT_NE(m.find("same order"), std::string::npos) << m;
  }
}

}  // namespace
