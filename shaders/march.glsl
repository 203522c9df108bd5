// The ray caster of pass 2 (Correa & Silver 2007, sections 3 and 5) as functions of a ray in the
// box's local frame (object units): raywarp_clip and raywarp_cast, at the end. raywarp's fragment
// shader (raycast.frag.glsl) calls them, and so do the engines' shaders, which are translated from
// this text (docs/engines.md): it keeps to what GLSL 4.50, GLSL ES 3.00, HLSL (through SPIR-V) and
// Godot's shading language share. Textures are read at an explicit level 0 (textureLod: no
// mipmaps, and D3D refuses implicit derivatives in loops of varying length); matrices that an
// engine fills are passed as rows (vectors have one layout in every language). The same
// algorithm, in double, is raywarp::ray_cast_box in verify/reference.cpp: keep the two in step.
//
// Variants: the renderer #defines the macros of the box's features (gl/raycast_tables.h,
// kFeatures): one of RAYWARP_SAMPLING_LINEAR, _THRESHOLD, _JACOBIAN, _BOUNDED (sphere tracing with
// Lipschitz-bounded steps; continuous deformations only); RAYWARP_CUT (an alpha map) with one of
// RAYWARP_CUT_HOLLOW, _SOLID, _THICK (a shell of thickness tau), or none; RAYWARP_MOVES_NOTHING
// (D = 0: no deformation texture is read, and a sample just beyond the box after one inside it
// reads the distance grid, for the caps of a box cut); RAYWARP_SKIP (empty-space skipping);
// RAYWARP_TEXTURE_MAP (D and A read at M p', eq. 2's mapping); RAYWARP_DEPTH_CUBE (the implicit is a
// depth-map cube, library/depth_cube.h, not the distance grid: no skipping by f, whose |f| is no
// distance bound); RAYWARP_CYLINDRICAL (D and A stored over (angle, radius, height) about an axis
// of the box, library/cylindrical.h: D read as the preimage's cylindrical coordinates minus the
// point's, the angle periodic; no texture map M, no skipping). The samplers' units are
// kTextureUnits'.
#if defined(RAYWARP_SAMPLING_LINEAR) + defined(RAYWARP_SAMPLING_THRESHOLD) + defined(RAYWARP_SAMPLING_JACOBIAN) + defined(RAYWARP_SAMPLING_BOUNDED) != 1
#error a variant has exactly one RAYWARP_SAMPLING_* feature
#endif
#if defined(RAYWARP_CUT) != defined(RAYWARP_CUT_HOLLOW) + defined(RAYWARP_CUT_SOLID) + defined(RAYWARP_CUT_THICK)
#error a variant has RAYWARP_CUT and one RAYWARP_CUT_* mode, or neither
#endif
uniform vec3 u_half_extents;
uniform vec3 u_region_lower;      // where rays are cast
uniform vec3 u_region_upper;
#ifdef RAYWARP_DEPTH_CUBE
uniform sampler3D u_depth;        // map H_k in slice k of 8: faces -x, +x, -y, +y, -z, +z
uniform vec2 u_depth_origin_x;    // per axis: lower corner of its maps' texel grid on the face
uniform vec2 u_depth_origin_y;    // (one uniform per axis, not an array: engines' material
uniform vec2 u_depth_origin_z;    // properties have no arrays)
uniform vec2 u_depth_last_x;      // per axis: its maps' last texel centre (n_u - 1, n_v - 1)
uniform vec2 u_depth_last_y;
uniform vec2 u_depth_last_z;
uniform vec2 u_depth_layer;       // texels of a slice (each map lies in its lower corner)
#else
uniform sampler3D u_sdf;          // f > 0 inside, object units
uniform vec3 u_sdf_origin;        // lower corner of the grid region
uniform vec3 u_sdf_size;          // dims * spacing
#endif
uniform float u_sdf_decode;       // the implicit's object units per stored unit (1: decoded)
uniform float u_sdf_spacing;      // the implicit's voxel (depth cube: its maps' texel)
uniform float u_background;       // |f| of an invalid sample (grid: beyond its narrow band)
uniform float u_step;             // linear-search step, object units
uniform int u_max_steps;
uniform int u_refine_steps;
uniform float u_seam;             // tolerance at box faces, object units
#ifndef RAYWARP_MOVES_NOTHING
uniform sampler3D u_deformation;  // xyz: D(p') (p = p' + D), w: validity
uniform vec3 u_def_origin;
uniform vec3 u_def_size;
uniform vec3 u_def_spacing;       // texel sides per axis
uniform vec4 u_def_decode;        // per channel, object units per stored unit (1 when decoded)
#endif
#ifdef RAYWARP_TEXTURE_MAP
uniform vec4 u_texture_map_x;     // the rows of M (eq. 2): D is read at M p'
uniform vec4 u_texture_map_y;
uniform vec4 u_texture_map_z;
#endif
#ifdef RAYWARP_CYLINDRICAL
uniform vec3 u_cyl_e_u;           // the axis e_a and the next two cyclically, e_u and e_v
uniform vec3 u_cyl_e_v;
uniform vec3 u_cyl_e_a;
#endif
#ifdef RAYWARP_CUT
uniform sampler3D u_alpha;        // A(p') > 0 inside the cut: a signed distance to its boundary
uniform vec3 u_alpha_origin;
uniform vec3 u_alpha_size;
uniform vec3 u_alpha_spacing;
uniform float u_alpha_decode;     // object units per stored unit (1 when uploaded decoded)
#endif
#ifdef RAYWARP_CUT_THICK
uniform float u_thickness;        // tau of eq. 7
#endif
#ifdef RAYWARP_SAMPLING_THRESHOLD
uniform float u_threshold;        // object units
uniform float u_fine_factor;
#endif
#ifdef RAYWARP_SAMPLING_BOUNDED
uniform sampler3D u_bricks;       // per brick of D: bound of |I + J_D| there and around (NEAREST)
uniform vec3 u_brick_origin;      // D's first texel centre
uniform vec3 u_brick_spacing;     // brick sides per axis, object units
uniform sampler3D u_sdf_bricks;   // per brick of the distance grid: bound of |grad f| (NEAREST)
uniform vec3 u_sdf_brick_origin;  // the grid's first texel centre
uniform float u_sdf_brick_spacing;
uniform float u_inv_lipschitz_w;  // 1 / bound of |grad w| (0: w = 1 everywhere)
uniform float u_epsilon;          // a sample with g > -u_epsilon is the hit
#endif
#ifdef RAYWARP_SKIP
uniform float u_lipschitz;        // bound of |I + J_D| outside the cut
uniform float u_cut_margin;       // sqrt(3) (alpha texel + deformation texel / 2)
#endif
const float kSqrt3 = 1.7320508;
const float kGolden = 0.618034;  // (sqrt(5) - 1) / 2
const int kGrazeSteps = 6;       // golden-section steps for a grazing ray's peak
const float kGrazeMargin = 0.1;  // of the three samples' span: how near the surface their
                                 // parabola's peak must come for the search
