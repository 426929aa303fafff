// rt_mixed_triangle.rchit -- the closest hit of a triangle instance in the mixed TLAS of
// rt_conformance_test (hit group 1): t, the triangle (material = gl_PrimitiveID), the barycentrics
// (albedo_x, albedo_y) and the instance (instance = gl_InstanceID | gl_InstanceCustomIndexEXT << 16);
// points = 0 marks a triangle hit.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/host_device.h"

layout(location = 0) rayPayloadInEXT LsnifReferenceHit payload;
hitAttributeEXT vec2 barycentrics;

void main() {
  payload.hit = 1u;
  payload.points = 0u;
  payload.occlusion_logit = 0.0;
  payload.t = gl_HitTEXT;
  payload.normal_x = 0.0;
  payload.normal_y = 0.0;
  payload.normal_z = 0.0;
  payload.material = uint(gl_PrimitiveID);
  payload.albedo_x = barycentrics.x;
  payload.albedo_y = barycentrics.y;
  payload.albedo_z = 0.0;
  payload.surface = 0u;
  payload.emission_r = 0.0;
  payload.emission_g = 0.0;
  payload.emission_b = 0.0;
  payload.instance = uint(gl_InstanceID) | (uint(gl_InstanceCustomIndexEXT) << 16);
  payload.reports_uv = 0u;
  payload.uv_u = 0.0;
  payload.uv_v = 0.0;
}
