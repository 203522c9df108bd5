// The camera as both passes see it. Linear depth dot(p - eye, view_dir): docs/conventions.md#depth.
uniform mat4 u_view_proj;      // object -> clip
uniform mat4 u_inv_view_proj;  // clip -> object
uniform vec3 u_eye;            // object space
uniform vec3 u_view_dir;       // unit, object space
uniform vec2 u_viewport;       // pixels
uniform bool u_orthographic;

float linear_depth(vec3 p) { return dot(p - u_eye, u_view_dir); }

// Unit direction of the camera ray that reaches object-space point p.
vec3 ray_towards(vec3 p) { return u_orthographic ? u_view_dir : normalize(p - u_eye); }

#ifdef RAYWARP_FRAGMENT
// The ray through this fragment's pixel centre, from the near plane to the far plane.
void fragment_ray(out vec3 origin, out vec3 direction, out float t_far) {
  vec2 ndc = gl_FragCoord.xy / u_viewport * 2.0 - 1.0;
  vec4 near_h = u_inv_view_proj * vec4(ndc, -1.0, 1.0);
  vec4 far_h = u_inv_view_proj * vec4(ndc, 1.0, 1.0);
  origin = near_h.xyz / near_h.w;
  vec3 to_far = far_h.xyz / far_h.w - origin;
  t_far = length(to_far);
  direction = to_far / t_far;
}

float window_depth(vec3 p) {
  vec4 clip = u_view_proj * vec4(p, 1.0);
  return clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0);
}
#endif
