// bench_trace_triangle.rchit -- `lsnif bench-trace`: the closest hit of the triangle hit group
// (record 1): t, flagged as a triangle hit.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/apps/lsnif/shaders/bench_trace_common.glsl"

layout(location = 0) rayPayloadInEXT BenchTraceResult payload;

void main() {
  payload.t = gl_HitTEXT;
  payload.info = BENCH_TRACE_HIT | BENCH_TRACE_TRIANGLE;
}
