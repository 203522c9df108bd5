// Named after no one source: sequences of library/mesh_pairs.h (pairs: from_mesh_test).
// A from_mesh sequence (library/mesh_pairs.h): a folder of deformed copies in natural name order,
// or a glTF's morph targets; a fractional frame blends the copies on either side; frames past the
// last, empty folders and conflicting fields are refused naming the field and what is allowed.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/error.h"
#include "library/bake.h"
#include "library/bake_cache.h"
#include "library/mesh_pairs.h"
#include "library/scene.h"
#include "tests/mesh_files.h"
#include "tests/temp_folder.h"

using namespace raywarp;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// A tetrahedron, its vertices shifted by `shift` along x.
PolygonSoup tetrahedron(double shift) {
  PolygonSoup soup;
  soup.vertices = {{shift, 0, 0}, {1 + shift, 0, 0}, {shift, 1, 0}, {shift, 0, 1}};
  soup.sizes = {3, 3, 3, 3};
  soup.corners = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  return soup;
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

class MeshSequence : public TempFolderTest {
 protected:
  // copy_1.ply, copy_2.ply, copy_10.ply shifted by 0, 1 and 2; a hidden copy and a text file
  // that are not frames.
  std::string write_copies() {
    const fs::path dir = dir_ / "copies";
    fs::create_directories(dir);
    raywarp::testing::write_ply((dir / "copy_10.ply").string(), tetrahedron(2));
    raywarp::testing::write_ply((dir / "copy_2.ply").string(), tetrahedron(1));
    raywarp::testing::write_ply((dir / "copy_1.ply").string(), tetrahedron(0));
    raywarp::testing::write_ply((dir / ".copy_0.ply").string(), tetrahedron(7));
    std::ofstream(dir / "notes.txt") << "not a frame\n";
    return dir.string();
  }
};

TEST_F(MeshSequence, FolderFramesAreItsMeshFilesInNaturalOrder) {
  const std::string dir = write_copies();
  const std::vector<std::string> files = sequence_files(dir);
  ASSERT_EQ(files.size(), 3u);
  EXPECT_EQ(fs::path(files[0]).filename(), "copy_1.ply");
  EXPECT_EQ(fs::path(files[1]).filename(), "copy_2.ply");
  EXPECT_EQ(fs::path(files[2]).filename(), "copy_10.ply");
  EXPECT_EQ(sequence_frames(dir), 3);
}

TEST_F(MeshSequence, FractionalFrameBlendsTheCopiesOnEitherSide) {
  const std::string dir = write_copies();
  for (double frame : {0.0, 1.0, 2.0, 0.25, 1.75}) {
    const DeformedCopy copy = read_deformed_copy(dir, -1, 1.0, frame);
    EXPECT_EQ(copy.frames, 3);
    ASSERT_EQ(copy.vertices.positions.size(), 4u);
    // Copy k is shifted by k: the blend by the frame itself.
    EXPECT_DOUBLE_EQ(copy.vertices.positions[0].x(), frame) << frame;
    EXPECT_DOUBLE_EQ(copy.vertices.positions[1].x(), 1.0 + frame) << frame;
    EXPECT_EQ(copy.files.size(), frame == std::floor(frame) ? 1u : 2u) << frame;
  }
  // No frame given: a folder's first copy.
  EXPECT_DOUBLE_EQ(read_deformed_copy(dir, -1, 1.0, -1).vertices.positions[0].x(), 0.0);
}

TEST_F(MeshSequence, FramesPastTheLastAndEmptyFoldersAreRefused) {
  const std::string dir = write_copies();
  std::string m = message_of([&] { read_deformed_copy(dir, -1, 1.0, 2.5); });
  EXPECT_EQ(m.rfind("frame = 2.5", 0), 0u) << m;
  EXPECT_NE(m.find("last frame, 2 (3 copies in"), std::string::npos) << m;
  m = message_of([&] { read_deformed_copy(dir, 0, 1.0, 1); });
  EXPECT_EQ(m.rfind("morph", 0), 0u) << m;
  fs::create_directories(dir_ / "empty");
  std::ofstream(dir_ / "empty" / "readme.txt") << "no mesh here\n";
  m = message_of([&] { sequence_files((dir_ / "empty").string()); });
  EXPECT_NE(m.find("no mesh file"), std::string::npos) << m;
  // A copy with another vertex count than the frame before it.
  PolygonSoup bigger = tetrahedron(3);
  bigger.vertices.push_back({9, 9, 9});
  raywarp::testing::write_ply((fs::path(dir) / "copy_11.ply").string(), bigger);
  m = message_of([&] { read_deformed_copy(dir, -1, 1.0, 2.5); });
  EXPECT_NE(m.find("copy_11.ply has 5 vertices"), std::string::npos) << m;
}

TEST_F(MeshSequence, GltfFramesAreItsMorphTargets) {
  const std::string gltf = path("morphs.gltf");
  raywarp::testing::write_gltf(gltf, tetrahedron(0), {tetrahedron(1), tetrahedron(2)});
  EXPECT_EQ(sequence_frames(gltf), 2);
  EXPECT_EQ(sequence_frames(path("plain.ply")), 0);
  for (double frame : {0.0, 0.5, 1.0}) {
    const DeformedCopy copy = read_deformed_copy(gltf, -1, 1.0, frame);
    EXPECT_EQ(copy.frames, 2);
    // Morph target k is the base shifted by k + 1 (stored as floats: exact for these values).
    EXPECT_DOUBLE_EQ(copy.vertices.positions[0].x(), 1.0 + frame) << frame;
  }
  // Frame k is morph target k at weight 1.
  const DeformedCopy morph = read_deformed_copy(gltf, 1, 1.0, -1);
  EXPECT_EQ(morph.frames, 0);
  EXPECT_EQ(morph.vertices.positions[3],
            read_deformed_copy(gltf, -1, 1.0, 1).vertices.positions[3]);
  const std::string m = message_of([&] { read_deformed_copy(gltf, -1, 1.0, 1.5); });
  EXPECT_NE(m.find("last frame, 1 (2 morph targets in"), std::string::npos) << m;
  raywarp::testing::write_ply(path("plain.ply"), tetrahedron(0));
  const std::string none = message_of([&] { read_deformed_copy(path("plain.ply"), -1, 1, 0); });
  EXPECT_NE(none.find("no morph target"), std::string::npos) << none;
}

// The scene file: a folder target's frames are checked when the scene is read.
TEST_F(MeshSequence, SceneFieldsAreCheckedWhenTheSceneIsRead) {
  const std::string dir = write_copies();
  raywarp::testing::write_ply(path("mesh.ply"), tetrahedron(0));
  auto scene = [&](const json& deformer) {
    return json{{"mesh", "mesh.ply"},
                {"boxes", {{{"min", {-1, -1, -1}}, {"max", {4, 2, 2}}, {"deformer", deformer}}}}};
  };
  auto load = [&](const json& deformer) {
    return message_of([&] { load_scene_json(scene(deformer), path("s.json")); });
  };
  EXPECT_EQ(load({{"type", "from_mesh"}, {"target", "copies"}, {"frame", 2}}), "");
  EXPECT_EQ(load({{"type", "from_mesh"}, {"target", "copies"}}), "");
  std::string m = load({{"type", "from_mesh"}, {"target", "copies"}, {"frame", 3}});
  EXPECT_NE(m.find("boxes[0].deformer.frame = 3: past the sequence's last frame, 2"),
            std::string::npos)
      << m;
  m = load({{"type", "from_mesh"}, {"target", "copies"}, {"morph", 0}});
  EXPECT_NE(m.find("boxes[0].deformer.morph"), std::string::npos) << m;
  EXPECT_NE(m.find("give \"frame\""), std::string::npos) << m;
  raywarp::testing::write_gltf(path("m.gltf"), tetrahedron(0), {tetrahedron(1)});
  m = load({{"type", "from_mesh"}, {"target", "m.gltf"}, {"morph", 0}, {"frame", 0}});
  EXPECT_NE(m.find("boxes[0].deformer.frame"), std::string::npos) << m;
  m = load({{"type", "from_mesh"}, {"target", "copies"}, {"frame", -1}});
  EXPECT_NE(m.find("boxes[0].deformer.frame"), std::string::npos) << m;
  fs::create_directories(dir_ / "empty");
  m = load({{"type", "from_mesh"}, {"target", "empty"}});
  EXPECT_NE(m.find("boxes[0].deformer.target"), std::string::npos) << m;
  EXPECT_NE(m.find("no mesh file"), std::string::npos) << m;
  (void)dir;
}

// A from_mesh fit is a stage of the bake: a second session with the same disk cache reads the
// fitted lattice (and reads no copy), and its deformer is the fitted one; another frame fits
// again.
TEST_F(MeshSequence, TheFitIsCachedPerFrame) {
  // An octahedron as the mesh, so that the box holds a solid; its copies raise the top vertex.
  const fs::path dir = dir_ / "octa";
  fs::create_directories(dir);
  auto octahedron = [](double top) {
    PolygonSoup soup;
    soup.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, top, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    soup.sizes = std::vector<int>(8, 3);
    soup.corners = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    return soup;
  };
  raywarp::testing::write_ply(path("octa.ply"), octahedron(1.0));
  raywarp::testing::write_ply((dir / "a_0.ply").string(), octahedron(1.0));
  raywarp::testing::write_ply((dir / "a_1.ply").string(), octahedron(1.3));
  auto scene_at = [&](double frame) {
    const json doc = {
        {"mesh", "octa.ply"},
        {"boxes",
         {{{"min", {-1.2, -1.2, -1.2}},
           {"max", {1.2, 1.6, 1.2}},
           {"deformer",
            {{"type", "from_mesh"}, {"target", "octa"}, {"frame", frame}, {"resolution", 8}}},
           {"implicit", {{"resolution", 16}}},
           {"deformation", {{"resolution", 16}}}}}}};
    return load_scene_json(doc, path("s.json"));
  };
  BakeCache cache(dir_ / "cache");
  auto bake = [&](double frame) {
    BakeSession session(&cache);
    const Scene scene = scene_at(frame);
    return session.bake(make_job(scene, 0, session.mesh(scene.mesh)));
  };
  const BakedBox first = bake(1);
  const BakedBox again = bake(1);
  const BakedBox other = bake(0.5);
  ASSERT_NE(first.report.stage(Stage::Fit), nullptr);
  EXPECT_EQ(first.report.stage(Stage::Fit)->source, Source::Baked);
  EXPECT_EQ(again.report.stage(Stage::Fit)->source, Source::Disk);
  EXPECT_EQ(other.report.stage(Stage::Fit)->source, Source::Baked);
  ASSERT_TRUE(again.report.from_mesh);
  EXPECT_EQ(again.report.from_mesh->pairs, first.report.from_mesh->pairs);
  EXPECT_EQ(again.report.from_mesh->frames, 2);
  EXPECT_EQ(again.report.deformer, first.report.deformer);
  // The top vertex (box frame: its centre is (0, 0.2, 0)) goes where the copy puts it.
  const Eigen::Vector3d top(0, 0.8, 0);
  EXPECT_NEAR((first.deformer->forward(top) - Eigen::Vector3d(0, 1.1, 0)).norm(), 0, 1e-3);
  EXPECT_EQ(first.deformer->forward(top), again.deformer->forward(top));
  EXPECT_NEAR(other.deformer->forward(top).y(), 0.95, 1e-3);
}

}  // namespace

