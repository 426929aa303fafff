// lsnif_hit.hlsl -- the HLSL twin of lsnif_hit.glsl: decodes the hit attributes of the LSNIF
// intersection shader (LsnifHitAttributes of src/lsnif/host_device.h, 32 bytes) in an application's
// HLSL (or Slang) closest-hit shader. The intersection shader itself stays the library's SPIR-V (or
// one built from lsnif/shaders/lsnif_intersection.glsl); SPIR-V pipelines mix stages compiled from
// either language, so only the decoding is needed here. Usage in a closest-hit shader:
//   #include "lsnif/lsnif_hit.hlsl"
//   [shader("closesthit")] void main(inout Payload p, in LsnifHitAttributes a) {
//     LsnifSurface s = lsnif_surface(a);  // world normal, albedo, ...: lsnif_decode_hit(a, (float3x3)WorldToObject3x4())
//     if (s.surface_learned) ...  // s.metallic, s.roughness, s.ambient_occlusion, s.emission
//     bool front = HitKind() == LSNIF_HIT_KIND_FRONT_FACING;                 // hit distance: RayTCurrent()
//   }
// Every function but the current hit's forms at the end takes the instance's world-to-object matrix
// as a parameter, so the file compiles in any stage (tests/gpu/hit_decode_test.cpp compiles it with
// glslang as a compute shader, the end's forms on a stand-in WorldToObject3x4, and checks it decodes
// what lsnif_hit.glsl decodes). Slang reads the same file (`#include`; define LSNIF_HIT_RAY_TRACING
// for lsnif_surface). glslang's HLSL front end cannot build ray-tracing stages (docs/integration.md).
#ifndef LSNIF_HIT_HLSL
#define LSNIF_HIT_HLSL

// host_device.h: the hit kinds (HitKind()) and the leaving rule's constant.
#define LSNIF_HIT_KIND_FRONT_FACING 0u
#define LSNIF_HIT_KIND_BACK_FACING 1u
#define LSNIF_HIT_SURFACE_LEARNED_BIT 0x80000000u
#define LSNIF_HIT_UV_BIT 0x40000000u
#define LSNIF_RGBE_BIAS 136

struct LsnifHitAttributes {
  float normal_x, normal_y, normal_z;  // object-space unit normal as predicted
  uint albedo_material;                // albedo r, g, b as unorm8 in bytes 0-2, material in byte 3
  uint surface_points;                 // metallic, roughness, ambient occlusion as unorm8 in bytes 0-2;
                                       // byte 3: walk points in bits 0-5, LSNIF_HIT_UV_BIT,
                                       // LSNIF_HIT_SURFACE_LEARNED_BIT
  uint emission_rgbe;                  // emission as shared-exponent RGBE (lsnif_unpack_rgbe); with
                                       // LSNIF_HIT_UV_BIT the texture coordinate with albedo's bytes
  float occlusion_logit;
  float leaving_distance;              // object units
};

struct LsnifSurface {
  float3 normal;         // world space, normalized (zero if the prediction was zero)
  float3 object_normal;  // object space
  float3 albedo;         // in [0, 1], unorm8-rounded
  uint material;         // index into the model's materials
  uint points;           // boundary points of the walk that produced the hit
  float occlusion_logit;
  float leaving_distance;  // object units
  // The surface channels, when the model learned them (surface_learned; else all zero and the
  // application takes them from the material `material`): unorm8-rounded, in [0, 1].
  bool surface_learned;
  float metallic, roughness, ambient_occlusion;
  float3 emission;       // linear RGB, >= 0 (RGBE-rounded)
  // A hit of a texture-coordinate material (LSNIF_HIT_UV_BIT): its texture coordinate, where the
  // application samples the material's own textures (albedo, surface channels and emission zero).
  bool reports_uv;
  float2 uv;
};

// A 28-bit two's complement field in bits 0-27 of `bits` as an int (the sign bit 27 extended).
int lsnif_uv_field(uint bits) { return int(bits << 4) >> 4; }

// Bytes 0, 1, 2 of `bits` as unorm8 (GLSL's unpackUnorm4x8 components x, y, z).
float3 lsnif_unorm8x3(uint bits) {
  return float3(float(bits & 0xffu), float((bits >> 8) & 0xffu), float((bits >> 16) & 0xffu)) / 255.0;
}

// 2^k for k in [-126, 127], built from its bits (exact; HLSL's ldexp takes a float exponent).
float lsnif_pow2(int k) {
  return asfloat(uint(k + 127) << 23);
}

