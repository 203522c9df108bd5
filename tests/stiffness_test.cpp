// `raywarp study --stiffness --quick` (studies/stiffness.h): the files it writes, their columns and
// figures, and its refusal of bad options.
#include "studies/stiffness.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "studies/stiffness_images.h"

namespace fs = std::filesystem;

namespace {

struct Result {
  int code;
  std::string output;
};

Result run(const std::string& args) {
  std::string cmd = RAYWARP_BINARY;
  cmd.append(" ").append(args).append(" 2>&1");
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), pipe)) out.append(buf.data(), n);
  int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> f;
  std::string cur;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      f.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  f.push_back(cur);
  return f;
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(StiffnessStudy, QuickRunWritesCsvChartsAndReport) {
  std::random_device rd;
  const fs::path dir = fs::temp_directory_path() / ("raywarp_stiffness_" + std::to_string(rd()));
  Result r = run("study --stiffness --quick --out " + dir.string() + " " + RAYWARP_SOURCE_DIR +
                 "/examples/bunny_simulation.json");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("stiffness ["), std::string::npos) << r.output;  // progress lines
  std::ifstream csv(dir / "stiffness.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header, raywarp::kStiffnessCsvHeader);
  const std::vector<std::string> columns = split(header);
  ASSERT_EQ(columns.size(), 13u);
  EXPECT_EQ(columns[0], "section");
  EXPECT_EQ(columns[10], "quantity");
  EXPECT_EQ(columns[11], "value");
  std::set<std::string> sections, quantities;
  double verlet_step = 0, predicted = 0;
  std::string line;
  int rows = 0;
  while (std::getline(csv, line)) {
    std::vector<std::string> f = split(line);
    ASSERT_EQ(f.size(), columns.size()) << line;
    ++rows;
    sections.insert(f[0]);
    quantities.insert(f[10]);
    if (f[0] == "stability" && f[5] == "Verlet" && f[6] == "10000" &&
        f[10] == "largest_stable_step")
      verlet_step = std::stod(f[11]);
    if (f[0] == "stability" && f[6] == "10000" && f[10] == "predicted_step")
      predicted = std::stod(f[11]);
  }
  EXPECT_GT(rows, 30);
  for (const char* s : {"stability", "amplitude", "cg", "local_global", "speed", "replay"})
    EXPECT_EQ(sections.count(s), 1u) << s;
  for (const char* q : {"omega_max", "predicted_step", "largest_stable_step", "energy_drift",
                        "amplitude_per_period", "theory_amplitude_per_period",
                        "cg_iterations_per_step", "error_vs_converged_implicit", "ms_per_step"})
    EXPECT_EQ(quantities.count(q), 1u) << q;
  // Verlet's measured limit on the bar within 5 % of 2/ω_max (the quick search's tolerance).
  ASSERT_GT(predicted, 0);
  EXPECT_NEAR(verlet_step / predicted, 1, 0.06);
  const std::string report = read(dir / "report.md");
  EXPECT_NE(report.find("Tejada & Ertl"), std::string::npos);
  EXPECT_NE(report.find("2.22 ms"), std::string::npos);
  for (const char* svg : {"stability.svg", "amplitude.svg", "solvers.svg", "images.svg"}) {
    EXPECT_NE(read(dir / svg).find("<svg"), std::string::npos) << svg;
  }

  // The image part: one stiffness, four routes against the exact ground truth of its state.
  std::ifstream images(dir / "images.csv");
  std::getline(images, header);
  EXPECT_EQ(header, raywarp::kStiffnessImagesCsvHeader);
  const std::vector<std::string> image_columns = split(header);
  ASSERT_EQ(image_columns.size(), 20u);
  EXPECT_EQ(image_columns[7], "iou");
  EXPECT_EQ(image_columns[8], "over_1pct_percent");
  std::set<std::string> routes;
  while (std::getline(images, line)) {
    std::vector<std::string> f = split(line);
    ASSERT_EQ(f.size(), image_columns.size()) << line;
    routes.insert(f[1]);
    EXPECT_EQ(f[0], "30000") << line;
    EXPECT_GT(std::stod(f[5]), 0.5) << line;  // the drag moved the body
    // Image space within the foundation's thresholds; object space measured against the same
    // truth (its error is the mapping's own, recorded, with a loose bound).
    EXPECT_GT(std::stod(f[17]), 0) << line;  // GPU memory
    if (f[1] == "image space" || f[1] == "tet walk (surface)") {
      EXPECT_GE(std::stod(f[7]), 0.98) << line;
      EXPECT_LE(std::stod(f[8]), 2.0) << line;
      if (f[1] == "image space")
        EXPECT_GT(std::stod(f[13]), 0) << line;  // D texels
      else
        EXPECT_GT(std::stod(f[18]), 0) << line;  // tetrahedra
    } else {
      EXPECT_GE(std::stod(f[7]), 0.9) << line;
      EXPECT_GE(std::stod(f[11]), 0) << line;  // vertex error
    }
    EXPECT_GT(std::stod(f[10]), 0) << line;  // frame ms
  }
  EXPECT_EQ(routes, (std::set<std::string>{"image space", "object space (triangle)",
                                           "object space (interpolated)", "tet walk (surface)"}));
  for (const char* png :
       {"ks_30000_image.png", "ks_30000_object.png", "ks_30000_tets.png", "ks_30000_truth.png"})
    EXPECT_TRUE(fs::exists(dir / "images" / png)) << png;
  EXPECT_NE(report.find("Images against ks"), std::string::npos);
  fs::remove_all(dir);
}

TEST(StiffnessStudy, BadOptionsExitTwo) {
  Result r = run("study --stiffness --quick");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--out"), std::string::npos) << r.output;
  r = run("study --stiffness --stability --out /tmp/x");
  EXPECT_EQ(r.code, 2) << r.output;
  r = run("study --stiffness --quick --out /tmp/x a.json b.json");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("at most one scene"), std::string::npos) << r.output;
}

}  // namespace
