// Engine bundles: what each game engine needs to import one exported box (library/export.h), next
// to its textures. For a sidecar STEM.json in `dir`, write_engine_bundles writes
//   dir/STEM.engines/threejs/raywarp_STEM.js        ES module: KTX2 -> Data3DTexture, material
//   dir/STEM.engines/unity/Editor/RaywarpImport_STEM.cs      DDS/KTX2 -> Texture3D asset
//   dir/STEM.engines/unity/Editor/RaywarpAtlasImport_STEM.cs flipbook atlas importer settings
//   dir/STEM.engines/unreal/import_STEM.py          atlas -> Texture2D -> VolumeTexture
//   dir/STEM.engines/godot/STEM.TEXTURE.exr.import  Texture3D import settings of each atlas
//   dir/STEM.engines/ENGINE/CHECKLIST.md            files, decode, settings, orientation test
// Each bundle uses only the formats the sidecar lists; where one it needs is missing, its
// checklist names the `--format` to add instead of failing.
#pragma once
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace raywarp {

// `sidecar` is export_box's return value (or the parsed STEM.json); its `files` name files in
// `dir`. Returns, relative to `dir`:
//   {"folder": "STEM.engines",
//    "engines": {"threejs"|"unity"|"unreal"|"godot":
//                {"files": [...], "formats": ["ktx2", ...], "missing": ["--format atlas-exr"]}}}
// where `formats` are the sidecar formats the bundle reads and `missing` the formats to add for
// the bundle to be complete. Throws Error on a sidecar that is not raywarp.export version 1.
nlohmann::json write_engine_bundles(const nlohmann::json& sidecar, const std::filesystem::path& dir,
                                    const std::string& stem);

}  // namespace raywarp
