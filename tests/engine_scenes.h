// The scenes the engine tests export: every shipped example, and the cut modes, mappings and
// settings the examples do not combine (a groove in a thick shell, a thick-shell incision, a
// hollow peel, a bend with bounded sampling, a depth cube, two boxes: a twist and a hollow cut).
// The extra scenes are written into a folder, their mesh and camera given by absolute paths.
#pragma once
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace raywarp::testing {

struct ExtraScene {
  const char* name;
  const char* example;
  std::function<void(nlohmann::json&)> edit;
};

inline std::vector<ExtraScene> extra_scenes() {
  auto thick = [](nlohmann::json& d) {
    d["boxes"][0]["cut_mode"] = "thick_shell";
    d["boxes"][0]["shell_thickness"] = 0.45;
  };
  return {
      {"groove_thick_shell", "bunny_groove.json", thick},
      {"incision_thick_shell", "bunny_incision.json", thick},
      {"peel_hollow", "bunny_peel.json",
       [](nlohmann::json& d) { d["boxes"][0]["cut_mode"] = "hollow"; }},
      {"bend_bounded", "bunny_bend.json",
       [](nlohmann::json& d) { d["render"]["sampling"] = "bounded"; }},
      {"twist_depth_cube", "bunny_twist.json",
       [](nlohmann::json& d) {
         d["boxes"][0]["implicit"] = {{"type", "depth_cube"}, {"resolution", 128}};
       }},
      {"twist_and_hollow_cut", "bunny_two_boxes.json",
       [](nlohmann::json& d) {
         d["boxes"][1]["deformer"] = {
             {"type", "box_cut"}, {"wedge", {{"axis", "y"}, {"from_deg", 0}, {"angle_deg", 90}}}};
         d["boxes"][1]["cut_mode"] = "hollow";
       }},
  };
}

// The example `name` (examples/NAME) as a document whose mesh and camera are absolute paths.
inline nlohmann::json example_document(const std::string& name) {
  const std::filesystem::path examples = std::filesystem::path(RAYWARP_SOURCE_DIR) / "examples";
  std::ifstream in(examples / name);
  nlohmann::json d = nlohmann::json::parse(in);
  d["mesh"] = (examples / d["mesh"].get<std::string>()).string();
  if (d.contains("camera") && d["camera"].is_string())
    d["camera"] = (examples / d["camera"].get<std::string>()).string();
  return d;
}

// Every shipped example's path, then the extra scenes written into `dir`.
inline std::vector<std::filesystem::path> engine_test_scenes(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(fs::path(RAYWARP_SOURCE_DIR) / "examples"))
    if (e.path().extension() == ".json") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  fs::create_directories(dir);
  for (const ExtraScene& s : extra_scenes()) {
    nlohmann::json d = example_document(s.example);
    s.edit(d);
    out.push_back(dir / (std::string(s.name) + ".json"));
    std::ofstream(out.back()) << d.dump(2);
  }
  return out;
}

}  // namespace raywarp::testing
