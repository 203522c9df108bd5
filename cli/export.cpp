#include "cli/export.h"

#include <ostream>

#include "base/error.h"
#include "base/format.h"
#include "cli/engine_bundles.h"
#include "cli/pipeline.h"
#include "cli/viewer_assets.h"

namespace raywarp {

namespace fs = std::filesystem;

BakeJob export_job(const Scene& scene, size_t index, MeshPtr mesh) {
  BakeJob job = make_job(scene, index, std::move(mesh));
  job.texture_bits = 32;
  job.sampling = "bounded";  // bakes the step bounds where the box can use them
  if (job.spec.implicit.type == "depth_cube") job.spec.implicit.type = "sdf";
  return job;
}

std::string export_stem(const fs::path& scene, size_t index) {
  return scene.stem().string() + "_box" + std::to_string(index);
}

std::vector<nlohmann::json> bake_and_export(const fs::path& scene_file,
                                            const ExportOptions& options, const fs::path& out,
                                            BakeSession& session, std::ostream& log, int only) {
  const nlohmann::json document = read_scene_document(scene_file);
  const Scene scene = load_scene_json(document, scene_file);
  if (only >= static_cast<int>(scene.boxes.size()))
    throw Error("--box " + std::to_string(only) + ": " + scene_file.string() + " has " +
                std::to_string(scene.boxes.size()) + " boxes (0 to " +
                std::to_string(int(scene.boxes.size()) - 1) + ")");
  MeshPtr mesh = session.mesh(scene.mesh);
  log << "mesh: " << describe(mesh->stats) << "\n";
  std::vector<nlohmann::json> sidecars;
  std::vector<BoxTextures> exported;  // for the shaders: each box as a consumer loads it
  for (size_t i = 0; i < scene.boxes.size(); ++i) {
    if (only >= 0 && static_cast<int>(i) != only) continue;
    const std::string tag = "box " + std::to_string(i) + ": ";
    if (scene.boxes[i].implicit.type == "depth_cube")
      log << tag
          << "the scene asks for a depth cube; the export bakes and carries a distance "
             "grid instead\n";
    const BakedBox baked = bake_logged(session, export_job(scene, i, mesh), log, tag);
    ExportSource source = export_source(scene, document, i, *mesh);
    source.input_hash = export_input_hash(source.mesh_hash, source.box, options);
    const std::string stem = export_stem(scene_file, i);
    nlohmann::json side = export_box(baked, source, options, out, stem);
    for (const auto& f : side["files"])
      log << tag << "wrote " << (out / f["file"].get<std::string>()).string() << " ("
          << fmt("%.1f", f["bytes"].get<double>() / 1024.0) << " KiB, largest error "
          << fmt("%.3g", f["max_error"].get<double>()) << ")\n";
    log << tag << "wrote " << (out / (stem + ".json")).string() << "\n";
    sidecars.push_back(std::move(side));
    exported.push_back(baked.textures);
  }
  // The scene's ray-cast variants as standalone GLSL, for engines; with --box, that box's alone.
  const nlohmann::json shaders =
      write_shader_bundle(exported, scene.render, out, scene_file.stem().string());
  log << "shaders: wrote " << (out / shaders["uniforms"].get<std::string>()).string()
      << " and the GLSL 4.50 and ES 3.00 files it documents\n";
  // What each engine needs to import the box (after the shaders: three.js's module reads them).
  for (size_t n = 0; n < sidecars.size(); ++n) {
    const size_t i = only >= 0 ? size_t(only) : n;
    const std::string stem = export_stem(scene_file, i);
    const nlohmann::json engines = write_engine_bundles(sidecars[n], out, stem);
    log << "box " << i << ": engine bundles in "
        << (out / engines["folder"].get<std::string>()).string()
        << " (three.js, Unity, Unreal, Godot; each with CHECKLIST.md)\n";
  }
  return sidecars;
}

}  // namespace raywarp
