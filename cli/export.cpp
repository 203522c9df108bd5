#include "cli/export.h"

#include <cstdio>
#include <ostream>

#include "base/atomic_file.h"
#include "base/error.h"
#include "base/format.h"
#include "cli/engine_bundles.h"
#include "cli/viewer_assets.h"
#include "gl/renderer.h"
#include "library/prepare.h"

namespace raywarp {

namespace fs = std::filesystem;

namespace {

// Refuses, before anything is written, a baked box whose texture has more texels a side than an
// engine of `engines` guarantees, naming the box, the texture, the engine, its limit and the
// resolution that would fit.
void check_engine_limits(const Scene& scene, const fs::path& scene_file,
                         const std::vector<size_t>& indices, const std::vector<BakedBox>& baked,
                         const std::vector<std::string>& engines) {
  for (size_t n = 0; n < baked.size(); ++n) {
    const BoxTextures& t = baked[n].textures;
    const BoxSpec& spec = scene.boxes[indices[n]];
    struct Texture {
      const char* name;
      Eigen::Vector3i dims;
      const char* field;
      int resolution;
    };
    std::vector<Texture> textures;
    if (t.uses_depth_cube) {
      const DepthCube::Layers l = t.depth_cube.layers();
      textures.push_back({"depth",
                          {l.width, l.height, DepthCube::Layers::kDepth},
                          "implicit.resolution",
                          spec.implicit.resolution});
    } else {
      textures.push_back(
          {"distance", t.sdf.grid.dims, "implicit.resolution", spec.implicit.resolution});
    }
    if (!t.moves_nothing)
      textures.push_back({"deformation", t.deformation.grid.dims, "deformation_resolution",
                          spec.deformation_resolution});
    if (t.has_cut)
      textures.push_back({"alpha", t.alpha.grid.dims, "alpha_resolution", spec.alpha_resolution});
    for (const EngineLimit& e : kEngineLimits) {
      if (std::find(engines.begin(), engines.end(), e.name) == engines.end()) continue;
      for (const Texture& tex : textures) {
        const int side = tex.dims.maxCoeff();
        if (side <= e.max_3d_texels) continue;
        const std::string field = "boxes[" + std::to_string(indices[n]) + "]." + tex.field;
        const std::string fit = tex.resolution > 0
                                    ? "set " + field + " to at most " +
                                          std::to_string(tex.resolution * e.max_3d_texels / side)
                                    : "set " + field + " (now automatic) to a resolution under " +
                                          std::to_string(e.max_3d_texels);
        throw Error(scene_file.string() + ": " + field.substr(0, field.find(']') + 1) + ": its " +
                    tex.name + " texture is " + std::to_string(tex.dims.x()) + " x " +
                    std::to_string(tex.dims.y()) + " x " + std::to_string(tex.dims.z()) +
                    " texels, over the " + std::to_string(e.max_3d_texels) + " a side that " +
                    e.name + " allows (" + e.why + "); " + fit + ", or leave " + e.name +
                    " out with --engines");
      }
    }
  }
}

// Bakes and exports the boxes of one scene (document and its loaded scene) with stems
// SCENESTEM_boxI + suffix; appends each exported box's textures to `exported`. Every box is baked
// and checked against the engines' limits before anything is written.
std::vector<nlohmann::json> export_boxes(const fs::path& scene_file, const nlohmann::json& document,
                                         const Scene& scene, const ExportOptions& options,
                                         const fs::path& out, BakeSession& session,
                                         std::ostream& log, int only, const std::string& suffix,
                                         const std::vector<std::string>& engines,
                                         std::vector<BoxTextures>& exported) {
  MeshPtr mesh = session.mesh(scene.mesh);
  std::vector<size_t> indices;
  std::vector<BakedBox> baked_boxes;
  for (size_t i = 0; i < scene.boxes.size(); ++i) {
    if (only >= 0 && static_cast<int>(i) != only) continue;
    const std::string tag = "box " + std::to_string(i) + ": ";
    baked_boxes.push_back(bake_logged(session, export_job(scene, i, mesh), log, tag));
    indices.push_back(i);
  }
  check_engine_limits(scene, scene_file, indices, baked_boxes, engines);
  std::vector<nlohmann::json> sidecars;
  for (size_t n = 0; n < indices.size(); ++n) {
    const size_t i = indices[n];
    const std::string tag = "box " + std::to_string(i) + ": ";
    const BakedBox& baked = baked_boxes[n];
    ExportSource source = export_source(scene, document, i, *mesh);
    source.input_hash = export_input_hash(source.mesh_hash, source.box, options);
    source.animation = export_animation(scene, i);
    const std::string stem = export_stem(scene_file, i) + suffix;
    nlohmann::json side = export_box(baked, source, options, out, stem);
    for (const auto& f : side["files"])
      log << tag << "wrote " << (out / f["file"].get<std::string>()).string() << " ("
          << fmt("%.1f", f["bytes"].get<double>() / 1024.0) << " KiB, largest error "
          << fmt("%.3g", f["max_error"].get<double>()) << ")\n";
    log << tag << "wrote " << (out / (stem + ".json")).string() << "\n";
    sidecars.push_back(std::move(side));
    exported.push_back(baked.textures);
  }
  return sidecars;
}

void check_box(const Scene& scene, const fs::path& scene_file, int only) {
  if (only >= static_cast<int>(scene.boxes.size()))
    throw Error("--box " + std::to_string(only) + ": " + scene_file.string() + " has " +
                std::to_string(scene.boxes.size()) + " boxes (0 to " +
                std::to_string(int(scene.boxes.size()) - 1) + ")");
}

// The scene's ray-cast variants as standalone GLSL, and what each engine needs to import a box
// (after the shaders: three.js's module reads them); `stems` name the sidecars' files.
void write_bundles(const fs::path& scene_file, const Scene& scene,
                   const std::vector<nlohmann::json>& sidecars,
                   const std::vector<BoxTextures>& exported, const std::vector<std::string>& stems,
                   const std::vector<size_t>& boxes, const fs::path& out,
                   const std::vector<std::string>& engines, std::ostream& log) {
  const nlohmann::json shaders =
      write_shader_bundle(exported, scene.render, out, scene_file.stem().string());
  log << "shaders: wrote " << (out / shaders["uniforms"].get<std::string>()).string()
      << " and the GLSL 4.50 and ES 3.00 files it documents\n";
  for (size_t n = 0; n < sidecars.size(); ++n) {
    const nlohmann::json written = write_engine_bundles(
        sidecars[n], out, stems[n],
        BundleShaders{gl::raycast_variant(exported[n], scene.render), scene.render}, engines);
    std::string names;
    for (const std::string& e : engines) names += (names.empty() ? "" : ", ") + e;
    log << "box " << boxes[n] << ": engine bundles in "
        << (out / written["folder"].get<std::string>()).string() << " (" << names
        << "; each with CHECKLIST.md)\n";
  }
}

}  // namespace

std::vector<nlohmann::json> bake_and_export(const fs::path& scene_file,
                                            const ExportOptions& options, const fs::path& out,
                                            BakeSession& session, std::ostream& log, int only,
                                            const std::vector<std::string>& engines) {
  const nlohmann::json document = read_scene_document(scene_file);
  const Scene scene = load_scene_json(document, scene_file);
  check_box(scene, scene_file, only);
  log << "mesh: " << describe(session.mesh(scene.mesh)->stats) << "\n";
  std::vector<BoxTextures> exported;  // for the shaders: each box as a consumer loads it
  std::vector<nlohmann::json> sidecars = export_boxes(scene_file, document, scene, options, out,
                                                      session, log, only, "", engines, exported);
  std::vector<std::string> stems;
  std::vector<size_t> boxes;
  for (size_t n = 0; n < sidecars.size(); ++n) {
    boxes.push_back(only >= 0 ? size_t(only) : n);
    stems.push_back(export_stem(scene_file, boxes.back()));
  }
  write_bundles(scene_file, scene, sidecars, exported, stems, boxes, out, engines, log);
  return sidecars;
}

std::vector<nlohmann::json> bake_and_export_sequence(const fs::path& scene_file,
                                                     const std::vector<AnimatedParam>& params,
                                                     int frames, const ExportOptions& options,
                                                     const fs::path& out, BakeSession& session,
                                                     std::ostream& log, int only,
                                                     const std::vector<std::string>& engines) {
  if (frames < 2 || frames > 10000)
    throw Error("--frames " + std::to_string(frames) + ": must be 2 to 10000");
  if (params.empty())
    throw Error("--frames: give --sequence or a --param FIELD=FROM:TO to animate");
  const nlohmann::json document = read_scene_document(scene_file);
  // Every frame's scene is validated before anything is baked or written.
  std::vector<nlohmann::json> documents;
  std::vector<Scene> scenes;
  for (int f = 0; f < frames; ++f) {
    documents.push_back(document_at(document, params, f, frames, scene_file));
    scenes.push_back(load_scene_json(documents.back(), scene_file));
  }
  check_box(scenes[0], scene_file, only);
  log << "mesh: " << describe(session.mesh(scenes[0].mesh)->stats) << "\n";
  std::vector<size_t> boxes;
  for (size_t i = 0; i < scenes[0].boxes.size(); ++i)
    if (only < 0 || static_cast<int>(i) == only) boxes.push_back(i);
  std::vector<nlohmann::json> manifests(boxes.size());
  for (size_t n = 0; n < boxes.size(); ++n) {
    nlohmann::json& m = manifests[n];
    m["raywarp_sequence"] = 1;
    m["scene"] = scene_file.filename().string();
    m["box"] = boxes[n];
    m["frame_count"] = frames;
    m["parameters"] = nlohmann::json::array();
    for (const AnimatedParam& p : params)
      m["parameters"].push_back({{"field", p.path}, {"from", p.from}, {"to", p.to}});
    m["frames"] = nlohmann::json::array();
  }
  std::vector<nlohmann::json> first_sidecars;
  std::vector<BoxTextures> first_exported;
  for (int f = 0; f < frames; ++f) {
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, "_f%04d", f);
    std::string values;
    for (const AnimatedParam& p : params)
      values += " " + p.path + " = " + shortest_text(p.at(f, frames));
    log << "frame " << f + 1 << "/" << frames << ":" << values << "\n";
    std::vector<BoxTextures> exported;
    std::vector<nlohmann::json> sidecars =
        export_boxes(scene_file, documents[f], scenes[f], options, out, session, log, only, suffix,
                     engines, exported);
    for (size_t n = 0; n < sidecars.size(); ++n) {
      nlohmann::json frame = {{"frame", f},
                              {"sidecar", export_stem(scene_file, boxes[n]) + suffix + ".json"}};
      nlohmann::json values_json = nlohmann::json::object();
      for (const AnimatedParam& p : params) values_json[p.path] = p.at(f, frames);
      frame["values"] = values_json;
      frame["files"] = nlohmann::json::array();
      for (const auto& file : sidecars[n]["files"]) frame["files"].push_back(file["file"]);
      manifests[n]["frames"].push_back(std::move(frame));
    }
    if (f == 0) {
      first_sidecars = std::move(sidecars);
      first_exported = std::move(exported);
    }
  }
  std::vector<std::string> stems;
  for (size_t b : boxes) stems.push_back(export_stem(scene_file, b) + "_f0000");
  write_bundles(scene_file, scenes[0], first_sidecars, first_exported, stems, boxes, out, engines,
                log);
  for (size_t n = 0; n < boxes.size(); ++n) {
    const fs::path path = out / (export_stem(scene_file, boxes[n]) + "_sequence.json");
    write_file_atomic(path.string(), manifests[n].dump(2) + "\n");
    log << "box " << boxes[n] << ": wrote " << path.string() << " (" << frames
        << " frames; the shaders and engine bundles load frame 0)\n";
  }
  return manifests;
}

std::string export_stem(const fs::path& scene, size_t index) {
  return scene.stem().string() + "_box" + std::to_string(index);
}

}  // namespace raywarp
