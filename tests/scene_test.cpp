// Tests of library/scene.cpp: valid scenes parse to the documented values and defaults; every
// bad input is refused with a message naming the scene file, the field, the value and what is
// allowed; the overlap test of oriented boxes agrees with a brute-force reference.
#include "library/scene.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "base/error.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// One temporary folder per test process, holding a tiny mesh and a camera next to the scenes.
class SceneFolder : public ::testing::Environment {
 public:
  static fs::path path;

  void SetUp() override {
    path = fs::temp_directory_path() / ("raywarp_scene_test_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path / "meshes");
    fs::create_directories(path / "cameras");
    // A tetrahedron, counter-clockwise seen from outside.
    write("meshes/tet.obj",
          "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
    write(
        "cameras/front.json",
        R"({"eye": [0, 0, 5], "target": [0, 0, 0], "fov_y_deg": 30, "width": 800, "height": 600})");
    write("cameras/degenerate.json", R"({"eye": [1, 2, 3], "target": [1, 2, 3]})");
    write("cameras/overflow.json", R"({"eye": [1e400, 2, 3], "target": [0, 0, 0]})");
  }
  void TearDown() override { fs::remove_all(path); }

  static fs::path write(const std::string& name, const std::string& text) {
    fs::path p = path / name;
    std::ofstream(p) << text;
    return p;
  }
};
fs::path SceneFolder::path;
[[maybe_unused]] auto* const kFolder = ::testing::AddGlobalTestEnvironment(new SceneFolder);

// A valid scene to start each case from.
json base_scene() {
  return json::parse(R"({
    "mesh": "meshes/tet.obj",
    "boxes": [{"min": [-1, 0, -2], "max": [1, 4, 2],
               "deformer": {"type": "twist", "axis": "y", "angle_deg": 90}}]
  })");
}

Scene load_text(const std::string& name, const std::string& text) {
  return load_scene(SceneFolder::write(name, text));
}

Scene load_json(const std::string& name, const json& j) { return load_text(name, j.dump(2)); }

// Cut deformers as the brief of each type writes them.
json peel() {
  return json::parse(R"({"type": "peel", "axis": "z", "from": "+y", "angle_deg": 120,
                         "thickness": 0.8, "radius": 1.5})");
}
json incision() {
  return json::parse(
      R"({"type": "incision", "axis": "x", "from": "+y", "depth": 3, "opening": 1.2})");
}
json box_cut() { return json::parse(R"({"type": "box_cut"})"); }

void expect_near(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double tol = 1e-12) {
  EXPECT_LE((a - b).cwiseAbs().maxCoeff(), tol)
      << "got " << a.transpose() << ", expected " << b.transpose();
}

// The default step is threshold's coarse one; a scene that picks linear or jacobian without a
// step gets the fine step, and a given step is kept.
TEST(Scene, StepDefaultsFollowTheSamplingMethod) {
  json j = base_scene();
  j["render"] = {{"sampling", "linear"}};
  EXPECT_EQ(load_json("linear.json", j).render.step_voxels, kFineStepVoxels);
  j["render"] = {{"sampling", "jacobian"}};
  EXPECT_EQ(load_json("jacobian.json", j).render.step_voxels, kFineStepVoxels);
  j["render"] = {{"sampling", "linear"}, {"step_voxels", 2}};
  EXPECT_EQ(load_json("linear2.json", j).render.step_voxels, 2.0);
  j["render"] = {{"sampling", "threshold"}};
  EXPECT_EQ(load_json("threshold.json", j).render.step_voxels, 4.0);
}

TEST(Scene, MinMaxGivesCentreHalfExtentsAndDefaults) {
  Scene s = load_json("minmax.json", base_scene());
  EXPECT_EQ(s.file, SceneFolder::path / "minmax.json");
  EXPECT_EQ(s.mesh, SceneFolder::path / "meshes" / "tet.obj");
  EXPECT_TRUE(fs::exists(s.mesh));
  ASSERT_EQ(s.boxes.size(), 1u);
  const BoxSpec& b = s.boxes[0];
  expect_near(b.box.centre, {0, 2, 0});
  expect_near(b.box.half_extents, {1, 2, 2});
  EXPECT_TRUE(b.box.rotation.isIdentity(0.0));
  EXPECT_EQ(b.deformer.type, "twist");
  EXPECT_EQ(b.deformer.axis, 1);
  EXPECT_EQ(b.deformer.angle_deg, 90.0);
  // Defaults as scene.h and docs/scene.md state them.
  EXPECT_EQ(b.implicit.type, "sdf");
  EXPECT_EQ(b.implicit.resolution, kAutoResolution);
  EXPECT_EQ(b.implicit.max_mib, 48.0);
  EXPECT_EQ(b.implicit.band_voxels, 4.0);
  EXPECT_EQ(b.implicit.margin_voxels, 2.0);
  EXPECT_EQ(b.deformation_resolution, kAutoResolution);
  EXPECT_EQ(b.deformation_max_mib, 64.0);
  EXPECT_EQ(b.cut_mode, CutMode::Solid);
  EXPECT_EQ(b.shell_thickness, 0.0);
  EXPECT_EQ(b.alpha_resolution, kAutoResolution);
  EXPECT_EQ(b.alpha_max_mib, 16.0);
  EXPECT_FALSE(s.camera.has_value());
  EXPECT_EQ(s.render.width, 512);
  EXPECT_EQ(s.render.height, 512);
  EXPECT_EQ(s.render.sampling, Sampling::Threshold);
  EXPECT_EQ(s.render.step_voxels, 4.0);
  EXPECT_EQ(s.render.fine_factor, 0.125);
  EXPECT_EQ(s.render.max_steps, 1024);
  EXPECT_EQ(s.render.refine_steps, 8);
  expect_near(s.render.background, {1, 1, 1});
  expect_near(s.render.colour, {0.8, 0.62, 0.45});
  expect_near(s.render.cut_colour, {0.75, 0.18, 0.16});
  expect_near(s.render.inside_colour, {0.3, 0.42, 0.62});
  EXPECT_TRUE(s.render.skipping);
}

TEST(Scene, CentreFormWithRotationZYX) {
  json j = base_scene();
  j["boxes"][0] = json::parse(R"({"centre": [1, 2, 3], "half_extents": [0.5, 1, 2],
      "rotation_deg": [90, 0, 90], "deformer": {"type": "bend", "axis": "z", "angle_deg": -45}})");
  Scene s = load_json("rotated.json", j);
  const Box& box = s.boxes[0].box;
  expect_near(box.centre, {1, 2, 3});
  expect_near(box.half_extents, {0.5, 1, 2});
  // R = Rz(90) Ry(0) Rx(90): x is rotated about x first (stays x), then about z (becomes y);
  // y becomes z under Rx and stays z under Rz. The other order (Rx Rz) would send y to -x.
  expect_near(box.rotation.col(0), {0, 1, 0}, 1e-15);
  expect_near(box.rotation.col(1), {0, 0, 1}, 1e-15);
  expect_near(box.rotation.col(2), {1, 0, 0}, 1e-15);
  EXPECT_NEAR(box.rotation.determinant(), 1.0, 1e-15);
  EXPECT_EQ(s.boxes[0].deformer.type, "bend");
  EXPECT_EQ(s.boxes[0].deformer.axis, 2);
  EXPECT_EQ(s.boxes[0].deformer.angle_deg, -45.0);
}

