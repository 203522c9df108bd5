// `raywarp study` on a small scale: the quick sweep of the shipped bunny twist at 64², its three
// files, the object-space peer's subdivision, the Pareto front, and the errors on bad input.
#include "cli/study.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "base/error.h"
#include "gl/context.h"

using namespace raywarp;
namespace fs = std::filesystem;

namespace {

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(Study, QuickSweepWritesItsFilesAndMeasuresEveryMethod) {
  static auto context = gl::create_osmesa_context();
  StudyOptions o;
  o.scenes = {fs::path(RAYWARP_SOURCE_DIR) / "examples/bunny_twist.json"};
  o.out = "study_test_out";
  fs::remove_all(o.out);
  o.size = 64;
  o.frames = 1;
  o.quick = true;
  o.machine = context->description();
  std::ostringstream progress;
  const std::vector<StudyRun> runs = run_study(o, progress);

  // linear x2, threshold, jacobian, bounded, object-space at one level.
  ASSERT_EQ(runs.size(), 6u);
  for (const StudyRun& r : runs) {
    EXPECT_EQ(r.scene, "bunny_twist");
    EXPECT_GT(r.ms, 0.0) << r.method;
    EXPECT_GE(r.iou, 0.95) << r.method << " " << r.settings;
    EXPECT_LE(r.fraction_over, 0.05) << r.method << " " << r.settings;
    EXPECT_GT(r.memory_bytes, 0u) << r.method;
  }
  EXPECT_EQ(runs.back().method, "object-space");
  EXPECT_EQ(runs.back().triangles, 3674 * 4);  // one level: four triangles each
  EXPECT_EQ(runs[4].method, "bounded");

  // The front: no run on it is beaten in both time and error by another run.
  const std::vector<size_t> front = study_front(runs);
  ASSERT_FALSE(front.empty());
  for (size_t i : front)
    for (const StudyRun& r : runs)
      EXPECT_FALSE(r.ms < runs[i].ms && r.fraction_over < runs[i].fraction_over);

  const std::string csv = read(o.out / "study.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 7);  // header + 6 rows
  EXPECT_NE(csv.find("scene,method,settings,"), std::string::npos);
  const std::string report = read(o.out / "report.md");
  EXPECT_NE(report.find("![error against frame time](pareto.png)"), std::string::npos);
  EXPECT_NE(report.find("| bunny_twist |"), std::string::npos);
  EXPECT_NE(report.find(o.machine), std::string::npos);
  EXPECT_GT(fs::file_size(o.out / "pareto.png"), 1000u);
  EXPECT_NE(progress.str().find("[1/1] bunny_twist"), std::string::npos);
}

TEST(Study, RejectsBadInputBeforeAnyWork) {
  StudyOptions o;
  o.out = "study_test_bad";
  EXPECT_THROW(run_study(o, std::cerr), Error);  // no scenes
  o.scenes = {"no_such_scene.json"};
  try {
    run_study(o, std::cerr);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_scene.json"), std::string::npos);
  }
  o.scenes = {fs::path(RAYWARP_SOURCE_DIR) / "examples/bunny_twist.json"};
  o.size = 8;
  EXPECT_THROW(run_study(o, std::cerr), Error);
  EXPECT_FALSE(fs::exists(o.out));  // nothing written
}

}  // namespace
