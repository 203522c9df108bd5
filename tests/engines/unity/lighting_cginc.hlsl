// Stand-in for the built-in pipeline's Lighting.cginc (README.md).
float4 _WorldSpaceLightPos0;
half4 _LightColor0;