// A grazing peak this near the surface (voxels of the distance grid) is the hit: bounded's rule
// (RenderSettings::hit_epsilon_voxels). A depth cube's |f| is no distance: only a peak inside.
#ifdef RAYWARP_DEPTH_CUBE
const float kGrazeHitVoxels = 0.0;
#else
const float kGrazeHitVoxels = 0.02;
#endif

#ifdef RAYWARP_DEPTH_CUBE
// The depth-map cube, as depth_cube_value (library/depth_cube.cpp): per face f_k = d_k - H_k, d_k
// the depth of p from the face; f = min |f_k|, negated unless every f_k > 0. H at the map's
// texel centres, clamped to its outer centres: clamp-to-edge within its corner of the slice.
float distance_at(vec3 p) {
  bool inside = true;
  float nearest = 1e30;
  for (int a = 0; a < 3; ++a) {
    vec2 uv = a == 0 ? p.yz : (a == 1 ? p.xz : p.xy);
    vec2 origin = a == 0 ? u_depth_origin_x : (a == 1 ? u_depth_origin_y : u_depth_origin_z);
    vec2 last = a == 0 ? u_depth_last_x : (a == 1 ? u_depth_last_y : u_depth_last_z);
    vec2 x = clamp((uv - origin) / u_sdf_spacing - 0.5, vec2(0.0), last);
    vec2 tc = (x + 0.5) / u_depth_layer;
    float z = float(2 * a) * 0.125;  // slice k's centre (k + 0.5) / 8, exact in binary
    float h_lo = textureLod(u_depth, vec3(tc, z + 0.0625), 0.0).r * u_sdf_decode;
    float h_hi = textureLod(u_depth, vec3(tc, z + 0.1875), 0.0).r * u_sdf_decode;
    float f_lo = (u_half_extents[a] + p[a]) - h_lo;
    float f_hi = (u_half_extents[a] - p[a]) - h_hi;
    inside = inside && f_lo > 0.0 && f_hi > 0.0;
    nearest = min(nearest, min(abs(f_lo), abs(f_hi)));
  }
  return inside ? nearest : -nearest;
}
#else
float distance_at(vec3 p) {
  return textureLod(u_sdf, (p - u_sdf_origin) / u_sdf_size, 0.0).r * u_sdf_decode;
}
#endif
bool in_box(vec3 p) { return all(lessThanEqual(abs(p), u_half_extents)); }
// Where the textures are read: M p' (eq. 2's mapping), or p'.
vec3 texture_point(vec3 p_def) {
#ifdef RAYWARP_TEXTURE_MAP
  vec4 p = vec4(p_def, 1.0);
  return vec3(dot(u_texture_map_x, p), dot(u_texture_map_y, p), dot(u_texture_map_z, p));
#else
  return p_def;
#endif
}
#ifdef RAYWARP_CYLINDRICAL
// (theta, r, h) of a box-frame point, and back (library/cylindrical.h's convention).
vec3 cylindrical(vec3 p) {
  vec3 q = vec3(dot(u_cyl_e_u, p), dot(u_cyl_e_v, p), dot(u_cyl_e_a, p));
  return vec3(atan(q.y, q.x), length(q.xy), q.z);
}
// A texture coordinate over (theta, r, h) clamped to the texel centres along r and h: the clamp to
// edge done here, so that the sampler may repeat on every axis (an engine such as Godot has one
// wrap mode per texture), the angle alone being periodic.
vec3 cylinder_clamp(vec3 tc, ivec3 dims) {
  vec2 half_texel = 0.5 / vec2(dims.yz);
  return vec3(tc.x, clamp(tc.yz, half_texel, vec2(1.0) - half_texel));
}
vec3 cartesian(vec3 c) { return c.y * cos(c.x) * u_cyl_e_u + c.y * sin(c.x) * u_cyl_e_v + c.z * u_cyl_e_a; }
#endif
#ifndef RAYWARP_MOVES_NOTHING
// (D, w) at p': the texel read at M p', or for a cylindrical texture the preimage's coordinates
// read at p''s, as a Cartesian displacement (no preimage beyond the grid along r or h).
vec4 deformation(vec3 p_def) {
#ifdef RAYWARP_CYLINDRICAL
  vec3 c = cylindrical(p_def);
  vec3 tc = (c - u_def_origin) / u_def_size;
  if (tc.y > 1.0 || tc.z < 0.0 || tc.z > 1.0) return vec4(0.0);
  vec4 t = textureLod(u_deformation, cylinder_clamp(tc, textureSize(u_deformation, 0)), 0.0) *
           u_def_decode;
  return vec4(cartesian(c + t.xyz) - p_def, t.w);
#else
  return textureLod(u_deformation, (texture_point(p_def) - u_def_origin) / u_def_size, 0.0) *
         u_def_decode;
#endif
}
#endif
#ifdef RAYWARP_CUT
float alpha_at(vec3 p_def) {
#ifdef RAYWARP_CYLINDRICAL
  vec3 tc = (cylindrical(p_def) - u_alpha_origin) / u_alpha_size;
  return textureLod(u_alpha, cylinder_clamp(tc, textureSize(u_alpha, 0)), 0.0).r * u_alpha_decode;
#else
  return textureLod(u_alpha, (texture_point(p_def) - u_alpha_origin) / u_alpha_size, 0.0).r *
         u_alpha_decode;
#endif
}
#endif

