// Image tests of the from_mesh deformer (docs/from_mesh.md): a deformation authored elsewhere,
// brought in as a deformed copy of the mesh or as a glTF morph target, baked into a deformation
// texture and rendered by the GL renderer (OSMesa), against an independent reference, with the
// image thresholds of tests/render_test.cpp (IoU >= 0.98, at most 2 % of the common pixels off by
// more than 1 % of the deformed mesh's diagonal):
//   CopiesOfExactDeformations  the mesh's vertices in the box moved by raywarp's own exact twist
//                              (90 degrees) or bend, written out as a PLY, the faces the map holds
//                              pinned; the render against the analytic
//                              deformation's ground truth (the mesh subdivided to a quarter voxel
//                              and mapped by the exact F), on the bunny (3,674 triangles) and the
//                              armadillo (52,000).
//   GltfMorphTargets           a glTF written here with two morph targets (the twist of the
//                              head and the bend of the whole bunny, as displacements); each
//                              target rendered against the target mesh itself, rasterised.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>

#include "library/mesh_file.h"
#include "library/mesh_pairs.h"
#include "tests/ground_truth_render.h"

using namespace raywarp;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr int kSize = 256;

// A fresh folder under the system's temporary folder, removed afterwards.
struct Folder {
  fs::path dir;
  Folder() {
    dir =
        fs::temp_directory_path() / ("raywarp_from_mesh_" + std::to_string(std::random_device()()));
    fs::create_directories(dir);
  }
  ~Folder() { fs::remove_all(dir); }
  fs::path path() const { return dir; }
};

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

void write_ply(const std::string& path, const PolygonSoup& soup) {
  std::ofstream out(path);
  out.precision(17);
  out << "ply\nformat ascii 1.0\nelement vertex " << soup.vertices.size()
      << "\nproperty double x\nproperty double y\nproperty double z\nelement face "
      << soup.sizes.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& v : soup.vertices) out << v[0] << " " << v[1] << " " << v[2] << "\n";
  size_t next = 0;
  for (int size : soup.sizes) {
    out << size;
    for (int c = 0; c < size; ++c) out << " " << soup.corners[next++];
    out << "\n";
  }
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
                       const Image& truth) {
  std::printf(
      "[figures] from_mesh %s: IoU %.4f, over 1%% of diag %.2f%%, mean depth err %.4g, max "
      "%.4g\n",
      name.c_str(), c.iou, 100 * c.fraction_over, c.mean_depth_error, c.max_depth_error);
  fs::create_directories("from_mesh_render_test_images");
  write_png("from_mesh_render_test_images/" + name + "_gl.png", gl);
  write_png("from_mesh_render_test_images/" + name + "_truth.png", truth);
  EXPECT_GE(c.iou, 0.98) << name;
  EXPECT_LE(c.fraction_over, 0.02) << name;
}

Image render(const Scene& scene, const Camera& camera, PreparedScene& prepared) {
  std::ostringstream log;
  prepared = prepare_scene(scene, log);
  raywarp::testing::osmesa_context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  const Image image = renderer.render(camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);
  const BakeReport& r = prepared.boxes.at(0).report;
  if (r.from_mesh)
    std::printf(
        "[figures] from_mesh pairs: %ld of %ld vertices, largest move %.4g, fit max %.3g rms %.3g, "
        "%.2f s; folded %.3g of %.3g; D error %.3g voxels; %s\n",
        r.from_mesh->pairs, r.from_mesh->mesh_vertices, r.from_mesh->largest_move,
        r.from_mesh->fit_max_error, r.from_mesh->fit_rms_error, r.from_mesh->seconds,
        r.folds.folded_volume, r.folds.box_volume, r.texture_error_voxels(), r.deformer.c_str());
  return image;
}

class CopiesOfExactDeformations : public ::testing::TestWithParam<const char*> {};

TEST_P(CopiesOfExactDeformations, RenderWithinTheThresholdsOfTheAnalyticMap) {
  const std::string root = RAYWARP_SOURCE_DIR;
  const fs::path scene_file = root + "/examples/" + GetParam();
  Scene exact = load_scene(scene_file);
  // The bunny's head twisted by 90 degrees (the example's 360 folds the fitted field inside the
  // head, where no vertex constrains it: docs/from_mesh.md).
  if (exact.boxes[0].deformer.type == "twist") exact.boxes[0].deformer.angle_deg = 90;
  ASSERT_EQ(exact.boxes.size(), 1u);
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
  const Image image = render(scene, camera, prepared);

  const BakedBox& box = prepared.boxes[0];
  const double quarter_voxel = 0.25 * box.textures.sdf.grid.voxel();
  const Mesh truth_mesh = ground_truth_mesh(
      prepared.mesh(), box.textures.box, [&](const Eigen::Vector3d& p) { return F->forward(p); },
      quarter_voxel);
  const Image truth = rasterize(truth_mesh, camera, kSize, kSize, scene.render);
  const double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  std::string name = fs::path(GetParam()).stem().string();
  expect_thresholds(name, compare_images(image, truth, 0.01 * diagonal), image, truth);
}

