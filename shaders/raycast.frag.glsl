// Pass 2: ray casting of the deformed part of the mesh (Correa & Silver 2007, section 5).
// Everything is in the box's local frame (object units). The same algorithm, in double, is
// raywarp::ray_cast_box in library/reference.cpp: keep the two in step.
#include "camera.glsl"
#include "shading.glsl"
uniform mat4 u_object_to_box;
uniform mat3 u_box_to_object_dir;
uniform vec3 u_half_extents;
uniform sampler3D u_sdf;          // f > 0 inside, object units
uniform vec3 u_sdf_origin;        // lower corner of the grid region
uniform vec3 u_sdf_size;          // dims * spacing
uniform float u_sdf_spacing;
uniform float u_background;       // |f| beyond the narrow band
uniform sampler3D u_deformation;  // xyz: D(p') (p = p' + D), w: validity
uniform vec3 u_def_origin;
uniform vec3 u_def_size;
uniform float u_def_spacing;
uniform float u_step;             // linear-search step, object units
uniform int u_max_steps;
uniform int u_refine_steps;
uniform float u_seam;             // tolerance at box faces, object units
layout(location = 0) out vec4 out_colour;
layout(location = 1) out float out_depth;

vec4 deformation(vec3 p_def) { return texture(u_deformation, (p_def - u_def_origin) / u_def_size); }
float distance_at(vec3 p) { return texture(u_sdf, (p - u_sdf_origin) / u_sdf_size).r; }

// g(p') = f(p' + D(p')), the implicit surface seen through the inverse displacement; empty
// where p' has no preimage in the box.
float g(vec3 p_def) {
  vec4 d = deformation(p_def);
  if (d.w < 0.5) return -u_background;
  vec3 p = p_def + d.xyz;
  if (any(greaterThan(abs(p), u_half_extents))) return -u_background;
  return distance_at(p);
}

// Outward normal of the deformed surface, eq. 5: (I + J_D)^T n(p + D(p')), with both
// derivatives by central differences of the textures.
vec3 deformed_normal(vec3 p_def) {
  vec3 p = p_def + deformation(p_def).xyz;
  float hf = u_sdf_spacing, hd = u_def_spacing;
  vec3 grad_f = vec3(distance_at(p + vec3(hf, 0, 0)) - distance_at(p - vec3(hf, 0, 0)),
                     distance_at(p + vec3(0, hf, 0)) - distance_at(p - vec3(0, hf, 0)),
                     distance_at(p + vec3(0, 0, hf)) - distance_at(p - vec3(0, 0, hf))) / (2.0 * hf);
  mat3 jd;  // columns: dD/dx, dD/dy, dD/dz
  jd[0] = (deformation(p_def + vec3(hd, 0, 0)).xyz - deformation(p_def - vec3(hd, 0, 0)).xyz) / (2.0 * hd);
  jd[1] = (deformation(p_def + vec3(0, hd, 0)).xyz - deformation(p_def - vec3(0, hd, 0)).xyz) / (2.0 * hd);
  jd[2] = (deformation(p_def + vec3(0, 0, hd)).xyz - deformation(p_def - vec3(0, 0, hd)).xyz) / (2.0 * hd);
  return transpose(mat3(1.0) + jd) * (-grad_f);
}

void main() {
  vec3 origin_obj, dir_obj;
  float t_far;
  fragment_ray(origin_obj, dir_obj, t_far);
  vec3 o = (u_object_to_box * vec4(origin_obj, 1.0)).xyz;
  vec3 d = transpose(u_box_to_object_dir) * dir_obj;

  // Clip the ray to the deformation texture's region (slab method).
  vec3 inv = 1.0 / d;
  vec3 ta = (u_def_origin - o) * inv, tb = (u_def_origin + u_def_size - o) * inv;
  float t0 = max(max(max(min(ta.x, tb.x), min(ta.y, tb.y)), min(ta.z, tb.z)), 0.0);
  float t1 = min(min(min(max(ta.x, tb.x), max(ta.y, tb.y)), max(ta.z, tb.z)), t_far);
  if (t0 >= t1) discard;

  // The samples are the regular ones, t0 + i * u_step, merged with one just before each crossing
  // of a box face plane: that catches slivers of S_D thinner than a step that end on a face
  // (at the seam with the raster pass, where a missed sliver would show the mesh's inside).
  float before = 1e-3 * u_step;
  vec3 cross_lo = (-u_half_extents - o) * inv - before, cross_hi = (u_half_extents - o) * inv - before;

  // Linear search, bounded by u_max_steps (+ the 6 face samples).
  float lo = t0, hi = t0, regular = t0 + u_step;
  bool hit = g(o + t0 * d) > 0.0;
  for (int i = 1; i <= u_max_steps + 6 && !hit; ++i) {
    lo = hi;
    vec3 a = mix(vec3(1e30), cross_lo, greaterThan(cross_lo, vec3(lo)));
    vec3 b = mix(vec3(1e30), cross_hi, greaterThan(cross_hi, vec3(lo)));
    vec3 m = min(a, b);
    float next_crossing = min(min(m.x, m.y), m.z);
    bool at_face = next_crossing < min(regular, t1);
    if (at_face) {
      hi = next_crossing;
    } else {
      hi = min(regular, t1);
      regular += u_step;
    }
    float value = g(o + hi * d);
    hit = value > 0.0;
    // At a face the implicit surface may lie up to a fraction of a voxel inside the mesh that
    // the raster pass draws beyond the face: within u_seam of it counts as the hit, so no crack
    // opens between the passes.
    if (at_face && !hit && value > -u_seam) {
      hit = true;
      lo = hi;
    }
    if (hi >= t1) break;
  }
  if (!hit) discard;
  // Binary refinement between the last outside and the first inside sample.
  for (int i = 0; i < u_refine_steps; ++i) {
    float mid = 0.5 * (lo + hi);
    if (g(o + mid * d) > 0.0) hi = mid; else lo = mid;
  }
  vec3 p_def = o + 0.5 * (lo + hi) * d;
  vec3 p_obj = origin_obj + 0.5 * (lo + hi) * dir_obj;

  out_colour = shade(u_box_to_object_dir * deformed_normal(p_def), dir_obj);
  out_depth = linear_depth(p_obj);
  gl_FragDepth = window_depth(p_obj);
}