// A copy with one vertex sent far away (a slip of a modelling tool, a broken export) is refused
// naming the vertex and how far it strays from its neighbours' motion; a rigid move of the whole
// copy, however large, is no stray.
TEST_F(MeshSequence, AStrayVertexIsNamedAndRefused) {
  auto sheet = [](int stray, double far, double shift) {
    PolygonSoup soup;  // a 6 x 6 grid of vertices over [0, 1]^2 at z = 0, two triangles a cell
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 6; ++i)
        soup.vertices.push_back({0.2 * i + shift, 0.2 * j, (j * 6 + i == stray) ? far : 0.0});
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) {
        const int a = j * 6 + i;
        soup.sizes.insert(soup.sizes.end(), {3, 3});
        soup.corners.insert(soup.corners.end(), {a, a + 1, a + 7, a, a + 7, a + 6});
      }
    return soup;
  };
  raywarp::testing::write_ply(path("sheet.ply"), sheet(-1, 0.0, 0.0));
  raywarp::testing::write_ply(path("torn.ply"), sheet(14, 1e6, 0.0));
  raywarp::testing::write_ply(path("moved.ply"), sheet(-1, 0.0, 1000.0));
  const Mesh mesh = load_mesh(path("sheet.ply"));
  Box box;
  box.centre = Eigen::Vector3d(0.5, 0.5, 0.0);
  box.half_extents = Eigen::Vector3d(0.6, 0.6, 0.2);
  const std::string message = message_of([&] {
    mesh_pairs(path("sheet.ply"), mesh, load_file_vertices(path("torn.ply")), "torn.ply", box);
  });
  EXPECT_NE(message.find("torn.ply: vertex 14 moves 1e+06 units"), std::string::npos) << message;
  EXPECT_NE(message.find("6 neighbours"), std::string::npos) << message;
  const MeshPairs moved =
      mesh_pairs(path("sheet.ply"), mesh, load_file_vertices(path("moved.ply")), "moved.ply", box);
  EXPECT_EQ(moved.sources.size(), 36u);
  EXPECT_NEAR(moved.largest_move, 1000.0, 1e-9);
}
