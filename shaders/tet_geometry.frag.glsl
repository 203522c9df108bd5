// Per-tetrahedron planes and gradient.
#include "tet_common.glsl"
uniform isampler2D u_tet_nodes;  // the four node numbers
uniform sampler2D u_nodes;       // xyz: position (centred), w: scalar
uniform int u_tet_count;
uniform float u_degenerate;
layout(location = 0) out vec4 out_plane0;  // (unit normal away from vertex k, offset)
layout(location = 1) out vec4 out_plane1;
layout(location = 2) out vec4 out_plane2;
layout(location = 3) out vec4 out_plane3;
layout(location = 4) out vec4 out_gradient;  // (g, ĝ): s(x) = g · x + ĝ

const ivec3 kFace[4] = ivec3[4](ivec3(1, 2, 3), ivec3(0, 3, 2), ivec3(0, 1, 3), ivec3(0, 2, 1));

void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  int t = px.y * kWidth + px.x;
  vec4 plane[4] = vec4[4](vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0));
  vec4 gradient = vec4(0.0);
  if (t < u_tet_count) {
    ivec4 n = texelFetch(u_tet_nodes, px, 0);
    vec3 v[4];
    float s[4];
    for (int k = 0; k < 4; ++k) {
      vec4 p = texelFetch(u_nodes, texel(n[k]), 0);
      v[k] = p.xyz;
      s[k] = p.w;
    }
    float six_volume = dot(v[1] - v[0], cross(v[2] - v[0], v[3] - v[0]));
    float longest = 0.0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) longest = max(longest, length(v[a] - v[b]));
    bool degenerate = !(abs(six_volume) > u_degenerate * longest * longest * longest) ||
                      !(abs(six_volume) < 3.0e38);
    if (degenerate) {
      gradient = vec4(0.0, 0.0, 0.0, s[0]);
    } else {
      vec3 g = vec3(0.0);
      for (int k = 0; k < 4; ++k) {
        vec3 a = v[kFace[k].x], b = v[kFace[k].y], c = v[kFace[k].z];
        vec3 normal = cross(b - a, c - a);
        if (dot(normal, v[k] - a) > 0.0) normal = -normal;
        normal = normalize(normal);
        plane[k] = vec4(normal, dot(normal, v[3 - k]));
        if (k > 0) g += (s[k] - s[0]) * normal / dot(normal, v[k] - v[3 - k]);
      }
      gradient = vec4(g, -dot(g, v[0]) + s[0]);
    }
  }
  out_plane0 = plane[0];
  out_plane1 = plane[1];
  out_plane2 = plane[2];
  out_plane3 = plane[3];
  out_gradient = gradient;
}
