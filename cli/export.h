// `raywarp bake`: a scene's boxes baked and written in the formats engines and DCC tools read
// (library/export.h), each with its JSON sidecar; and the orientation test volume.
#pragma once
#include <filesystem>
#include <iosfwd>
#include <nlohmann/json.hpp>
#include <vector>

#include "cli/animate.h"
#include "cli/engine_bundles.h"
#include "library/bake.h"
#include "library/export.h"

namespace raywarp {

// Bakes every box of the scene file `scene` (or only box `only`, when >= 0) in `session` and
// exports each into `out` as SCENESTEM_boxI.*, with the bundles of `engines` (parse_engines'
// names, cli/engine_bundles.h); logs progress and each box's report. Every box is baked and
// checked against the engines' largest 3D texture before anything is written (Error naming the
// box, the texture, the engine, its limit and the resolution that would fit). Returns the
// sidecars.
std::vector<nlohmann::json> bake_and_export(
    const std::filesystem::path& scene, const ExportOptions& options,
    const std::filesystem::path& out, BakeSession& session, std::ostream& log, int only = -1,
    const std::vector<std::string>& engines = parse_engines("all"));

// A sequence of bakes exported frame by frame: `frames` frames while each parameter runs from
// its FROM to its TO (cli/animate.h; --sequence gives a from_mesh sequence's frames). Each box's
// textures and sidecar go to SCENESTEM_boxI_fNNNN.*, and SCENESTEM_boxI_sequence.json lists the
// frames with the parameters' values; the shaders and engine bundles are written once, for
// frame 0 (what each frame holds differs, not how it is read). Every frame's scene is validated
// before anything is baked. Returns the sequences' manifests, one per box.
std::vector<nlohmann::json> bake_and_export_sequence(
    const std::filesystem::path& scene, const std::vector<AnimatedParam>& params, int frames,
    const ExportOptions& options, const std::filesystem::path& out, BakeSession& session,
    std::ostream& log, int only = -1,
    const std::vector<std::string>& engines = parse_engines("all"));

// The file name stem of a scene's box: "bunny_twist_box0".
std::string export_stem(const std::filesystem::path& scene, size_t index);

}  // namespace raywarp
