// The library API the front ends use (library/bake.h): one box baked by a job, a distance-grid
// bake cancelled mid-way (no cache entry, no file, back within 100 ms), re-bake by stage, and
// every figure read from the BakeReport.
#include "library/bake.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <thread>

#include "library/scene.h"
#include "library/winding.h"
#include "tests/sanitizer.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;

Scene example(const std::string& name) {
  return load_scene(std::string(RAYWARP_SOURCE_DIR) + "/examples/" + name);
}

// The example with small grids (testing::kSmallGrid texels: 64, 24 under the sanitizers): what a
// cancel or a cache read does depends on the stages, not on their sizes.
Scene small_example(const std::string& name) {
  Scene scene = example(name);
  for (BoxSpec& box : scene.boxes) {
    box.implicit.resolution = std::max(32, raywarp::testing::kSmallGrid);
    box.deformation_resolution = raywarp::testing::kSmallGrid;
    box.alpha_resolution = raywarp::testing::kSmallGrid;
  }
  return scene;
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("raywarp_bake_job_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

long files_in(const fs::path& dir) {
  long n = 0;
  if (fs::exists(dir))
    for (const auto& e : fs::recursive_directory_iterator(dir)) n += e.is_regular_file();
  return n;
}

TEST(BakeJob, BakesOneBoxAndReportsEveryFigure) {
  const Scene scene = example("bunny_twist.json");
  BakeSession session;
  const MeshPtr mesh = session.mesh(scene.mesh);
  EXPECT_EQ(session.mesh(scene.mesh), mesh);  // loaded and hashed once
  EXPECT_GT(mesh->stats.faces, 1000);
  EXPECT_EQ(mesh->hash.size(), 16u);

  std::vector<std::string> stages;
  Interrupter progress(
      [&](const std::string& stage, double) {
        if (stages.empty() || stages.back() != stage) stages.push_back(stage);
      },
      0.0);
  const BakedBox box = session.bake(make_job(scene, 0, mesh), &progress);
  EXPECT_GT(progress.polls(), 20);
  EXPECT_NE(std::find(stages.begin(), stages.end(), "distance"), stages.end());
  EXPECT_NE(std::find(stages.begin(), stages.end(), "deformation texture"), stages.end());

  const BakeReport& r = box.report;
  EXPECT_EQ(r.deformer, "twist about y by 360\u00b0");
  EXPECT_EQ(r.parameters, "twist: axis y, angle_deg 360");
  const StageReport* sdf = r.stage(Stage::DistanceGrid);
  const StageReport* def = r.stage(Stage::Deformation);
  ASSERT_TRUE(sdf && def);
  EXPECT_EQ(r.stage(Stage::Alpha), nullptr);  // no cut
  EXPECT_EQ(sdf->source, Source::Baked);
  EXPECT_EQ(sdf->resolution, box.textures.sdf.grid.dims);
  EXPECT_EQ(sdf->bytes, box.textures.sdf.grid.size() * 4);
  EXPECT_GT(sdf->seconds, 0.0);
  EXPECT_EQ(sdf->spacing, box.textures.sdf.grid.spacing);
  EXPECT_EQ(def->resolution, box.textures.deformation.grid.dims);
  // The automatic layout: at least the cubic floor's texels, an error within its target.
  EXPECT_EQ(scene.boxes[0].deformation_resolution, kAutoResolution);
  EXPECT_GE(def->resolution.maxCoeff(), kAutoFloorResolution);
  EXPECT_TRUE(r.deformation_choice.automatic);
  EXPECT_GE(r.deformation_choice.bakes, 1);
  EXPECT_DOUBLE_EQ(r.deformation_choice.target, kAutoErrorVoxels * r.voxel);
  EXPECT_LE(r.texture_error, r.deformation_choice.target);
  EXPECT_LE(def->bytes, r.deformation_choice.budget_bytes);
  EXPECT_EQ(def->bytes, box.textures.deformation.grid.size() * 16);
  EXPECT_DOUBLE_EQ(r.voxel, sdf->spacing.x());
  EXPECT_GT(r.active_voxels, 1000);
  EXPECT_FALSE(r.sign_method.empty());
  EXPECT_GT(r.lipschitz, 1.0);
  EXPECT_TRUE(std::isfinite(r.lipschitz));
  EXPECT_GT(r.texture_error, 0.0);
  EXPECT_LT(r.texture_error_voxels(), 1.0);
  EXPECT_GT(r.residual.texels, 1000);
  EXPECT_EQ(r.residual.over_tolerance, 0);
  EXPECT_FALSE(r.folds.folds());
  EXPECT_GT(r.folds.box_volume, 0.0);
  EXPECT_TRUE(r.warnings.empty());
  std::printf(
      "[figures] bunny twist job: grid %dx%dx%d (%.1f MiB, %.2f s), D %dx%dx%d (%.1f MiB, %.2f s), "
      "|I + J_D| <= %.3g, texture error %.3g voxels, residual max %.3g\n",
      sdf->resolution.x(), sdf->resolution.y(), sdf->resolution.z(), sdf->bytes / 1048576.0,
      sdf->seconds, def->resolution.x(), def->resolution.y(), def->resolution.z(),
      def->bytes / 1048576.0, def->seconds, r.lipschitz, r.texture_error_voxels(), r.residual.max);
}

TEST(BakeJob, ChangingTheAngleRebakesOnlyTheDeformationTexture) {
  Scene scene = small_example("bunny_twist.json");
  const fs::path dir = fresh_dir("stages");
  BakeCache cache(dir);
  BakeSession session(&cache);
  const MeshPtr mesh = session.mesh(scene.mesh);
  session.bake(make_job(scene, 0, mesh));
  EXPECT_EQ(session.counters().distance_grid, 1);
  EXPECT_EQ(session.counters().deformation, 1);

  scene.boxes[0].deformer.angle_deg = 200;
  const BakedBox second = session.bake(make_job(scene, 0, mesh));
  EXPECT_EQ(session.counters().distance_grid, 1);  // from memory
  EXPECT_EQ(session.counters().deformation, 2);
  EXPECT_EQ(second.report.stage(Stage::DistanceGrid)->source, Source::Memory);
  EXPECT_EQ(second.report.stage(Stage::Deformation)->source, Source::Baked);

  // The same job again bakes nothing; a new session reads both stages from the disk cache.
  session.bake(make_job(scene, 0, mesh));
  EXPECT_EQ(session.counters().baked(), 3);
  BakeSession later(&cache);
  const BakedBox again = later.bake(make_job(scene, 0, later.mesh(scene.mesh)));
  EXPECT_EQ(later.counters().baked(), 0);
  EXPECT_EQ(later.counters().disk_hits, 2);
  EXPECT_EQ(again.report.stage(Stage::DistanceGrid)->source, Source::Disk);
  EXPECT_EQ(again.textures.deformation.grid.data, second.textures.deformation.grid.data);
  fs::remove_all(dir);
}

// A distance grid big enough to take a while (the dragon at 384^3), cancelled from another
// thread once its bake is under way: the bake throws Cancelled promptly, stores nothing, and the
// session bakes the next job at once.
TEST(BakeJob, CancelledDistanceGridLeavesNothingBehind) {
  const fs::path dragon = fs::path(RAYWARP_DATA_DIR) / "dragon_res2.ply";
  if (!fs::exists(dragon)) GTEST_SKIP() << "no " << dragon;
  Scene scene = example("study/dragon_twist.json");
  scene.mesh = dragon;
  scene.boxes[0].implicit.resolution = 384;
  const fs::path dir = fresh_dir("cancel");
  BakeCache cache(dir);
  BakeSession session(&cache);
  const MeshPtr mesh = session.mesh(scene.mesh);

  std::atomic<bool> started{false};
  Interrupter interrupter([&](const std::string&, double) { started = true; }, 0.0);
  std::chrono::steady_clock::time_point cancelled_at, returned_at;
  std::thread canceller([&] {
    while (!started) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    cancelled_at = std::chrono::steady_clock::now();
    interrupter.cancel();
  });
  bool threw = false;
  try {
    session.bake(make_job(scene, 0, mesh), &interrupter);
  } catch (const Cancelled&) {
    threw = true;
  }
  returned_at = std::chrono::steady_clock::now();
  canceller.join();
  ASSERT_TRUE(threw) << "the bake finished before it was cancelled";
  const double ms = std::chrono::duration<double, std::milli>(returned_at - cancelled_at).count();
  std::printf("[figures] distance grid 384^3 of the dragon: cancel returned after %.1f ms\n", ms);
#if RAYWARP_UNDER_SANITIZER
  EXPECT_LT(ms, 1000.0);  // the sanitizers slow every poll's chunk of work several-fold
#else
  EXPECT_LT(ms, 100.0);
#endif
  EXPECT_EQ(session.counters().baked(), 0);
  EXPECT_EQ(session.memory_bytes(), 0u);
  EXPECT_EQ(files_in(dir), 0);  // no cache entry, no temporary file

  // The next job starts at once and completes.
  scene.boxes[0].implicit.resolution = 64;
  scene.boxes[0].deformation_resolution = raywarp::testing::kSmallGrid;
  const BakedBox next = session.bake(make_job(scene, 0, mesh));
  EXPECT_EQ(session.counters().distance_grid, 1);
  EXPECT_EQ(next.report.stage(Stage::DistanceGrid)->resolution.maxCoeff(), 64 + 4);
  EXPECT_GE(files_in(dir), 2);
  fs::remove_all(dir);
}

// Every stage of a bake polls: cancelled as soon as it reports, each throws Cancelled within
// 100 ms and leaves nothing in the session.
TEST(BakeJob, EveryStageCancelsPromptly) {
  struct Case {
    std::string scene, stage;
    std::function<void(Scene&)> edit;
    long before = 0;  // stages that finish before the cancelled one
  };
  const std::vector<Case> cases = {
      {"bunny_twist.json", "distance", [](Scene&) {}},
      {"bunny_twist.json", "sign", [](Scene&) {}},
      {"bunny_twist.json", "deformation texture",
       [](Scene& s) { s.boxes[0].deformation_resolution = 256; }, 1},
      // A stage is cancelled at its first poll, so the stages before it run at the defaults
      // (a 256 texture there only lengthened the run, most under the sanitizers).
      {"bunny_twist.json", "deformation texture: error", [](Scene&) {}, 1},
      {"bunny_twist.json", "deformation texture: inverse residual", [](Scene&) {}, 1},
      {"bunny_twist.json", "folds", [](Scene&) {}, 1},
      {"bunny_control_points.json", "deformation texture",
       [](Scene& s) { s.boxes[0].deformation_resolution = 128; }, 1},
      {"bunny_peel.json", "alpha map", [](Scene& s) { s.boxes[0].alpha_resolution = 256; }, 2},
      {"bunny_twist.json", "step bounds", [](Scene& s) { s.render.sampling = Sampling::Bounded; },
       2},
      {"bunny_twist.json", "depth cube",
       [](Scene& s) {
         s.boxes[0].implicit.type = "depth_cube";
         s.boxes[0].implicit.resolution = 2048;
       }},
  };
  for (const Case& c : cases) {
    Scene scene = small_example(c.scene);
    c.edit(scene);
    BakeSession session;
    const MeshPtr mesh = session.mesh(scene.mesh);
    std::chrono::steady_clock::time_point cancelled_at{};
    Interrupter* self = nullptr;
    Interrupter interrupter(
        [&](const std::string& stage, double) {
          if (stage == c.stage && !self->cancelled()) {
            cancelled_at = std::chrono::steady_clock::now();
            self->cancel();
          }
        },
        0.0);
    self = &interrupter;
    bool threw = false;
    try {
      session.bake(make_job(scene, 0, mesh), &interrupter);
    } catch (const Cancelled&) {
      threw = true;
    }
    const auto returned_at = std::chrono::steady_clock::now();
    ASSERT_TRUE(threw) << c.scene << ": stage \"" << c.stage << "\" never reported";
    const double ms = std::chrono::duration<double, std::milli>(returned_at - cancelled_at).count();
    std::printf("[figures] %s, cancelled in \"%s\": returned after %.2f ms\n", c.scene.c_str(),
                c.stage.c_str(), ms);
#if RAYWARP_UNDER_SANITIZER
    EXPECT_LT(ms, 1000.0) << c.stage;
#else
    EXPECT_LT(ms, 100.0) << c.stage;
#endif
    // What finished before the cancel stays; the cancelled stage left nothing.
    EXPECT_EQ(session.counters().baked(), c.before) << c.stage;
    if (c.before == 0) {
      EXPECT_EQ(session.memory_bytes(), 0u) << c.stage;
    }
  }
}

TEST(BakeJob, CutReportsItsAlphaStageAndWarningsAreCoded) {
  const Scene scene = example("bunny_peel.json");
  BakeSession session;
  const BakedBox box = session.bake(make_job(scene, 0, session.mesh(scene.mesh)));
  const StageReport* alpha = box.report.stage(Stage::Alpha);
  ASSERT_NE(alpha, nullptr);
  EXPECT_EQ(alpha->resolution, box.textures.alpha.grid.dims);
  // The automatic layout: from the cubic floor up, within its target and budget.
  const BakeReport& r = box.report;
  EXPECT_GE(alpha->resolution.maxCoeff(), kAutoAlphaFloorResolution);
  EXPECT_TRUE(r.alpha_choice.automatic);
  EXPECT_LE(r.alpha_error, r.alpha_choice.target);
  EXPECT_DOUBLE_EQ(r.alpha_choice.target, kAutoErrorVoxels * r.voxel);
  EXPECT_LE(alpha->bytes, r.alpha_choice.budget_bytes);
  // An explicit resolution wins, and its error is measured too.
  Scene fixed = scene;
  fixed.boxes[0].alpha_resolution = 64;
  const BakedBox f = session.bake(make_job(fixed, 0, session.mesh(scene.mesh)));
  EXPECT_EQ(f.report.stage(Stage::Alpha)->resolution.maxCoeff(), 64);
  EXPECT_FALSE(f.report.alpha_choice.automatic);
  EXPECT_GT(f.report.alpha_error, 0.0);
  for (const BakeWarning& w : box.report.warnings) {
    EXPECT_FALSE(w.code.empty());
    EXPECT_FALSE(w.message.empty());
  }
}

bool has_warning(const BakeReport& r, const std::string& code) {
  for (const BakeWarning& w : r.warnings)
    if (w.code == code) return true;
  return false;
}

// A box beside the mesh deforms nothing and says so; one inside the mesh (no triangle in it)
// holds the mesh's inside, and one the surface crosses holds the surface.
TEST(BakeJob, ABoxThatHoldsNoPartOfTheMeshWarns) {
  Scene scene = example("bunny_cut_solid.json");
  BakeSession session;
  const MeshPtr mesh = session.mesh(scene.mesh);
  const Eigen::AlignedBox3d bounds = mesh->stats.bounds;
  Box beside;
  beside.half_extents = 0.1 * bounds.sizes();
  beside.centre = bounds.max() + 0.5 * bounds.sizes();
  EXPECT_FALSE(box_holds_mesh(mesh->mesh, beside));
  scene.boxes[0].box = beside;
  scene.boxes[0].implicit.resolution = 16;
  EXPECT_TRUE(has_warning(session.bake(make_job(scene, 0, mesh)).report, "empty_box"));

  Box crossing = beside;
  crossing.centre = bounds.center();
  crossing.half_extents = 0.6 * bounds.sizes();
  EXPECT_TRUE(box_holds_mesh(mesh->mesh, crossing));
  // A small box around a point well inside the bunny's body (winding number 1 there).
  Box inside;
  inside.centre = mesh->mesh.V.colwise().mean().transpose();
  inside.half_extents = Eigen::Vector3d::Constant(1e-4 * bounds.diagonal().norm());
  ASSERT_GT(WindingNumber(mesh->mesh).exact(inside.centre), 0.5);
  EXPECT_TRUE(box_holds_mesh(mesh->mesh, inside));
}

TEST(BakeJob, ErrorsNameTheBox) {
  Scene scene = example("bunny_twist.json");
  scene.boxes[0].deformer.type = "stretch";
  scene.boxes[0].deformer.factor = 50;  // beyond what a 5.8-unit box allows
  BakeSession session;
  try {
    session.bake(make_job(scene, 0, session.mesh(scene.mesh)));
    FAIL() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("boxes[0].deformer.stretch factor = 50"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace raywarp
