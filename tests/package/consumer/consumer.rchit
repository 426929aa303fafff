// consumer.rchit -- a closest-hit shader of a consumer whose own host_device.h sits on the include
// path beside LSNIF's GLSL folder: it gets its own, and lsnif_hit.glsl gets LSNIF's.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "host_device.h"
#include "lsnif/lsnif_hit.glsl"
#ifndef CONSUMER_OWN_HOST_DEVICE
#error "LSNIF's host_device.h shadows the consumer's own"
#endif

layout(location = 0) rayPayloadInEXT vec4 payload;
hitAttributeEXT LsnifHitAttributes lsnif_attributes;

void main() {
  const LsnifSurface s = lsnif_surface(lsnif_attributes);
  payload = vec4(s.albedo, float(LSNIF_MAX_POINTS));
}
