// lsnif_hit.hlsl -- the HLSL twin of lsnif_hit.glsl: decodes the hit attributes of the LSNIF
// intersection shader (LsnifHitAttributes of src/lsnif/host_device.h, 28 bytes) in an application's
// HLSL (or Slang) closest-hit shader. The intersection shader itself stays the library's SPIR-V (or
// one built from lsnif/shaders/lsnif_intersection.glsl); SPIR-V pipelines mix stages compiled from
// either language, so only the decoding is needed here. Usage in a closest-hit shader:
//   #include "lsnif/lsnif_hit.hlsl"
//   [shader("closesthit")] void main(inout Payload p, in LsnifHitAttributes a) {
//     LsnifSurface s = lsnif_decode_hit(a, (float3x3)WorldToObject3x4());  // world normal, albedo, ...
//     bool front = HitKind() == LSNIF_HIT_KIND_FRONT_FACING;                 // hit distance: RayTCurrent()
//   }
// Every function takes the instance's world-to-object matrix as a parameter, so the file compiles
// in any stage (tests/gpu/hit_decode_test.cpp compiles it with glslang as a compute shader and
// checks it decodes what lsnif_hit.glsl decodes). Slang reads the same file (`#include`).
#ifndef LSNIF_HIT_HLSL
#define LSNIF_HIT_HLSL

// host_device.h: the hit kinds (HitKind()) and the leaving rule's constant.
#define LSNIF_HIT_KIND_FRONT_FACING 0u
#define LSNIF_HIT_KIND_BACK_FACING 1u

struct LsnifHitAttributes {
  float normal_x, normal_y, normal_z;  // object-space unit normal as predicted
  uint albedo_rg;                      // albedo r, g as unorm16 (low half r)
  uint albedo_b_material_points;       // bits 0-15 albedo b as unorm16, 16-23 material, 24-31 points
  float occlusion_logit;
  float leaving_distance;              // object units
};

struct LsnifSurface {
  float3 normal;         // world space, normalized (zero if the prediction was zero)
  float3 object_normal;  // object space
  float3 albedo;         // in [0, 1], unorm16-rounded
  uint material;         // index into the model's materials
  uint points;           // boundary points of the walk that produced the hit
  float occlusion_logit;
  float leaving_distance;  // object units
};

// The unorm16 in the low 16 bits of `bits` (GLSL's unpackUnorm2x16 component).
float lsnif_unorm16(uint bits) {
  return float(bits & 0xffffu) / 65535.0;
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
  s.albedo = float3(lsnif_unorm16(a.albedo_rg), lsnif_unorm16(a.albedo_rg >> 16), lsnif_unorm16(a.albedo_b_material_points));
  s.material = (a.albedo_b_material_points >> 16) & 0xffu;
  s.points = a.albedo_b_material_points >> 24;
  s.occlusion_logit = a.occlusion_logit;
  s.leaving_distance = a.leaving_distance;
  return s;
}

// tmin of a ray leaving the hit's surface in world direction `world_direction` (any length): the
// surface's leaving distance in object units as a world ray parameter (host_device.h's rule).
float lsnif_leaving_tmin(LsnifSurface s, float3 world_direction, float3x3 world_to_object) {
  const float len = length(mul(world_to_object, world_direction));
  return len > 0.0 ? s.leaving_distance / len : 0.0;
}

#endif
