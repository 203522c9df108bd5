// Stand-in for URP's ShaderLibrary/Lighting.hlsl (README.md).
struct Light {
  half3 direction;
  half3 color;
  float distanceAttenuation;
  half shadowAttenuation;
  uint layerMask;
};
Light GetMainLight(float4 shadowCoord) {
  Light l;
  l.direction = half3(0.0, 1.0, 0.0);
  l.color = half3(1.0, 1.0, 1.0);
  l.distanceAttenuation = 1.0;
  l.shadowAttenuation = half(shadowCoord.w);
  l.layerMask = 0u;
  return l;
}
int GetAdditionalLightsCount() { return 0; }
Light GetAdditionalLight(uint i, float3 positionWS) { return GetMainLight(float4(positionWS, float(i))); }
half3 SampleSH(half3 normalWS) { return normalWS * 0.0 + 0.2; }
