// render_surface.glsl -- what the path tracer knows about a surface it hit, from the hit's identity
// alone, so that the closest-hit shaders (render_triangle.rchit, render_lsnif.rchit) and the
// wavefront shading pass (render_wave.comp, from an LsnifQueryResult) report the same RenderHit:
// a triangle's interpolated normal, uv and material (textures included), an LSNIF hit's predicted
// normal and albedo with metallic / roughness / ambient occlusion / emission learned by a model with
// surface channels, else from the scene material its predicted material index maps to
// (RenderInstance::material_map).
#ifndef RENDER_SURFACE_GLSL
#define RENDER_SURFACE_GLSL

#include "lsnif/renderer/shaders/render_common.glsl"

// normal_mapped_shading_normal (src/lsnif/import/mesh.h): the object-space unit shading normal n of
// the triangle (object-space positions p, uvs) perturbed by the normal map's linear `texel` with
// glTF's scale, the tangent frame from the triangle's uv derivatives.
vec3 render_normal_mapped(vec3 n, vec3 p[3], vec2 uv[3], vec3 texel, float scale) {
  const vec3 dp1 = p[1] - p[0], dp2 = p[2] - p[0];
  const vec2 duv1 = uv[1] - uv[0], duv2 = uv[2] - uv[0];
  const float det = duv1.x * duv2.y - duv2.x * duv1.y;
  if (!(abs(det) > 1e-20)) return n;
  const vec3 t = (dp1 * duv2.y - dp2 * duv1.y) / det;
  const vec3 b = (dp2 * duv1.x - dp1 * duv2.x) / det;
  const vec3 t_ortho = t - n * dot(n, t);
  const float t_len = length(t_ortho);
  if (!(t_len > 1e-20) || isinf(t_len) || isnan(t_len)) return n;
  const vec3 tangent = t_ortho / t_len;
  const vec3 bitangent = cross(n, tangent) * (dot(cross(n, tangent), b) < 0.0 ? -1.0 : 1.0);
  const vec3 m = 2.0 * texel - 1.0;
  const vec3 mapped = tangent * (m.x * scale) + bitangent * (m.y * scale) + n * m.z;
  const float len = length(mapped);
  if (!(len > 1e-20) || isinf(len) || isnan(len) || !(dot(mapped, n) > 0.0)) return n;
  return mapped / len;
}

// uv through texture slot `slot`'s transform of material m (RenderMaterial::uv_transform).
vec2 render_slot_uv(RenderMaterial m, uint slot, vec2 uv) {
  const uint k = 6u * slot;
  return vec2(m.uv_transform[k] * uv.x + m.uv_transform[k + 2u] * uv.y + m.uv_transform[k + 4u],
              m.uv_transform[k + 1u] * uv.x + m.uv_transform[k + 3u] * uv.y + m.uv_transform[k + 5u]);
}

// Whether the point of triangle `primitive` of geometry `geometry` of TLAS instance `custom_index` at
// barycentrics (weights of vertices 1 and 2) is surface: its material's alpha (base_a x the base
// colour texture's alpha at the point's uv) is at least its alpha_cutoff; always for a cutoff of 0.
// The alpha test of Mesh::opaque_at (src/lsnif/import/mesh.h), run by render_triangle.rahit.
bool render_triangle_opaque(RenderFrame f, uint custom_index, uint geometry, uint primitive, vec2 barycentrics) {
  const RenderInstance inst = RenderInstanceRef(f.instances).v[custom_index];
  const RenderPrimitive prim = RenderPrimitiveRef(f.primitives).v[inst.first_primitive + geometry];
  const RenderMaterial m = RenderMaterialRef(f.materials).v[prim.material];
  if (!(m.alpha_cutoff > 0.0)) return true;
  float alpha = m.base_a;
  if (m.base_texture != RENDER_NO_TEXTURE && prim.uvs != 0ul) {
    RenderUintRef idx = RenderUintRef(prim.indices);
    RenderVec2Ref tex = RenderVec2Ref(prim.uvs);
    const vec2 uv = (1.0 - barycentrics.x - barycentrics.y) * tex.v[idx.v[3 * primitive]] +
                    barycentrics.x * tex.v[idx.v[3 * primitive + 1]] + barycentrics.y * tex.v[idx.v[3 * primitive + 2]];
    alpha *= render_texture(f, m.base_texture, render_slot_uv(m, RENDER_SLOT_BASE, uv), true).a;
  }
  return alpha >= m.alpha_cutoff;
}

