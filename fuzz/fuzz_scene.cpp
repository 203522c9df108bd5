// libFuzzer target: a scene document, read as `raywarp render` reads one (JSON parse with its
// depth limit, then every field validated). Paths resolve against examples/, so the seeds'
// meshes and cameras exist. Any exception but raywarp::Error is a bug, as is a crash or a hang.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "base/error.h"
#include "base/json_reader.h"
#include "library/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path scene_file =
      std::filesystem::path(RAYWARP_SOURCE_DIR) / "examples" / "fuzz.json";
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    raywarp::load_scene_json(raywarp::parse_json(text, scene_file.string()), scene_file);
  } catch (const raywarp::Error&) {
  }
  return 0;
}
