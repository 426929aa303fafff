// hello_lsnif.rchit -- the closest hit of the LSNIF object (hit group 1, with the library's
// intersection shader): the hit decoded by lsnif_hit.glsl (installed with LSNIF), its predicted
// albedo under the light with its world normal.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "hello_common.glsl"
#include "lsnif/lsnif_hit.glsl"

layout(location = 0) rayPayloadInEXT HelloPixel payload;
hitAttributeEXT LsnifHitAttributes lsnif_attributes;

void main() {
  const LsnifSurface s = lsnif_surface(lsnif_attributes);
  const vec3 color = hello_shade(s.albedo, s.normal);
#ifdef HELLO_ENGINE_LAYOUT
  payload.kind = HelloObjects(pc.objects).kind[gl_InstanceCustomIndexEXT];  // the application's own table
#else
  payload.kind = HELLO_KIND_LSNIF;
#endif
  payload.t = gl_HitTEXT;
  payload.normal_x = s.normal.x;
  payload.normal_y = s.normal.y;
  payload.normal_z = s.normal.z;
  payload.r = color.r;
  payload.g = color.g;
  payload.b = color.b;
}
