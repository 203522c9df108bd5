// The walk of one section.
#include "camera.glsl"
#include "tet_common.glsl"
#include "tet_planes.glsl"
uniform isampler2D u_entry;       // (tet, face) of this pass's entry, -1: none
uniform sampler2D u_state_a;      // surface: (normal, t_hit); volume: (C, alpha)
uniform sampler2D u_state_b;      // (t_end, steps, t_first, sections * 4 + flag)
uniform isampler2D u_neighbours;  // 4 n + f per face, -1 on the boundary
uniform sampler2D u_gradient;     // (g, ĝ)
uniform int u_step_cap;
uniform float u_diagonal;
uniform float u_behind;
#ifdef RAYWARP_VOLUME
uniform sampler3D u_table;
uniform vec3 u_table_texels;  // (N, N, M)
uniform float u_s_min;
uniform float u_inv_ds;
uniform float u_inv_dl;
uniform float u_max_length;
uniform float u_termination;
#endif
layout(location = 0) out vec4 out_a;
layout(location = 1) out vec4 out_b;
layout(early_fragment_tests) in;

#ifdef RAYWARP_VOLUME
vec4 composite(vec4 front, vec4 back) {
  return vec4(front.rgb + (1.0 - front.a) * back.rgb, front.a + (1.0 - front.a) * back.a);
}
// PreintegrationTable's trilinear read: node i at texel centre (i + 0.5) / N, clamped.
vec4 trilinear(float s_front, float s_back, float len) {
  vec3 x = vec3((s_front - u_s_min) * u_inv_ds, (s_back - u_s_min) * u_inv_ds, len * u_inv_dl);
  return texture(u_table, (x + 0.5) / u_table_texels);
}
vec4 lookup(float s_front, float s_back, float len) {
  if (!(len > 0.0)) return vec4(0.0);
  if (len <= u_max_length) return trilinear(s_front, s_back, len);
  int count = int(min(ceil(len / u_max_length), float(RAYWARP_MAX_PIECES)));
  vec4 sum = vec4(0.0);
  for (int p = 0; p < count && sum.a < 1.0; ++p) {
    float a = float(p) / float(count), b = float(p + 1) / float(count);
    sum = composite(sum, trilinear(s_front + (s_back - s_front) * a,
                                   s_front + (s_back - s_front) * b, len / float(count)));
  }
  return sum;
}
#endif

void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  vec4 a = texelFetch(u_state_a, px, 0);
  vec4 b = texelFetch(u_state_b, px, 0);
  out_a = a;
  out_b = b;
  int code = int(b.w);
  ivec2 entry = texelFetch(u_entry, px, 0).xy;
  if (entry.x < 0 || (code & 3) != 0) return;

  vec3 o, r;
  float t_min, t_far;
  pixel_ray(o, r, t_min, t_far);
  int tet = entry.x, face = entry.y;
  vec4 plane[4];
  planes_of(tet, plane);
  float t_in = max((plane[face].w - dot(plane[face].xyz, o)) / dot(plane[face].xyz, r), t_min);
  int sections = (code >> 2) + 1;
  int flag = RAYWARP_ACTIVE;
  int steps = int(b.y);
  float t_first = b.z;
  vec3 entry_normal = plane[face].xyz;
  // Entry fix-up. The rasteriser places a pixel centre in a triangle to within its sub-pixel
  // snapping (1/256 pixel on llvmpipe), far coarser than the planes, so near an edge of the
  // boundary the entry point p can lie outside the entry tetrahedron. Beyond an inner face the
  // ray leaves by (r · n > 0): cross it with no length. Before a face the ray comes in by
  // (r · n < 0): on the boundary, enter there instead (the later plane, as for a ray into a
  // convex corner); inside, go to the neighbour, with no entry face. At most 4 moves, each
  // counted as a step.
  ivec4 across = texelFetch(u_neighbours, texel(tet), 0);
  for (int fix = 0; fix < 4 && steps < u_step_cap; ++fix) {
    vec3 p = o + t_in * r;
    int worst = -1;
    float worst_distance = 0.0;
    for (int k = 0; k < 4; ++k) {
      if (k == face) continue;
      float rn = dot(r, plane[k].xyz);
      float outside = dot(plane[k].xyz, p) - plane[k].w;
      bool beyond = rn > 0.0 && across[k] >= 0 && outside > 0.0;
      bool before = rn < 0.0 && outside > 0.0;
      if ((beyond || before) && outside > worst_distance) {
        worst = k;
        worst_distance = outside;
      }
    }
    if (worst < 0) break;
    float rn = dot(r, plane[worst].xyz);
    if (rn < 0.0 && across[worst] < 0) {
      face = worst;
      entry_normal = plane[face].xyz;
      t_in = max((plane[face].w - dot(plane[face].xyz, o)) / rn, t_min);
    } else {
      ++steps;
      int next = across[worst];
      tet = next >> 2;
      face = rn > 0.0 ? next & 3 : -1;
      planes_of(tet, plane);
      across = texelFetch(u_neighbours, texel(tet), 0);
    }
  }
  bool first = true;
  float f_previous = 0.0;
  while (true) {
    if (steps >= u_step_cap) {
      flag = RAYWARP_CAPPED;
      break;
    }
    ++steps;
    if (!first) planes_of(tet, plane);
    float tolerance = u_behind * (u_diagonal + abs(t_in));
    int exit_face = -1;
    float lambda = kInfinity;
    for (int k = 0; k < 4; ++k) {
      if (k == face) continue;
      float rn = dot(r, plane[k].xyz);
      if (!(rn > 0.0)) continue;
      float l = (plane[k].w - dot(plane[k].xyz, o)) / rn;
      if (!(l >= t_in - tolerance)) continue;
      if (l < lambda) {
        lambda = l;
        exit_face = k;
      }
    }
    if (exit_face < 0) break;  // lost: a degenerate tetrahedron, or no exit face
    float t_out = max(lambda, t_in);
    bool clipped = t_out > t_far;
    if (clipped) t_out = t_far;
    vec4 g = texelFetch(u_gradient, texel(tet), 0);
    float s_in = dot(g.xyz, o + t_in * r) + g.w;
    float s_out = dot(g.xyz, o + t_out * r) + g.w;
    if (t_first == kInfinity) t_first = t_in;
    bool stop = false;
#ifdef RAYWARP_SURFACE
    if (first) {
      if (s_in > 0.0) {  // entering where f > 0: a hit on the boundary face
        a = vec4(entry_normal, t_in);
        stop = true;
      }
      f_previous = s_in;
    }
    if (!stop && f_previous <= 0.0 && s_out > 0.0) {
      float gr = dot(g.xyz, r);
      float t = t_in;
      if (gr > 0.0) t = t_in - s_in / gr;
      float gn = length(g.xyz);
      a = vec4(gn > 0.0 ? -g.xyz / gn : vec3(0.0), clamp(t, t_in, t_out));
      stop = true;
    }
    f_previous = s_out;
#else
    float len = t_out - t_in;
    if (len > 0.0) {
      a = composite(a, lookup(s_in, s_out, len));
      stop = a.a >= u_termination;
    }
#endif
    first = false;
    t_in = t_out;
    if (stop || clipped) {
      flag = RAYWARP_DONE;
      break;
    }
    across = texelFetch(u_neighbours, texel(tet), 0);
    int next = across[exit_face];
    if (next < 0) break;  // left the mesh: the section ends here
    tet = next >> 2;
    face = next & 3;
  }
  out_a = a;
  out_b = vec4(t_in, float(steps), t_first, float(sections * 4 + flag));
}
