// Pass 2: the bounds of the deformed box F(box), drawn back faces only, so the pass also runs
// when the camera is inside them.
#include "camera.glsl"
uniform mat4 u_box_to_object;
uniform vec3 u_region_lower;  // box frame
uniform vec3 u_region_upper;
layout(location = 0) in vec3 a_corner;  // [0, 1]^3

void main() {
  vec3 local = mix(u_region_lower, u_region_upper, a_corner);
  gl_Position = u_view_proj * (u_box_to_object * vec4(local, 1.0));
}
