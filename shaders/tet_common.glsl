// Per-element 2D textures, kWidth texels a row.
const int kWidth = RAYWARP_TEXTURE_WIDTH;
ivec2 texel(int i) { return ivec2(i % kWidth, i / kWidth); }
const float kInfinity = uintBitsToFloat(0x7F800000u);

#ifdef RAYWARP_FRAGMENT
// The ray through this fragment's pixel centre as Camera::pixel_ray builds it (centred frame):
// from the eye (perspective) or the image plane (orthographic), t over [t_min, t_max] between
// the near and far planes.
uniform vec3 u_ray_eye;      // the eye, less the centre
uniform vec3 u_ray_forward;  // f
uniform vec3 u_ray_right;    // s times tan(fov / 2) aspect (perspective) or the half width
uniform vec3 u_ray_up;       // u times tan(fov / 2) (perspective) or the half height
uniform vec2 u_ray_planes;   // near, far
uniform vec2 u_ray_size;     // the image in pixels
uniform bool u_ray_orthographic;
void pixel_ray(out vec3 origin, out vec3 direction, out float t_min, out float t_max) {
  vec2 ndc = gl_FragCoord.xy / u_ray_size * 2.0 - 1.0;
  if (u_ray_orthographic) {
    origin = u_ray_eye + ndc.x * u_ray_right + ndc.y * u_ray_up;
    direction = u_ray_forward;
    t_min = u_ray_planes.x;
    t_max = u_ray_planes.y;
  } else {
    vec3 d = u_ray_forward + ndc.x * u_ray_right + ndc.y * u_ray_up;
    float len = length(d);
    origin = u_ray_eye;
    direction = d / len;
    t_min = u_ray_planes.x * len;
    t_max = u_ray_planes.y * len;
  }
}
#endif
