// For the rest of the mesh: whether a world-space point lies in raywarp's box (box frame
// |q| <= h, as raywarp's raster pass tests), whose fragments the box's pass draws instead. A
// template of raywarp's (engines/unity/RaywarpInsideBox.hlsl), the same for every box. The
// remainder shader (RaywarpRemainder_STEM.shader) includes it; so can the mesh's own shader, with
// the box's properties u_object_axes, u_object_to_box_x, _y, _z and u_half_extents declared
// before it, and `clip(-1)` where it holds.
#ifndef RAYWARP_INSIDE_BOX_INCLUDED
#define RAYWARP_INSIDE_BOX_INCLUDED

bool raywarp_inside_box(float3 world) {
  float3 p = mul(unity_WorldToObject, float4(world, 1.0)).xyz / u_object_axes.xyz;
  float4 q = float4(p, 1.0);
  float3 b = float3(dot(u_object_to_box_x, q), dot(u_object_to_box_y, q), dot(u_object_to_box_z, q));
  return all(abs(b) <= u_half_extents);
}

#endif
