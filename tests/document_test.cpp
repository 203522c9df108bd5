// The editor's document (editor/document.h): edits are taken only when the scene reader accepts
// them, the steps of one drag merge into one edit, undo and redo step between valid states, a
// bare mesh opens with a twist box on its upper half, and a saved document is a scene that
// `raywarp render` reads, with its camera inline and its mesh path relative to its new folder.
#include "editor/document.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "base/error.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "tests/temp_folder.h"

namespace raywarp::editor {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const fs::path kExamples = fs::path(RAYWARP_SOURCE_DIR) / "examples";

class DocumentTest : public TempFolderTest {};

TEST_F(DocumentTest, InvalidEditsAreRefusedWithTheReadersMessage) {
  Document d = Document::open(kExamples / "bunny_twist.json");
  json next = d.json();
  next["boxes"][0]["deformer"]["angle_deg"] = "ninety";
  const std::string error = d.edit(next);
  EXPECT_NE(error.find("boxes[0].deformer.angle_deg"), std::string::npos) << error;
  EXPECT_EQ(d.edits(), 0u);
  EXPECT_FALSE(d.can_undo());
  EXPECT_EQ(d.json()["boxes"][0]["deformer"]["angle_deg"], 360);
}

TEST_F(DocumentTest, DragStepsMergeAndUndoRedoStepBetweenStates) {
  Document d = Document::open(kExamples / "bunny_twist.json");
  json next = d.json();
  for (int angle : {370, 380, 390}) {
    next["boxes"][0]["deformer"]["angle_deg"] = angle;
    ASSERT_EQ(d.edit(next, angle != 370), "");
  }
  EXPECT_EQ(d.edits(), 1u);
  EXPECT_DOUBLE_EQ(d.scene().boxes[0].deformer.angle_deg, 390);
  next["boxes"][0]["deformer"]["axis"] = "x";
  ASSERT_EQ(d.edit(next), "");
  EXPECT_EQ(d.edits(), 2u);
  d.undo();
  EXPECT_EQ(d.json()["boxes"][0]["deformer"]["axis"], "y");
  d.undo();
  EXPECT_DOUBLE_EQ(d.scene().boxes[0].deformer.angle_deg, 360);
  EXPECT_FALSE(d.can_undo());
  d.redo();
  EXPECT_DOUBLE_EQ(d.scene().boxes[0].deformer.angle_deg, 390);
  // A new edit after an undo drops the states that could be redone.
  next = d.json();
  next["boxes"][0]["deformer"]["angle_deg"] = 10;
  ASSERT_EQ(d.edit(next), "");
  EXPECT_FALSE(d.can_redo());
}

TEST_F(DocumentTest, ABareMeshOpensWithATwistOnItsUpperHalf) {
  fs::copy_file(kExamples / "meshes" / "bunny.ply", path("bunny.ply"));
  const Document d = Document::open(path("bunny.ply"));
  EXPECT_EQ(d.path(), fs::path(path("bunny.json")));
  ASSERT_EQ(d.scene().boxes.size(), 1u);
  EXPECT_EQ(d.scene().boxes[0].deformer.type, "twist");
  ASSERT_TRUE(d.scene().camera.has_value());
  const Eigen::AlignedBox3d bounds = mesh_bounds(load_mesh(path("bunny.ply")));
  const Box& box = d.scene().boxes[0].box;
  EXPECT_NEAR(box.centre.y() - box.half_extents.y(), bounds.center().y(), 1e-9);
  EXPECT_GE(box.centre.y() + box.half_extents.y(), bounds.max().y());
}

TEST_F(DocumentTest, AZUpMeshOpensWithTheBoxOnItsUpperHalfAlongZ) {
  fs::copy_file(kExamples / "meshes" / "bunny.ply", path("bunny.ply"));
  const Document d = Document::open(path("bunny.ply"), 2);
  const Eigen::AlignedBox3d bounds = mesh_bounds(load_mesh(path("bunny.ply")));
  const Box& box = d.scene().boxes[0].box;
  EXPECT_EQ(d.scene().boxes[0].deformer.axis, 2);
  EXPECT_NEAR(box.centre.z() - box.half_extents.z(), bounds.center().z(), 1e-9);
  EXPECT_GE(box.centre.y() + box.half_extents.y(), bounds.max().y());
  EXPECT_LE(box.centre.y() - box.half_extents.y(), bounds.min().y());
  EXPECT_TRUE(d.scene().camera->up.isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_THROW(Document::open(path("bunny.ply"), 3), Error);
}

TEST(TwistAngleChanges, OnlyATwistsAngleCountsAndNothingElse) {
  const json was = {{"mesh", "m.ply"},
                    {"boxes",
                     {{{"min", {0, 0, 0}},
                       {"max", {1, 1, 1}},
                       {"deformer", {{"type", "twist"}, {"angle_deg", 90}}}},
                      {{"min", {2, 0, 0}},
                       {"max", {3, 1, 1}},
                       {"deformer", {{"type", "bend"}, {"angle_deg", 30}}}}}}};
  json now = was;
  EXPECT_FALSE(twist_angle_changes(now, was).has_value());  // nothing changed
  now["boxes"][0]["deformer"]["angle_deg"] = 45;
  ASSERT_TRUE(twist_angle_changes(now, was).has_value());
  EXPECT_EQ(*twist_angle_changes(now, was), std::vector<size_t>{0});
  now["boxes"][0]["deformer"].erase("angle_deg");  // the default angle: still only the angle
  EXPECT_TRUE(twist_angle_changes(now, was).has_value());
  json bend = was;
  bend["boxes"][1]["deformer"]["angle_deg"] = 40;  // a bend's angle needs a bake
  EXPECT_FALSE(twist_angle_changes(bend, was).has_value());
  json moved = now;
  moved["boxes"][0]["max"][1] = 2;  // the box too
  EXPECT_FALSE(twist_angle_changes(moved, was).has_value());
  json axis = now;
  axis["boxes"][0]["deformer"]["axis"] = "x";
  EXPECT_FALSE(twist_angle_changes(axis, was).has_value());
  json render = now;
  render["render"] = {{"sampling", "linear"}};
  EXPECT_FALSE(twist_angle_changes(render, was).has_value());
}

TEST_F(DocumentTest, SavedSceneLoadsWithItsCameraInlineAndItsMeshFound) {
  const Document d = Document::open(kExamples / "bunny_twist.json");
  Camera camera =
      frame_bounds(Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1)));
  camera.width = 320;
  camera.height = 200;
  d.save(path("saved.json"), camera);
  const Scene saved = load_scene(path("saved.json"));
  EXPECT_TRUE(fs::equivalent(saved.mesh, d.scene().mesh));
  ASSERT_TRUE(saved.camera.has_value());
  EXPECT_EQ(saved.camera->width, 320);
  EXPECT_EQ(saved.camera->height, 200);
  EXPECT_TRUE(saved.camera->eye.isApprox(camera.eye));
  EXPECT_DOUBLE_EQ(saved.boxes[0].deformer.angle_deg, 360);
  EXPECT_EQ(listing(), std::vector<std::string>{"saved.json"});  // no temporary left
}

TEST_F(DocumentTest, AFileThatIsNotASceneOrAMeshThrowsNamingIt) {
  std::ofstream(path("broken.json")) << "{ \"mesh\": ";
  EXPECT_THROW(Document::open(path("broken.json")), Error);
  std::ofstream(path("broken.ply")) << "ply\nformat ascii 1.0\nelement vertex 99\n";
  try {
    Document::open(path("broken.ply"));
    FAIL() << "a broken mesh opened";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("broken.ply"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace raywarp::editor
