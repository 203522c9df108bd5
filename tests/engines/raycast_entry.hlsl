// A stand-in engine for the round trip of tests/engine_shaders_test.cpp: raywarp's pass 2
// (shaders/raycast.frag.glsl) written in HLSL against the translated march, the way an engine's
// shader calls it, with D3D's conventions (pixel rows from the top, mul(M, v) with matrices as
// set from C++). The test puts before it either the include (Unity's form) or the struct form
// (Unreal's) with RAYWARP_MARCH_SETUP and RAYWARP_MARCH(f) defined to reach the functions; it is
// compiled by glslang's HLSL front end, carried to GLSL by SPIRV-Cross and drawn by raywarp's own
// renderer in place of raycast.frag.glsl, with the uniforms the renderer sets.
float4x4 u_view_proj;
float4x4 u_inv_view_proj;
float2 u_viewport;
float4x4 u_object_to_box;
float3x3 u_box_to_object_dir;
float3 u_eye;
float3 u_view_dir;
float3 u_albedo;
float3 u_inside_colour;
float3 u_cut_colour;

struct PixelOut {
  float4 colour : SV_Target0;
  float depth : SV_Target1;
  float window_depth : SV_Depth;
};

float3 srgb_encode(float3 c) {
  c = saturate(c);
  return lerp(12.92 * c, 1.055 * pow(c, 1.0 / 2.4) - 0.055, step(0.0031308, c));
}

PixelOut main(float4 position : SV_Position) {
  // The pixel's ray from the near plane to the far plane (camera.glsl's fragment_ray).
  float2 ndc = float2(position.x / u_viewport.x * 2.0 - 1.0, 1.0 - position.y / u_viewport.y * 2.0);
  float4 near_h = mul(u_inv_view_proj, float4(ndc, -1.0, 1.0));
  float4 far_h = mul(u_inv_view_proj, float4(ndc, 1.0, 1.0));
  float3 origin = near_h.xyz / near_h.w;
  float3 to_far = far_h.xyz / far_h.w - origin;
  float t_far = length(to_far);
  float3 dir = to_far / t_far;
  float3 o = mul(u_object_to_box, float4(origin, 1.0)).xyz;
  float3 d = mul(transpose(u_box_to_object_dir), dir);

  RAYWARP_MARCH_SETUP
  float t0 = 0.0, t1 = 0.0, t = 0.0;
  float3 normal = float3(0.0, 0.0, 1.0);
  int kind = 0;
  if (!RAYWARP_MARCH(raywarp_clip)(o, d, t_far, t0, t1) ||
      !RAYWARP_MARCH(raywarp_cast)(o, d, t0, t1, t, normal, kind))
    discard;
  float3 p = origin + t * dir;
  float3 albedo = kind == 1 ? u_inside_colour : (kind == 2 ? u_cut_colour : u_albedo);
  float3 n = normalize(mul(u_box_to_object_dir, normal));
  float lambert = max(dot(n, -dir), 0.0);
  PixelOut result;
  result.colour = float4(srgb_encode(albedo * (0.2 + 0.8 * lambert)), 1.0);
  result.depth = dot(p - u_eye, u_view_dir);
  float4 clip = mul(u_view_proj, float4(p, 1.0));
  result.window_depth = saturate(0.5 * clip.z / clip.w + 0.5);
  return result;
}
