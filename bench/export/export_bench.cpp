// Export times: each format's writer on a baked box, and the KTX2 files read back, medians of
// --runs runs (docs/export.md#export-times). The bake itself is not timed (bench/bench.cpp times
// bakes). Usage: raywarp_export_bench [--runs N] [SCENE ...] (default: the bunny's twist and the
// probe's peel).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "library/export.h"
#include "library/scene.h"

using namespace raywarp;
namespace fs = std::filesystem;

namespace {

template <class F>
double time_ms(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 5;
  std::vector<fs::path> scenes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--help" || a == "-h" || a.rfind("--", 0) == 0) {
      std::cerr << "usage: raywarp_export_bench [--runs N] [SCENE ...]\n";
      return a == "--help" || a == "-h" ? 0 : 2;
    } else {
      scenes.emplace_back(a);
    }
  }
  if (scenes.empty())
    scenes = {fs::path(RAYWARP_SOURCE_DIR) / "examples/bunny_twist.json",
              fs::path(RAYWARP_SOURCE_DIR) / "examples/library/peel.json"};
  const fs::path out = fs::temp_directory_path() / "raywarp_export_bench";
  std::printf(
      "| scene | texels (all textures) | format | storage | bytes | write ms | read back ms |\n"
      "| --- | ---: | --- | --- | ---: | ---: | ---: |\n");
  try {
    for (const fs::path& file : scenes) {
      const nlohmann::json document = read_scene_document(file);
      const Scene scene = load_scene_json(document, file);
      BakeSession session;
      MeshPtr mesh = session.mesh(scene.mesh);
      const BakedBox baked = session.bake(export_job(scene, 0, mesh));
      const ExportSource source = export_source(scene, document, 0, *mesh);
      size_t texels = 0;
      for (const auto& t : export_textures(baked)) texels += t.volume.texels();
      for (const std::string name : {"ktx2", "dds", "vdb", "atlas-png", "atlas-exr"})
        for (Storage storage : {Storage::Half, Storage::Float}) {
          if (name == "vdb" || name == "atlas-png") {
            if (storage == Storage::Float) continue;  // one precision only
          }
          ExportOptions options;
          options.formats = parse_formats(name, "format");
          options.storage = storage;
          std::vector<double> write, read;
          nlohmann::json side;
          for (int r = 0; r < runs; ++r) {
            fs::remove_all(out);
            write.push_back(time_ms([&] { side = export_box(baked, source, options, out, "b"); }));
            if (name != "vdb")
              read.push_back(time_ms([&] { import_box(out / "b.json", options.formats[0]); }));
          }
          std::uintmax_t bytes = 0;
          for (const auto& f : side["files"]) bytes += f["bytes"].get<std::uintmax_t>();
          const bool one_precision = name == "vdb" || name == "atlas-png";
          std::printf("| %s | %zu | %s | %s | %ju | %.0f | %s |\n", file.filename().c_str(), texels,
                      name.c_str(),
                      one_precision ? (name == "vdb" ? "float" : "unorm16") : storage_name(storage),
                      bytes, median(write),
                      read.empty() ? "-" : std::to_string(int(median(read) + 0.5)).c_str());
          std::fflush(stdout);
        }
    }
  } catch (const std::exception& e) {
    std::cerr << "raywarp_export_bench: " << e.what() << "\n";
    return 2;
  }
  fs::remove_all(out);
  return 0;
}
