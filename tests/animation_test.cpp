// Progressive animation: a twist's angle animated by the texture map M of eq. 2 bakes once and
// each frame matches the exact ground truth of the twist at that frame's angle; other
// parameters re-bake every frame, reading unchanged textures from the bake cache.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "base/error.h"
#include "cli/animate.h"
#include "deformers/twist.h"
#include "library/image.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "verify/reference.h"

using namespace raywarp;
namespace fs = std::filesystem;

namespace {

const std::string kRoot = RAYWARP_SOURCE_DIR;

fs::path temp_dir(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("raywarp_animation_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(AnimatedParam, Parses) {
  AnimatedParam p = parse_animated_param("boxes[0].deformer.angle_deg=0:360");
  EXPECT_EQ(p.path, "boxes[0].deformer.angle_deg");
  EXPECT_EQ(p.from, 0.0);
  EXPECT_EQ(p.to, 360.0);
  EXPECT_DOUBLE_EQ(p.at(30, 61), 180.0);
  EXPECT_EQ(parse_animated_param("render.step_voxels=-1.5:2e0").from, -1.5);
  for (const char* bad :
       {"boxes[0].deformer.angle_deg", "=0:1", "a=0", "a=x:1", "a=0:1x", "a=0:inf", "a=nan:1"})
    EXPECT_THROW(parse_animated_param(bad), Error) << bad;
}

// The twist of the head: the box reaches above the mesh, so only face -y meets it (and stays).
const char* kHeadTwist = R"({
  "mesh": "MESH",
  "boxes": [{"min": [-5.2, 4.0, -4.0], "max": [5.2, 9.9, 4.0],
             "deformer": {"type": "twist", "axis": "y", "angle_deg": 360},
             "implicit": {"type": "sdf", "resolution": 96}, "deformation": {"resolution": 64}}],
  "camera": "CAMERA",
  "render": {"width": 128, "height": 128}
})";

fs::path head_twist_scene(const fs::path& dir) {
  std::string text = kHeadTwist;
  text.replace(text.find("MESH"), 4, kRoot + "/examples/meshes/bunny.ply");
  text.replace(text.find("CAMERA"), 6, kRoot + "/examples/cameras/front.json");
  fs::path path = dir / "head_twist.json";
  std::ofstream(path) << text;
  return path;
}

TEST(Animation, TwistAngleBakesOnceAndMatchesEachFramesTruth) {
  const fs::path dir = temp_dir("mapped");
  AnimationOptions opt;
  opt.scene = head_twist_scene(dir);
  opt.params = {parse_animated_param("boxes[0].deformer.angle_deg=0:270")};
  opt.frames = 60;
  opt.context = "osmesa";
  opt.output = dir / "twist.png";
  opt.width = opt.height = 128;
  std::ostringstream log;
  AnimationResult r = animate(opt, log);
  EXPECT_TRUE(r.mapped) << log.str();
  EXPECT_EQ(r.bakes, 1) << log.str();
  ASSERT_EQ(r.images.size(), 60u);
  EXPECT_TRUE(fs::exists(dir / "twist_0000.png"));
  EXPECT_TRUE(fs::exists(dir / "twist_0059.png"));
  EXPECT_FALSE(fs::exists(dir / "twist_0060.png"));
  std::ifstream gif(dir / "twist.gif", std::ios::binary);
  char magic[6] = {};
  gif.read(magic, 6);
  EXPECT_EQ(std::string(magic, 6), "GIF89a");

  // Each checked frame against the exact twist at its angle.
  Scene scene = load_scene(opt.scene);
  const Camera camera = *scene.camera;
  const Mesh mesh = load_mesh(scene.mesh.string());
  const Box& box = scene.boxes[0].box;
  for (int f : {0, 11, 30, 59}) {
    const double angle = opt.params[0].at(f, opt.frames);
    auto twist = make_twist(box.half_extents, Axis::Y, angle);
    auto F = [&](const Eigen::Vector3d& p) { return twist->forward(p); };
    Mesh truth_mesh = ground_truth_mesh(mesh, box, F, 0.03);
    Image truth = rasterize(truth_mesh, camera, 128, 128, scene.render);
    const double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
    ImageComparison c = compare_images(r.images[f], truth, 0.01 * diagonal);
    std::printf("[figures] mapped twist frame %d (%.0f deg): IoU %.4f, over 1%% of diag %.2f%%\n",
                f, angle, c.iou, 100 * c.fraction_over);
    EXPECT_GE(c.iou, 0.98) << "frame " << f;
    EXPECT_LE(c.fraction_over, 0.02) << "frame " << f;
  }
}

TEST(Animation, OtherParametersRebakeThroughTheCache) {
  const fs::path dir = temp_dir("rebake");
  AnimationOptions opt;
  opt.scene = head_twist_scene(dir);
  // Changing sign: a scale about the fixed face cannot mirror the twist, so every frame bakes.
  opt.params = {parse_animated_param("boxes[0].deformer.angle_deg=-30:30")};
  opt.frames = 3;
  opt.context = "osmesa";
  opt.output = dir / "rebake.gif";
  opt.write_frames = false;
  opt.width = opt.height = 64;
  BakeCache cache(dir / "cache");
  opt.cache = &cache;
  std::ostringstream log;
  AnimationResult r = animate(opt, log);
  EXPECT_FALSE(r.mapped);
  EXPECT_EQ(r.bakes, 3);
  // The distance grid once, a deformation texture per frame.
  EXPECT_EQ(r.textures_baked, 4) << log.str();
  EXPECT_NE(log.str().find("re-baked every frame (the angle changes sign"), std::string::npos)
      << log.str();
  EXPECT_TRUE(fs::exists(dir / "rebake.gif"));
  EXPECT_FALSE(fs::exists(dir / "rebake_0000.png"));
}

TEST(Animation, BadParametersFailBeforeAnyFrame) {
  const fs::path dir = temp_dir("bad");
  AnimationOptions opt;
  opt.scene = head_twist_scene(dir);
  opt.frames = 5;
  opt.context = "osmesa";
  opt.output = dir / "bad.png";
  auto error = [&](const std::string& param) {
    opt.params = {parse_animated_param(param)};
    try {
      animate(opt, std::cerr);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  std::string e = error("boxes[3].deformer.angle_deg=0:1");
  EXPECT_NE(e.find("boxes has no element 3"), std::string::npos) << e;
  e = error("boxes[0].deformer.type=0:1");
  EXPECT_NE(e.find("not a number"), std::string::npos) << e;
  e = error("render.width=0:100");  // frame 0 has width 0: the scene's own check names it
  EXPECT_NE(e.find("render.width"), std::string::npos) << e;
  e = error("boxes[0]..angle=0:1");
  EXPECT_NE(e.find("not a field path"), std::string::npos) << e;
  EXPECT_TRUE(fs::is_empty(dir / "") || !fs::exists(dir / "bad_0000.png"));
  opt.params.clear();
  EXPECT_THROW(animate(opt, std::cerr), Error);
}

}  // namespace
