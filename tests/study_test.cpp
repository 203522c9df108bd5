// `raywarp study` on a small scale: the quick sweep of the shipped bunny twist at 64², its three
// files, the object-space peer's subdivision, the Pareto front, the chart drawn again from a
// study.csv, and the errors on bad input.
#include "studies/study.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

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

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
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
  // Every row has the header's fields (commas outside quotes).
  std::vector<size_t> fields;
  bool quoted = false;
  size_t n = 1;
  for (char c : csv) {
    if (c == '"') quoted = !quoted;
    if (c == ',' && !quoted) ++n;
    if (c == '\n') fields.push_back(n), n = 1;
  }
  for (size_t row = 1; row < fields.size(); ++row) EXPECT_EQ(fields[row], fields[0]) << row;
  const std::string report = read(o.out / "report.md");
  EXPECT_NE(report.find("![error against frame time](pareto.svg)"), std::string::npos);
  EXPECT_NE(report.find("| bunny_twist |"), std::string::npos);
  EXPECT_NE(report.find(o.machine), std::string::npos);
  const std::string svg = read(o.out / "pareto.svg");
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_EQ(count(svg, "<g class=\"panel\">"), 1u);
  EXPECT_EQ(count(svg, "<circle class=\"point\""), runs.size());
  EXPECT_EQ(count(svg, "<circle class=\"front-point\""), front.size());
  EXPECT_NE(progress.str().find("[1/1] bunny_twist"), std::string::npos);
}

// The chart drawn again from a study.csv: the shipped study's (docs/study), whose pareto.svg is
// written this way. A copy lands in the working directory, study_chart_from_docs.svg.
TEST(Study, ChartFromTheShippedCsv) {
  const fs::path csv = fs::path(RAYWARP_SOURCE_DIR) / "docs/study/study.csv";
  const fs::path svg = "study_chart_from_docs.svg";
  write_study_chart_from_csv(csv, svg);
  const std::string text = read(svg);
  const std::string rows = read(csv);
  const size_t runs = static_cast<size_t>(std::count(rows.begin(), rows.end(), '\n')) - 1;
  std::set<std::string> scenes;  // the first column of every row after the header
  for (size_t at = rows.find('\n') + 1; at < rows.size(); at = rows.find('\n', at) + 1)
    scenes.insert(rows.substr(at, rows.find(',', at) - at));
  EXPECT_GE(scenes.size(), 8u);
  EXPECT_EQ(count(text, "<g class=\"panel\">"), scenes.size());  // one per scene
  EXPECT_EQ(count(text, "<circle class=\"point\""), runs);
  EXPECT_GT(count(text, "<circle class=\"front-point\""), 8u);
  EXPECT_NE(text.find(">bunny_twist</text>"), std::string::npos);
  EXPECT_EQ(text.find("left out"), std::string::npos);

  const fs::path dir = "study_test_csv";
  fs::create_directories(dir);
  auto fails = [&](const std::string& contents, const std::string& message) {
    std::ofstream(dir / "s.csv") << contents;
    try {
      write_study_chart_from_csv(dir / "s.csv", dir / "s.svg");
      ADD_FAILURE() << "expected an error for " << contents;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  fails("", "empty");
  fails("scene,method,fraction_over\n", "no column 'ms'");
  fails("scene,method,ms,fraction_over\na,linear,1\n", "record 2: 3 fields");
  fails("scene,method,ms,fraction_over\na,linear,fast,0\n", "ms 'fast': not a number");
  EXPECT_THROW(write_study_chart_from_csv(dir / "none.csv", dir / "s.svg"), Error);
  // Quoted fields, a blank line, columns in any order.
  std::ofstream(dir / "s.csv") << "fraction_over,\"settings\",ms,scene,method\n"
                               << "0.001,\"step 1, \"\"a\"\"\",10,\"x, y\",linear\n\n";
  write_study_chart_from_csv(dir / "s.csv", dir / "s.svg");
  const std::string one = read(dir / "s.svg");
  EXPECT_EQ(count(one, "<circle class=\"point\""), 1u);
  EXPECT_NE(one.find(">x, y</text>"), std::string::npos);
  fs::remove_all(dir);
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
