// lsnif_hit.glsl -- the hit attributes of src/lsnif/shaders/lsnif.rint (layout: LsnifHitAttributes in
// src/lsnif/host_device.h): packing for the intersection shader and decoding for an application's
// closest-hit shader. Usage in a closest-hit shader (GL_EXT_ray_tracing enabled first):
//   #include "lsnif/lsnif_hit.glsl"
//   hitAttributeEXT LsnifHitAttributes lsnif_attributes;
//   ... const LsnifSurface s = lsnif_surface(lsnif_attributes);  // world normal, albedo, material
// The hit distance is gl_HitTEXT; the instance gl_InstanceID / gl_InstanceCustomIndexEXT.
// A ray leaving the surface (self-intersection rule, host_device.h): origin = the hit point
// gl_WorldRayOriginEXT + gl_HitTEXT * gl_WorldRayDirectionEXT, tmin = lsnif_leaving_tmin(s, dir),
// flags |= gl_RayFlagsCullBackFacingTrianglesEXT.
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
// (A^-1)^T n, A^-1 being the linear part of gl_WorldToObjectEXT. Closest-hit / intersection only.
vec3 lsnif_world_normal(vec3 object_normal) {
  const vec3 n = transpose(mat3(gl_WorldToObjectEXT)) * object_normal;
  const float len = length(n);
  return len > 0.0 ? n / len : vec3(0.0);
}

// Decodes the attributes of the current hit (closest-hit shader).
LsnifSurface lsnif_surface(LsnifHitAttributes a) {
  LsnifSurface s;
  s.object_normal = vec3(a.normal_x, a.normal_y, a.normal_z);
  s.normal = lsnif_world_normal(s.object_normal);
  s.albedo = vec3(unpackUnorm2x16(a.albedo_rg), unpackUnorm2x16(a.albedo_b_material_points & 0xffffu).x);
  s.material = (a.albedo_b_material_points >> 16) & 0xffu;
  s.points = a.albedo_b_material_points >> 24;
  s.occlusion_logit = a.occlusion_logit;
  s.leaving_distance = a.leaving_distance;
  return s;
}

// tmin of a ray leaving the current hit's surface in world direction `world_direction` (any
// length): s.leaving_distance object units along the object-space direction, as a world ray
// parameter. Closest-hit shader of the hit (uses gl_WorldToObjectEXT).
float lsnif_leaving_tmin(LsnifSurface s, vec3 world_direction) {
  const float len = length(mat3(gl_WorldToObjectEXT) * world_direction);
  return len > 0.0 ? s.leaving_distance / len : 0.0;
}

#endif
