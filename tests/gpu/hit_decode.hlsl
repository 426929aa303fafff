// hit_decode.hlsl -- the HLSL twin of hit_decode.comp: decodes LsnifHitAttributes with
// lsnif/lsnif_hit.hlsl, compiled by glslang (-D) as a compute shader; the same buffers and results.
// Through the current hit's forms (lsnif_surface, 2-argument lsnif_leaving_tmin), which read the
// ray-tracing intrinsic WorldToObject3x4(): here a stand-in returning this invocation's matrix.
static float3x3 g_world_to_object;
float3x4 WorldToObject3x4() {
  return float3x4(float4(g_world_to_object[0], 0.0), float4(g_world_to_object[1], 0.0),
                  float4(g_world_to_object[2], 0.0));
}
#define LSNIF_HIT_RAY_TRACING
#include "lsnif/lsnif_hit.hlsl"

struct HitDecodeResult {
  float4 normal;  // xyz: world normal, w: lsnif_leaving_tmin along the direction
  float4 albedo;  // xyz: albedo, w: occlusion logit
  uint4 fields;   // material, points, leaving distance (float bits), object normal x (float bits)
  float4 surface;   // metallic, roughness, ambient occlusion, 1 when learned (else 0)
  float4 emission;  // xyz: emission, w: 0
  uint4 packed;     // 0: the packers are GLSL's only (hit_decode.comp)
  uint4 uv;         // 1 when the hit reports a texture coordinate, its u and v (float bits), 0
  uint4 uv_packed;  // 0 (GLSL's packer only)
};

struct Push {
  uint count;
};

[[vk::binding(0, 0)]] StructuredBuffer<LsnifHitAttributes> attributes;
[[vk::binding(1, 0)]] StructuredBuffer<float4> inputs;
[[vk::binding(2, 0)]] RWStructuredBuffer<HitDecodeResult> results;
[[vk::push_constant]] ConstantBuffer<Push> pc;

[numthreads(64, 1, 1)] void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.count) return;
  g_world_to_object = float3x3(inputs[5 * i].xyz, inputs[5 * i + 1].xyz, inputs[5 * i + 2].xyz);
  const LsnifSurface s = lsnif_surface(attributes[i]);
  HitDecodeResult r;
  r.normal = float4(s.normal, lsnif_leaving_tmin(s, inputs[5 * i + 3].xyz));
  r.albedo = float4(s.albedo, s.occlusion_logit);
  r.fields = uint4(s.material, s.points, asuint(s.leaving_distance), asuint(s.object_normal.x));
  r.surface = float4(s.metallic, s.roughness, s.ambient_occlusion, s.surface_learned ? 1.0 : 0.0);
  r.emission = float4(s.emission, 0.0);
  r.packed = uint4(0, 0, 0, 0);
  r.uv = uint4(s.reports_uv ? 1u : 0u, asuint(s.uv.x), asuint(s.uv.y), 0u);
  r.uv_packed = uint4(0, 0, 0, 0);
  results[i] = r;
}
