// Named after no one source: it runs the raywarp binary as a user does, every command.
// The `raywarp` command on bad input: each case must exit non-zero, print a message naming
// the file, the field and what is allowed, and leave no output file behind.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "library/image.h"

namespace fs = std::filesystem;

namespace {

struct Result {
  int code;
  std::string output;
};

Result run(const std::string& args) {
  std::string cmd = std::string(RAYWARP_BINARY) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), pipe)) out.append(buf.data(), n);
  int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir = fs::temp_directory_path() / ("raywarp_cli_" + std::to_string(rd()));
    fs::create_directories(dir);
    // A small closed mesh: an octahedron.
    std::ofstream(dir / "m.obj")
        << "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
           "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";
    std::ofstream(dir / "cam.json")
        << R"({"eye": [0, 0, 5], "target": [0, 0, 0], "fov_y_deg": 40, "width": 32, "height": 32})";
  }
  void TearDown() override { fs::remove_all(dir); }

  // Writes a scene whose box and deformer parts can be replaced, renders it, and checks the
  // failure.
  void expect_failure(const std::string& scene_text, const std::string& extra_args,
                      const std::vector<std::string>& needles) {
    std::ofstream(dir / "s.json") << scene_text;
    fs::path out = dir / "out.png";
    Result r = run((dir / "s.json").string() + " -o " + out.string() + " " + extra_args);
    EXPECT_EQ(r.code, 2) << r.output;
    for (const auto& n : needles)
      EXPECT_NE(r.output.find(n), std::string::npos) << "missing '" << n << "' in: " << r.output;
    EXPECT_FALSE(fs::exists(out)) << "an output file was left behind";
    for (const auto& e : fs::directory_iterator(dir))
      EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  }

  Result run(const std::string& args) { return ::run("render " + args); }

  static std::string scene(
      const std::string& box = R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
      const std::string& deformer = R"({"type": "twist", "axis": "y", "angle_deg": 90})",
      const std::string& rest = R"("camera": "cam.json")", const std::string& mesh = "m.obj") {
    return R"({"mesh": ")" + mesh + R"(", "boxes": [{)" + box + R"(, "deformer": )" + deformer +
           R"(, "implicit": {"resolution": 16}, "deformation": {"resolution": 16}}], )" + rest +
           "}";
  }
  fs::path dir;
};

TEST_F(CliTest, HelpListsOptions) {
  Result r = ::run("--help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("render"), std::string::npos);
  r = ::run("render --help");
  EXPECT_EQ(r.code, 0);
  for (const char* opt : {"--depth", "--mask", "--camera", "--width", "--height", "--output"})
    EXPECT_NE(r.output.find(opt), std::string::npos) << opt;
}

TEST_F(CliTest, StudyHelpAndBadInput) {
  Result r = ::run("study --help");
  EXPECT_EQ(r.code, 0);
  for (const char* opt : {"--out", "--size", "--frames", "--stability", "--quick", "--context"})
    EXPECT_NE(r.output.find(opt), std::string::npos) << opt;
  std::ofstream(dir / "s.json") << scene();
  r = ::run("study " + (dir / "s.json").string());  // no --out
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--out DIR: required"), std::string::npos) << r.output;
  r = ::run("study " + (dir / "none.json").string() + " --out " + (dir / "study").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("none.json"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "study"));
}

TEST_F(CliTest, StudyQuickWritesItsThreeFiles) {
  std::ofstream(dir / "s.json") << scene();
  const fs::path out = dir / "study";
  Result r = ::run("study " + (dir / "s.json").string() + " --out " + out.string() +
                   " --quick --size 32 --frames 1 --context osmesa");
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* f : {"study.csv", "pareto.svg", "report.md"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  EXPECT_NE(r.output.find("[1/1] s:"), std::string::npos) << r.output;
}

TEST_F(CliTest, ValidSceneRendersAllOutputs) {
  std::ofstream(dir / "s.json") << scene();
  Result r = run((dir / "s.json").string() + " -o " + (dir / "sub/out.png").string() + " --depth " +
                 (dir / "d.f32").string() + " --mask " + (dir / "m.png").string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir / "sub/out.png"));
  EXPECT_EQ(fs::file_size(dir / "d.f32"), 32u * 32u * 4u);
  EXPECT_TRUE(fs::exists(dir / "d.f32.json"));
  EXPECT_TRUE(fs::exists(dir / "m.png"));
}

TEST_F(CliTest, TetRouteNeedsSimulationBoxes) {
  expect_failure(scene(), "--route tets",
                 {"--route tets", "boxes[0].deformer.type is \"twist\"", "simulation boxes only"});
  expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                       R"({"type": "twist", "axis": "y", "angle_deg": 90})",
                       R"("camera": "cam.json", "render": {"route": "tets"})"),
                 "", {"s.json", "render.route = \"tets\"", "simulation boxes only"});
  expect_failure(scene(), "--route mesh", {"--route", "mesh"});
}

