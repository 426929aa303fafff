// lsnif_query_broad.rmiss -- a ray of lsnif_query_broad.rgen that met nothing keeps the payload the
// ray generation shader set (no hit).
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/shaders/lsnif_query_common.glsl"

layout(location = 0) rayPayloadInEXT LsnifQueryResult lsnif_query_payload;

void main() {}