// One sample of the ray: f at the preimage (valid: the preimage lies in the box) and A.
struct Sample {
  float f;
  float a;
  bool valid;
};

// `beyond_ok`: the previous sample lay in the box. Then, where D is the identity (|D| below the
// seam tolerance), a point beyond the box is read (D = 0 everywhere: beyond every face), and so is
// a point within a deformation texel of a face where the interpolated w falls below 1/2: the texel
// beyond the face holds no preimage, but the point's preimage is itself, in the box.
Sample sample_at(vec3 p_def, bool beyond_ok) {
  Sample s;
#ifdef RAYWARP_MOVES_NOTHING
  s.valid = beyond_ok || in_box(p_def);
  s.f = s.valid ? distance_at(p_def) : -u_background;
#else
  vec4 d = deformation(p_def);
  vec3 p = p_def + d.xyz;
  vec3 past = abs(p_def) - u_half_extents + u_def_spacing;
  bool near_face = max(max(past.x, past.y), past.z) > 0.0;
  bool identity = length(d.xyz) < u_seam;
#ifdef RAYWARP_TEXTURE_MAP
  // Read through M, a texel beyond the box that holds the identity (w = 0 as baked: its
  // preimage, itself, lay outside the box) is the identity here too, and the box decides (a
  // peel's translation reads past the box's -a face; library/texture_map.h).
  bool mapped_out = identity && !in_box(texture_point(p_def));
#else
  bool mapped_out = false;
#endif
  s.valid = in_box(p) && (d.w >= 0.5 || mapped_out || (beyond_ok && near_face && identity));
  s.f = s.valid ? distance_at(p) : -u_background;
#endif
#ifdef RAYWARP_CUT
  s.a = alpha_at(p_def);
#else
  s.a = -1.0;
#endif
  return s;
}