// Material `m`'s channels at texture coordinate `uv` (its textures read through each slot's uv
// transform) into `hit`: albedo, metallic, roughness, ambient occlusion and emission. Triangle hits,
// and LSNIF hits that report their texture coordinate.
void render_material_at(RenderFrame f, RenderMaterial m, vec2 uv, inout RenderHit hit) {
  vec3 albedo = vec3(m.base_r, m.base_g, m.base_b);
  if (m.base_texture != RENDER_NO_TEXTURE)
    albedo *= render_texture(f, m.base_texture, render_slot_uv(m, RENDER_SLOT_BASE, uv), true).rgb;
  float metallic = m.metallic, roughness = m.roughness;
  if (m.metallic_roughness_texture != RENDER_NO_TEXTURE) {
    const vec4 mr = render_texture(f, m.metallic_roughness_texture, render_slot_uv(m, RENDER_SLOT_METALLIC_ROUGHNESS, uv), false);
    metallic *= mr.b;
    roughness *= mr.g;
  }
  vec3 emission = vec3(m.emission_r, m.emission_g, m.emission_b);
  if (m.emission_texture != RENDER_NO_TEXTURE)
    emission *= render_texture(f, m.emission_texture, render_slot_uv(m, RENDER_SLOT_EMISSION, uv), true).rgb;
  float occlusion = 1.0;
  if (m.occlusion_texture != RENDER_NO_TEXTURE)
    occlusion = 1.0 + m.occlusion_strength *
                          (render_texture(f, m.occlusion_texture, render_slot_uv(m, RENDER_SLOT_OCCLUSION, uv), false).r - 1.0);
  hit.albedo = albedo;
  hit.metallic = metallic;
  hit.roughness = roughness;
  hit.ambient_occlusion = occlusion;
  hit.emission = emission;
}

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
  const vec3 face = cross(p1 - p0, p2 - p0);
  const vec3 ng = normalize(normal_to_world * face);
  vec3 n_object = normalize(face);  // the shading normal in object space (Mesh::shading_normal)
  if (prim.normals != 0ul) {
    RenderVec3Ref nrm = RenderVec3Ref(prim.normals);
    const vec3 n = b.x * nrm.v[i0] + b.y * nrm.v[i1] + b.z * nrm.v[i2];
    if (dot(n, n) > 0.0) n_object = normalize(n);
  }
  vec2 uv = vec2(0.0);
  const RenderMaterial m = RenderMaterialRef(f.materials).v[prim.material];
  if (prim.uvs != 0ul) {
    RenderVec2Ref tex = RenderVec2Ref(prim.uvs);
    uv = b.x * tex.v[i0] + b.y * tex.v[i1] + b.z * tex.v[i2];
    if (m.normal_texture != RENDER_NO_TEXTURE) {
      vec3 p[3] = vec3[3](p0, p1, p2);
      vec2 uvs[3] = vec2[3](render_slot_uv(m, RENDER_SLOT_NORMAL, tex.v[i0]), render_slot_uv(m, RENDER_SLOT_NORMAL, tex.v[i1]),
                            render_slot_uv(m, RENDER_SLOT_NORMAL, tex.v[i2]));
      n_object = render_normal_mapped(n_object, p, uvs,
                                      render_texture(f, m.normal_texture, render_slot_uv(m, RENDER_SLOT_NORMAL, uv), false).rgb,
                                      m.normal_scale);
    }
  }
  RenderHit hit;
  hit.t = t;
  hit.flags = 0u;
  hit.normal = normalize(normal_to_world * n_object);
  hit.geometric_normal = ng;
  render_material_at(f, m, uv, hit);
  hit.world_to_object = world_to_object;
  hit.leaving_distance = 0.0;
  return hit;
}

// An LSNIF hit of TLAS instance `custom_index`: the predicted world normal, albedo and material
// (the model's index), with `learned` the surface channels (metallic, roughness, ambient occlusion)
// and emission the model learned, at ray parameter t; leaving_distance:
// LsnifSurface::leaving_distance. A hit that reports its texture coordinate (`reports_uv`, `uv`)
// takes every channel from the material's own textures there, as a triangle hit does.
RenderHit render_lsnif_hit(RenderFrame f, uint custom_index, vec3 normal, vec3 albedo, uint material, bool learned,
                           vec3 channels, vec3 emission, bool reports_uv, vec2 uv, mat3 world_to_object,
                           float leaving_distance, float t) {
  const RenderInstance inst = RenderInstanceRef(f.instances).v[custom_index];
  const uint slot = min(material, max(inst.material_count, 1u) - 1u);
  const RenderMaterial m = RenderMaterialRef(f.materials).v[RenderUintRef(f.material_maps).v[inst.material_map + slot]];
  RenderHit hit;
  hit.t = t;
  hit.flags = RENDER_HIT_LSNIF;
  hit.normal = normal;
  hit.geometric_normal = normal;
  hit.albedo = albedo;
  if (learned) {
    hit.metallic = channels.x;
    hit.roughness = channels.y;
    hit.ambient_occlusion = channels.z;
    hit.emission = emission;
  } else {
    hit.metallic = m.metallic;
    hit.roughness = m.roughness;
    hit.ambient_occlusion = 1.0;
    hit.emission = vec3(m.emission_r, m.emission_g, m.emission_b);
  }
  if (reports_uv) render_material_at(f, m, uv, hit);
  hit.world_to_object = world_to_object;
  hit.leaving_distance = leaving_distance;
  return hit;
}

#endif
