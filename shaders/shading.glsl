// Shading shared by the raster and ray-cast passes, so the seam between them is invisible.
// A headlight: the light comes from the eye along the ray. Must match verify/reference.cpp.
uniform vec3 u_albedo;         // linear RGB
uniform vec3 u_inside_colour;  // the inside of a shell, seen through a cut

// Must match the C++ srgb_encode (library/image.h), which the CPU reference and the
// renderer's clear colour use.
vec3 srgb_encode(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

vec4 shade_albedo(vec3 normal, vec3 ray_direction, vec3 albedo) {
  float lambert = max(dot(normalize(normal), -ray_direction), 0.0);
  return vec4(srgb_encode(albedo * (0.2 + 0.8 * lambert)), 1.0);
}

vec4 shade(vec3 normal, vec3 ray_direction) { return shade_albedo(normal, ray_direction, u_albedo); }
