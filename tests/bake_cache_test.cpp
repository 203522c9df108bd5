// The bake cache (library/bake_cache.h): entries read back exactly, a changed key or a damaged file
// is a miss, and a second preparation of a scene (or one with a new camera) bakes nothing.
#include "library/bake_cache.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "library/prepare.h"
#include "library/scene.h"
#include "tests/sanitizer.h"

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
    // Small grids: what the cache keeps does not depend on the sizes (testing::kSmallGrid).
    for (BoxSpec& box : scene.boxes) {
      box.implicit.resolution = std::max(32, raywarp::testing::kSmallGrid);
      box.deformation_resolution = raywarp::testing::kSmallGrid;
      box.alpha_resolution = raywarp::testing::kSmallGrid;
    }
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
    EXPECT_EQ(first.boxes[0].report.texture_error, second.boxes[0].report.texture_error);
    EXPECT_EQ(first.boxes[0].report.warning_messages(), second.boxes[0].report.warning_messages());
  }
  // A new angle re-bakes the deformation texture only.
  Scene twist = load_scene(std::string(RAYWARP_SOURCE_DIR) + "/examples/bunny_twist.json");
  twist.boxes[0].implicit.resolution = std::max(32, raywarp::testing::kSmallGrid);  // as above
  twist.boxes[0].deformation_resolution = raywarp::testing::kSmallGrid;
  twist.boxes[0].deformer.angle_deg = 200;
  double s = 0;
  EXPECT_EQ(prepare(twist, &cache, &s).bakes, 1);
  // Without a cache everything bakes.
  EXPECT_GE(prepare(twist, nullptr, &s).bakes, 2);
  BakeCache::clear(dir);
}

// Every declared parameter of every registered type enters the key: changing any one of them (as
// a scene would) changes it, so a new parameter cannot serve a stale bake.
TEST(BakeCache, KeysNameEveryDeformerParameter) {
  auto changed = [](const ParamDecl& p, DeformerSpec& d) {
    switch (p.kind) {
      case ParamKind::Number:
        d.*std::get<double DeformerSpec::*>(p.field) += 1e-12;
        break;
      case ParamKind::Axis: {
        int& a = d.*std::get<int DeformerSpec::*>(p.field);
        a = (a + 1) % 3;
        break;
      }
      case ParamKind::Face:
        d.from_side = -d.from_side;
        break;
      case ParamKind::Fractions:
        (d.*std::get<Eigen::Vector3d DeformerSpec::*>(p.field)).z() = 0.5;
        break;
      case ParamKind::Faces:
        d.pinned[3] = !d.pinned[3];
        break;
      case ParamKind::Points:
        d.points.push_back({});
        break;
      case ParamKind::Choice: {
        int& c = d.*std::get<int DeformerSpec::*>(p.field);
        c = (c + 1) % static_cast<int>(p.choices.size());
        break;
      }
      case ParamKind::Direction:
        (d.*std::get<Eigen::Vector3d DeformerSpec::*>(p.field)).x() += 1e-12;
        break;
      case ParamKind::Drags:
        d.drags.push_back({});
        break;
      case ParamKind::Group:
        break;
      case ParamKind::File:
        d.*std::get<std::string DeformerSpec::*>(p.field) += "_other";
        break;
    }
  };
  int checked = 0;
  for (const DeformerType& type : deformer_types()) {
    BoxSpec a;
    a.deformer.type = type.name;
    const std::string base = deformer_key(a);
    std::vector<const ParamDecl*> params;
    for (const ParamDecl& p : type.params) {
      params.push_back(&p);
      for (const ParamDecl& c : p.children) params.push_back(&c);
    }
    for (const ParamDecl* p : params) {
      if (p->kind == ParamKind::Group) continue;
      BoxSpec b = a;
      changed(*p, b.deformer);
      EXPECT_NE(deformer_key(b), base) << type.name << "." << p->key;
      ++checked;
    }
    BoxSpec longer = a;
    longer.then.push_back(a.deformer);
    EXPECT_NE(deformer_key(longer), base);
    BoxSpec wider = a;
    wider.box.half_extents.x() = 2;
    EXPECT_NE(deformer_key(wider), base);
    BoxSpec moved = a;
    moved.box.centre.x() = 2;
    EXPECT_EQ(deformer_key(moved), base);  // D lives in the box frame
  }
  EXPECT_GE(checked, 20);
}

}  // namespace