TEST(Scene, CenterIsAnAliasAndRotationDefaultsToIdentity) {
  json j = base_scene();
  j["boxes"][0] = json::parse(R"({"center": [0, 0, 0], "half_extents": [1, 1, 1],
      "deformer": {"type": "twist", "axis": "x", "angle_deg": 1080}})");
  Scene s = load_json("center.json", j);
  expect_near(s.boxes[0].box.centre, {0, 0, 0});
  EXPECT_TRUE(s.boxes[0].box.rotation.isIdentity(0.0));
  EXPECT_EQ(s.boxes[0].deformer.axis, 0);
  EXPECT_EQ(s.boxes[0].deformer.angle_deg, 1080.0);  // twist: any finite angle
}

TEST(Scene, OptionalSectionsAreRead) {
  json j = base_scene();
  j["boxes"][0]["implicit"] = {
      {"type", "sdf"}, {"resolution", 64}, {"band_voxels", 4.5}, {"margin_voxels", 0}};
  j["boxes"][0]["deformation"] = {{"resolution", 4}};
  j["render"] = json::parse(R"({"width": 320, "height": 200, "step_voxels": 8, "max_steps": 1,
      "refine_steps": 0, "background": [0, 0.5, 1], "colour": [1, 1, 0]})");
  Scene s = load_json("optional.json", j);
  EXPECT_EQ(s.boxes[0].implicit.resolution, 64);
  EXPECT_EQ(s.boxes[0].implicit.band_voxels, 4.5);
  EXPECT_EQ(s.boxes[0].implicit.margin_voxels, 0.0);
  EXPECT_EQ(s.boxes[0].deformation_resolution, 4);
  EXPECT_EQ(s.render.width, 320);
  EXPECT_EQ(s.render.height, 200);
  EXPECT_EQ(s.render.step_voxels, 8.0);
  EXPECT_EQ(s.render.max_steps, 1);
  EXPECT_EQ(s.render.refine_steps, 0);
  expect_near(s.render.background, {0, 0.5, 1});
  expect_near(s.render.colour, {1, 1, 0});
}

TEST(Scene, AutoResolutionsAndTheirBudgets) {
  json j = base_scene();
  j["boxes"][0]["deformation"] = {{"resolution", "auto"}, {"max_mib", 12.5}};
  Scene s = load_json("auto.json", j);
  EXPECT_EQ(s.boxes[0].deformation_resolution, kAutoResolution);
  EXPECT_EQ(s.boxes[0].deformation_max_mib, 12.5);
  j["boxes"][0]["deformer"] = peel();
  j["boxes"][0]["alpha"] = {{"max_mib", 2}};
  s = load_json("auto_alpha.json", j);
  EXPECT_EQ(s.boxes[0].alpha_resolution, kAutoResolution);
  EXPECT_EQ(s.boxes[0].alpha_max_mib, 2.0);
}

TEST(Scene, RenderCutColoursAndSkipping) {
  json j = base_scene();
  j["render"] = json::parse(
      R"({"cut_colour": [1, 0, 0.25], "inside_colour": [0, 0.5, 1], "skipping": false})");
  Scene s = load_json("render_cuts.json", j);
  expect_near(s.render.cut_colour, {1, 0, 0.25});
  expect_near(s.render.inside_colour, {0, 0.5, 1});
  EXPECT_FALSE(s.render.skipping);
  j["render"] = {{"skipping", true}};
  EXPECT_TRUE(load_json("render_skipping.json", j).render.skipping);
}

TEST(Scene, PeelIsReadWithDefaults) {
  json j = base_scene();
  j["boxes"][0]["deformer"] = peel();
  Scene s = load_json("peel.json", j);
  const BoxSpec& b = s.boxes[0];
  EXPECT_EQ(b.deformer.type, "peel");
  EXPECT_EQ(b.deformer.axis, 2);
  EXPECT_EQ(b.deformer.from_axis, 1);
  EXPECT_EQ(b.deformer.from_side, 1);
  EXPECT_EQ(b.deformer.angle_deg, 120.0);
  EXPECT_EQ(b.deformer.thickness, 0.8);
  EXPECT_EQ(b.deformer.radius, 1.5);
  EXPECT_EQ(b.deformer.hinge, 0.0);  // default
  // Cut defaults.
  EXPECT_EQ(b.cut_mode, CutMode::Solid);
  EXPECT_EQ(b.shell_thickness, 0.0);
  EXPECT_EQ(b.alpha_resolution, kAutoResolution);
}

TEST(Scene, PeelWithHingeHollowAndAlpha) {
  json j = base_scene();
  j["boxes"][0]["deformer"] = peel();
  j["boxes"][0]["deformer"]["from"] = "-x";
  j["boxes"][0]["deformer"]["angle_deg"] = 180;  // the upper end is allowed
  j["boxes"][0]["deformer"]["hinge"] = -0.25;
  j["boxes"][0]["cut_mode"] = "hollow";
  j["boxes"][0]["alpha"] = {{"resolution", 4}};
  Scene s = load_json("peel_hinge.json", j);
  const BoxSpec& b = s.boxes[0];
  EXPECT_EQ(b.deformer.from_axis, 0);
  EXPECT_EQ(b.deformer.from_side, -1);
  EXPECT_EQ(b.deformer.angle_deg, 180.0);
  EXPECT_EQ(b.deformer.hinge, -0.25);
  EXPECT_EQ(b.cut_mode, CutMode::Hollow);
  EXPECT_EQ(b.alpha_resolution, 4);
}

TEST(Scene, IncisionWithThickShell) {
  json j = base_scene();
  j["boxes"][0]["deformer"] = incision();
  j["boxes"][0]["deformer"]["from"] = "-z";
  j["boxes"][0]["cut_mode"] = "thick_shell";
  j["boxes"][0]["shell_thickness"] = 0.25;
  j["boxes"][0]["alpha"] = {{"resolution", 256}};
  Scene s = load_json("incision.json", j);
  const BoxSpec& b = s.boxes[0];
  EXPECT_EQ(b.deformer.type, "incision");
  EXPECT_EQ(b.deformer.axis, 0);
  EXPECT_EQ(b.deformer.from_axis, 2);
  EXPECT_EQ(b.deformer.from_side, -1);
  EXPECT_EQ(b.deformer.depth, 3.0);
  EXPECT_EQ(b.deformer.opening, 1.2);
  EXPECT_EQ(b.cut_mode, CutMode::ThickShell);
  EXPECT_EQ(b.shell_thickness, 0.25);
  EXPECT_EQ(b.alpha_resolution, 256);
}

TEST(Scene, IncisionDefaultsToSolid) {
  json j = base_scene();
  j["boxes"][0]["deformer"] = incision();
  j["boxes"][0]["alpha"] = json::object();  // every field of alpha has a default
  Scene s = load_json("incision_default.json", j);
  EXPECT_EQ(s.boxes[0].cut_mode, CutMode::Solid);
  EXPECT_EQ(s.boxes[0].alpha_resolution, kAutoResolution);
  EXPECT_EQ(s.boxes[0].deformer.from_axis, 1);
  EXPECT_EQ(s.boxes[0].deformer.from_side, 1);
}

