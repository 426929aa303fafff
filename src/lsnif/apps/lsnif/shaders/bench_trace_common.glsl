// bench_trace_common.glsl -- what the shaders of `lsnif bench-trace` (bench_trace.rgen, .rmiss,
// .rchit, bench_trace_triangle.rchit) share: the push constant block (the LSNIF model table first,
// as the binding convention of src/lsnif/host_device.h requires; the C++ twin is BenchTracePush in
// src/lsnif/apps/lsnif/bench_trace_device.cpp), the per-ray result and the payload.
#ifndef BENCH_TRACE_COMMON_GLSL
#define BENCH_TRACE_COMMON_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "lsnif/host_device.h"

// Result of one ray (8 bytes; the C++ twin is BenchTraceResult):
//  t:    gl_HitTEXT of the closest hit, 0 on a miss
//  info: bit 0 hit; bits 8-15 the boundary points of the LSNIF walk that produced the hit (0 for a
//        triangle hit or a miss); bit 1 set by the triangle hit group
#define BENCH_TRACE_HIT 1u
#define BENCH_TRACE_TRIANGLE 2u
#define BENCH_TRACE_POINTS_SHIFT 8u
struct BenchTraceResult {
  float t;
  uint info;
};

layout(push_constant) uniform BenchTracePush {
  uint64_t model_table;  // LSNIF_RT_PUSH_MODEL_TABLE_OFFSET (read by lsnif.rint)
  uint model_count;      // LSNIF_RT_PUSH_MODEL_COUNT_OFFSET
  uint reserved;
  uint64_t rays;         // LsnifReferenceRay[ray_count], world space (LSNIF_RT_PUSH_APP_OFFSET)
  uint64_t results;      // BenchTraceResult[ray_count]
  uint ray_count;
} pc;

#endif
