// render_lsnif.rchit -- closest hit on an LSNIF object (hit group with src/lsnif/shaders/lsnif.rint): the
// network's normal, albedo and material (src/lsnif/lsnif_hit.glsl) as a RenderHit
// (render_lsnif_hit, render_surface.glsl).
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/renderer/shaders/render_surface.glsl"
#include "lsnif/lsnif_hit.glsl"

layout(location = 0) rayPayloadInEXT RenderHit hit;
hitAttributeEXT LsnifHitAttributes lsnif_attributes;

void main() {
  const LsnifSurface s = lsnif_surface(lsnif_attributes);
  hit = render_lsnif_hit(render_frame(), gl_InstanceCustomIndexEXT, s.normal, s.albedo, s.material, s.surface_learned,
                         vec3(s.metallic, s.roughness, s.ambient_occlusion), s.emission, s.reports_uv, s.uv,
                         mat3(gl_WorldToObjectEXT), s.leaving_distance, gl_HitTEXT);
}