// The colour of an RGBE word (lsnif_hit.glsl lsnif_unpack_rgbe): m x 2^(e - LSNIF_RGBE_BIAS), the
// power of two applied in two exact halves (e - LSNIF_RGBE_BIAS spans [-135, 119]).
float3 lsnif_unpack_rgbe(uint rgbe) {
  const int e = int(rgbe >> 24);
  if (e == 0) return float3(0.0, 0.0, 0.0);
  const float3 m = float3(float(rgbe & 0xffu), float((rgbe >> 8) & 0xffu), float((rgbe >> 16) & 0xffu));
  const int k = e - LSNIF_RGBE_BIAS, half_k = k / 2;
  return m * lsnif_pow2(half_k) * lsnif_pow2(k - half_k);
}

// Object-space normal to world space with the inverse transpose of the instance's linear part:
// (A^-1)^T n, A^-1 = `world_to_object` ((float3x3)WorldToObject3x4() in a ray-tracing stage).
float3 lsnif_world_normal_of(float3 object_normal, float3x3 world_to_object) {
  const float3 n = mul(object_normal, world_to_object);
  const float len = length(n);
  return len > 0.0 ? n / len : float3(0.0, 0.0, 0.0);
}

// Decodes attributes of a hit of the instance whose world-to-object linear part is `world_to_object`.
LsnifSurface lsnif_decode_hit(LsnifHitAttributes a, float3x3 world_to_object) {
  LsnifSurface s;
  s.object_normal = float3(a.normal_x, a.normal_y, a.normal_z);
  s.normal = lsnif_world_normal_of(s.object_normal, world_to_object);
  s.albedo = lsnif_unorm8x3(a.albedo_material);
  s.material = a.albedo_material >> 24;
  s.points = (a.surface_points >> 24) & 0x3fu;
  s.occlusion_logit = a.occlusion_logit;
  s.leaving_distance = a.leaving_distance;
  s.surface_learned = (a.surface_points & LSNIF_HIT_SURFACE_LEARNED_BIT) != 0u;
  const float3 channels = lsnif_unorm8x3(a.surface_points);
  s.metallic = channels.x;
  s.roughness = channels.y;
  s.ambient_occlusion = channels.z;
  s.emission = lsnif_unpack_rgbe(a.emission_rgbe);
  s.reports_uv = (a.surface_points & LSNIF_HIT_UV_BIT) != 0u;
  s.uv = float2(0.0, 0.0);
  if (s.reports_uv) {
    const int fu = lsnif_uv_field(a.emission_rgbe & 0x0fffffffu);
    const int fv = lsnif_uv_field((a.emission_rgbe >> 28) | ((a.albedo_material & 0xffffffu) << 4));
    s.uv = float2(float(fu), float(fv)) / 65536.0;
    s.albedo = float3(0.0, 0.0, 0.0);
    s.emission = float3(0.0, 0.0, 0.0);
  }
  return s;
}

// tmin of a ray leaving the hit's surface in world direction `world_direction` (any length): the
// surface's leaving distance in object units as a world ray parameter (host_device.h's rule).
float lsnif_leaving_tmin(LsnifSurface s, float3 world_direction, float3x3 world_to_object) {
  const float len = length(mul(world_to_object, world_direction));
  return len > 0.0 ? s.leaving_distance / len : 0.0;
}

// The current hit's forms (lsnif_hit.glsl's lsnif_surface, lsnif_world_normal and 2-argument
// lsnif_leaving_tmin), on the intrinsic WorldToObject3x4() of the ray-tracing stages: declared in a
// DXC library target (-T lib_6_x, where closest-hit shaders are compiled) or wherever
// LSNIF_HIT_RAY_TRACING is defined before the include (Slang, or a stand-in WorldToObject3x4 for a
// test); never with LSNIF_HIT_DECODE_ONLY.
#if !defined(LSNIF_HIT_DECODE_ONLY) && \
    (defined(LSNIF_HIT_RAY_TRACING) || (defined(__SHADER_TARGET_STAGE) && __SHADER_TARGET_STAGE == __SHADER_STAGE_LIBRARY))
float3 lsnif_world_normal(float3 object_normal) {
  return lsnif_world_normal_of(object_normal, (float3x3)WorldToObject3x4());
}

// Decodes the attributes of the current hit (closest-hit shader).
LsnifSurface lsnif_surface(LsnifHitAttributes a) {
  return lsnif_decode_hit(a, (float3x3)WorldToObject3x4());
}

// tmin of a ray leaving the current hit's surface in world direction `world_direction`.
float lsnif_leaving_tmin(LsnifSurface s, float3 world_direction) {
  return lsnif_leaving_tmin(s, world_direction, (float3x3)WorldToObject3x4());
}
#endif

#endif
