// The bake cache: entries read back exactly, a changed key or a damaged file is a miss, and a
// second preparation of a scene (or one with a new camera) bakes nothing.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli/pipeline.h"
#include "library/bake_cache.h"
#include "library/scene.h"

using namespace raywarp;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("raywarp_cache_test_" + name);
  fs::remove_all(dir);
  return dir;
}

TEST(BakeCache, RoundTripAndMisses) {
  const fs::path dir = temp_dir("roundtrip");
  BakeCache cache(dir);
  EXPECT_FALSE(cache.get("sdf", "key"));
  Grid3<float> g(Eigen::Vector3d(1, 2, 3), 0.5, Eigen::Vector3i(3, 4, 5), 0.f);
  for (size_t i = 0; i < g.data.size(); ++i) g.data[i] = float(i) * 0.25f;
  CacheWriter w;
  w.grid(g);
  w.text("winding");
  ASSERT_TRUE(cache.put("sdf", "key", w.bytes()));
  auto back = cache.get("sdf", "key");
  ASSERT_TRUE(back);
  CacheReader r(*back);
  Grid3<float> h;
  ASSERT_TRUE(r.grid(h, 1 << 20));
  EXPECT_EQ(r.text(), "winding");
  EXPECT_TRUE(r.ok() && r.at_end());
  EXPECT_EQ(h.data, g.data);
  EXPECT_EQ(h.dims, g.dims);
  EXPECT_EQ(h.origin, g.origin);
  // A grid larger than the reader's budget is refused, not allocated.
  CacheReader small(*back);
  EXPECT_FALSE(small.grid(h, 16));
  EXPECT_FALSE(cache.get("sdf", "other key"));
  EXPECT_FALSE(cache.get("alpha", "key"));
  EXPECT_EQ(BakeCache::contents(dir).entries, 1);

  // Damage: a flipped payload byte, then a truncated file.
  fs::path entry = fs::directory_iterator(dir)->path();
  {
    std::fstream f(entry, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-20, std::ios::end);
    f.put('\x7f');
  }
  EXPECT_FALSE(cache.get("sdf", "key"));
  fs::resize_file(entry, 10);
  EXPECT_FALSE(cache.get("sdf", "key"));
  EXPECT_EQ(BakeCache::clear(dir), 1);
  EXPECT_FALSE(fs::exists(dir));
}

PreparedScene prepare(const Scene& scene, BakeCache* cache, double* seconds) {
  std::ostringstream log;
  const auto start = std::chrono::steady_clock::now();
  PreparedScene p = prepare_scene(scene, log, cache);
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return p;
}

TEST(BakeCache, SecondPreparationBakesNothing) {
  const fs::path dir = temp_dir("scenes");
  BakeCache cache(dir);
  for (const char* name : {"bunny_twist.json", "bunny_cut_solid.json"}) {
    Scene scene = load_scene(std::string(RAYWARP_SOURCE_DIR) + "/examples/" + name);
    double first_s = 0, second_s = 0;
    PreparedScene first = prepare(scene, &cache, &first_s);
    // A new camera and new render settings change no bake.
    scene.camera.reset();
    scene.render.step_voxels = 1.0;
    scene.render.width = 64;
    PreparedScene second = prepare(scene, &cache, &second_s);
    std::printf("[figures] %s: first preparation %.3f s (%d textures baked), second %.3f s (%d)\n",
                name, first_s, first.bakes, second_s, second.bakes);
    EXPECT_GE(first.bakes, 2);
    EXPECT_EQ(second.bakes, 0);
    ASSERT_EQ(first.boxes.size(), second.boxes.size());
    const BoxTextures &a = first.boxes[0].textures, &b = second.boxes[0].textures;
    EXPECT_EQ(a.sdf.grid.data, b.sdf.grid.data);
    EXPECT_EQ(a.sdf.background, b.sdf.background);
    EXPECT_EQ(a.deformation.grid.data.size(), b.deformation.grid.data.size());
    EXPECT_TRUE(std::equal(a.deformation.grid.data.begin(), a.deformation.grid.data.end(),
                           b.deformation.grid.data.begin()));
    EXPECT_EQ(a.alpha.grid.data, b.alpha.grid.data);
    EXPECT_EQ(a.lipschitz, b.lipschitz);
    EXPECT_EQ(a.region.min(), b.region.min());
    EXPECT_EQ(first.boxes[0].texture_error, second.boxes[0].texture_error);
    EXPECT_EQ(first.boxes[0].warnings, second.boxes[0].warnings);
  }
  // A new angle re-bakes the deformation texture only.
  Scene twist = load_scene(std::string(RAYWARP_SOURCE_DIR) + "/examples/bunny_twist.json");
  twist.boxes[0].deformer.angle_deg = 200;
  double s = 0;
  EXPECT_EQ(prepare(twist, &cache, &s).bakes, 1);
  // Without a cache everything bakes.
  EXPECT_GE(prepare(twist, nullptr, &s).bakes, 2);
  BakeCache::clear(dir);
}

TEST(BakeCache, KeysNameEveryDeformerParameter) {
  BoxSpec a;
  a.deformer.type = "twist";
  const std::string base = deformer_key(a);
  auto differs = [&](auto change) {
    BoxSpec b = a;
    change(b);
    return deformer_key(b) != base;
  };
  EXPECT_TRUE(differs([](BoxSpec& b) { b.deformer.angle_deg = 1e-12; }));
  EXPECT_TRUE(differs([](BoxSpec& b) { b.deformer.axis = 0; }));
  EXPECT_TRUE(differs([](BoxSpec& b) { b.deformer.hinge = 0.5; }));
  EXPECT_TRUE(differs([](BoxSpec& b) { b.deformer.sub_max.z() = 0.5; }));
  EXPECT_TRUE(differs([](BoxSpec& b) { b.deformer.wedge_angle_deg = 5; }));
  EXPECT_TRUE(differs([](BoxSpec& b) { b.deformer.points.push_back({}); }));
  EXPECT_TRUE(differs([](BoxSpec& b) { b.deformer.pinned[3] = true; }));
  EXPECT_TRUE(differs([](BoxSpec& b) { b.deformer.influence_radius = 2; }));
  EXPECT_TRUE(differs([](BoxSpec& b) { b.then.push_back(b.deformer); }));
  EXPECT_TRUE(differs([](BoxSpec& b) { b.box.half_extents.x() = 2; }));
  EXPECT_FALSE(differs([](BoxSpec& b) { b.box.centre.x() = 2; }));  // D lives in the box frame
}

}  // namespace