// The octahedron's middle as a simulation box (tets model, 4 cells), shown by the tetrahedral
// route in both modes.
TEST_F(CliTest, TetRouteRendersASimulationBox) {
  for (const char* tets : {R"({"mode": "surface", "refine": 2})",
                           R"({"mode": "volume", "scalar": "strain", "scalar_samples": 16,
                               "length_samples": 8})"}) {
    std::ofstream(dir / "s.json") << scene(
        R"("min": [-0.6, -0.3, -0.6], "max": [0.6, 0.6, 0.6])",
        R"({"type": "simulation", "model": "tets", "resolution": 4, "ks": 1000, "density": 10,
            "steps": 5})",
        std::string(R"("camera": "cam.json", "render": {"route": "tets", "tets": )") + tets + "}");
    Result r = run((dir / "s.json").string() + " -o " + (dir / "t.png").string() + " --depth " +
                   (dir / "t.f32").string());
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("tetrahedral route"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("peeling passes"), std::string::npos) << r.output;
    const raywarp::Image image = raywarp::read_png((dir / "t.png").string());
    long differs = 0;
    for (size_t i = 0; i < image.rgba.size(); i += 4) differs += image.rgba[i + 1] != 255;
    EXPECT_GT(differs, 10) << tets;  // something shows besides the white background
    EXPECT_EQ(fs::file_size(dir / "t.f32"), 32u * 32u * 4u);
  }
}

// A from_mesh sequence: a folder of the octahedron's copies, its top vertex raised further in
// each. --sequence renders one frame per copy (and a GIF), bake --sequence exports each frame and
// a manifest; a scene without a sequence, and a frame past the last, are refused.
TEST_F(CliTest, SequenceRendersAndExportsEveryCopy) {
  fs::create_directories(dir / "seq");
  for (int k = 0; k < 3; ++k)
    std::ofstream(dir / "seq" / ("copy_" + std::to_string(k) + ".obj"))
        << "v 1 0 0\nv -1 0 0\nv 0 " << 1.0 + 0.25 * k
        << " 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
           "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";
  const std::string box = R"("min": [-1.2, -1.2, -1.2], "max": [1.2, 1.7, 1.2])";
  std::ofstream(dir / "s.json") << scene(
      box, R"({"type": "from_mesh", "target": "seq", "resolution": 8})");
  Result r = run((dir / "s.json").string() + " -o " + (dir / "anim" / "a.png").string() +
                 " --sequence --gif-only");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("frame 3/3: boxes[0].deformer.frame = 2"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(dir / "anim" / "a.gif"));

  r = ::run("bake " + (dir / "s.json").string() + " --out " + (dir / "x").string() +
            " --sequence --format ktx2 --no-cache");
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream in(dir / "x" / "s_box0_sequence.json");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("\"frame_count\": 3"), std::string::npos) << text.str();
  for (int k = 0; k < 3; ++k) {
    const std::string stem = "s_box0_f000" + std::to_string(k);
    EXPECT_TRUE(fs::exists(dir / "x" / (stem + ".deformation.ktx2"))) << stem;
    EXPECT_TRUE(fs::exists(dir / "x" / (stem + ".json"))) << stem;
  }

  expect_failure(scene(), "--sequence", {"s.json", "--sequence", "no box's from_mesh target"});
  expect_failure(scene(box, R"({"type": "from_mesh", "target": "seq", "frame": 5})"), "",
                 {"s.json", "boxes[0].deformer.frame = 5", "last frame, 2", "3 copies"});
}

