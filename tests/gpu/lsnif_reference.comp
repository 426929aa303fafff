// lsnif_reference.comp -- evaluates a buffer of world-space rays against one instance of one LSNIF
// model with src/lsnif/shaders/lsnif_intersect.glsl, for comparison with the CPU reference
// (src/lsnif/core/intersector.cpp). Everything is addressed by buffer device addresses in the push constant.
// The instance: object-to-world A x + T (rows of the 3x4 VkTransformMatrixKHR layout) and A^-1
// (computed on the host exactly as the CPU reference does, as a driver provides
// gl_WorldToObjectEXT): object ray = A^-1 (o - T), A^-1 d; world normal = normalize(A^-T n).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "lsnif/shaders/lsnif_intersect.glsl"
#define LSNIF_HIT_DECODE_ONLY  // a compute shader: the packers of lsnif_hit.glsl only
#include "lsnif/lsnif_hit.glsl"

layout(local_size_x = 64) in;

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer RayRef {
  LsnifReferenceRay rays[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer HitRef {
  LsnifReferenceHit hits[];
};

layout(push_constant) uniform Push {
  uint64_t model;
  uint64_t rays;
  uint64_t hits;
  uint ray_count;
  uint pad;
  vec4 object_to_world[3];  // rows: A[r][0..2], T[r]
  vec4 world_to_object[3];  // rows of A^-1 in xyz
} pc;

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.ray_count) return;
  const LsnifReferenceRay ray = RayRef(pc.rays).rays[i];
  const mat3 A_inv = transpose(mat3(pc.world_to_object[0].xyz, pc.world_to_object[1].xyz,
                                    pc.world_to_object[2].xyz));
  const vec3 T = vec3(pc.object_to_world[0].w, pc.object_to_world[1].w, pc.object_to_world[2].w);
  const vec3 origin = vec3(ray.origin_x, ray.origin_y, ray.origin_z);
  const vec3 direction = vec3(ray.direction_x, ray.direction_y, ray.direction_z);

  LsnifModel m = lsnif_load_model(pc.model);
  const LsnifHitInfo h = lsnif_intersect(m, A_inv * (origin - T), A_inv * direction, ray.tmin, ray.tmax, 0u);

  LsnifReferenceHit out_hit;
  out_hit.hit = h.hit ? 1u : 0u;
  out_hit.points = h.points;
  out_hit.occlusion_logit = h.occlusion_logit;
  out_hit.t = h.t;
  vec3 nw = transpose(A_inv) * h.normal;
  const float len = length(nw);
  nw = len > 0.0 ? nw / len : vec3(0.0);
  out_hit.normal_x = nw.x;
  out_hit.normal_y = nw.y;
  out_hit.normal_z = nw.z;
  out_hit.material = h.material;
  out_hit.albedo_x = h.albedo.x;
  out_hit.albedo_y = h.albedo.y;
  out_hit.albedo_z = h.albedo.z;
  out_hit.surface = lsnif_pack_surface(h.surface_learned, h.metallic, h.roughness, h.ambient_occlusion);
  out_hit.emission_r = h.emission.r;
  out_hit.emission_g = h.emission.g;
  out_hit.emission_b = h.emission.b;
  const float dir_len = length(A_inv * direction);
  out_hit.leaving_tmin = h.hit && dir_len > 0.0 ? lsnif_leaving_distance(m) / dir_len : 0.0;
  out_hit.instance = 0u;
  out_hit.reports_uv = h.reports_uv ? 1u : 0u;
  out_hit.uv_u = h.uv.x;
  out_hit.uv_v = h.uv.y;
  HitRef(pc.hits).hits[i] = out_hit;
}
