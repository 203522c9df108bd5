// Section entries.
#include "camera.glsl"
#include "tet_common.glsl"
#include "tet_planes.glsl"
uniform isampler2D u_boundary;  // by boundary face: (tet, face)
uniform sampler2D u_state_b;    // (t_end, steps, t_first, sections * 4 + flag)
layout(location = 0) out ivec2 out_entry;

void main() {
  vec4 state = texelFetch(u_state_b, ivec2(gl_FragCoord.xy), 0);
  if ((int(state.w) & 3) != 0) discard;
  ivec2 face = texelFetch(u_boundary, texel(gl_PrimitiveID), 0).xy;
  vec4 plane[4];
  planes_of(face.x, plane);
  vec3 o, r;
  float t_min, t_max;
  pixel_ray(o, r, t_min, t_max);
  vec4 p = plane[face.y];
  float rn = dot(r, p.xyz);
  if (!(rn < 0.0)) discard;
  float t = (p.w - dot(p.xyz, o)) / rn;
  if (!(t > state.x)) discard;
  // The depth test orders the faces by t itself, linear in [0, 1] over the ray: the window depth
  // of a perspective with a small near plane keeps too few bits at a distance.
  gl_FragDepth = clamp(t / t_max, 0.0, 1.0);
  out_entry = face;
}