TEST_F(CliTest, MissingSceneFile) {
  expect_failure("", "--camera /nonexistent/none.json", {"s.json"});
}
// Mesh files that lie about their contents, in a scene and for `raywarp info`: exit status 2, the
// file and the element named, nothing written.
TEST_F(CliTest, BrokenMeshFiles) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::vector<std::pair<std::string, std::string>> files = {
      {"short.ply", header + "0 0 0\n1 0 0\n"},
      {"index.ply", header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"},
      {"overflow.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n"},
      {"nan.obj", "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n"},
      {"flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"}};
  const std::vector<std::string> needles = {"PLY vertex 2 of", "uses vertex 7",
                                            "OBJ vertex 2 (line 2) has x = 1e+39",
                                            "OBJ vertex 3 (line 3) has y = nan", "degenerate"};
  for (size_t i = 0; i < files.size(); ++i) {
    std::ofstream(dir / files[i].first) << files[i].second;
    const std::string needle = i == 0 ? "cut short" : needles[i];
    expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                         R"({"type": "twist", "axis": "y", "angle_deg": 90})",
                         R"("camera": "cam.json")", files[i].first),
                   "", {files[i].first + ": cannot read mesh: ", needle});
    const Result info = ::run("info " + (dir / files[i].first).string());
    EXPECT_EQ(info.code, 2) << info.output;
    EXPECT_NE(info.output.find(needle), std::string::npos) << info.output;
  }
}

TEST_F(CliTest, ABoxBesideTheMeshWarns) {
  std::ofstream(dir / "s.json") << scene(R"("min": [5, 5, 5], "max": [6, 6, 6])");
  const Result r = run((dir / "s.json").string() + " -o " + (dir / "out.png").string());
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("holds no part of the mesh"), std::string::npos) << r.output;
}

TEST_F(CliTest, InvalidJson) { expect_failure("{\"mesh\": ", "", {"s.json", "JSON"}); }
TEST_F(CliTest, MeshFileMissing) {
  expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                       R"({"type": "twist", "axis": "y", "angle_deg": 90})",
                       R"("camera": "cam.json")", "nope.obj"),
                 "", {"nope.obj"});
}
TEST_F(CliTest, MinNotBelowMax) {
  expect_failure(scene(R"("min": [0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])"), "",
                 {"boxes[0]", "min"});
}
TEST_F(CliTest, NegativeHalfExtents) {
  expect_failure(scene(R"("centre": [0, 0, 0], "half_extents": [1, 1, -1])"), "",
                 {"boxes[0].half_extents[2]", "-1"});
}
TEST_F(CliTest, UnknownDeformer) {
  expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                       R"({"type": "twsit", "axis": "y", "angle_deg": 90})"),
                 "", {"boxes[0].deformer.type", "twsit", "twist"});
}
TEST_F(CliTest, BadAxis) {
  expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                       R"({"type": "twist", "axis": "w", "angle_deg": 90})"),
                 "", {"boxes[0].deformer.axis", "\"w\""});
}
TEST_F(CliTest, BendAngleOutOfRange) {
  expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                       R"({"type": "bend", "axis": "z", "angle_deg": 360})"),
                 "", {"boxes[0].deformer.angle_deg", "360", "(-360, 360)"});
}
TEST_F(CliTest, AngleNotANumber) {
  expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                       R"({"type": "twist", "axis": "y", "angle_deg": "90"})"),
                 "", {"boxes[0].deformer.angle_deg"});
}
TEST_F(CliTest, MisspelledKey) {
  expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                       R"({"type": "twist", "axis": "y", "anlge_deg": 90})"),
                 "", {"anlge_deg", "angle_deg"});
}
TEST_F(CliTest, NoCamera) {
  expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                       R"({"type": "twist", "axis": "y", "angle_deg": 90})",
                       R"("render": {"width": 32, "height": 32})"),
                 "", {"camera"});
}
TEST_F(CliTest, CameraEyeEqualsTarget) {
  std::ofstream(dir / "bad_cam.json") << R"({"eye": [0, 0, 0], "target": [0, 0, 0]})";
  expect_failure(scene(), "--camera " + (dir / "bad_cam.json").string(),
                 {"bad_cam.json", "target"});
}
TEST_F(CliTest, WidthOutOfRange) { expect_failure(scene(), "--width 0", {"--width"}); }
TEST_F(CliTest, RenderWidthInScene) {
  expect_failure(scene(R"("min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5])",
                       R"({"type": "twist", "axis": "y", "angle_deg": 90})",
                       R"("camera": "cam.json", "render": {"width": -4})"),
                 "", {"render.width", "-4"});
}
TEST_F(CliTest, OutputInUnwritablePlace) {
  std::ofstream(dir / "s.json") << scene();
  Result r = run((dir / "s.json").string() + " -o /proc/raywarp_cannot_write_here.png");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("raywarp_cannot_write_here.png"), std::string::npos) << r.output;
}

}  // namespace
