// Named after no one source: it runs cli/simulate.h's command through the binary.
// `raywarp simulate` (cli/simulate.h): the run's states rendered as a sequence, through the real
// binary; its refusals exit with status 2 and name the scene.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

namespace fs = std::filesystem;

namespace {

struct Result {
  int code;
  std::string output;
};

Result run(const std::string& args) {
  const std::string cmd = std::string(RAYWARP_BINARY) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), pipe)) out.append(buf.data(), n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

class SimulateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir = fs::temp_directory_path() / ("raywarp_simulate_" + std::to_string(rd()));
    fs::create_directories(dir);
    // The bunny's head in a coarse body: 6 steps, a frame every 3.
    std::ofstream(dir / "sim.json")
        << R"({"mesh": ")" << RAYWARP_SOURCE_DIR << R"(/examples/meshes/bunny.ply",
      "boxes": [{"min": [-5.2, 4, -4], "max": [5.2, 9.9, 4],
        "implicit": {"type": "sdf", "resolution": 48}, "deformation": {"resolution": 24},
        "deformer": {"type": "simulation", "resolution": 6, "ks": 3e4, "density": 100,
                     "steps": 6, "drags": [{"sub_min": [0, 0.8, 0],
                     "path": [{"t": 0.06, "offset": [1, 0, 0]}]}]}}],
      "camera": ")"
        << RAYWARP_SOURCE_DIR << R"(/examples/cameras/front.json",
      "render": {"width": 48, "height": 48}})";
  }
  void TearDown() override { fs::remove_all(dir); }
  fs::path dir;
};

TEST_F(SimulateCli, RendersEveryKthState) {
  const Result r = run("simulate " + (dir / "sim.json").string() + " -o " +
                       (dir / "out" / "f.png").string() + " --every 3 --no-cache");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir / "out" / "f_0000.png"));
  EXPECT_TRUE(fs::exists(dir / "out" / "f_0001.png"));
  EXPECT_FALSE(fs::exists(dir / "out" / "f_0002.png"));
  EXPECT_GT(fs::file_size(dir / "out" / "f.gif"), 100u);
  EXPECT_NE(r.output.find("frame 2/2: step 6"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("simulation runs: 1 for 2 frames"), std::string::npos) << r.output;
}

TEST_F(SimulateCli, RefusesASceneWithoutSimulation) {
  std::ofstream(dir / "twist.json")
      << R"({"mesh": ")" << RAYWARP_SOURCE_DIR << R"(/examples/meshes/bunny.ply",
      "boxes": [{"min": [-5, 4, -4], "max": [5, 9.9, 4],
                 "deformer": {"type": "twist", "axis": "y", "angle_deg": 90}}]})";
  const Result r =
      run("simulate " + (dir / "twist.json").string() + " -o " + (dir / "f.png").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("twist.json: boxes: no box has a \"simulation\" deformer"),
            std::string::npos)
      << r.output;
  const Result help = run("simulate --help");
  EXPECT_EQ(help.code, 0);
  EXPECT_NE(help.output.find("--every"), std::string::npos);
}

}  // namespace