#ifdef RAYWARP_CUT_HOLLOW
// The deformation moves p' by less than the seam tolerance.
bool identity_at(vec3 p_def) {
#ifdef RAYWARP_MOVES_NOTHING
  return true;
#else
  return length(deformation(p_def).xyz) < u_seam;
#endif
}
#endif

// The surface function: f, or eq. 7's shell f^ = tau - f where f > tau / 2.
float surface(float f) {
#ifdef RAYWARP_CUT_THICK
  return min(f, u_thickness - f);
#else
  return f;
#endif
}

// The solid the ray looks for, > 0 inside: the surface minus the cut (a CSG difference, which
// finds the first point inside the object and outside the cut, as section 5.1.2's search does).
float value(Sample s) {
  if (!s.valid) return -u_background;
#if defined(RAYWARP_CUT_SOLID) || defined(RAYWARP_CUT_THICK)
  return min(surface(s.f), -s.a);
#else
  return s.f;
#endif
}

// The value whose nearness to 0 the threshold method watches.
#ifdef RAYWARP_CUT_HOLLOW
#define RAYWARP_THRESHOLD_VALUE s.f
#else
#define RAYWARP_THRESHOLD_VALUE value(s)
#endif

#ifdef RAYWARP_SKIP
// How far the ray may advance without passing a hit. Trilinear interpolation of a texture whose
// texels differ by at most one spacing per axis is sqrt(3)-Lipschitz, and f(p' + D(p')) is
// sqrt(3) u_lipschitz-Lipschitz outside the cut.
float skip_distance(Sample s) {
  if (!s.valid) return 0.0;
#ifdef RAYWARP_CUT
  if (s.a > 0.0) return s.a / kSqrt3;  // inside the cut: A stays > 0 (section 6.2)
#endif
#ifdef RAYWARP_DEPTH_CUBE
  float skip = 0.0;                    // a depth cube's |f| bounds no distance: no skip by it
#else
#ifdef RAYWARP_CUT_HOLLOW
  float room = abs(s.f);               // a thin shell: no sign change of f
#else
  float room = -surface(s.f);          // outside the solid: f^ stays < 0
#endif
  float skip = room / (kSqrt3 * u_lipschitz);
#endif
#if defined(RAYWARP_CUT) && !defined(RAYWARP_MOVES_NOTHING)
  skip = min(skip, -s.a - u_cut_margin);  // the bound holds only away from the cut
#endif
  return skip;
}
#endif

#if defined(RAYWARP_SAMPLING_JACOBIAN) && !defined(RAYWARP_MOVES_NOTHING)
// Eq. 4: dt = ds / |(I + J_D) v|, the step whose preimage moves by ds; J_D by central
// differences of D. Clamped to [ds / 16, 4 ds] so that every ray stays bounded.
float jacobian_step(vec3 p_def, vec3 v) {
  float h = min(min(u_def_spacing.x, u_def_spacing.y), u_def_spacing.z);
  vec3 jv = (deformation(p_def + h * v).xyz - deformation(p_def - h * v).xyz) / (2.0 * h);
  return u_step / clamp(length(v + jv), 0.25, 16.0);
}
#endif

