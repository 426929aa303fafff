// lsnif_hit.glsl -- the hit attributes of the LSNIF intersection shader
// (src/lsnif/shaders/lsnif_intersection.glsl; layout: LsnifHitAttributes in src/lsnif/host_device.h):
// packing for the intersection shader and decoding for an application's closest-hit shader. Usage in
// a closest-hit shader (GL_EXT_ray_tracing enabled first):
//   #include "lsnif/lsnif_hit.glsl"
//   hitAttributeEXT LsnifHitAttributes lsnif_attributes;
//   ... const LsnifSurface s = lsnif_surface(lsnif_attributes);  // world normal, albedo, material
// The hit distance is gl_HitTEXT; the instance gl_InstanceID / gl_InstanceCustomIndexEXT; the facing
// gl_HitKindEXT (LSNIF_HIT_KIND_FRONT_FACING or LSNIF_HIT_KIND_BACK_FACING, host_device.h).
// A ray leaving the surface (self-intersection rule, host_device.h): origin = the hit point
// gl_WorldRayOriginEXT + gl_HitTEXT * gl_WorldRayDirectionEXT, tmin = lsnif_leaving_tmin(s, dir),
// flags |= gl_RayFlagsCullBackFacingTrianglesEXT.
// Outside the ray-tracing stages (e.g. a compute pass decoding stored attributes), define
// LSNIF_HIT_DECODE_ONLY before the include: only lsnif_pack_hit and the functions that take the
// instance's world-to-object matrix (lsnif_decode_hit, lsnif_world_normal_of, lsnif_leaving_tmin with
// 3 arguments) are declared. HLSL: lsnif/lsnif_hit.hlsl, the same decoding.
#ifndef LSNIF_HIT_GLSL
#define LSNIF_HIT_GLSL

#include "lsnif/host_device.h"

struct LsnifSurface {
  vec3 normal;         // world space, normalized (zero if the prediction was zero)
  vec3 object_normal;  // object space, normalized
  vec3 albedo;         // in [0, 1], unorm16-rounded
  uint material;       // index into the model's materials
  uint points;         // boundary points of the walk that produced the hit
  float occlusion_logit;
  float leaving_distance;  // object units (LsnifHitAttributes::leaving_distance)
};

// Packs one accepted prediction (object-space normal, albedo, material, walk points, logit).
LsnifHitAttributes lsnif_pack_hit(vec3 object_normal, vec3 albedo, uint material, uint points,
                                  float occlusion_logit, float leaving_distance) {
  LsnifHitAttributes a;
  a.normal_x = object_normal.x;
  a.normal_y = object_normal.y;
  a.normal_z = object_normal.z;
  a.albedo_rg = packUnorm2x16(albedo.xy);
  a.albedo_b_material_points =
      (packUnorm2x16(vec2(albedo.z, 0.0)) & 0xffffu) | ((material & 0xffu) << 16) | ((points & 0xffu) << 24);
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
  s.albedo = vec3(unpackUnorm2x16(a.albedo_rg), unpackUnorm2x16(a.albedo_b_material_points & 0xffffu).x);
  s.material = (a.albedo_b_material_points >> 16) & 0xffu;
  s.points = a.albedo_b_material_points >> 24;
  s.occlusion_logit = a.occlusion_logit;
  s.leaving_distance = a.leaving_distance;
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
