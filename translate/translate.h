// Shader translation between GLSL, SPIR-V and HLSL through two well-kept translators: glslang
// (Khronos' reference front end for GLSL and HLSL, to SPIR-V) and SPIRV-Cross (SPIR-V to HLSL and
// GLSL). raywarp's GLSL stays the one source of the ray caster; the engines' HLSL is made from it
// by these functions (docs/engines.md), and the tests carry HLSL back to GLSL to render it with
// raywarp's own OpenGL. Nothing here needs a GL context.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace raywarp::translate {

enum class Stage { Vertex, Fragment };

using Spirv = std::vector<std::uint32_t>;

// GLSL 4.50 (OpenGL semantics: loose uniforms allowed, locations and bindings mapped
// automatically) to SPIR-V 1.0 with the names of every function and variable kept. `where` names
// the source in errors. Throws Error with glslang's log when it does not compile or link.
Spirv glsl_to_spirv(const std::string& glsl, Stage stage, const std::string& where);

// HLSL (shader model 5) to SPIR-V 1.0 through glslang's HLSL front end, entry point `entry`.
// Throws Error with glslang's log.
Spirv hlsl_to_spirv(const std::string& hlsl, Stage stage, const std::string& entry,
                    const std::string& where);

struct HlslOptions {
  int shader_model = 50;
  // Samplers of combined GLSL samplers (`uniform sampler3D u_sdf`): SPIRV-Cross splits each into
  // a Texture3D named after it and a SamplerState; the SamplerState is named here by the
  // texture's name (default: SPIRV-Cross's `_NAME_sampler`).
  std::map<std::string, std::string> sampler_names;
};
// SPIR-V to HLSL; no register bindings are written (an engine assigns its own). Throws Error
// with SPIRV-Cross's message.
std::string spirv_to_hlsl(const Spirv& spirv, const HlslOptions& options = {});

// SPIR-V to GLSL 4.50 for an OpenGL program that sets its uniforms by name: separate textures
// and samplers combined into one sampler named after the texture, uniform buffers written as
// loose uniforms (each member of a cbuffer a `uniform` of its own name), no bindings. Throws Error
// with SPIRV-Cross's message, or when a member's name is taken twice.
std::string spirv_to_glsl(const Spirv& spirv);

}  // namespace raywarp::translate
