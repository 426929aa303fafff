// render_surface.glsl -- what the path tracer knows about a surface it hit, from the hit's identity
// alone, so that the closest-hit shaders (render_triangle.rchit, render_lsnif.rchit) and the
// wavefront shading pass (render_wave.comp, from an LsnifQueryResult) report the same RenderHit:
// a triangle's interpolated normal, uv and material (textures included), an LSNIF hit's predicted
// normal and albedo with metallic / roughness / emission from the scene material its predicted
// material index maps to (RenderInstance::material_map).
#ifndef RENDER_SURFACE_GLSL
#define RENDER_SURFACE_GLSL

#include "lsnif/renderer/shaders/render_common.glsl"

// Triangle `primitive` of geometry `geometry` of TLAS instance `custom_index` at barycentrics
// (weights of vertices 1 and 2), hit at ray parameter t; world_to_object: the instance's linear part.
RenderHit render_triangle_hit(RenderFrame f, uint custom_index, uint geometry, uint primitive, vec2 barycentrics,
                              mat3 world_to_object, float t) {
  const RenderInstance inst = RenderInstanceRef(f.instances).v[custom_index];
  const RenderPrimitive prim = RenderPrimitiveRef(f.primitives).v[inst.first_primitive + geometry];
  RenderUintRef idx = RenderUintRef(prim.indices);
  const uint i0 = idx.v[3 * primitive], i1 = idx.v[3 * primitive + 1], i2 = idx.v[3 * primitive + 2];
  const vec3 b = vec3(1.0 - barycentrics.x - barycentrics.y, barycentrics.x, barycentrics.y);
  RenderVec3Ref pos = RenderVec3Ref(prim.positions);
  const vec3 p0 = pos.v[i0], p1 = pos.v[i1], p2 = pos.v[i2];
  const mat3 normal_to_world = transpose(world_to_object);
  const vec3 ng = normalize(normal_to_world * cross(p1 - p0, p2 - p0));
  vec3 ns = ng;
  if (prim.normals != 0ul) {
    RenderVec3Ref nrm = RenderVec3Ref(prim.normals);
    const vec3 n = normal_to_world * (b.x * nrm.v[i0] + b.y * nrm.v[i1] + b.z * nrm.v[i2]);
    if (dot(n, n) > 0.0) ns = normalize(n);
  }
  vec2 uv = vec2(0.0);
  if (prim.uvs != 0ul) {
    RenderVec2Ref tex = RenderVec2Ref(prim.uvs);
    uv = b.x * tex.v[i0] + b.y * tex.v[i1] + b.z * tex.v[i2];
  }
  const RenderMaterial m = RenderMaterialRef(f.materials).v[prim.material];
  vec3 albedo = vec3(m.base_r, m.base_g, m.base_b);
  if (m.base_texture != RENDER_NO_TEXTURE) albedo *= render_texture(f, m.base_texture, uv, true).rgb;
  float metallic = m.metallic, roughness = m.roughness;
  if (m.metallic_roughness_texture != RENDER_NO_TEXTURE) {
    const vec4 mr = render_texture(f, m.metallic_roughness_texture, uv, false);
    metallic *= mr.b;
    roughness *= mr.g;
  }
  vec3 emission = vec3(m.emission_r, m.emission_g, m.emission_b);
  if (m.emission_texture != RENDER_NO_TEXTURE) emission *= render_texture(f, m.emission_texture, uv, true).rgb;

  RenderHit hit;
  hit.t = t;
  hit.flags = 0u;
  hit.normal = ns;
  hit.geometric_normal = ng;
  hit.albedo = albedo;
  hit.metallic = metallic;
  hit.roughness = roughness;
  hit.emission = emission;
  hit.world_to_object = world_to_object;
  hit.leaving_distance = 0.0;
  return hit;
}

// An LSNIF hit of TLAS instance `custom_index`: the predicted world normal, albedo and material
// (the model's index), at ray parameter t; leaving_distance: LsnifSurface::leaving_distance.
RenderHit render_lsnif_hit(RenderFrame f, uint custom_index, vec3 normal, vec3 albedo, uint material,
                           mat3 world_to_object, float leaving_distance, float t) {
  const RenderInstance inst = RenderInstanceRef(f.instances).v[custom_index];
  const uint slot = min(material, max(inst.material_count, 1u) - 1u);
  const RenderMaterial m = RenderMaterialRef(f.materials).v[RenderUintRef(f.material_maps).v[inst.material_map + slot]];
  RenderHit hit;
  hit.t = t;
  hit.flags = RENDER_HIT_LSNIF;
  hit.normal = normal;
  hit.geometric_normal = normal;
  hit.albedo = albedo;
  hit.metallic = m.metallic;
  hit.roughness = m.roughness;
  hit.emission = vec3(m.emission_r, m.emission_g, m.emission_b);
  hit.world_to_object = world_to_object;
  hit.leaving_distance = leaving_distance;
  return hit;
}

#endif
