// lsnif_hit.glsl -- the hit attributes of the LSNIF intersection shader
// (src/lsnif/shaders/lsnif_intersection.glsl; layout: LsnifHitAttributes in src/lsnif/host_device.h):
// packing for the intersection shader and decoding for an application's closest-hit shader. Usage in
// a closest-hit shader (GL_EXT_ray_tracing enabled first):
//   #include "lsnif/lsnif_hit.glsl"
//   hitAttributeEXT LsnifHitAttributes lsnif_attributes;
//   ... const LsnifSurface s = lsnif_surface(lsnif_attributes);  // world normal, albedo, material
//   if (s.surface_learned) ... s.metallic, s.roughness, s.ambient_occlusion, s.emission
//   else ...                   the application's material s.material (the model learned base colour only)
// The hit distance is gl_HitTEXT; the instance gl_InstanceID / gl_InstanceCustomIndexEXT; the facing
// gl_HitKindEXT (LSNIF_HIT_KIND_FRONT_FACING or LSNIF_HIT_KIND_BACK_FACING, host_device.h).
// A ray leaving the surface (self-intersection rule, host_device.h): origin = the hit point
// gl_WorldRayOriginEXT + gl_HitTEXT * gl_WorldRayDirectionEXT, tmin = lsnif_leaving_tmin(s, dir),
// flags |= gl_RayFlagsCullBackFacingTrianglesEXT.
// The packed surface word of the batched queries (LsnifQueryHit::surface, LsnifQueryResult::surface)
// reads with lsnif_unpack_surface, their emission is plain floats.
// The packers (lsnif_unorm8, lsnif_pack_surface, lsnif_pack_rgbe, lsnif_unpack_rgbe) are the GLSL
// twins of src/lsnif/core/head.cpp's pack_surface, pack_rgbe and unpack_rgbe and give the same bits
// for the same floats; values below 2^-126 (subnormal) may read as 0 on devices that flush them.
// Outside the ray-tracing stages (e.g. a compute pass decoding stored attributes), define
// LSNIF_HIT_DECODE_ONLY before the include: only the packers, lsnif_pack_hit and the functions that
// take the instance's world-to-object matrix (lsnif_decode_hit, lsnif_world_normal_of,
// lsnif_leaving_tmin with 3 arguments) are declared. HLSL: lsnif/lsnif_hit.hlsl, the same decoding.
#ifndef LSNIF_HIT_GLSL
#define LSNIF_HIT_GLSL

#include "lsnif/host_device.h"

struct LsnifSurface {
  vec3 normal;         // world space, normalized (zero if the prediction was zero)
  vec3 object_normal;  // object space, normalized
  vec3 albedo;         // in [0, 1], unorm8-rounded
  uint material;       // index into the model's materials
  uint points;         // boundary points of the walk that produced the hit
  float occlusion_logit;
  float leaving_distance;  // object units (LsnifHitAttributes::leaving_distance)
  // The surface channels, when the model learned them (surface_learned; else all zero and the
  // application takes them from the material `material`): unorm8-rounded, in [0, 1].
  bool surface_learned;
  float metallic, roughness, ambient_occlusion;
  vec3 emission;       // linear RGB, >= 0, RGBE-rounded (relative error <= 2^-8 of the largest channel)
  // A hit of a texture-coordinate material (LSNIF_HIT_UV_BIT): its texture coordinate, where the
  // application samples the material `material`'s own textures for the albedo and the other
  // channels (albedo, the surface channels and emission are then zero). Else false and zero.
  bool reports_uv;
  vec2 uv;
};

// round(clamp(x, 0, 1) x 255) with halves rounded away from zero, as head.cpp (std::lround); x not
// NaN. (packUnorm4x8's formula, whose rounding of halves GLSL leaves to the implementation.)
// `precise`: the product must be rounded to fp32 before the fraction is taken, as on the CPU.
uint lsnif_unorm8(float x) {
  precise float y = clamp(x, 0.0, 1.0) * 255.0;
  const float whole = floor(y);
  precise float fraction = y - whole;  // exact (Sterbenz)
  return uint(whole) + (fraction >= 0.5 ? 1u : 0u);
}