TEST(Scene, BoxCutDefaultsToTheWholeBoxWithoutWedge) {
  json j = base_scene();
  j["boxes"][0]["deformer"] = box_cut();
  Scene s = load_json("box_cut.json", j);
  const BoxSpec& b = s.boxes[0];
  EXPECT_EQ(b.deformer.type, "box_cut");
  expect_near(b.deformer.sub_min, {0, 0, 0});
  expect_near(b.deformer.sub_max, {1, 1, 1});
  EXPECT_EQ(b.deformer.wedge_angle_deg, 0.0);  // no wedge
  EXPECT_EQ(b.cut_mode, CutMode::Solid);
}

TEST(Scene, BoxCutWithSubBoxAndWedge) {
  json j = base_scene();
  j["boxes"][0]["deformer"] = json::parse(R"({"type": "box_cut", "sub_min": [0.5, 0, 0.25],
      "sub_max": [1, 0.75, 1], "wedge": {"axis": "z", "from_deg": -30, "angle_deg": 180}})");
  j["boxes"][0]["cut_mode"] = "hollow";
  Scene s = load_json("box_cut_wedge.json", j);
  const DeformerSpec& d = s.boxes[0].deformer;
  expect_near(d.sub_min, {0.5, 0, 0.25});
  expect_near(d.sub_max, {1, 0.75, 1});
  EXPECT_EQ(d.wedge_axis, 2);
  EXPECT_EQ(d.wedge_from_deg, -30.0);
  EXPECT_EQ(d.wedge_angle_deg, 180.0);
  EXPECT_EQ(s.boxes[0].cut_mode, CutMode::Hollow);

  // from_deg defaults to 0; sub_max alone leaves sub_min at 0.
  j["boxes"][0]["deformer"] =
      json::parse(R"({"type": "box_cut", "sub_max": [0.5, 1, 1], "wedge": {"axis": "x",
          "angle_deg": 45}})");
  DeformerSpec e = load_json("box_cut_wedge_default.json", j).boxes[0].deformer;
  expect_near(e.sub_min, {0, 0, 0});
  expect_near(e.sub_max, {0.5, 1, 1});
  EXPECT_EQ(e.wedge_axis, 0);
  EXPECT_EQ(e.wedge_from_deg, 0.0);
  EXPECT_EQ(e.wedge_angle_deg, 45.0);
}

TEST(Scene, CameraAsPathRelativeToTheSceneFile) {
  fs::create_directories(SceneFolder::path / "sub");
  json j = base_scene();
  j["mesh"] = "../meshes/tet.obj";
  j["camera"] = "../cameras/front.json";
  Scene s = load_json("sub/camera_path.json", j);
  EXPECT_EQ(s.mesh, SceneFolder::path / "meshes" / "tet.obj");
  ASSERT_TRUE(s.camera.has_value());
  expect_near(s.camera->eye, {0, 0, 5});
  EXPECT_EQ(s.camera->fov_y_deg, 30.0);
  EXPECT_EQ(s.camera->width, 800);
  EXPECT_EQ(s.camera->height, 600);
}

TEST(Scene, CameraInline) {
  json j = base_scene();
  j["camera"] = json::parse(
      R"({"projection": "orthographic", "eye": [3, 0, 0], "target": [0, 0, 0], "ortho_height": 4})");
  Scene s = load_json("camera_inline.json", j);
  ASSERT_TRUE(s.camera.has_value());
  EXPECT_EQ(s.camera->projection, Camera::Projection::Orthographic);
  expect_near(s.camera->eye, {3, 0, 0});
  EXPECT_EQ(s.camera->ortho_height, 4.0);
  EXPECT_EQ(s.camera->width, 0);
}

TEST(Scene, ImageSizePrecedence) {
  json j = base_scene();
  j["render"] = {{"width", 640}, {"height", 480}};
  Scene s = load_json("image_size.json", j);
  Camera none;  // width = height = 0: not given
  Camera sized;
  sized.width = 800;
  sized.height = 600;
  Camera width_only;
  width_only.width = 1000;
  EXPECT_EQ(image_size(s, none, 0, 0), Eigen::Vector2i(640, 480));
  EXPECT_EQ(image_size(s, sized, 0, 0), Eigen::Vector2i(800, 600));
  EXPECT_EQ(image_size(s, sized, 1024, 768), Eigen::Vector2i(1024, 768));
  // Each side on its own: the command line's width, the camera's height.
  EXPECT_EQ(image_size(s, sized, 1024, 0), Eigen::Vector2i(1024, 600));
  EXPECT_EQ(image_size(s, width_only, 0, 0), Eigen::Vector2i(1000, 480));
  EXPECT_EQ(image_size(s, none, -1, -5), Eigen::Vector2i(640, 480));
}

TEST(Scene, SeveralBoxesThatTouchAreAccepted) {
  json j = base_scene();
  json second = j["boxes"][0];
  second["min"] = {1, 0, -2};  // shares the face x = 1 with the first box
  second["max"] = {3, 4, 2};
  j["boxes"].push_back(second);
  Scene s = load_json("touching.json", j);
  EXPECT_EQ(s.boxes.size(), 2u);
}

TEST(Scene, SixteenBoxesAreAcceptedSeventeenAreNot) {
  json j = base_scene();
  json box = j["boxes"][0];
  j["boxes"] = json::array();
  for (int i = 0; i < 17; ++i) {
    box["min"] = {3 * i, 0, 0};
    box["max"] = {3 * i + 1, 1, 1};
    j["boxes"].push_back(box);
  }
  EXPECT_THROW(load_json("seventeen.json", j), Error);
  j["boxes"].erase(16);
  EXPECT_EQ(load_json("sixteen.json", j).boxes.size(), 16u);
}

TEST(Scene, RotatedBoxesAreTestedAsOrientedBoxes) {
  // Two thin slabs rotated 45 degrees about z, 0.3 apart along their normal (thickness 0.2):
  // their axis-aligned bounds overlap, the boxes do not. At 0.15 apart they overlap.
  auto scene = [](double offset) {
    json j = base_scene();
    json slab = json::parse(R"({"half_extents": [1, 0.1, 1], "rotation_deg": [0, 0, 45],
        "deformer": {"type": "twist", "axis": "x", "angle_deg": 30}})");
    double s = std::sqrt(0.5);
    slab["centre"] = {0, 0, 0};
    j["boxes"] = json::array({slab});
    slab["centre"] = {-s * offset, s * offset, 0};
    j["boxes"].push_back(slab);
    return j;
  };
  EXPECT_EQ(load_json("slabs_apart.json", scene(0.3)).boxes.size(), 2u);
  EXPECT_THROW(load_json("slabs_overlap.json", scene(0.15)), Error);
}

// Reference for the overlap of two solid boxes: convex polyhedra with a common interior point
// have an edge of one that meets the other (a contained vertex included). Each edge is clipped
// against the other box's slabs in that box's frame (Liang-Barsky).
bool edge_meets_box(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Box& b) {
  Eigen::Vector3d q0 = b.to_local(p0), d = b.to_local(p1) - q0;
  double t0 = 0, t1 = 1;
  for (int a = 0; a < 3; ++a) {
    double h = b.half_extents[a];
    if (std::abs(d[a]) < 1e-300) {
      if (std::abs(q0[a]) > h) return false;
      continue;
    }
    double ta = (-h - q0[a]) / d[a], tb = (h - q0[a]) / d[a];
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  }
  return t0 <= t1;
}

