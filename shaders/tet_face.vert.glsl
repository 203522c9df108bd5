// Boundary faces.
#include "camera.glsl"
#include "tet_common.glsl"
uniform sampler2D u_nodes;
void main() {
  gl_Position = u_view_proj * vec4(texelFetch(u_nodes, texel(gl_VertexID), 0).xyz, 1.0);
}