#ifdef RAYWARP_SAMPLING_BOUNDED
// g(p') = min(f(p), b(p), (w - 1/2) / L_w) at p = p' + D(p') (library/textures.h, StepBounds):
// > 0 exactly where the linear search's sample is inside; b is the distance to the box faces.
float bounded_g(vec3 p_def, out vec3 p) {
  vec4 dv = deformation(p_def);
  p = p_def + dv.xyz;
  vec3 room = u_half_extents - abs(p);
  float g = min(distance_at(p), min(min(room.x, room.y), room.z));
  if (u_inv_lipschitz_w > 0.0) g = min(g, (dv.w - 0.5) * u_inv_lipschitz_w);
  return g;
}

float brick_at(sampler3D bricks, vec3 origin, vec3 spacing, vec3 q) {
  ivec3 b = clamp(ivec3(floor(clamp((q - origin) / spacing, -1.0, 1e9))), ivec3(0),
                  textureSize(bricks, 0) - 1);
  return texelFetch(bricks, b, 0).r;
}

// The longest step from p' (preimage p) that passes no point where g > 0: |g| / (L_f L_D), at
// most min(B_D, B_f / L_D) so that the bounds' bricks hold it.
float bounded_step(vec3 p_def, vec3 p, float g) {
  float l_d = brick_at(u_bricks, u_brick_origin, u_brick_spacing, p_def);
  float l_f = brick_at(u_sdf_bricks, u_sdf_brick_origin, vec3(u_sdf_brick_spacing), p);
  float b_d = min(min(u_brick_spacing.x, u_brick_spacing.y), u_brick_spacing.z);
  return min(-g / (l_f * l_d), min(b_d, u_sdf_brick_spacing / l_d));
}
#endif

vec3 gradient_f(vec3 p) {
  float h = u_sdf_spacing;
  return vec3(distance_at(p + vec3(h, 0, 0)) - distance_at(p - vec3(h, 0, 0)),
              distance_at(p + vec3(0, h, 0)) - distance_at(p - vec3(0, h, 0)),
              distance_at(p + vec3(0, 0, h)) - distance_at(p - vec3(0, 0, h))) / (2.0 * h);
}

// Outward normal of the deformed surface, eq. 5: (I + J_D)^T n(p + D(p')), with both
// derivatives by central differences of the textures.
vec3 deformed_normal(vec3 p_def) {
#ifdef RAYWARP_MOVES_NOTHING
  return -gradient_f(p_def);
#else
  vec3 p = p_def + deformation(p_def).xyz;
  vec3 hd = u_def_spacing;
  mat3 jd;  // columns: dD/dx, dD/dy, dD/dz
  jd[0] = (deformation(p_def + vec3(hd.x, 0, 0)).xyz - deformation(p_def - vec3(hd.x, 0, 0)).xyz) / (2.0 * hd.x);
  jd[1] = (deformation(p_def + vec3(0, hd.y, 0)).xyz - deformation(p_def - vec3(0, hd.y, 0)).xyz) / (2.0 * hd.y);
  jd[2] = (deformation(p_def + vec3(0, 0, hd.z)).xyz - deformation(p_def - vec3(0, 0, hd.z)).xyz) / (2.0 * hd.z);
  return transpose(mat3(1.0) + jd) * (-gradient_f(p));
#endif
}

#ifdef RAYWARP_CUT
// The cut face's outward normal (into the cut): grad A (eq. 6).
vec3 alpha_gradient(vec3 p_def) {
  vec3 h = u_alpha_spacing;
  return vec3(alpha_at(p_def + vec3(h.x, 0, 0)) - alpha_at(p_def - vec3(h.x, 0, 0)),
              alpha_at(p_def + vec3(0, h.y, 0)) - alpha_at(p_def - vec3(0, h.y, 0)),
              alpha_at(p_def + vec3(0, 0, h.z)) - alpha_at(p_def - vec3(0, 0, h.z))) / (2.0 * h);
}
#endif


