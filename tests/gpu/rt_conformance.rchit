// rt_conformance.rchit -- the closest hit of an LSNIF object, decoded with src/lsnif/lsnif_hit.glsl
// as an application would: world normal, albedo, material, surface channels and emission; plus t,
// the walk's points, the logit, the instance and the facing (instance = gl_InstanceID | gl_HitKindEXT << 15 |
// gl_InstanceCustomIndexEXT << 16; the hit kind is LSNIF_HIT_KIND_FRONT_FACING or _BACK_FACING).
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/lsnif_hit.glsl"

layout(location = 0) rayPayloadInEXT LsnifReferenceHit payload;
hitAttributeEXT LsnifHitAttributes attributes;

void main() {
  const LsnifSurface s = lsnif_surface(attributes);
  payload.hit = 1u;
  payload.points = s.points;
  payload.occlusion_logit = s.occlusion_logit;
  payload.t = gl_HitTEXT;
  payload.normal_x = s.normal.x;
  payload.normal_y = s.normal.y;
  payload.normal_z = s.normal.z;
  payload.material = s.material;
  payload.albedo_x = s.albedo.x;
  payload.albedo_y = s.albedo.y;
  payload.albedo_z = s.albedo.z;
  // The learned channels as the device packs them (lsnif_pack_surface), the emission decoded from RGBE.
  payload.surface = lsnif_pack_surface(s.surface_learned, s.metallic, s.roughness, s.ambient_occlusion);
  payload.leaving_tmin = lsnif_leaving_tmin(s, gl_WorldRayDirectionEXT);
  payload.emission_r = s.emission.r;
  payload.emission_g = s.emission.g;
  payload.emission_b = s.emission.b;
  payload.instance = uint(gl_InstanceID) | (gl_HitKindEXT << 15) | (uint(gl_InstanceCustomIndexEXT) << 16);
  payload.reports_uv = s.reports_uv ? 1u : 0u;
  payload.uv_u = s.uv.x;
  payload.uv_v = s.uv.y;
}
