// The image of the walk's state.
#include "camera.glsl"
#include "shading.glsl"
#include "tet_common.glsl"
uniform sampler2D u_state_a;
uniform sampler2D u_state_b;
uniform vec3 u_background;  // linear RGB
layout(location = 0) out vec4 out_colour;
layout(location = 1) out vec4 out_depth;

void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  vec4 a = texelFetch(u_state_a, px, 0);
  vec3 o, r;
  float t_min, t_max;
  pixel_ray(o, r, t_min, t_max);
#ifdef RAYWARP_SURFACE
  if (a.w == kInfinity) discard;  // no hit: the clear colour and +inf stay
  float lambert = dot(a.xyz, a.xyz) > 0.0 ? max(dot(a.xyz, -r), 0.0) : 0.0;
  out_colour = vec4(srgb_encode(u_albedo * (0.2 + 0.8 * lambert)), 1.0);
  out_depth = vec4(linear_depth(o + a.w * r), 0.0, 0.0, 0.0);
#else
  float t_first = texelFetch(u_state_b, px, 0).z;
  out_colour = vec4(srgb_encode(a.rgb + (1.0 - a.a) * u_background), 1.0);
  out_depth = vec4(t_first == kInfinity ? kInfinity : linear_depth(o + t_first * r), 0.0, 0.0, 0.0);
#endif
}
