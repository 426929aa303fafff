// rt_conformance_common.glsl -- what the ray-tracing conformance shaders (rt_conformance.rgen,
// .rmiss, .rchit) share: the push constant block (LSNIF model table first, as the binding
// convention of src/lsnif/host_device.h requires; the C++ twin is RtPush in rt_conformance_test.cpp)
// and the payload, one LsnifReferenceHit per ray.
#ifndef RT_CONFORMANCE_COMMON_GLSL
#define RT_CONFORMANCE_COMMON_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "lsnif/host_device.h"

#define RT_MODE_CLOSEST 0u  // closest hit: t, world normal, albedo, material, instance
#define RT_MODE_SHADOW 1u   // TerminateOnFirstHit | SkipClosestHitShader: hit = occluded only

layout(push_constant) uniform RtPush {
  uint64_t model_table;  // LSNIF_RT_PUSH_MODEL_TABLE_OFFSET
  uint model_count;      // LSNIF_RT_PUSH_MODEL_COUNT_OFFSET
  uint reserved;
  uint64_t rays;         // LsnifReferenceRay[ray_count] (LSNIF_RT_PUSH_APP_OFFSET)
  uint64_t hits;         // LsnifReferenceHit[ray_count]
  uint ray_count;
  uint mode;             // RT_MODE_*
  uint ray_flags;        // more ray flags for traceRayEXT (culling: host_device.h)
} pc;

#endif
