// What the browser viewer (viewer/, `raywarp library`) and engines read besides the exported
// textures: the mesh as a small binary, the ray-cast shaders of a scene's boxes as standalone
// GLSL 4.50 and GLSL ES 3.00 files with a page documenting their uniforms, the render settings as
// JSON, and the viewer's own files.
#pragma once
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "library/mesh.h"
#include "library/scene.h"
#include "library/textures.h"

namespace raywarp {

// The mesh as the raster pass draws it, little-endian: the magic "RWM1", uint32 vertex count,
// uint32 triangle count, float32 xyz positions (object units), float32 xyz vertex normals
// (vertex_normals: area-weighted, as the renderer uploads them), uint32 indices (3 per triangle,
// counter-clockwise seen from outside). Written atomically; Error naming the file on failure.
void write_mesh_bin(const Mesh& mesh, const std::filesystem::path& file);

// Writes into `dir`, for each box i, the ray-cast fragment shader of its variant under
// `settings` exactly as raywarp compiles it (gl::raycast_fragment_source) as
// STEM_boxI.raycast.frag.glsl and in GLSL ES 3.00 (gl::glsl_es_300) as
// STEM_boxI.raycast.es.frag.glsl; once per stem, the ray-cast pass's vertex shader
// (STEM.raycast.vert.glsl, STEM.raycast.es.vert.glsl) and the raster pass's
// (STEM.raster.vert.glsl, STEM.raster.frag.glsl, STEM.raster.es.vert.glsl,
// STEM.raster.es.frag.glsl); and STEM.shaders.md, every uniform of each variant with its type,
// meaning and how to compute it from the export sidecar and the camera. `boxes` should be the
// textures as imported from the export (import_box), so that each variant is the one of what a
// consumer loads. Returns the files, named relative to `dir`:
//   {"raster": {"glsl450": {"vertex", "fragment"}, "glsl_es300": {"vertex", "fragment"}},
//    "raycast_vertex": {"glsl450", "glsl_es300"},
//    "boxes": [{"glsl450": {"vertex", "fragment"}, "glsl_es300": {...}, "defines": [MACRO...]}],
//    "uniforms": "STEM.shaders.md"}
nlohmann::json write_shader_bundle(const std::vector<BoxTextures>& boxes,
                                   const RenderSettings& settings, const std::filesystem::path& dir,
                                   const std::string& stem);

// Every field of `settings` under the scene file's keys of "render" (docs/scene.md): width,
// height, step_voxels, max_steps, refine_steps, background, colour, cut_colour, inside_colour,
// skipping, sampling, threshold_voxels, fine_factor, hit_epsilon_voxels, texture_bits.
nlohmann::json render_settings_to_json(const RenderSettings& settings);

// Writes every file of embedded_viewer_files() (viewer/*) into `dir` (created), atomically.
void write_viewer(const std::filesystem::path& dir);

}  // namespace raywarp
