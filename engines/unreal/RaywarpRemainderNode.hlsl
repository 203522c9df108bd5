// raywarp's remainder test for Unreal 5, the code of the Custom node of the material
// M_Raywarp_STEM_Remainder that import_STEM.py makes (a template of raywarp's,
// engines/unreal/RaywarpRemainderNode.hlsl, the same for every box). Inputs: PixelWorld (float3,
// Absolute World Position), WorldToBoxX, WorldToBoxY, WorldToBoxZ (float4: the rows of world, in
// Unreal units, to raywarp's box frame) and HalfExtents (float3, the box's, raywarp units).
// Output (float): 0 inside the box, whose pixels the box's own material draws, 1 elsewhere: the
// Opacity Mask of a Masked material, as raywarp's raster pass discards them.
float4 p = float4(PixelWorld, 1.0);
float3 q = float3(dot(WorldToBoxX, p), dot(WorldToBoxY, p), dot(WorldToBoxZ, p));
return all(abs(q) <= HalfExtents) ? 0.0 : 1.0;
