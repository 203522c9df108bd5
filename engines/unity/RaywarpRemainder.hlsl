// The passes of the remainder shader (RaywarpRemainder_STEM.shader) for Unity, after the
// pipeline's includes and the material's uniforms. A template of raywarp's
// (engines/unity/RaywarpRemainder.hlsl), the same for every box.
#ifndef RAYWARP_REMAINDER_INCLUDED
#define RAYWARP_REMAINDER_INCLUDED
#include "RaywarpInsideBox.hlsl"

struct RaywarpRemainderAttributes {
  float4 position : POSITION;
  float3 normal : NORMAL;
};

struct RaywarpRemainderVaryings {
  float4 position : SV_Position;
  float3 world : TEXCOORD0;
  float3 normal : TEXCOORD1;
};

RaywarpRemainderVaryings raywarp_remainder_vert(RaywarpRemainderAttributes input) {
  RaywarpRemainderVaryings output;
  output.world = mul(unity_ObjectToWorld, float4(input.position.xyz, 1.0)).xyz;
  output.normal = normalize(mul(input.normal, (float3x3)unity_WorldToObject));
  output.position = mul(UNITY_MATRIX_VP, float4(output.world, 1.0));
  return output;
}

// The face's albedo and its normal towards the viewer: a back face shows the inside colour.
float3 raywarp_remainder_albedo(bool front) {
  return front ? u_albedo.rgb : u_inside_colour.rgb;
}

void raywarp_remainder_depth(RaywarpRemainderVaryings input) {
  clip(raywarp_inside_box(input.world) ? -1.0 : 1.0);
}

#endif
