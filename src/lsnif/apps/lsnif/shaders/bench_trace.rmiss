// bench_trace.rmiss -- `lsnif bench-trace`: a miss, no hit.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/apps/lsnif/shaders/bench_trace_common.glsl"

layout(location = 0) rayPayloadInEXT BenchTraceResult payload;

void main() {
  payload.t = 0.0;
  payload.info = 0u;
}