// The packed surface channels of a hit (host_device.h, LSNIF_SURFACE_LEARNED; head.cpp
// pack_surface): metallic, roughness and ambient occlusion as unorm8 in bytes 0-2 and
// LSNIF_SURFACE_LEARNED in byte 3; 0 when the model did not learn them.
uint lsnif_pack_surface(bool learned, float metallic, float roughness, float ambient_occlusion) {
  if (!learned) return 0u;
  return lsnif_unorm8(metallic) | (lsnif_unorm8(roughness) << 8) | (lsnif_unorm8(ambient_occlusion) << 16) |
         (LSNIF_SURFACE_LEARNED << 24);
}

// A packed surface word (LsnifQueryHit::surface, LsnifQueryResult::surface): xyz metallic,
// roughness and ambient occlusion in [0, 1], w 1 when the model learned them (else all 0).
vec4 lsnif_unpack_surface(uint surface) {
  if ((surface >> 24) != LSNIF_SURFACE_LEARNED) return vec4(0.0);
  return vec4(unpackUnorm4x8(surface).xyz, 1.0);
}

// Shared-exponent RGBE of a colour (LsnifHitAttributes::emission_rgbe; head.cpp pack_rgbe, the
// same bits): negative and NaN channels count as 0; byte 3 the exponent e, bytes 0-2 the mantissas
// m = round(c 2^(LSNIF_RGBE_BIAS - e)) (halves away from zero) in [0, 255]; 0 is black.
uint lsnif_pack_rgbe(vec3 c) {
  float largest = 0.0;
  for (int k = 0; k < 3; ++k) {
    c[k] = c[k] > 0.0 ? c[k] : 0.0;
    largest = max(largest, c[k]);
  }
  if (largest == 0.0 || isinf(largest)) return 0u;
  int x;
  frexp(largest, x);  // largest = f 2^x, f in [0.5, 1)
  if (x < 1 - 128) return 0u;
  x = min(x, 127);
  uint rgbe = uint(x + 128) << 24;
  for (int k = 0; k < 3; ++k) {
    const float y = ldexp(c[k], 8 - x);  // exact: a power-of-two scale
    const float whole = floor(y);
    const uint m = uint(whole) + (y - whole >= 0.5 ? 1u : 0u);
    rgbe |= min(m, 255u) << (8 * k);
  }
  return rgbe;
}

// The colour of an RGBE word (head.cpp unpack_rgbe): m x 2^(e - LSNIF_RGBE_BIAS) per channel.
vec3 lsnif_unpack_rgbe(uint rgbe) {
  const int e = int(rgbe >> 24);
  if (e == 0) return vec3(0.0);
  const vec3 m = vec3(float(rgbe & 0xffu), float((rgbe >> 8) & 0xffu), float((rgbe >> 16) & 0xffu));
  return ldexp(m, ivec3(e - LSNIF_RGBE_BIAS));
}

// One coordinate as head.cpp pack_uv writes it: round(clamp(x, +-LSNIF_MAX_UV) 2^16) (halves away
// from zero; NaN as 0), 28-bit two's complement.
uint lsnif_uv_fixed(float x) {
  if (isnan(x)) return 0u;
  precise float y = abs(clamp(x, -float(LSNIF_MAX_UV), float(LSNIF_MAX_UV))) * 65536.0;  // exact
  const float whole = floor(y);
  precise float fraction = y - whole;  // exact
  const int magnitude = int(whole) + (fraction >= 0.5 ? 1 : 0);
  return uint(x < 0.0 ? -magnitude : magnitude) & 0x0fffffffu;
}

// Packs one accepted prediction: object-space normal, albedo, material, walk points, the packed
// surface channels (lsnif_pack_surface), emission, occlusion logit and leaving distance.
LsnifHitAttributes lsnif_pack_hit(vec3 object_normal, vec3 albedo, uint material, uint points, uint surface,
                                  vec3 emission, float occlusion_logit, float leaving_distance) {
  LsnifHitAttributes a;
  a.normal_x = object_normal.x;
  a.normal_y = object_normal.y;
  a.normal_z = object_normal.z;
  a.albedo_material = lsnif_unorm8(albedo.r) | (lsnif_unorm8(albedo.g) << 8) | (lsnif_unorm8(albedo.b) << 16) |
                      ((material & 0xffu) << 24);
  a.surface_points = (surface & 0xffffffu) | ((points & 0x3fu) << 24) |
                     ((surface >> 24) == LSNIF_SURFACE_LEARNED ? LSNIF_HIT_SURFACE_LEARNED_BIT : 0u);
  a.emission_rgbe = lsnif_pack_rgbe(emission);
  a.occlusion_logit = occlusion_logit;
  a.leaving_distance = leaving_distance;
  return a;
}

