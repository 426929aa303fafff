// lsnif_query_broad.rchit -- the triangle hit the traversal of lsnif_query_broad.rgen
// (LSNIF_QUERY_BROAD_TRIANGLES) committed, as the query's result.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/shaders/lsnif_query_common.glsl"

layout(location = 0) rayPayloadInEXT LsnifQueryResult lsnif_query_payload;
hitAttributeEXT vec2 lsnif_query_barycentrics;

void main() {
  lsnif_query_payload = lsnif_query_triangle_hit(gl_HitTEXT, uint(gl_InstanceID), uint(gl_InstanceCustomIndexEXT),
                                                 uint(gl_PrimitiveID), uint(gl_GeometryIndexEXT),
                                                 lsnif_query_barycentrics, gl_HitKindEXT == gl_HitKindFrontFacingTriangleEXT);
}
