// Pass 2: ray casting of the deformed part of the mesh. The search is march.glsl's raywarp_cast in
// the box's frame; this shader makes the pixel's ray, shades the hit and writes its depth.
#include "camera.glsl"
#include "shading.glsl"
#include "march.glsl"
uniform mat4 u_object_to_box;
uniform mat3 u_box_to_object_dir;
#ifdef RAYWARP_CUT
uniform vec3 u_cut_colour;
#endif
layout(location = 0) out vec4 out_colour;
layout(location = 1) out float out_depth;

void main() {
  vec3 origin_obj, dir_obj;
  float t_far;
  fragment_ray(origin_obj, dir_obj, t_far);
  vec3 o = (u_object_to_box * vec4(origin_obj, 1.0)).xyz;
  vec3 d = transpose(u_box_to_object_dir) * dir_obj;
  float t0, t1, t;
  vec3 normal;
  int kind;
  if (!raywarp_clip(o, d, t_far, t0, t1) || !raywarp_cast(o, d, t0, t1, t, normal, kind)) discard;
  vec3 p_obj = origin_obj + t * dir_obj;
  vec3 albedo = u_albedo;
#ifdef RAYWARP_CUT
  if (kind == kRaywarpInner) albedo = u_inside_colour;
  if (kind == kRaywarpCutFace) albedo = u_cut_colour;
#endif
  out_colour = shade_albedo(u_box_to_object_dir * normal, dir_obj, albedo);
  out_depth = linear_depth(p_obj);
  gl_FragDepth = window_depth(p_obj);
}
