// render_triangle.rchit -- closest hit on a triangle mesh: the surface at the hit's barycentrics
// (render_triangle_hit, render_surface.glsl) as a RenderHit.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/renderer/shaders/render_surface.glsl"

layout(location = 0) rayPayloadInEXT RenderHit hit;
hitAttributeEXT vec2 barycentrics;

void main() {
  hit = render_triangle_hit(render_frame(), gl_InstanceCustomIndexEXT, gl_GeometryIndexEXT, gl_PrimitiveID, barycentrics,
                            mat3(gl_WorldToObjectEXT), gl_HitTEXT);
}
