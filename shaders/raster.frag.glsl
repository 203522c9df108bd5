// Pass 1: the mesh, with the fragments inside any deformation box discarded (the ray-cast pass
// draws what the box holds).
#include "camera.glsl"
#include "shading.glsl"
uniform int u_box_count;
uniform mat4 u_object_to_box[RAYWARP_MAX_BOXES];
uniform vec3 u_half_extents[RAYWARP_MAX_BOXES];
uniform bool u_two_sided;  // the scene has a cut: back faces show the inside of the shell
in vec3 v_position;
in vec3 v_normal;
layout(location = 0) out vec4 out_colour;
layout(location = 1) out float out_depth;

void main() {
  for (int i = 0; i < u_box_count; ++i) {
    vec3 q = (u_object_to_box[i] * vec4(v_position, 1.0)).xyz;
    if (all(lessThanEqual(abs(q), u_half_extents[i]))) discard;
  }
  // Back faces (the mesh is oriented outwards) are the inside of the shell, seen through a cut.
  if (u_two_sided && !gl_FrontFacing)
    out_colour = shade_albedo(-v_normal, ray_towards(v_position), u_inside_colour);
  else
    out_colour = shade(v_normal, ray_towards(v_position));
  out_depth = linear_depth(v_position);
}
