// bench_trace.rchit -- `lsnif bench-trace`: the closest hit of the LSNIF hit group (record 0, with
// src/lsnif/shaders/lsnif.rint): t and the walk's boundary points, decoded with src/lsnif/lsnif_hit.glsl.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/apps/lsnif/shaders/bench_trace_common.glsl"
#include "lsnif/lsnif_hit.glsl"

layout(location = 0) rayPayloadInEXT BenchTraceResult payload;
hitAttributeEXT LsnifHitAttributes attributes;

void main() {
  const LsnifSurface s = lsnif_surface(attributes);
  payload.t = gl_HitTEXT;
  payload.info = BENCH_TRACE_HIT | (min(s.points, 255u) << BENCH_TRACE_POINTS_SHIFT);
}
