// The ray caster for game engines, translated from raywarp's one GLSL source: a box's variant of
// shaders/march.glsl (raywarp_clip, raywarp_cast and what they call) goes GLSL 4.50 -> SPIR-V
// (glslang) -> HLSL shader model 5.0 (SPIRV-Cross), and its entry (march_entry.frag.glsl) is
// dropped again. Unity includes the result as it is; Unreal's Custom node, which cannot declare
// globals, gets the same text as a struct whose members are the uniforms and textures and whose
// methods are the functions. docs/engines.md says which text is generated and which is a template.
#pragma once
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gl/raycast_tables.h"
#include "library/scene.h"

namespace raywarp {

struct MarchHlsl {
  std::vector<std::string> features;   // the variant's macros, RAYWARP_*
  std::vector<std::string> uniforms;   // "float3 u_half_extents", "int u_max_steps"
  std::vector<std::string> resources;  // "Texture3D<float4> u_sdf", "SamplerState u_sdf_..."
  std::string types;                   // the structs the functions use
  std::string functions;               // the functions; raywarp_cast the last
};

// The sampler state an engine binds to a texture of the march: its name says the filter and the
// wrap, which Unity reads from the name (inline sampler states): "u_sdf_linear_clamp_sampler",
// "u_bricks_point_clamp_sampler" (read texel by texel),
// "u_deformation_linear_repeat_sampler" (cylindrical: the angle is periodic).
std::string march_sampler_name(const std::string& texture, bool cylindrical);

// Translates the variant's march. Throws Error with the translator's log when a step fails, or
// when SPIRV-Cross's output has a shape the extraction does not know (then nothing is written).
MarchHlsl translate_march(const gl::Variant& variant);

// The HLSL include (Unity's .hlsl, any HLSL engine): a header naming the variant, the uniforms
// in a constant buffer opened by RAYWARP_CBUFFER_START and closed by RAYWARP_CBUFFER_END (by
// default `cbuffer RaywarpBox {` and `};`; Unity defines them as CBUFFER_START(UnityPerMaterial)
// and CBUFFER_END), the textures and samplers, and the functions.
std::string march_hlsl_include(const MarchHlsl& march);

// The same as `struct NAME { members; methods };` for code that lives inside a function (Unreal's
// Custom node): the caller declares a NAME, fills every member (march_members) and calls
// its raywarp_clip and raywarp_cast.
std::string march_hlsl_struct(const MarchHlsl& march, const std::string& name);

// The names of the members march_hlsl_struct declares, uniforms then resources.
std::vector<std::string> march_members(const MarchHlsl& march);

// Every uniform an engine's ray-cast pass sets, by the shaders' names, from an export sidecar and
// the scene's render settings: box_uniform_values (cli/engine_bundles.h), the settings' (u_step,
// u_max_steps, u_refine_steps, u_threshold, u_fine_factor, u_epsilon; the colours as u_albedo,
// u_inside_colour, u_cut_colour), and the rigid maps between raywarp's object space and the box
// frame by rows (u_box_to_object_x/_y/_z, u_object_to_box_x/_y/_z: vec4s, the last column the
// translation). An unknown Lipschitz bound (-1 in the sidecar) is 1e30; a box an animation drives
// through M (the sidecar's "animation") has the bound for every M it takes.
nlohmann::json raycast_uniform_values(const nlohmann::json& sidecar,
                                      const RenderSettings& settings);

// Unity's ShaderLab shader of one box (template engines/unity/Raywarp.shader): the march's
// uniforms as material properties whose defaults are `values`, its textures as 3D (or 2DArray)
// properties. Throws Error naming a uniform of the march that `values` lacks.
std::string unity_shader(const MarchHlsl& march, const nlohmann::json& values,
                         const std::string& stem);
// The material of the mesh outside the box (engines/unity/RaywarpRemainder.shader): lit like the
// box's pass, both faces, every pass clipping what lies inside the box; defaults from `values`.
std::string unity_remainder_shader(const nlohmann::json& values, const std::string& stem);

// Unreal 5's Custom node: the inputs it takes, in order, as (HLSL type, name): the march's
// uniforms (float, float2..4; ints arrive as float), its textures (Texture3D, Texture2DArray; each
// with a SamplerState NAMESampler, as Unreal passes Texture Object inputs), then PixelWorld,
// CameraWorld, WorldToBoxX/Y/Z, BoxToWorldX/Y/Z, Albedo, InsideColour, CutColour.
std::vector<std::pair<std::string, std::string>> unreal_node_inputs(const MarchHlsl& march);
// The node's code (template engines/unreal/RaywarpCustomNode.hlsl) with the march as a local
// struct filled from the inputs. `stem` is made an identifier for the struct's name.
std::string unreal_custom_node(const MarchHlsl& march, const std::string& stem);

// The inputs of the Custom node as Unreal's material script makes them (engines/unreal/import.py,
// INPUTS): [kind, name, value] per input of unreal_node_inputs but the samplers, the values from
// `values` (raycast_uniform_values) but the decode factors, which are the sidecar's scales (the
// volumes hold the stored values).
nlohmann::json unreal_material_inputs(const MarchHlsl& march, const nlohmann::json& sidecar,
                                      const nlohmann::json& values);

// Writes the engines' shaders of one exported box into `root` (STEM.engines/), and returns the
// files written per engine, relative to `root`:
//   unity/Shaders/Raywarp_STEM.shader, unity/Shaders/raywarp_STEM.hlsl,
//   unity/Shaders/RaywarpUnity.hlsl, unreal/RaywarpCustomNode_STEM.hlsl (the Custom node's code),
//   unreal/Raywarp_STEM.ush (the march as a struct, for a plugin's Shaders folder),
//   unreal/import_STEM.py (the import script with the material: unreal_import_script),
//   godot/STEM.gdshader, godot/STEM.remainder.gdshader, godot/raywarp_import_STEM.gd,
//   godot/STEM.tscn (cli/engine_godot.h)
// A box the sidecar says an animation drives through M ("animation", cli/export.h) gets the variant
// with RAYWARP_TEXTURE_MAP, M's rows being material properties. Only the files of `engines`
// (empty: all) are written. Throws Error when the translation fails;
// nothing is then written.
nlohmann::json write_engine_shaders(const nlohmann::json& sidecar,
                                    const std::filesystem::path& root, const std::string& stem,
                                    const gl::Variant& variant, const RenderSettings& settings,
                                    const std::vector<std::string>& engines = {});

// `s` with every character that cannot be in an identifier replaced by '_' (and a leading digit
// prefixed), for names built from file stems.
std::string identifier(const std::string& s);

}  // namespace raywarp