bool edges_meet(const Box& a, const Box& b) {
  for (int axis = 0; axis < 3; ++axis)
    for (int corner = 0; corner < 8; ++corner) {
      if (corner & (1 << axis)) continue;
      Eigen::Vector3d s0, s1;
      for (int k = 0; k < 3; ++k) s0[k] = (corner & (1 << k)) ? 1 : -1;
      s1 = s0;
      s1[axis] = 1;
      if (edge_meets_box(a.to_object(s0.cwiseProduct(a.half_extents)),
                         a.to_object(s1.cwiseProduct(a.half_extents)), b))
        return true;
    }
  return false;
}

TEST(Scene, OverlapTestAgreesWithBruteForceOnRandomBoxes) {
  std::mt19937 rng(20070101);
  std::uniform_real_distribution<double> centre(-1.5, 1.5), half(0.1, 1.2), angle(-180, 180);
  int overlapping = 0, disjoint = 0;
  for (int trial = 0; trial < 300; ++trial) {
    json j = base_scene();
    j["boxes"] = json::array();
    Box boxes[2];
    for (Box& b : boxes) {
      Eigen::Vector3d c(centre(rng), centre(rng), centre(rng));
      Eigen::Vector3d h(half(rng), half(rng), half(rng));
      Eigen::Vector3d r(angle(rng), angle(rng), angle(rng));
      j["boxes"].push_back({{"centre", {c.x(), c.y(), c.z()}},
                            {"half_extents", {h.x(), h.y(), h.z()}},
                            {"rotation_deg", {r.x(), r.y(), r.z()}},
                            {"deformer", {{"type", "twist"}, {"axis", "z"}, {"angle_deg", 10}}}});
      // The box as the scene states it (R = Rz Ry Rx), independently of scene.cpp.
      Eigen::Vector3d rad = r * M_PI / 180;
      b.centre = c;
      b.half_extents = h;
      b.rotation = (Eigen::AngleAxisd(rad.z(), Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(rad.y(), Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(rad.x(), Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
    }
    bool expected = edges_meet(boxes[0], boxes[1]) || edges_meet(boxes[1], boxes[0]);
    bool refused = false;
    try {
      load_json("random_boxes.json", j);
    } catch (const Error& e) {
      refused = true;
      EXPECT_NE(std::string(e.what()).find("boxes[1] = "), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("overlaps boxes[0]"), std::string::npos) << e.what();
    }
    EXPECT_EQ(refused, expected) << "trial " << trial << ": " << j["boxes"].dump();
    (expected ? overlapping : disjoint)++;
  }
  // Both outcomes must be exercised for the comparison to mean anything.
  EXPECT_GT(overlapping, 30);
  EXPECT_GT(disjoint, 30);
}

TEST(Scene, FlatBoxAtFullResolutionFitsTheBudget) {
  // The distance grid follows the box's aspect: 1024 x 1024 x 11 voxels plus margins.
  json j = base_scene();
  j["boxes"][0]["min"] = {-1, -1, -0.01};
  j["boxes"][0]["max"] = {1, 1, 0.01};
  j["boxes"][0]["implicit"] = {{"resolution", 1024}};
  j["boxes"][0]["deformation"] = {{"resolution", 512}};
  EXPECT_EQ(load_json("flat.json", j).boxes[0].implicit.resolution, 1024);
}

#ifdef RAYWARP_SOURCE_DIR
TEST(Scene, ShippedExamplesLoad) {
  int loaded = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(RAYWARP_SOURCE_DIR) / "examples")) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().string());
    Scene s = load_scene(entry.path());
    EXPECT_FALSE(s.boxes.empty());
    EXPECT_TRUE(fs::exists(s.mesh));
    ++loaded;
  }
  EXPECT_GT(loaded, 0);
}
#endif

// ---- Bad inputs: each message starts with the scene file and names the field and the value.

struct BadCase {
  std::string name;
  std::function<std::string()> scene;  // the scene file's text
  std::vector<std::string> expected;   // substrings of the message; {dir} = the scene folder
};

// Names the case in test output instead of dumping its bytes.
void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

std::string edit(const std::function<void(json&)>& change) {
  json j = base_scene();
  change(j);
  return j.dump(2);
}

json& box0(json& j) { return j["boxes"][0]; }

