// Named after no one source: an image test across the bake, the renderer and the references.
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
#include "library/prepare.h"
#include "library/scene.h"
#include "verify/reference.h"

using namespace raywarp;
namespace fs = std::filesystem;
using nlohmann::json;

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

// The peel of examples/bunny_peel.json progressing (its hinge from the box's +a end to the
// example's): one bake at the lowest hinge, each frame read through a translation M. Each checked
// frame against the peel baked at that frame's own hinge, ray cast by the CPU reference in double
// (independent of M and of GL).
TEST(Animation, PeelHingeBakesOnceAndMatchesEachFramesOwnBake) {
  const fs::path dir = temp_dir("peel");
  json example = read_scene_document(kRoot + "/examples/bunny_peel.json");
  for (const char* key : {"mesh", "camera"})
    example[key] = kRoot + "/examples/" + example[key].get<std::string>();
  AnimationOptions opt;
  opt.scene = dir / "peel.json";
  std::ofstream(opt.scene) << example.dump();
  opt.params = {parse_animated_param("boxes[0].deformer.hinge=1.8:-1.7")};
  opt.frames = 60;
  opt.context = "osmesa";
  opt.output = dir / "peel.png";
  opt.write_frames = false;
  opt.width = opt.height = 128;
  std::ostringstream log;
  AnimationResult r = animate(opt, log);
  EXPECT_TRUE(r.mapped) << log.str();
  EXPECT_EQ(r.bakes, 1) << log.str();
  EXPECT_NE(log.str().find("a translation along the peel direction"), std::string::npos)
      << log.str();
  ASSERT_EQ(r.images.size(), 60u);

  const json document = read_scene_document(opt.scene);
  const Camera camera = *load_scene(opt.scene).camera;
  for (int f : {0, 17, 35, 52}) {
    const json doc = document_at(document, opt.params, f, opt.frames, opt.scene);
    const Scene scene = load_scene_json(doc, opt.scene);
    std::ostringstream bake_log;
    const PreparedScene own = prepare_scene(scene, bake_log);
    const Image cpu = reference_render(own.mesh(), own.textures(), camera, 128, 128, scene.render);
    const double diagonal = mesh_bounds(own.mesh()).diagonal().norm();
    const ImageComparison c = compare_images(r.images[f], cpu, 0.01 * diagonal);
    std::printf(
        "[figures] mapped peel frame %d (hinge %.3f): against its own bake (CPU reference) IoU "
        "%.4f, over 1%% of diag %.2f%%\n",
        f, scene.boxes[0].deformer.hinge, c.iou, 100 * c.fraction_over);
    EXPECT_GE(c.iou, 0.98) << "frame " << f;
    EXPECT_LE(c.fraction_over, 0.02) << "frame " << f;
    // The flap is a small part of the image: the pixels whose colour differs (by more than
    // 48/255 in a channel) from its own bake must be few, and far fewer than those from the
    // fully peeled last frame (which a wrong M would show).
    auto differing = [](const Image& a, const Image& b) {
      long n = 0;
      for (size_t i = 0; i < a.rgba.size(); i += 4)
        for (int k = 0; k < 3; ++k)
          if (std::abs(int(a.rgba[i + k]) - int(b.rgba[i + k])) > 48) {
            ++n;
            break;
          }
      return n;
    };
    const long own_diff = differing(r.images[f], cpu), last_diff = differing(r.images[59], cpu);
    std::printf(
        "[figures] mapped peel frame %d: %ld pixels differ from its own bake, %ld from the "
        "last frame\n",
        f, own_diff, last_diff);
    EXPECT_LE(own_diff, 128 * 128 / 200) << "frame " << f;
    if (f < 52) {
      EXPECT_LT(4 * own_diff, last_diff) << "frame " << f;
    }
  }
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
