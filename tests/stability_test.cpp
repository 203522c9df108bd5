// The stability study on three extreme cases and one missing scene: every case is measured and
// finite, a twist of 0 degrees matches the exact ground truth, a folding bend is flagged by
// raywarp's own warning, a scene that cannot be loaded is recorded as rejected rather than
// stopping the study, and the report holds one row per case.
#include "studies/stability.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "gl/context.h"

using namespace raywarp;

namespace {

const StabilityCase& find_case(const std::vector<StabilityCase>& cases, const std::string& name) {
  for (const StabilityCase& c : cases)
    if (c.name == name) return c;
  throw std::runtime_error("no case " + name);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

TEST(StabilityTest, MeasuresVerdictsAndReport) {
  static auto context = gl::create_osmesa_context();
  const std::filesystem::path dir = std::filesystem::path(RAYWARP_SOURCE_DIR) / "examples/extreme";
  const std::vector<std::filesystem::path> scenes = {dir / "angle_0.json", dir / "bend_folds.json",
                                                     dir / "box_thinner_than_voxel.json",
                                                     dir / "no_such_scene.json"};
  std::ostringstream progress;
  const std::vector<StabilityCase> cases = run_stability(scenes, 64, 2, progress);
  std::cout << progress.str();
  ASSERT_EQ(cases.size(), scenes.size());
  // One progress line per case, numbered.
  EXPECT_NE(progress.str().find("[1/4] angle_0: "), std::string::npos);
  EXPECT_NE(progress.str().find("[4/4] no_such_scene: rejected"), std::string::npos);

  for (size_t i = 0; i + 1 < cases.size(); ++i) {
    const StabilityCase& c = cases[i];
    SCOPED_TRACE(c.name);
    EXPECT_TRUE(c.failure.empty()) << c.failure;
    EXPECT_TRUE(c.textures_finite);
    EXPECT_TRUE(c.image_finite);
    EXPECT_EQ(c.nonfinite_pixels, 0);
    EXPECT_NE(c.verdict, "fails") << c.error;
    EXPECT_GT(c.frame_ms, 0.0);
    EXPECT_GE(c.worst_frame_ms, c.frame_ms);
    // Every shipped case has its row in examples/extreme/README.md.
    EXPECT_FALSE(c.stresses.empty());
  }

  const StabilityCase& flat = find_case(cases, "angle_0");
  EXPECT_EQ(flat.verdict, "pass");
  EXPECT_GE(flat.iou, 0.98);
  EXPECT_LE(flat.fraction_over, 0.02);
  EXPECT_TRUE(flat.warnings.empty());
  EXPECT_EQ(flat.error.rfind("IoU ", 0), 0u) << flat.error;

  // bend_folds shares its README row with peel_folds: both names map to the row's text.
  const StabilityCase& folds = find_case(cases, "bend_folds");
  EXPECT_NE(folds.stresses.find("fold"), std::string::npos) << folds.stresses;
  EXPECT_EQ(folds.verdict, "warns");
  bool mentions_fold = false;
  for (const std::string& w : folds.warnings)
    mentions_fold = mentions_fold || lower(w).find("fold") != std::string::npos;
  EXPECT_TRUE(mentions_fold);
  // prepare_scene logs each box warning as well; it is listed once.
  for (size_t i = 0; i < folds.warnings.size(); ++i)
    for (size_t j = i + 1; j < folds.warnings.size(); ++j)
      EXPECT_EQ(folds.warnings[i].find(folds.warnings[j]), std::string::npos);

  const StabilityCase& missing = find_case(cases, "no_such_scene");
  EXPECT_EQ(missing.verdict, "rejected");
  EXPECT_EQ(missing.failure.rfind("error: ", 0), 0u) << missing.failure;
  EXPECT_NE(missing.failure.find("no_such_scene.json"), std::string::npos);
  EXPECT_TRUE(missing.stresses.empty());

  const std::filesystem::path out = "stability_test_out/stability.md";
  std::filesystem::create_directories(out.parent_path());
  std::filesystem::remove(out);
  write_stability_report(cases, out, 64, 2, context->description());
  std::ifstream in(out);
  ASSERT_TRUE(in) << out;
  std::stringstream text;
  text << in.rdbuf();
  const std::string md = text.str();
  EXPECT_NE(md.find(context->description()), std::string::npos);
  for (const StabilityCase& c : cases) {
    int rows = 0;
    std::istringstream lines(md);
    for (std::string line; std::getline(lines, line);)
      rows += line.rfind("| ", 0) == 0 && line.find("`" + c.name + "`") != std::string::npos;
    EXPECT_EQ(rows, 1) << c.name << "\n" << md;
  }
  EXPECT_NE(md.find("4 cases: "), std::string::npos) << md;
  EXPECT_NE(md.find(" 0 fail, 1 rejected."), std::string::npos) << md;
}

}  // namespace
