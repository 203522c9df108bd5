// `raywarp library` (cli/library.h): a folder of scenes built into entries, an index, a contact
// sheet and the viewer; unchanged entries skipped; the same index from the jobs run by GNU
// parallel and merged with --index-only as from the serial run; a broken entry named and the
// others still indexed.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "library/image.h"
#include "tests/temp_folder.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;

struct CommandResult {
  int code;
  std::string output;
};

CommandResult shell(const std::string& command) {
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), pipe)) out.append(buf.data(), n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

class LibraryTest : public TempFolderTest {
 protected:
  void SetUp() override {
    TempFolderTest::SetUp();
    scenes_ = dir_ / "scenes";
    fs::create_directories(scenes_);
    // Three entries of examples/library, their mesh and camera named by absolute paths.
    for (const char* name : {"twist", "box_cut", "taper"}) copy_scene(name);
  }
  void copy_scene(const std::string& name) {
    const fs::path src = fs::path(RAYWARP_SOURCE_DIR) / "examples" / "library" / (name + ".json");
    nlohmann::json doc = read_json(src);
    doc["mesh"] = (src.parent_path() / doc["mesh"].get<std::string>()).lexically_normal().string();
    doc["camera"] =
        (src.parent_path() / doc["camera"].get<std::string>()).lexically_normal().string();
    std::ofstream(scenes_ / (name + ".json")) << doc.dump(2);
  }
  CommandResult library(const fs::path& out, const std::string& extra = "") {
    return shell(std::string(RAYWARP_BINARY) + " library " + scenes_.string() + " --out " +
                 out.string() + " --cache-dir " + (dir_ / "cache").string() +
                 " --thumbnail-size 96 " + extra);
  }
  static std::vector<std::string> hidden(const fs::path& entries) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(entries))
      if (e.path().filename().string().front() == '.') names.push_back(e.path().filename());
    return names;
  }
  fs::path scenes_;
};

TEST_F(LibraryTest, BuildsSkipsAndMergesParallelJobsIntoTheSameIndex) {
  const fs::path serial = dir_ / "serial";
  CommandResult r = library(serial);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("3 built, 0 unchanged, 0 failed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[########################] 3/3"), std::string::npos) << r.output;
  const nlohmann::json index = read_json(serial / "index.json");
  ASSERT_EQ(index["entries"].size(), 3u);
  EXPECT_EQ(index["entries"][0]["name"], "box_cut");  // sorted by name
  EXPECT_EQ(index["entries"][1]["name"], "taper");
  EXPECT_EQ(index["entries"][2]["name"], "twist");
  for (const auto& e : index["entries"]) {
    EXPECT_TRUE(fs::exists(serial / e["thumbnail"].get<std::string>()));
    EXPECT_TRUE(fs::exists(serial / e["mesh"].get<std::string>()));
    for (const auto& b : e["boxes"]) {
      const nlohmann::json side = read_json(serial / b.get<std::string>());
      EXPECT_EQ(side["input_hash"], e["input_hash"]);
      for (const auto& f : side["files"])
        EXPECT_TRUE(
            fs::exists(serial / e["folder"].get<std::string>() / f["file"].get<std::string>()));
    }
  }
  EXPECT_TRUE(fs::exists(serial / "viewer" / "index.html"));
  EXPECT_TRUE(hidden(serial / "entries").empty()) << "a temporary entry folder was left behind";
  // The contact sheet: three cells of 96 + 8 pixels and a margin, one row with its label.
  const Image sheet = read_png((serial / "contact_sheet.png").string());
  EXPECT_EQ(sheet.width, 3 * (96 + 8) + 8);
  EXPECT_EQ(sheet.height, 96 + 24 + 8 + 8);
  const std::string first_index = [&] {
    std::ifstream in(serial / "index.json");
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }();

  // Again: nothing changed, nothing built, the same index.
  r = library(serial);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("0 built, 3 unchanged"), std::string::npos) << r.output;
  EXPECT_EQ(read_json(serial / "index.json"), index);

  // One scene changed: only its entry is built again.
  nlohmann::json twist = read_json(scenes_ / "twist.json");
  twist["boxes"][0]["deformer"]["angle_deg"] = 90;
  std::ofstream(scenes_ / "twist.json") << twist.dump(2);
  r = library(serial);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("1 built, 2 unchanged"), std::string::npos) << r.output;
  const nlohmann::json changed = read_json(serial / "index.json");
  EXPECT_NE(changed["entries"][2]["input_hash"], index["entries"][2]["input_hash"]);
  EXPECT_EQ(changed["entries"][0], index["entries"][0]);

  // The same library as jobs, run by GNU parallel, then merged.
  const fs::path jobs = dir_ / "jobs.txt";
  const fs::path parallel_out = dir_ / "parallel";
  r = library(parallel_out, "--emit-jobs " + jobs.string());
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream jin(jobs);
  int lines = 0;
  for (std::string line; std::getline(jin, line);) {
    ++lines;
    EXPECT_NE(line.find(" --entry "), std::string::npos) << line;
  }
  EXPECT_EQ(lines, 3);
  EXPECT_FALSE(fs::exists(parallel_out / "index.json")) << "--emit-jobs built something";
  if (shell("command -v parallel").code != 0)
    GTEST_SKIP() << "GNU parallel is not installed (Debian package parallel): the jobs were not "
                    "run";
  r = shell("parallel --will-cite --halt now,fail=1 -j 2 < " + jobs.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_FALSE(fs::exists(parallel_out / "index.json")) << "a job wrote the index";
  r = library(parallel_out, "--index-only");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(read_json(parallel_out / "index.json"), changed)
      << "the index of the jobs differs from the serial run's";
  EXPECT_TRUE(hidden(parallel_out / "entries").empty());
}

