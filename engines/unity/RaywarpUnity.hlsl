// raywarp's ray-cast pass for Unity (the built-in pipeline and URP): the pixel's ray in the box's
// frame, the translated march (raywarp_STEM.hlsl, included before this file) and the hit back in
// world space. A template of raywarp's (engines/unity/RaywarpUnity.hlsl), the same for every box;
// docs/engines.md gives the conventions.
//
// Frames. The box's GameObject shares the mesh's object space (a child with an identity local
// transform). Unity object space = raywarp object space times u_object_axes per axis: the
// importer's axis flip (Unity is left-handed: Unity's FBX and OBJ importers negate x, so the
// default is (-1, 1, 1)) and its unit scale. The box frame is raywarp's: u_object_to_box_* and
// u_box_to_object_* are the rows of the rigid maps between it and raywarp object space.
#ifndef RAYWARP_UNITY_INCLUDED
#define RAYWARP_UNITY_INCLUDED

struct RaywarpAttributes {
  float4 corner : POSITION;  // Unity's cube mesh: [-0.5, 0.5]^3
};

struct RaywarpVaryings {
  float4 position : SV_Position;
  float3 world : TEXCOORD0;  // the back face of the ray-cast region, world space
};

struct RaywarpHit {
  float3 world;   // the hit, world space
  float3 normal;  // unit, world space
  int kind;       // 0 the mesh's surface, 1 its inside, 2 a cut face
  float depth;    // SV_Depth of the hit under UNITY_MATRIX_VP
};

float3 raywarp_box_to_object(float3 p) {
  float4 q = float4(p, 1.0);
  return float3(dot(u_box_to_object_x, q), dot(u_box_to_object_y, q), dot(u_box_to_object_z, q));
}

float3 raywarp_object_to_box(float3 p) {
  float4 q = float4(p, 1.0);
  return float3(dot(u_object_to_box_x, q), dot(u_object_to_box_y, q), dot(u_object_to_box_z, q));
}

// A box-frame point to world space, through raywarp's and Unity's object space.
float3 raywarp_box_to_world(float3 p) {
  return mul(unity_ObjectToWorld, float4(raywarp_box_to_object(p) * u_object_axes.xyz, 1.0)).xyz;
}

RaywarpVaryings raywarp_vert(RaywarpAttributes input) {
  RaywarpVaryings output;
  float3 box = lerp(u_region_lower, u_region_upper, input.corner.xyz + 0.5);
  output.world = raywarp_box_to_world(box);
  output.position = mul(UNITY_MATRIX_VP, float4(output.world, 1.0));
  return output;
}

// The eye of the view bound now (the camera's, or a light's in a shadow pass): -R^T t of the view
// matrix [R | t]; an orthographic projection's rays run along the view's -z instead.
bool raywarp_orthographic() { return UNITY_MATRIX_P[3][3] == 1.0; }

// Ray casts the pixel whose region back face is at `world`; false on a miss.
bool raywarp_trace(float3 world, out RaywarpHit hit) {
  hit.world = world;
  hit.normal = float3(0.0, 1.0, 0.0);
  hit.kind = 0;
  hit.depth = 0.0;
  float3 forward = -UNITY_MATRIX_V[2].xyz;
  float3 eye = -mul(transpose((float3x3)UNITY_MATRIX_V), UNITY_MATRIX_V._m03_m13_m23);
  float3 origin = eye;
  if (raywarp_orthographic()) origin = world - forward * dot(world - eye, forward);
  // The ray in raywarp's object space, then in the box frame (a rigid map: t is kept).
  float3 o_obj = mul(unity_WorldToObject, float4(origin, 1.0)).xyz / u_object_axes.xyz;
  float3 w_obj = mul(unity_WorldToObject, float4(world, 1.0)).xyz / u_object_axes.xyz;
  float3 o = raywarp_object_to_box(o_obj);
  float3 to_back = raywarp_object_to_box(w_obj) - o;
  float t_far = length(to_back) * 1.0001;
  float3 d = to_back / max(length(to_back), 1e-20);
  float t0 = 0.0, t1 = 0.0, t = 0.0;
  float3 normal = float3(0.0, 0.0, 1.0);
  int kind = 0;
  if (!raywarp_clip(o, d, t_far, t0, t1) || !raywarp_cast(o, d, t0, t1, t, normal, kind))
    return false;
  hit.world = raywarp_box_to_world(o + t * d);
  // Normals: box -> raywarp object (rotation), -> Unity object (the inverse of the axes' scale),
  // -> world (the inverse transpose of unity_ObjectToWorld).
  float3 n_obj = float3(dot(u_box_to_object_x.xyz, normal), dot(u_box_to_object_y.xyz, normal),
                        dot(u_box_to_object_z.xyz, normal)) / u_object_axes.xyz;
  hit.normal = normalize(mul(n_obj, (float3x3)unity_WorldToObject));
  hit.kind = kind;
  float4 clip = mul(UNITY_MATRIX_VP, float4(hit.world, 1.0));
  hit.depth = clip.z / clip.w;
  if (UNITY_NEAR_CLIP_VALUE < 0.0) hit.depth = 0.5 * hit.depth + 0.5;  // OpenGL: [-1, 1] -> [0, 1]
  return true;
}

#include "RaywarpInsideBox.hlsl"

float3 raywarp_albedo(int kind) {
  return kind == 2 ? u_cut_colour.rgb : (kind == 1 ? u_inside_colour.rgb : u_albedo.rgb);
}

// The shadow and depth passes: the march alone, its depth.
float raywarp_frag_depth(RaywarpVaryings input) : SV_Depth {
  RaywarpHit hit;
  if (!raywarp_trace(input.world, hit)) discard;
  return hit.depth;
}

#endif
