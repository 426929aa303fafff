// render_triangle.rchit -- closest hit on a triangle mesh: interpolates the primitive's normal and
// uv at the barycentrics, evaluates its material (textures included) and reports a RenderHit.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(location = 0) rayPayloadInEXT RenderHit hit;
hitAttributeEXT vec2 barycentrics;

void main() {
  const RenderFrame f = render_frame();
  const RenderInstance inst = RenderInstanceRef(f.instances).v[gl_InstanceCustomIndexEXT];
  const RenderPrimitive prim = RenderPrimitiveRef(f.primitives).v[inst.first_primitive + gl_GeometryIndexEXT];
  RenderUintRef idx = RenderUintRef(prim.indices);
  const uint i0 = idx.v[3 * gl_PrimitiveID], i1 = idx.v[3 * gl_PrimitiveID + 1], i2 = idx.v[3 * gl_PrimitiveID + 2];
  const vec3 b = vec3(1.0 - barycentrics.x - barycentrics.y, barycentrics.x, barycentrics.y);
  RenderVec3Ref pos = RenderVec3Ref(prim.positions);
  const vec3 p0 = pos.v[i0], p1 = pos.v[i1], p2 = pos.v[i2];
  const mat3 normal_to_world = transpose(mat3(gl_WorldToObjectEXT));
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

  hit.t = gl_HitTEXT;
  hit.flags = 0u;
  hit.normal = ns;
  hit.geometric_normal = ng;
  hit.albedo = albedo;
  hit.metallic = metallic;
  hit.roughness = roughness;
  hit.emission = emission;
  hit.world_to_object = mat3(gl_WorldToObjectEXT);
  hit.leaving_distance = 0.0;
}