INSTANTIATE_TEST_SUITE_P(FromMesh, CopiesOfExactDeformations,
                         ::testing::Values("bunny_head_twist.json", "bunny_bend.json",
                                           "zoo/armadillo_hand_twist.json",
                                           "zoo/armadillo_hand_bend.json"),
                         [](const auto& info) {
                           std::string s = fs::path(info.param).stem().string();
                           for (char& c : s)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return s;
                         });

std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned n = (unsigned char)bytes[i] << 16 | (unsigned char)bytes[i + 1] << 8 |
                       (unsigned char)bytes[i + 2];
    for (int s = 18; s >= 0; s -= 6) out += k[(n >> s) & 63];
  }
  if (i < bytes.size()) {
    unsigned n = (unsigned char)bytes[i] << 16;
    if (i + 1 < bytes.size()) n |= (unsigned char)bytes[i + 1] << 8;
    out += k[(n >> 18) & 63];
    out += k[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? k[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// A glTF 2.0 file (buffer embedded as a data URI) of one mesh, the bunny's triangles, with one
// morph target per `moved` soup (positions given absolute, stored as displacements).
void write_gltf(const std::string& path, const PolygonSoup& base,
                const std::vector<PolygonSoup>& moved) {
  std::string bin;
  auto put_float = [&](float f) { bin.append(reinterpret_cast<const char*>(&f), 4); };
  const size_t n = base.vertices.size();
  json accessors = json::array(), views = json::array();
  auto add_vec3 = [&](const std::vector<std::array<double, 3>>& v, bool displacement_of_base) {
    const size_t offset = bin.size();
    std::array<double, 3> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (size_t i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a) {
        const float f =
            static_cast<float>(displacement_of_base ? v[i][a] - base.vertices[i][a] : v[i][a]);
        put_float(f);
        lo[a] = std::min(lo[a], double(f));
        hi[a] = std::max(hi[a], double(f));
      }
    views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", 12 * n}});
    accessors.push_back({{"bufferView", views.size() - 1},
                         {"componentType", 5126},
                         {"count", n},
                         {"type", "VEC3"},
                         {"min", lo},
                         {"max", hi}});
    return accessors.size() - 1;
  };
  const size_t position = add_vec3(base.vertices, false);
  json targets = json::array();
  for (const PolygonSoup& m : moved) targets.push_back({{"POSITION", add_vec3(m.vertices, true)}});
  const size_t index_offset = bin.size();
  size_t indices = 0;
  for (size_t next = 0, f = 0; f < base.sizes.size(); next += base.sizes[f], ++f)
    for (int c = 1; c + 1 < base.sizes[f]; ++c)
      for (int k : {0, c, c + 1}) {
        const std::uint32_t idx = static_cast<std::uint32_t>(base.corners[next + k]);
        bin.append(reinterpret_cast<const char*>(&idx), 4);
        ++indices;
      }
  views.push_back({{"buffer", 0}, {"byteOffset", index_offset}, {"byteLength", 4 * indices}});
  accessors.push_back({{"bufferView", views.size() - 1},
                       {"componentType", 5125},
                       {"count", indices},
                       {"type", "SCALAR"}});
  json doc = {{"asset", {{"version", "2.0"}}},
              {"scene", 0},
              {"scenes", {{{"nodes", {0}}}}},
              {"nodes", {{{"mesh", 0}}}},
              {"meshes",
               {{{"primitives",
                  {{{"attributes", {{"POSITION", position}}},
                    {"indices", accessors.size() - 1},
                    {"targets", targets}}}},
                 {"weights", std::vector<double>(moved.size(), 0.0)}}}},
              {"buffers",
               {{{"byteLength", bin.size()},
                 {"uri", "data:application/octet-stream;base64," + base64(bin)}}}},
              {"bufferViews", views},
              {"accessors", accessors}};
  std::ofstream(path) << doc.dump();
}

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