TEST_F(LibraryTest, ABrokenEntryIsNamedAndTheOthersAreIndexed) {
  std::ofstream(scenes_ / "broken.json")
      << R"({"mesh": ")" << (fs::path(RAYWARP_SOURCE_DIR) / "examples/meshes/probe.ply").string()
      << R"(", "boxes": [{"min": [-1, -1, -1], "max": [1, 1, 1],
            "deformer": {"type": "twist", "axis": "w", "angle_deg": 90}}]})";
  const fs::path out = dir_ / "out";
  const CommandResult r = library(out);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("broken.json"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("axis"), std::string::npos) << r.output;
  EXPECT_EQ(read_json(out / "index.json")["entries"].size(), 3u);
}

TEST_F(LibraryTest, ABrokenEntryDoesNotStopTheOthers) {
  // A scene that loads but cannot be a library entry (no camera): named, the others indexed.
  std::ofstream(scenes_ / "nocamera.json")
      << R"({"mesh": ")" << (fs::path(RAYWARP_SOURCE_DIR) / "examples/meshes/probe.ply").string()
      << R"(", "boxes": [{"min": [-1.3, -0.6, -1.3], "max": [1.3, 2.2, 1.3],
            "deformer": {"type": "twist", "axis": "y", "angle_deg": 90}}]})";
  const fs::path out = dir_ / "out";
  const CommandResult r = library(out);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("nocamera.json: camera: missing"), std::string::npos) << r.output;
  EXPECT_EQ(read_json(out / "index.json")["entries"].size(), 3u);
  EXPECT_FALSE(fs::exists(out / "entries" / "nocamera"));
  EXPECT_TRUE(hidden(out / "entries").empty());
}

TEST_F(LibraryTest, APresetsFileBuildsOneEntryPerPreset) {
  // examples/presets/probe_twists.json: five presets on the probe mesh; its mesh and camera are
  // relative to the presets file, which stays where it is.
  const fs::path presets = fs::path(RAYWARP_SOURCE_DIR) / "examples/presets/probe_twists.json";
  const fs::path out = dir_ / "presets";
  const CommandResult r =
      shell(std::string(RAYWARP_BINARY) + " library " + presets.string() + " --out " +
            out.string() + " --cache-dir " + (dir_ / "cache").string() + " --thumbnail-size 64");
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json index = read_json(out / "index.json");
  ASSERT_EQ(index["entries"].size(), 5u);
  EXPECT_EQ(index["entries"][0]["name"], "twist_090");  // in the file's order
  EXPECT_EQ(index["entries"][3]["name"], "taper_top");
  EXPECT_EQ(index["entries"][4]["name"], "wedge_cut");
  // Each preset's box is the file's box with the preset's fields over it.
  const nlohmann::json side = read_json(out / index["entries"][4]["boxes"][0].get<std::string>());
  EXPECT_EQ(side["deformer"]["type"], "box_cut");
  EXPECT_EQ(side["render"]["cut_mode"], "hollow");
  EXPECT_NEAR(side["box"]["half_extents"][1].get<double>(), 1.4, 1e-12);

  // A preset with no name is refused, naming the field.
  std::ofstream(dir_ / "bad_presets.json")
      << R"({"mesh": "m.ply", "camera": "c.json", "box": {}, "presets": [{"deformer": {}}]})";
  const CommandResult bad =
      shell(std::string(RAYWARP_BINARY) + " library " + (dir_ / "bad_presets.json").string() +
            " --out " + (dir_ / "bad_out").string());
  EXPECT_EQ(bad.code, 2) << bad.output;
  EXPECT_NE(bad.output.find("bad_presets.json: presets[0].name: missing"), std::string::npos)
      << bad.output;
  EXPECT_FALSE(fs::exists(dir_ / "bad_out"));
}

}  // namespace
}  // namespace raywarp