// The surfaces raywarp_cast reports: the mesh's outer surface, and with a cut its inside (a shell
// seen through the cut) and the cut faces.
const int kRaywarpOuter = 0;
#ifdef RAYWARP_CUT
const int kRaywarpInner = 1;
const int kRaywarpCutFace = 2;
#endif

// The part [t0, t1] of the ray o + t d (box frame, object units, d a unit vector) that lies in the
// ray-cast region u_region_lower .. u_region_upper, from t = 0 up to t_far (slab method); false
// when it misses the region.
bool raywarp_clip(vec3 o, vec3 d, float t_far, out float t0, out float t1) {
  vec3 inv = 1.0 / d;
  vec3 ta = (u_region_lower - o) * inv, tb = (u_region_upper - o) * inv;
  t0 = max(max(max(min(ta.x, tb.x), min(ta.y, tb.y)), min(ta.z, tb.z)), 0.0);
  t1 = min(min(min(max(ta.x, tb.x), max(ta.y, tb.y)), max(ta.z, tb.z)), t_far);
  return t0 < t1;
}

// The peak of the parabola through (x0, y0), (x1, y1), (x2, y2), x0 < x1 < x2, y1 above both
// others.
float parabola_peak(float x0, float x1, float x2, float y0, float y1, float y2) {
  float d1 = (y1 - y0) / max(x1 - x0, 1e-30), d2 = (y2 - y1) / max(x2 - x1, 1e-30);
  float a = (d2 - d1) / max(x2 - x0, 1e-30);  // < 0
  float b = (d1 * (x2 - x1) + d2 * (x1 - x0)) / max(x2 - x0, 1e-30);  // slope at x1
  return a < 0.0 ? y1 - b * b / (4.0 * a) : y1;
}

