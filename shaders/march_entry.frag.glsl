// The entry point that carries march.glsl through SPIR-V to the engines' languages
// (cli/engine_shaders.h): it calls raywarp_clip and raywarp_cast on a ray given as inputs, so
// that glslang keeps them and every function they call. The translator drops this entry and its
// inputs and outputs again; only march.glsl's functions and uniforms reach an engine.
#include "march.glsl"
layout(location = 0) in vec3 raywarp_entry_origin;
layout(location = 1) in vec3 raywarp_entry_direction;
layout(location = 2) in float raywarp_entry_far;
layout(location = 0) out vec4 raywarp_entry_hit;
layout(location = 1) out vec3 raywarp_entry_normal;

void main() {
  float t0, t1, t;
  vec3 normal;
  int kind;
  bool hit = raywarp_clip(raywarp_entry_origin, raywarp_entry_direction, raywarp_entry_far, t0, t1) &&
             raywarp_cast(raywarp_entry_origin, raywarp_entry_direction, t0, t1, t, normal, kind);
  raywarp_entry_hit = vec4(hit ? 1.0 : 0.0, t, float(kind), 0.0);
  raywarp_entry_normal = normal;
}
