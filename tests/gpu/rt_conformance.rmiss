// rt_conformance.rmiss -- a miss: not occluded, no hit.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/host_device.h"

layout(location = 0) rayPayloadInEXT LsnifReferenceHit payload;

void main() { payload.hit = 0u; }