// The ray caster (sections 3 and 5), one function that every front end calls: raywarp's fragment
// shader (raycast.frag.glsl), the engines' shaders translated from this text, the CPU reference's
// twin (verify/reference.cpp). Searches [t0, t1] (raywarp_clip) of the ray o + t d in the box frame
// for the deformed surface; on a hit gives its t, its outward normal in the box frame (eq. 5, or
// eq. 6's grad A on a cut face; not normalised) and which surface it is (kRaywarp*).
bool raywarp_cast(vec3 o, vec3 d, float t0, float t1, out float t_hit, out vec3 normal,
                  out int surface_kind) {
  t_hit = t0;
  normal = vec3(0.0, 0.0, 1.0);
  surface_kind = kRaywarpOuter;
  vec3 inv = 1.0 / d;
  // Besides the regular samples (or skips), one just before each crossing of a box face plane:
  // that catches slivers of S_D thinner than a step that end on a face (at the seam with the
  // raster pass, where a missed sliver would show the mesh's inside).
  float before = 1e-3 * u_step;
  vec3 cross_lo = (-u_half_extents - o) * inv - before, cross_hi = (u_half_extents - o) * inv - before;

  float t = t0, lo = t0, hi = t0;
#ifdef RAYWARP_SAMPLING_BOUNDED
  // Sphere tracing of g: a step of |g| / L, at most a brick side, never passes a point where
  // g > 0; plus the samples before the face planes, where the seam tolerance applies.
  vec3 p_pre;
  float g = bounded_g(o + t0 * d, p_pre);
  bool hit = g > -u_epsilon;
  for (int i = 1; i <= u_max_steps + 6 && !hit && t < t1; ++i) {
    vec3 a = mix(vec3(1e30), cross_lo, greaterThan(cross_lo, vec3(t)));
    vec3 b = mix(vec3(1e30), cross_hi, greaterThan(cross_hi, vec3(t)));
    vec3 m = min(a, b);
    float next_crossing = min(min(m.x, m.y), m.z);
    float target = min(t + bounded_step(o + t * d, p_pre, g), t1);
    bool at_face = next_crossing < target;
    float tn = at_face ? next_crossing : target;
    vec3 pn_pre;
    float gn = bounded_g(o + tn * d, pn_pre);
    if (gn > 0.0) {  // only by rounding: refine between the two samples
      hit = true;
      lo = t;
      hi = tn;
    } else if (gn > -u_epsilon || (at_face && value(sample_at(o + tn * d, true)) > -u_seam)) {
      hit = true;
      lo = tn;
      hi = tn;
    }
    t = tn;
    g = gn;
    p_pre = pn_pre;
  }
#else
  bool was_in_box = in_box(o + t0 * d);
  Sample s = sample_at(o + t0 * d, false);
#ifdef RAYWARP_CUT_HOLLOW
  bool hit = false, front = true;
#else
  bool hit = value(s) > 0.0;
#endif
#ifndef RAYWARP_CUT_HOLLOW
  float t_before = t0, v_before = -1e30;  // the sample before the last one
  bool grazed = false;                    // the first grazing bracket, if any
  float graze_l = t0, graze_r = t0;
#endif
  // Linear search, bounded by u_max_steps (+ the 6 face samples).
  for (int i = 1; i <= u_max_steps + 6 && !hit && t < t1; ++i) {
    float advance = u_step;
#ifdef RAYWARP_SAMPLING_THRESHOLD
    // Within the threshold the fine step; beyond it no longer than |value|, the distance a
    // surface needs to reach the ray where the deformation stretches nothing (a thin part just
    // past the threshold is not stepped over), and at most the coarse step.
    float watched = abs(RAYWARP_THRESHOLD_VALUE);
    if (s.valid) advance = watched < u_threshold ? u_step * u_fine_factor : min(watched, u_step);
#elif defined(RAYWARP_SAMPLING_JACOBIAN) && !defined(RAYWARP_MOVES_NOTHING)
    advance = jacobian_step(o + t * d, d);
#endif
#ifdef RAYWARP_SKIP
    advance = max(advance, skip_distance(s));
#endif
    vec3 a = mix(vec3(1e30), cross_lo, greaterThan(cross_lo, vec3(t)));
    vec3 b = mix(vec3(1e30), cross_hi, greaterThan(cross_hi, vec3(t)));
    vec3 m = min(a, b);
    float next_crossing = min(min(m.x, m.y), m.z);
    float target = min(t + advance, t1);
    bool at_face = next_crossing < target;
    float tn = at_face ? next_crossing : target;
    vec3 pn = o + tn * d;
    Sample sn = sample_at(pn, was_in_box);
#ifdef RAYWARP_CUT_HOLLOW
    // A thin shell: any change of sign of f, kept where it lies outside the cut (section 5.1.1).
    if (s.valid && sn.valid && (s.f > 0.0) != (sn.f > 0.0)) {
      bool inside = s.f > 0.0;
      float l = t, r = tn;
      for (int k = 0; k < u_refine_steps; ++k) {
        float mid = 0.5 * (l + r);
        if ((sample_at(o + mid * d, true).f > 0.0) == inside) l = mid; else r = mid;
      }
      if (alpha_at(o + 0.5 * (l + r) * d) <= 0.0) {
        hit = true;
        front = !inside;
        lo = l;
        hi = r;
      }
    }
    // At a face, within u_seam of the surface counts as reaching it (see below).
    if (!hit && at_face && s.valid && sn.valid && s.f <= 0.0 && sn.f > -u_seam && sn.a <= 0.0) {
      hit = true;
      lo = tn;
      hi = tn;
    }
    // Entering the box's preimage, the sample before the face is not valid, so a surface within
    // the first step past the face changes no sign between samples. Where the deformation is the
    // identity there (the raster pass's mesh goes on into the box), a first sample inside the
    // solid means the ray entered it since the last sample: refine for that crossing, reading f
    // beyond the face, and it is the front surface.
    if (!hit && !s.valid && sn.valid && sn.f > 0.0 && sn.a <= 0.0 && identity_at(pn)) {
      float l = t, r = tn;
      for (int k = 0; k < u_refine_steps; ++k) {
        float mid = 0.5 * (l + r);
        if (sample_at(o + mid * d, true).f > 0.0) r = mid; else l = mid;
      }
      hit = true;
      front = true;
      lo = l;
      hi = r;
    }
#else
    float v = value(sn);
    if (v > 0.0) {
      hit = true;
      lo = t;
      hi = tn;
    } else if (at_face && v > -u_seam) {
      // At a face the implicit surface may lie up to a fraction of a voxel inside the mesh that
      // the raster pass draws beyond the face: within u_seam of it counts as the hit, so no
      // crack opens between the passes.
      hit = true;
      lo = tn;
      hi = tn;
    }
#ifdef RAYWARP_CUT
    else if (s.valid && sn.valid && s.a > 0.0 && sn.a <= 0.0 && surface(s.f) > 0.0) {
      // The step crossed a cut face from the object's removed part: the object may go on for
      // less than a step past the face (near a cap's outline, where the face meets the
      // surface). Its crossing, found by bisection on A, and just past it.
      float l = t, r = tn;
      for (int k = 0; k < u_refine_steps; ++k) {
        float mid = 0.5 * (l + r);
        if (sample_at(o + mid * d, true).a > 0.0) l = mid; else r = mid;
      }
      if (surface(sample_at(o + r * d, true).f) > 0.0) {
        hit = true;
        lo = l;
        hi = r;
      }
    }
#endif
#endif
#ifndef RAYWARP_CUT_HOLLOW
    // A grazing ray: the value peaks at the last sample, between two lower ones, and the
    // parabola through the three comes near the surface. The surface may reach past the ray
    // between the samples (a silhouette, a thin part); the first such bracket is searched after
    // the march.
    float v_last = value(s);
    if (!hit && !grazed && s.valid && sn.valid && v_last > v && v_last > v_before &&
        parabola_peak(t_before, t, tn, v_before, v_last, v) > -kGrazeMargin * (tn - t_before)) {
      grazed = true;
      graze_l = t_before;
      graze_r = tn;
    }
    t_before = t;
    v_before = s.valid ? v_last : -1e30;
#endif
    t = tn;
    s = sn;
    was_in_box = in_box(pn);
  }
#endif
#if !defined(RAYWARP_CUT_HOLLOW) && !defined(RAYWARP_SAMPLING_BOUNDED)
  // The first grazing bracket in front of the hit (or with no hit): golden-section search for
  // the value's peak in it, and the hit there where the peak is inside or within
  // kGrazeHitVoxels of the surface.
  if (grazed && (!hit || graze_r <= lo)) {
    float l = graze_l, r = graze_r;
    float x1 = r - kGolden * (r - l), x2 = l + kGolden * (r - l);
    float f1 = value(sample_at(o + x1 * d, true)), f2 = value(sample_at(o + x2 * d, true));
    float near_enough = -kGrazeHitVoxels * u_sdf_spacing;
    for (int k = 0; k < kGrazeSteps && max(f1, f2) <= near_enough; ++k) {
      if (f1 > f2) {
        r = x2;
        x2 = x1;
        f2 = f1;
        x1 = r - kGolden * (r - l);
        f1 = value(sample_at(o + x1 * d, true));
      } else {
        l = x1;
        x1 = x2;
        f1 = f2;
        x2 = l + kGolden * (r - l);
        f2 = value(sample_at(o + x2 * d, true));
      }
    }
    if (max(f1, f2) > near_enough) {
      hit = true;
      lo = graze_l;
      hi = f1 > near_enough ? x1 : x2;
    }
  }
#endif
  if (!hit) return false;
#ifndef RAYWARP_CUT_HOLLOW
  // Binary refinement between the last outside and the first inside sample.
  for (int i = 0; i < u_refine_steps; ++i) {
    float mid = 0.5 * (lo + hi);
    if (value(sample_at(o + mid * d, true)) > 0.0) hi = mid; else lo = mid;
  }
#endif
  t_hit = 0.5 * (lo + hi);
  vec3 p_def = o + t_hit * d;
  normal = deformed_normal(p_def);
#ifdef RAYWARP_CUT_HOLLOW
  if (!front) {  // the inside of the shell
    normal = -normal;
    surface_kind = kRaywarpInner;
  }
#elif defined(RAYWARP_CUT_SOLID) || defined(RAYWARP_CUT_THICK)
  // Eq. 6: on the object's surface the normal of eq. 5, on the cut face grad A.
  Sample sh = sample_at(p_def, true);
  if (surface(sh.f) > -sh.a) {
    normal = alpha_gradient(p_def);
    surface_kind = kRaywarpCutFace;
  }
#ifdef RAYWARP_CUT_THICK
  else if (sh.f > 0.5 * u_thickness) {  // the shell's inner surface
    normal = -normal;
    surface_kind = kRaywarpInner;
  }
#endif
#endif
  return true;
}
