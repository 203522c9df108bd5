// Engine bundles: what each game engine needs to import one exported box (library/export.h), next
// to its textures. For a sidecar STEM.json in `dir`, write_engine_bundles writes
//   dir/STEM.engines/threejs/raywarp_STEM.js        ES module: KTX2 -> Data3DTexture, material
//   dir/STEM.engines/unity/Editor/RaywarpImport_STEM.cs      DDS/KTX2 -> Texture3D asset
//   dir/STEM.engines/unity/Editor/RaywarpAtlasImport_STEM.cs flipbook atlas importer settings
//   dir/STEM.engines/unreal/import_STEM.py          atlas -> Texture2D -> VolumeTexture
//   dir/STEM.engines/godot/STEM.TEXTURE.exr.import  Texture3D import settings of each atlas
//   dir/STEM.engines/ENGINE/CHECKLIST.md            files, decode, settings, orientation test
// `engines` (empty: all) picks the bundles written. Each bundle uses only the formats the sidecar
// lists; where one it needs is missing, its checklist names the `--format` to add instead of
// failing.
#pragma once
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "gl/raycast_tables.h"
#include "library/scene.h"

namespace raywarp {

// `sidecar` is export_box's return value (or the parsed STEM.json); its `files` name files in
// `dir`. Returns, relative to `dir`:
//   {"folder": "STEM.engines",
//    "engines": {"threejs"|"unity"|"unreal"|"godot":
//                {"files": [...], "formats": ["ktx2", ...], "missing": ["--format atlas-exr"]}}}
// where `formats` are the sidecar formats the bundle reads and `missing` the formats to add for
// the bundle to be complete. Throws Error on a sidecar that is not raywarp.export version 1.
// The ray-cast uniforms gl/renderer.cpp sets that depend on the sidecar alone, by the shaders'
// names (u_half_extents, u_region_lower, u_sdf_origin, u_texture_map_x, ...): everything in
// object units, box frame; the matrix u_box_to_object as 4 rows. The render settings' uniforms
// (u_step, u_max_steps, ...) and the camera's are not among them.
nlohmann::json box_uniform_values(const nlohmann::json& sidecar);

// An engine raywarp writes a bundle for (`raywarp bake --engines`), with the largest side of a 3D
// texture it guarantees: a box whose texture is larger is refused before anything is written.
struct EngineLimit {
  const char* name;
  int max_3d_texels;
  const char* why;
};
inline constexpr EngineLimit kEngineLimits[] = {
    {"threejs", 256, "WebGL2 guarantees 3D textures of 256 texels a side"},
    {"unity", 2048, "Direct3D 11's 3D textures are at most 2048 texels a side"},
    {"unreal", 2048, "Direct3D 11's 3D textures are at most 2048 texels a side"},
    {"godot", 2048, "Direct3D 12's 3D textures, and desktop Vulkan's, are 2048 texels a side"},
};
// "all" or a comma-separated list of kEngineLimits' names -> the names, in the table's order.
// Throws Error naming --engines, the word and the names allowed.
std::vector<std::string> parse_engines(const std::string& list);

// Unreal 5's editor script of a box (template engines/unreal/import.py): imports the atlases as
// volume textures and, when `inputs` (the Custom node's, [kind, name, value] each: see the
// template) is not empty, makes the material around the node's code. Written as
// STEM.engines/unreal/import_STEM.py.
std::string unreal_import_script(const nlohmann::json& sidecar, const std::string& stem,
                                 const nlohmann::json& inputs);

// The ray-cast variant of the exported box and the scene's render settings: with them, the bundles
// also carry the engines' shaders (cli/engine_shaders.h: Unity's ShaderLab shader and HLSL
// include, Unreal's Custom node code).
struct BundleShaders {
  gl::Variant variant;
  RenderSettings settings;
};
nlohmann::json write_engine_bundles(const nlohmann::json& sidecar, const std::filesystem::path& dir,
                                    const std::string& stem,
                                    const std::optional<BundleShaders>& shaders = std::nullopt,
                                    const std::vector<std::string>& engines = {});

}  // namespace raywarp
