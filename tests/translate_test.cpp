// translate/translate.h on small shaders: GLSL to HLSL keeps functions and names, HLSL back to
// GLSL makes a cbuffer's members loose uniforms (row-major matrices read through transpose), the
// origin of SV_Position upper-left, and bad sources are errors naming them. No GL: the images
// that prove the translation right are tests/engine_shaders_test.cpp's.
#include "translate/translate.h"

#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "base/error.h"

using raywarp::Error;
using namespace raywarp::translate;

namespace {

bool has(const std::string& text, const std::string& word) {
  return text.find(word) != std::string::npos;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

const char* kGlsl = R"(#version 450 core
uniform float u_step;
uniform vec4 u_row_x;
uniform sampler3D u_sdf;
layout(location = 0) in vec3 v_p;
layout(location = 0) out vec4 out_colour;
float distance_at(vec3 p) { return textureLod(u_sdf, p, 0.0).r; }
bool march(vec3 o, out float t) {
  t = dot(u_row_x, vec4(o, 1.0));
  return distance_at(o + u_step) > 0.0;
}
void main() {
  float t;
  if (!march(v_p, t)) discard;
  out_colour = vec4(t);
}
)";

TEST(Translate, GlslToHlslKeepsFunctionsUniformsAndNamesSamplers) {
  HlslOptions options;
  options.sampler_names["u_sdf"] = "u_sdf_linear_clamp_sampler";
  const std::string hlsl = spirv_to_hlsl(glsl_to_spirv(kGlsl, Stage::Fragment, "k.glsl"), options);
  for (const char* word :
       {"float distance_at(float3 p)", "bool march(float3 o, out float t)", "uniform float u_step;",
        "uniform float4 u_row_x;", "Texture3D<float4> u_sdf;",
        "SamplerState u_sdf_linear_clamp_sampler;", "SampleLevel(u_sdf_linear_clamp_sampler"})
    EXPECT_TRUE(has(hlsl, word)) << word << "\n" << hlsl;
  EXPECT_FALSE(has(hlsl, "register(")) << "no bindings: an engine assigns its own\n" << hlsl;
}

TEST(Translate, HlslToGlslMakesCbufferMembersLooseAndKeepsMatrixMeaning) {
  const char* hlsl = R"(
cbuffer Box { float u_step; float4x4 u_m; int u_count; };
float2 u_viewport;
Texture3D<float4> u_sdf;
SamplerState u_sdf_sampler;
float4 main(float4 position : SV_Position) : SV_Target0 {
  float4 v = mul(u_m, float4(position.xy / u_viewport, 0.0, 1.0)) + u_m[1];
  return v * u_step * float(u_count) + u_sdf.SampleLevel(u_sdf_sampler, v.xyz, 0.0);
}
)";
  const std::string glsl = spirv_to_glsl(hlsl_to_spirv(hlsl, Stage::Fragment, "main", "k.hlsl"));
  for (const char* word : {"uniform float u_step;", "uniform mat4 u_m;", "uniform int u_count;",
                           "uniform vec2 u_viewport;", "uniform sampler3D u_sdf;",
                           "layout(origin_upper_left) in vec4 gl_FragCoord;", "transpose(u_m)[1]"})
    EXPECT_TRUE(has(glsl, word)) << word << "\n" << glsl;
  EXPECT_FALSE(has(glsl, "struct Box")) << glsl;
  EXPECT_FALSE(has(glsl, "raywarp_loose_block")) << glsl;
}

// An image read with a sampler and queried without one (GetDimensions, Load) is one sampler uniform
// in GLSL, the one a renderer binds by the image's name.
TEST(Translate, HlslImageSampledAndQueriedIsOneGlslSampler) {
  const char* hlsl = R"(
Texture3D<float4> u_alpha;
SamplerState u_alpha_sampler;
float4 main(float4 position : SV_Position) : SV_Target0 {
  uint w, h, d;
  u_alpha.GetDimensions(w, h, d);
  return u_alpha.SampleLevel(u_alpha_sampler, position.xyz / float(w), 0.0) +
         u_alpha.Load(int4(0, 0, int(d) - 1, 0));
}
)";
  const std::string glsl = spirv_to_glsl(hlsl_to_spirv(hlsl, Stage::Fragment, "main", "q.hlsl"));
  EXPECT_TRUE(has(glsl, "uniform sampler3D u_alpha;")) << glsl;
  EXPECT_TRUE(has(glsl, "textureSize(u_alpha, 0)")) << glsl;
  EXPECT_FALSE(has(glsl, "raywarp_unsampled")) << glsl;
  EXPECT_FALSE(has(glsl, "Dummy")) << glsl;
}

TEST(Translate, BadSourcesAreErrorsNamingThem) {
  std::string e = error_of([] {
    glsl_to_spirv("#version 450 core\nvoid main() { undeclared = 1; }\n", Stage::Fragment,
                  "broken.glsl");
  });
  EXPECT_TRUE(has(e, "broken.glsl: does not compile (glslang, GLSL)")) << e;
  EXPECT_TRUE(has(e, "undeclared")) << e;
  e = error_of([] {
    hlsl_to_spirv("float4 main() : SV_Target0 { return missing; }\n", Stage::Fragment, "main",
                  "broken.hlsl");
  });
  EXPECT_TRUE(has(e, "broken.hlsl: does not compile (glslang, HLSL)")) << e;
  e = error_of([] {
    hlsl_to_spirv("float4 main() : SV_Target0 { return 1.0; }\n", Stage::Fragment, "entry",
                  "entry.hlsl");
  });
  EXPECT_TRUE(has(e, "entry.hlsl")) << e;
  e = error_of([] { spirv_to_hlsl(Spirv{0x07230203u, 1u, 2u}); });
  EXPECT_TRUE(has(e, "SPIRV-Cross")) << e;
}

}  // namespace