// Packs an accepted prediction of a hit that reports texture coordinate `uv` (LSNIF_HIT_UV_BIT):
// object-space normal, material, walk points, the coordinate, occlusion logit and leaving distance.
LsnifHitAttributes lsnif_pack_uv_hit(vec3 object_normal, uint material, uint points, vec2 uv, float occlusion_logit,
                                     float leaving_distance) {
  LsnifHitAttributes a;
  a.normal_x = object_normal.x;
  a.normal_y = object_normal.y;
  a.normal_z = object_normal.z;
  const uint fu = lsnif_uv_fixed(uv.x), fv = lsnif_uv_fixed(uv.y);
  a.emission_rgbe = fu | (fv << 28);
  a.albedo_material = (fv >> 4) | ((material & 0xffu) << 24);
  a.surface_points = ((points & 0x3fu) << 24) | LSNIF_HIT_UV_BIT;
  a.occlusion_logit = occlusion_logit;
  a.leaving_distance = leaving_distance;
  return a;
}

// Object-space normal to world space with the inverse transpose of the instance's linear part:
// (A^-1)^T n, A^-1 = `world_to_object` (the linear part of the instance's world-to-object matrix).
vec3 lsnif_world_normal_of(vec3 object_normal, mat3 world_to_object) {
  const vec3 n = transpose(world_to_object) * object_normal;
  const float len = length(n);
  return len > 0.0 ? n / len : vec3(0.0);
}

// Decodes attributes of a hit of the instance whose world-to-object linear part is `world_to_object`.
LsnifSurface lsnif_decode_hit(LsnifHitAttributes a, mat3 world_to_object) {
  LsnifSurface s;
  s.object_normal = vec3(a.normal_x, a.normal_y, a.normal_z);
  s.normal = lsnif_world_normal_of(s.object_normal, world_to_object);
  s.albedo = unpackUnorm4x8(a.albedo_material).rgb;
  s.material = a.albedo_material >> 24;
  s.points = (a.surface_points >> 24) & 0x3fu;
  s.occlusion_logit = a.occlusion_logit;
  s.leaving_distance = a.leaving_distance;
  s.surface_learned = (a.surface_points & LSNIF_HIT_SURFACE_LEARNED_BIT) != 0u;
  const vec3 channels = unpackUnorm4x8(a.surface_points).xyz;
  s.metallic = channels.x;
  s.roughness = channels.y;
  s.ambient_occlusion = channels.z;
  s.emission = lsnif_unpack_rgbe(a.emission_rgbe);
  s.reports_uv = (a.surface_points & LSNIF_HIT_UV_BIT) != 0u;
  s.uv = vec2(0.0);
  if (s.reports_uv) {
    const int fu = bitfieldExtract(int(a.emission_rgbe), 0, 28);
    const int fv = bitfieldExtract(int((a.emission_rgbe >> 28) | ((a.albedo_material & 0xffffffu) << 4)), 0, 28);
    s.uv = vec2(float(fu), float(fv)) / 65536.0;
    s.albedo = vec3(0.0);
    s.emission = vec3(0.0);
  }
  return s;
}

// tmin of a ray leaving the hit's surface in world direction `world_direction` (any length): the
// surface's leaving distance in object units as a world ray parameter.
float lsnif_leaving_tmin(LsnifSurface s, vec3 world_direction, mat3 world_to_object) {
  const float len = length(world_to_object * world_direction);
  return len > 0.0 ? s.leaving_distance / len : 0.0;
}

#ifndef LSNIF_HIT_DECODE_ONLY
// lsnif_world_normal_of with the current instance's matrix. Closest-hit / intersection only.
vec3 lsnif_world_normal(vec3 object_normal) {
  return lsnif_world_normal_of(object_normal, mat3(gl_WorldToObjectEXT));
}

// Decodes the attributes of the current hit (closest-hit shader).
LsnifSurface lsnif_surface(LsnifHitAttributes a) {
  return lsnif_decode_hit(a, mat3(gl_WorldToObjectEXT));
}

// tmin of a ray leaving the current hit's surface in world direction `world_direction` (any
// length): s.leaving_distance object units along the object-space direction, as a world ray
// parameter. Closest-hit shader of the hit (uses gl_WorldToObjectEXT).
float lsnif_leaving_tmin(LsnifSurface s, vec3 world_direction) {
  return lsnif_leaving_tmin(s, world_direction, mat3(gl_WorldToObjectEXT));
}
#endif

#endif
