// Stand-in for URP's ShaderLibrary/Core.hlsl (README.md).
#define CBUFFER_START(name) cbuffer name {
#define CBUFFER_END };
#define UNITY_REVERSED_Z 1
#define UNITY_NEAR_CLIP_VALUE (1.0)
float4x4 unity_ObjectToWorld;
float4x4 unity_WorldToObject;
float4x4 unity_MatrixV;
float4x4 unity_MatrixP;
float4x4 unity_MatrixVP;
#define UNITY_MATRIX_V unity_MatrixV
#define UNITY_MATRIX_P unity_MatrixP
#define UNITY_MATRIX_VP unity_MatrixVP
float4 TransformWorldToShadowCoord(float3 positionWS) { return float4(positionWS, 1.0); }
