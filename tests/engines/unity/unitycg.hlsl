// Stand-in for the built-in pipeline's UnityCG.cginc (README.md).
#define CBUFFER_START(name) cbuffer name {
#define CBUFFER_END };
#define UNITY_NEAR_CLIP_VALUE (-1.0)
float4x4 unity_ObjectToWorld;
float4x4 unity_WorldToObject;
float4x4 unity_MatrixV;
float4x4 glstate_matrix_projection;
float4x4 unity_MatrixVP;
#define UNITY_MATRIX_V unity_MatrixV
#define UNITY_MATRIX_P glstate_matrix_projection
#define UNITY_MATRIX_VP unity_MatrixVP
half3 ShadeSH9(half4 normal) { return normal.xyz * 0.0 + 0.2; }
