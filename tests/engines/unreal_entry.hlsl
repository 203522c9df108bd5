// A stand-in Unreal material for the round trip of tests/engine_shaders_test.cpp: the Custom
// node's code (engines/unreal/RaywarpCustomNode.hlsl as raywarp fills it) is the body of
// RaywarpCustomNode, declared before this file with the node's inputs; this entry plays the
// material graph and Unreal's pixel shader. The world is raywarp's object space (so WorldToBox and
// BoxToWorld are the box's own maps), PixelWorld is the pixel's point on the near plane (where the
// box cube's front face would be), and the depth comes back from DepthOffset along the view, as
// Unreal's Pixel Depth Offset applies it. Stand-ins for the engine: FMaterialPixelParameters and
// ResolvedView.ViewForward.
float4x4 u_view_proj;
float4x4 u_inv_view_proj;
float2 u_viewport;
float4x4 u_object_to_box;
float4x4 u_box_to_object;
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
  ResolvedView.ViewForward = u_view_dir;
  float2 ndc = float2(position.x / u_viewport.x * 2.0 - 1.0, 1.0 - position.y / u_viewport.y * 2.0);
  float4 near_h = mul(u_inv_view_proj, float4(ndc, -1.0, 1.0));
  float3 pixel_world = near_h.xyz / near_h.w;
  FMaterialPixelParameters parameters;
  parameters.SvPosition = position;
  float3 world_normal = float3(0.0, 0.0, 1.0);
  float depth_offset = 0.0;
  float4 base = RAYWARP_NODE_CALL;
  if (base.a < 0.5) discard;  // the Masked material's opacity mask
  float3 dir = normalize(pixel_world - u_eye);
  float3 p = pixel_world + dir * (depth_offset / dot(dir, u_view_dir));
  float lambert = max(dot(normalize(world_normal), -dir), 0.0);
  PixelOut result;
  result.colour = float4(srgb_encode(base.rgb * (0.2 + 0.8 * lambert)), 1.0);
  result.depth = dot(p - u_eye, u_view_dir);
  float4 clip = mul(u_view_proj, float4(p, 1.0));
  result.window_depth = saturate(0.5 * clip.z / clip.w + 0.5);
  return result;
}
