// render_lsnif.rchit -- closest hit on an LSNIF object (hit group with shaders/lsnif.rint): the
// network's normal and albedo (shaders/lsnif_hit.glsl), metallic / roughness / emission from the
// scene material its predicted material index maps to (RenderInstance::material_map).
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"
#include "lsnif_hit.glsl"

layout(location = 0) rayPayloadInEXT RenderHit hit;
hitAttributeEXT LsnifHitAttributes lsnif_attributes;

void main() {
  const RenderFrame f = render_frame();
  const LsnifSurface s = lsnif_surface(lsnif_attributes);
  const RenderInstance inst = RenderInstanceRef(f.instances).v[gl_InstanceCustomIndexEXT];
  const uint slot = min(s.material, max(inst.material_count, 1u) - 1u);
  const RenderMaterial m = RenderMaterialRef(f.materials).v[RenderUintRef(f.material_maps).v[inst.material_map + slot]];
  hit.t = gl_HitTEXT;
  hit.flags = RENDER_HIT_LSNIF;
  hit.normal = s.normal;
  hit.geometric_normal = s.normal;
  hit.albedo = s.albedo;
  hit.metallic = m.metallic;
  hit.roughness = m.roughness;
  hit.emission = vec3(m.emission_r, m.emission_g, m.emission_b);
  hit.world_to_object = mat3(gl_WorldToObjectEXT);
  hit.leaving_distance = s.leaving_distance;
}