std::vector<BadCase> bad_cases() {
  return {
      {"MissingMesh",
       [] { return edit([](json& j) { j.erase("mesh"); }); },
       {": mesh: missing; give the mesh file"}},
      {"MeshFileAbsent",
       [] { return edit([](json& j) { j["mesh"] = "meshes/none.obj"; }); },
       {": mesh = \"meshes/none.obj\": no such file: {dir}/meshes/none.obj"}},
      {"MeshNotString",
       [] { return edit([](json& j) { j["mesh"] = 3; }); },
       {": mesh = 3: must be a path"}},
      {"MissingBoxes",
       [] { return edit([](json& j) { j.erase("boxes"); }); },
       {": boxes: missing; give a list of 1 to 16 boxes"}},
      {"BoxesEmpty",
       [] { return edit([](json& j) { j["boxes"] = json::array(); }); },
       {": boxes = []: must be a list of 1 to 16 boxes"}},
      {"MinNotBelowMax",
       [] { return edit([](json& j) {
              box0(j)["max"] = {1, 0, 2};
            }); },
       {": boxes[0].max[1] = 0: must be greater than boxes[0].min[1] = 0"}},
      {"MaxWithoutMin",
       [] { return edit([](json& j) { box0(j).erase("min"); }); },
       {": boxes[0].min: missing; give either min and max, or centre and half_extents"}},
      {"NegativeHalfExtents",
       [] {
         return edit([](json& j) {
           box0(j).erase("min");
           box0(j).erase("max");
           box0(j)["centre"] = {0, 0, 0};
           box0(j)["half_extents"] = {1, 1, -1};
         });
       },
       {": boxes[0].half_extents[2] = -1: must be > 0"}},
      {"BothMinAndCentre",
       [] { return edit([](json& j) {
              box0(j)["centre"] = {0, 0, 0};
            }); },
       {": boxes[0].centre = [0,0,0]: not allowed together with min/max"}},
      {"RotationWithMinMax",
       [] { return edit([](json& j) {
              box0(j)["rotation_deg"] = {0, 45, 0};
            }); },
       {": boxes[0].rotation_deg = [0,45,0]: not allowed together with min/max"}},
      {"CentreAndCenter",
       [] {
         return edit([](json& j) {
           json b = {{"centre", {0, 0, 0}},
                     {"center", {0, 0, 0}},
                     {"half_extents", {1, 1, 1}},
                     {"deformer", box0(j)["deformer"]}};
           box0(j) = b;
         });
       },
       {": boxes[0].center = [0,0,0]: an alias of centre; give only one of them"}},
      {"RotationOutOfRange",
       [] {
         return edit([](json& j) {
           box0(j) = {{"centre", {0, 0, 0}},
                      {"half_extents", {1, 1, 1}},
                      {"rotation_deg", {0, 400, 0}},
                      {"deformer", box0(j)["deformer"]}};
         });
       },
       {": boxes[0].rotation_deg[1] = 400: must be a number in [-360, 360]"}},
      {"HugeCoordinate",
       [] { return edit([](json& j) { box0(j)["min"][0] = -1e300; }); },
       {": boxes[0].min[0] = -1e+300: must be a number in [-1e+12, 1e+12]"}},
      {"DeformerMissing",
       [] { return edit([](json& j) { box0(j).erase("deformer"); }); },
       {": boxes[0].deformer: missing; give {\"type\""}},
      {"DeformerTypeUnknown",
       [] { return edit([](json& j) { box0(j)["deformer"]["type"] = "twsit"; }); },
       {": boxes[0].deformer.type = \"twsit\": must be one of twist, bend, taper, stretch, "
        "detail, peel, incision, box_cut"}},
      {"DeformerTypePoints",
       [] { return edit([](json& j) { box0(j)["deformer"]["type"] = "points"; }); },
       {": boxes[0].deformer.type = \"points\": must be one of twist, bend, taper, stretch, "
        "detail, peel, incision, box_cut, groove, control_points"}},
      {"DeformerListEmpty",
       [] { return edit([](json& j) { box0(j)["deformer"] = json::array(); }); },
       {": boxes[0].deformer = []: must be one deformer object or a list of 1 to 8 deformers"}},
      {"DeformerListWithCut",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = json::array({box0(j)["deformer"], {{"type", "box_cut"}}});
         });
       },
       {": boxes[0].deformer[1].type = \"box_cut\": a cut (peel, incision, box_cut, "
        "groove) cannot be composed"}},
      {"ControlPointsEmpty",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = {{"type", "control_points"}, {"points", json::array()}};
         });
       },
       {": boxes[0].deformer.points = []: must be a list of 1 to 1024"}},
      {"ControlPointsPinnedFace",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = {{"type", "control_points"},
                                  {"points", {{{"from", {0, 0, 0}}, {"to", {0, 0, 0}}}}},
                                  {"pinned", {"+w"}}};
         });
       },
       {": boxes[0].deformer.pinned[0] = \"+w\": must be one of -x, +x, -y, +y, -z, +z"}},
      {"ControlPointsSourceOutside",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = {{"type", "control_points"},
                                  {"points",
                                   {{{"from", {0, 0, 0}}, {"to", {0, 0, 0}}},
                                    {{"from", {0, 100, 0}}, {"to", {0, 0, 0}}}}}};
         });
       },
       {": boxes[0].deformer.points[1].from = [0,100,0]: must lie in the box (centre [0, 2, 0]"}},
      {"ControlPointsNoTo",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = {{"type", "control_points"}, {"points", {{{"from", {0, 0, 0}}}}}};
         });
       },
       {": boxes[0].deformer.points[0].to: missing"}},
      {"AxisW",
       [] { return edit([](json& j) { box0(j)["deformer"]["axis"] = "w"; }); },
       {": boxes[0].deformer.axis = \"w\": must be one of x, y, z"}},
      {"BendAngle360",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = {{"type", "bend"}, {"axis", "x"}, {"angle_deg", 360}};
         });
       },
       {": boxes[0].deformer.angle_deg = 360: must be a number in (-360, 360)"}},
      {"TwistAngleString",
       [] { return edit([](json& j) { box0(j)["deformer"]["angle_deg"] = "90"; }); },
       {": boxes[0].deformer.angle_deg = \"90\": must be a number; any finite value"}},
      {"UnknownKeyListsAllowed",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"].erase("angle_deg");
           box0(j)["deformer"]["anlge_deg"] = 90;
         });
       },
       {": boxes[0].deformer.anlge_deg = 90: unknown field; allowed: type, axis, angle_deg"}},
      {"UnknownTopLevelKey",
       [] { return edit([](json& j) { j["mesh_file"] = "x.obj"; }); },
       {": mesh_file = \"x.obj\": unknown field; allowed: mesh, boxes, camera, render"}},
      {"ImplicitResolution0",
       [] { return edit([](json& j) {
              box0(j)["implicit"] = {{"resolution", 0}};
            }); },
       {": boxes[0].implicit.resolution = 0: must be an integer in [8, 1024]"}},
      {"ImplicitResolution5000",
       [] { return edit([](json& j) {
              box0(j)["implicit"] = {{"resolution", 5000}};
            }); },
       {": boxes[0].implicit.resolution = 5000: must be an integer in [8, 1024]"}},
      {"DeformationResolutionFraction",
       [] { return edit([](json& j) {
              box0(j)["deformation"] = {{"resolution", 12.5}};
            }); },
       {": boxes[0].deformation.resolution = 12.5: must be an integer in [4, 1024]"}},
      {"ImplicitTypeUnknown",
       [] { return edit([](json& j) {
              box0(j)["implicit"] = {{"type", "octree"}};
            }); },
       {": boxes[0].implicit.type = \"octree\": must be one of sdf, depth_cube"}},
      {"BandVoxelsOutOfRange",
       [] { return edit([](json& j) {
              box0(j)["implicit"] = {{"band_voxels", 0.5}};
            }); },
       {": boxes[0].implicit.band_voxels = 0.5: must be a number in [1, 32]"}},
      {"InvalidJson",
       [] { return std::string("{\"mesh\": \"meshes/tet.obj\",\n \"boxes\": }"); },
       {": not valid JSON at line 2, column 12 in boxes: "}},
      {"NumberBeyondDouble",
       [] { return std::string("{\"mesh\": 1e400}"); },
       {": mesh = 1e400: must be a finite number"}},
      {"NumberBeyondDoubleDeep",
       [] {
         return std::string(
             "{\"mesh\": \"meshes/tet.obj\", \"boxes\": [{\"deformer\": {\"angle_deg\": 2e999}}]}");
       },
       {": boxes[0].deformer.angle_deg = 2e999: must be a finite number"}},
      {"NestedTooDeep",
       [] { return std::string(100000, '[') + std::string(100000, ']'); },
       {": [0][0][0]", "deeper than 64 levels"}},
      {"NestedTooDeepInAField",
       [] { return std::string("{\"render\": ").append(70, '[').append(70, ']').append("}"); },
       {": render[0][0]", "deeper than 64 levels"}},
      {"NotAnObject",
       [] { return std::string("[1, 2]"); },
       {": the scene = [1,2]: must be a JSON object"}},
      {"OverlappingBoxes",
       [] {
         return edit([](json& j) {
           json second = box0(j);
           second["min"] = {0.5, 0, -2};
           second["max"] = {3, 4, 2};
           j["boxes"].push_back(second);
         });
       },
       {": boxes[1] = {\"max\":[3,4,2],\"min\":[0.5,0,-2]}: overlaps boxes[0] (centre [0, 2, 0], "
        "half_extents [1, 2, 2] vs centre [1.75, 2, 0], half_extents [1.25, 2, 2]); boxes must not "
        "overlap"}},
      {"CameraFileMissing",
       [] { return edit([](json& j) { j["camera"] = "cameras/nope.json"; }); },
       {": camera = \"cameras/nope.json\": no such file: {dir}/cameras/nope.json"}},
      {"CameraNotPathOrObject",
       [] { return edit([](json& j) { j["camera"] = 5; }); },
       {": camera = 5: must be a path (string) or a camera object"}},
      {"CameraInlineEyeEqualsTarget",
       [] {
         return edit([](json& j) { j["camera"] = {{"eye", {1, 2, 3}}, {"target", {1, 2, 3}}}; });
       },
       {": camera.target: equals eye [1,2,3]; they must differ"}},
      {"CameraFileEyeEqualsTarget",
       [] { return edit([](json& j) { j["camera"] = "cameras/degenerate.json"; }); },
       {": camera = \"cameras/degenerate.json\": ", "target: equals eye [1,2,3]"}},
      {"CameraFileNumberBeyondDouble",
       [] { return edit([](json& j) { j["camera"] = "cameras/overflow.json"; }); },
       {": camera = \"cameras/overflow.json\": {dir}/cameras/overflow.json: ",
        "= 1e400: must be a finite number"}},
      {"RenderWidth0",
       [] { return edit([](json& j) {
              j["render"] = {{"width", 0}};
            }); },
       {": render.width = 0: must be an integer in [1, 8192]"}},
      {"RenderBackgroundOutOfRange",
       [] { return edit([](json& j) {
              j["render"] = {{"background", {0, 1.5, 0}}};
            }); },
       {": render.background[1] = 1.5: must be a number in [0, 1]"}},
      {"RenderStepZero",
       [] { return edit([](json& j) {
              j["render"] = {{"step_voxels", 0}};
            }); },
       {": render.step_voxels = 0: must be a number in (0, 8]"}},
      {"MemoryBudgetOneBox",
       [] { return edit([](json& j) {
              box0(j)["deformation"] = {{"resolution", 1024}};
            }); },
       {": boxes[0].deformation.resolution = 1024: the textures of all boxes would take 16.",
        "more than the budget of 4.00 GiB"}},
      {"MemoryBudgetDistanceGrid",
       [] {
         return edit([](json& j) {
           box0(j)["min"] = {-1, -1, -1};
           box0(j)["max"] = {1, 1, 1};
           box0(j)["implicit"] = {{"resolution", 1024}};
         });
       },
       {": boxes[0].implicit.resolution = 1024: the textures of all boxes would take 4.1"}},
      {"MemoryBudgetSummedOverBoxes",
       [] {
         // 600^3 texels of 16 bytes = 3.2 GiB: one box fits, two do not.
         return edit([](json& j) {
           box0(j)["deformation"] = {{"resolution", 600}};
           json second = box0(j);
           second["min"] = {5, 0, -2};
           second["max"] = {7, 4, 2};
           j["boxes"].push_back(second);
         });
       },
       {": boxes[0].deformation.resolution = 600: the textures of all boxes would take 6.5",
        "deformation textures 6.4"}},
      {"CutModeOnTwist",
       [] { return edit([](json& j) { box0(j)["cut_mode"] = "solid"; }); },
       {": boxes[0].cut_mode = \"solid\": cut_mode applies to cut deformers (peel, incision, "
        "box_cut, groove); boxes[0].deformer.type is twist"}},
      {"ShellThicknessOnBend",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = {{"type", "bend"}, {"axis", "x"}, {"angle_deg", 90}};
           box0(j)["shell_thickness"] = 0.5;
         });
       },
       {": boxes[0].shell_thickness = 0.5: shell_thickness applies to cut deformers (peel, "
        "incision, box_cut, groove); boxes[0].deformer.type is bend"}},
      {"AlphaOnTwist",
       [] { return edit([](json& j) {
              box0(j)["alpha"] = {{"resolution", 32}};
            }); },
       {": boxes[0].alpha = {\"resolution\":32}: alpha applies to cut deformers (peel, incision, "
        "box_cut, groove); boxes[0].deformer.type is twist"}},
      {"CutModeUnknown",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["cut_mode"] = "open";
         });
       },
       {": boxes[0].cut_mode = \"open\": must be one of hollow, solid, thick_shell"}},
      {"ThickShellWithoutThickness",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = incision();
           box0(j)["cut_mode"] = "thick_shell";
         });
       },
       {": boxes[0].shell_thickness: missing; required with cut_mode thick_shell"}},
      {"ShellThicknessZero",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = incision();
           box0(j)["cut_mode"] = "thick_shell";
           box0(j)["shell_thickness"] = 0;
         });
       },
       {": boxes[0].shell_thickness = 0: must be > 0"}},
      {"ShellThicknessWithSolid",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["cut_mode"] = "hollow";
           box0(j)["shell_thickness"] = 0.5;
         });
       },
       {": boxes[0].shell_thickness = 0.5: only with cut_mode thick_shell; boxes[0].cut_mode is "
        "hollow"}},
      {"ShellThicknessWithDefaultMode",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["shell_thickness"] = 0.5;
         });
       },
       {": boxes[0].shell_thickness = 0.5: only with cut_mode thick_shell; boxes[0].cut_mode is "
        "solid (the default)"}},
      {"AlphaResolution3",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["alpha"] = {{"resolution", 3}};
         });
       },
       {": boxes[0].alpha.resolution = 3: must be an integer in [4, 1024]"}},
      {"AlphaResolution2000",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["alpha"] = {{"resolution", 2000}};
         });
       },
       {": boxes[0].alpha.resolution = 2000: must be an integer in [4, 1024]"}},
      {"AlphaUnknownKey",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["alpha"] = {{"res", 64}};
         });
       },
       {": boxes[0].alpha.res = 64: unknown field; allowed: resolution, max_mib"}},
      {"AlphaNotObject",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["alpha"] = 64;
         });
       },
       {": boxes[0].alpha = 64: must be a JSON object like {\"resolution\": \"auto\"}"}},
      {"ResolutionNotAuto",
       [] { return edit([](json& j) {
              box0(j)["deformation"] = {{"resolution", "fine"}};
            }); },
       {": boxes[0].deformation.resolution = \"fine\": must be \"auto\" or an integer in [4, "
        "1024]"}},
      {"MaxMibWithExplicitResolution",
       [] {
         return edit([](json& j) {
           box0(j)["deformation"] = {{"resolution", 96}, {"max_mib", 8}};
         });
       },
       {": boxes[0].deformation.max_mib = 8: applies to \"resolution\": \"auto\" only"}},
      {"MaxMibTooSmall",
       [] { return edit([](json& j) {
              box0(j)["deformation"] = {{"max_mib", 0.5}};
            }); },
       {": boxes[0].deformation.max_mib = 0.5: must be a number in [1, 1024]"}},
      {"AlphaMaxMibTooLarge",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["alpha"] = {{"max_mib", 2048}};
         });
       },
       {": boxes[0].alpha.max_mib = 2048: must be a number in [1, 1024]"}},
      {"PeelFromSameAxis",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"]["axis"] = "y";
         });
       },
       {": boxes[0].deformer.from = \"+y\": must be a face on another axis than "
        "boxes[0].deformer.axis = \"y\"; allowed: +x, -x, +z, -z"}},
      {"PeelFromUnknown",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"]["from"] = "top";
         });
       },
       {": boxes[0].deformer.from = \"top\": must be one of +x, -x, +y, -y, +z, -z"}},
      {"PeelFromMissing",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"].erase("from");
         });
       },
       {": boxes[0].deformer.from: missing; give a face of the box: +x, -x, +y, -y, +z, -z"}},
      {"PeelAxisMissing",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"].erase("axis");
         });
       },
       {": boxes[0].deformer.axis: missing; give the curl axis, one of x, y, z"}},
      {"PeelAngle0",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"]["angle_deg"] = 0;
         });
       },
       {": boxes[0].deformer.angle_deg = 0: must be a number in (0, 180]"}},
      {"PeelAngle181",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"]["angle_deg"] = 181;
         });
       },
       {": boxes[0].deformer.angle_deg = 181: must be a number in (0, 180]"}},
      {"PeelThickness0",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"]["thickness"] = 0;
         });
       },
       {": boxes[0].deformer.thickness = 0: must be > 0"}},
      {"PeelRadiusNegative",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"]["radius"] = -1.5;
         });
       },
       {": boxes[0].deformer.radius = -1.5: must be > 0"}},
      {"PeelRadiusMissing",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"].erase("radius");
         });
       },
       {": boxes[0].deformer.radius: missing; give the curl radius in object units"}},
      {"PeelHingeString",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"]["hinge"] = "0";
         });
       },
       {": boxes[0].deformer.hinge = \"0\": must be a number; any finite value"}},
      {"PeelUnknownKeyListsPeelKeys",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformer"]["depth"] = 1;
         });
       },
       {": boxes[0].deformer.depth = 1: unknown field; allowed: type, axis, from, angle_deg, "
        "thickness, radius, hinge"}},
      {"IncisionFromSameAxis",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = incision();
           box0(j)["deformer"]["from"] = "-x";
         });
       },
       {": boxes[0].deformer.from = \"-x\": must be a face on another axis than "
        "boxes[0].deformer.axis = \"x\"; allowed: +y, -y, +z, -z"}},
      {"IncisionDepth0",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = incision();
           box0(j)["deformer"]["depth"] = 0;
         });
       },
       {": boxes[0].deformer.depth = 0: must be > 0"}},
      {"IncisionOpeningNegative",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = incision();
           box0(j)["deformer"]["opening"] = -1;
         });
       },
       {": boxes[0].deformer.opening = -1: must be > 0"}},
      {"IncisionOpeningMissing",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = incision();
           box0(j)["deformer"].erase("opening");
         });
       },
       {": boxes[0].deformer.opening: missing; give the width of the gap in object units"}},
      {"IncisionDepthMissing",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = incision();
           box0(j)["deformer"].erase("depth");
         });
       },
       {": boxes[0].deformer.depth: missing; give the depth of the cut in object units"}},
      {"IncisionUnknownKeyListsIncisionKeys",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = incision();
           box0(j)["deformer"]["angle_deg"] = 10;
         });
       },
       {": boxes[0].deformer.angle_deg = 10: unknown field; allowed: type, axis, from, depth, "
        "opening"}},
      {"BoxCutAxisIsUnknown",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["axis"] = "y";
         });
       },
       {": boxes[0].deformer.axis = \"y\": unknown field; allowed: type, sub_min, sub_max, "
        "wedge"}},
      {"BoxCutSubMaxNotAboveSubMin",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["sub_min"] = {0, 0.5, 0};
           box0(j)["deformer"]["sub_max"] = {1, 0.5, 1};
         });
       },
       {": boxes[0].deformer.sub_max[1] = 0.5: must be greater than "
        "boxes[0].deformer.sub_min[1] = 0.5"}},
      {"BoxCutSubMinAtDefaultMax",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["sub_min"] = {0, 0, 1};
         });
       },
       {": boxes[0].deformer.sub_min[2] = 1: must be less than boxes[0].deformer.sub_max[2] = 1 "
        "(the default"}},
      {"BoxCutSubMaxOutOfRange",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["sub_max"] = {1, 1.5, 1};
         });
       },
       {": boxes[0].deformer.sub_max[1] = 1.5: must be a number in [0, 1]"}},
      {"BoxCutSubMinNegative",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["sub_min"] = {-0.1, 0, 0};
         });
       },
       {": boxes[0].deformer.sub_min[0] = -0.1: must be a number in [0, 1]"}},
      {"WedgeAxisMissing",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["wedge"] = {{"angle_deg", 90}};
         });
       },
       {": boxes[0].deformer.wedge.axis: missing; give the wedge's axis, one of x, y, z"}},
      {"WedgeAngleMissing",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["wedge"] = {{"axis", "y"}};
         });
       },
       {": boxes[0].deformer.wedge.angle_deg: missing; give the wedge's angle in degrees"}},
      {"WedgeAngle0",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["wedge"] = {{"axis", "y"}, {"angle_deg", 0}};
         });
       },
       {": boxes[0].deformer.wedge.angle_deg = 0: must be a number in (0, 180]"}},
      {"WedgeAngle270",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["wedge"] = {{"axis", "y"}, {"angle_deg", 270}};
         });
       },
       {": boxes[0].deformer.wedge.angle_deg = 270: must be a number in (0, 180]"}},
      {"WedgeFromString",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["wedge"] = {{"axis", "y"}, {"from_deg", "0"}, {"angle_deg", 90}};
         });
       },
       {": boxes[0].deformer.wedge.from_deg = \"0\": must be a number; any finite value"}},
      {"WedgeAxisW",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["wedge"] = {{"axis", "w"}, {"angle_deg", 90}};
         });
       },
       {": boxes[0].deformer.wedge.axis = \"w\": must be one of x, y, z"}},
      {"WedgeUnknownKey",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["wedge"] = {{"axis", "y"}, {"angle_deg", 90}, {"to_deg", 90}};
         });
       },
       {": boxes[0].deformer.wedge.to_deg = 90: unknown field; allowed: axis, from_deg, "
        "angle_deg"}},
      {"WedgeNotObject",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["deformer"]["wedge"] = 90;
         });
       },
       {": boxes[0].deformer.wedge = 90: must be a JSON object like {\"axis\": \"y\""}},
      {"RenderCutColourOutOfRange",
       [] { return edit([](json& j) {
              j["render"] = {{"cut_colour", {1, 0, 2}}};
            }); },
       {": render.cut_colour[2] = 2: must be a number in [0, 1]"}},
      {"RenderInsideColourNotThree",
       [] { return edit([](json& j) {
              j["render"] = {{"inside_colour", {0.5, 0.5}}};
            }); },
       {": render.inside_colour = [0.5,0.5]: must be an array of 3 numbers"}},
      {"RenderInsideColourNegative",
       [] { return edit([](json& j) {
              j["render"] = {{"inside_colour", {0.5, -0.5, 0}}};
            }); },
       {": render.inside_colour[1] = -0.5: must be a number in [0, 1]"}},
      {"RenderSkippingString",
       [] { return edit([](json& j) {
              j["render"] = {{"skipping", "yes"}};
            }); },
       {": render.skipping = \"yes\": must be true or false"}},
      {"RenderSkippingNumber",
       [] { return edit([](json& j) {
              j["render"] = {{"skipping", 1}};
            }); },
       {": render.skipping = 1: must be true or false"}},
      {"RenderSamplingUnknown",
       [] { return edit([](json& j) {
              j["render"] = {{"sampling", "sphere"}};
            }); },
       {": render.sampling = \"sphere\": must be one of linear, threshold, jacobian, bounded"}},
      {"RenderBoundedWithCut",
       [] {
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           j["render"] = {{"sampling", "bounded"}};
         });
       },
       {": render.sampling = \"bounded\": boxes[0].deformer.type is \"box_cut\", a cut"}},
      {"RenderHitEpsilonZero",
       [] { return edit([](json& j) {
              j["render"] = {{"hit_epsilon_voxels", 0}};
            }); },
       {": render.hit_epsilon_voxels = 0: must be a number in (0, 1]"}},
      {"RenderThresholdZero",
       [] { return edit([](json& j) {
              j["render"] = {{"threshold_voxels", 0}};
            }); },
       {": render.threshold_voxels = 0: must be a number in (0, 64]"}},
      {"RenderTextureBits",
       [] { return edit([](json& j) {
              j["render"] = {{"texture_bits", 8}};
            }); },
       {": render.texture_bits = 8: must be 16 or 32"}},
      {"RenderRouteUnknown",
       [] { return edit([](json& j) {
              j["render"] = {{"route", "mesh"}};
            }); },
       {": render.route = \"mesh\": must be one of texture, tets"}},
      {"RenderRouteTetsNeedsSimulation",
       [] { return edit([](json& j) {
              j["render"] = {{"route", "tets"}};
            }); },
       {": render.route = \"tets\": boxes[0].deformer.type is \"twist\"", "simulation boxes only"}},
      {"TetsModeUnknown",
       [] { return edit([](json& j) {
              j["render"] = {{"tets", {{"mode", "points"}}}};
            }); },
       {": render.tets.mode = \"points\": must be one of surface, volume"}},
      {"TetsRefineOutOfRange",
       [] { return edit([](json& j) {
              j["render"] = {{"tets", {{"refine", 9}}}};
            }); },
       {": render.tets.refine = 9: must be an integer in [1, 8]"}},
      {"TetsUnknownField",
       [] { return edit([](json& j) {
              j["render"] = {{"tets", {{"modes", "volume"}}}};
            }); },
       {": render.tets.modes = \"volume\": unknown field; allowed: mode, refine"}},
      {"TetsTransferOnSurfaceMode",
       [] {
         return edit([](json& j) {
           j["render"] = {{"tets",
                           {{"transfer_function",
                             json::array({{{"s", 0}, {"colour", {1, 1, 1}}, {"tau", 1}}})}}}};
         });
       },
       {": render.tets.transfer_function = ", "applies to \"mode\": \"volume\" only"}},
      {"TetsTransferNotIncreasing",
       [] {
         return edit([](json& j) {
           j["render"] = {{"tets",
                           {{"mode", "volume"},
                            {"transfer_function",
                             json::array({{{"s", 1}, {"colour", {1, 1, 1}}, {"tau", 1}},
                                          {{"s", 0}, {"colour", {1, 1, 1}}, {"tau", 1}}})}}}};
         });
       },
       {": render.tets.transfer_function[1].s = 0: must be greater than the previous point's s "
        "(1)"}},
      {"TetsTransferColourOutOfRange",
       [] {
         return edit([](json& j) {
           j["render"] = {{"tets",
                           {{"mode", "volume"},
                            {"transfer_function",
                             json::array({{{"s", 0}, {"colour", {1, 2, 1}}, {"tau", 1}}})}}}};
         });
       },
       {": render.tets.transfer_function[0].colour[1] = 2: must be a number in [0, 1]"}},
      {"TetsTransferNegativeTau",
       [] {
         return edit([](json& j) {
           j["render"] = {{"tets",
                           {{"mode", "volume"},
                            {"transfer_function",
                             json::array({{{"s", 0}, {"colour", {1, 1, 1}}, {"tau", -1}}})}}}};
         });
       },
       {": render.tets.transfer_function[0].tau = -1: must be a number in [0, 1000000]"}},
      {"TetsTransferEmpty",
       [] {
         return edit([](json& j) {
           j["render"] = {{"tets", {{"mode", "volume"}, {"transfer_function", json::array()}}}};
         });
       },
       {": render.tets.transfer_function = []: must be a list of 1 to 4096 control points"}},
      {"RenderFineFactorAboveOne",
       [] { return edit([](json& j) {
              j["render"] = {{"fine_factor", 1.5}};
            }); },
       {": render.fine_factor = 1.5: must be a number in (0, 1]"}},
      {"MemoryBudgetAlphaMap",
       [] {
         // 1024^3 texels of 4 bytes: the alpha map alone is the whole budget.
         return edit([](json& j) {
           box0(j)["deformer"] = box_cut();
           box0(j)["alpha"] = {{"resolution", 1024}};
         });
       },
       {": boxes[0].alpha.resolution = 1024: the textures of all boxes would take 4.1",
        "alpha maps 4.00 GiB", "more than the budget of 4.00 GiB; lower this setting"}},
      {"MemoryBudgetCountsTheAlphaMap",
       [] {
         // D at 600^3 texels (3.22 GiB) fits alone (MemoryBudgetSummedOverBoxes); with an alpha
         // map of 600^3 floats (0.80 GiB) it does not.
         return edit([](json& j) {
           box0(j)["deformer"] = peel();
           box0(j)["deformation"] = {{"resolution", 600}};
           box0(j)["alpha"] = {{"resolution", 600}};
         });
       },
       {": boxes[0].deformation.resolution = 600: the textures of all boxes would take 4.0",
        "deformation textures 3.22 GiB, alpha maps 0.80 GiB"}},
  };
}

class BadScene : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadScene, IsRefusedNamingFieldAndValue) {
  const BadCase& c = GetParam();
  fs::path file = SceneFolder::write("bad_" + c.name + ".json", c.scene());
  try {
    load_scene(file);
    FAIL() << "accepted: " << c.scene();
  } catch (const Error& e) {
    std::string message = e.what();
    EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0u) << message;
    for (std::string want : c.expected) {
      if (auto at = want.find("{dir}"); at != std::string::npos)
        want.replace(at, 5, SceneFolder::path.string());
      EXPECT_NE(message.find(want), std::string::npos)
          << "message: " << message << "\nexpected to contain: " << want;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Scene, BadScene, ::testing::ValuesIn(bad_cases()),
                         [](const auto& info) { return info.param.name; });

TEST(Scene, MissingSceneFile) {
  fs::path file = SceneFolder::path / "absent.json";
  try {
    load_scene(file);
    FAIL() << "accepted a missing file";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": cannot open the scene file (no such file)");
  }
}

// docs/scene.md holds the deformer table the registry generates, as printed.
TEST(Scene, DocsHoldTheRegistrysDeformerTable) {
  std::ifstream in(std::string(RAYWARP_SOURCE_DIR) + "/docs/scene.md");
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string begin_mark =
      "<!-- deformers: generated by `raywarp deformers --markdown`; do not edit by hand -->\n";
  const size_t begin = doc.find(begin_mark);
  const size_t end = doc.find("<!-- end deformers -->");
  ASSERT_NE(begin, std::string::npos);
  ASSERT_NE(end, std::string::npos);
  const std::string held = doc.substr(begin + begin_mark.size(), end - begin - begin_mark.size());
  EXPECT_EQ(held, deformer_table()) << "regenerate with: build/raywarp deformers --markdown";
  for (const DeformerType& t : deformer_types())
    EXPECT_NE(held.find("`" + t.name + "`"), std::string::npos) << t.name;
}

}  // namespace
}  // namespace raywarp
