// lsnif_batch.comp -- the batched (wavefront) path of one model: the steps of lsnif_intersect
// (lsnif_intersect.glsl) as separate passes over many rays, so that the network runs on a dense
// batch with the model's weights at one address for the whole dispatch (paper section 4: narrow
// phase, batched inference, resolve). Compiled once per stage (glslangValidator -D):
//  LSNIF_BATCH_CLEAR   1 invocation: the batch size (scratch word 0) = 0.
//  LSNIF_BATCH_NARROW  1 invocation per ray: the walk (tmax = inf) and the hash-grid encoding; rays
//                      without boundary points get their miss written here, the others take a batch
//                      slot (atomic counter) and leave their walk and network input in the scratch.
//  LSNIF_BATCH_ORDER   1 workgroup: the batch slots by walk length into the order row (a counting
//                      sort, lsnif_rows_order_by_points), the order the portable MLP takes them in.
//  LSNIF_BATCH_MLP     1 invocation per two batch slots (half of each workgroup's lanes): the MLP
//                      (lsnif_mlp.glsl, lsnif_mlp_forward_pair) with the weights read at
//                      addresses uniform over the dispatch (one load serves every lane: on lavapipe
//                      a SIMD register of rays, on a GPU a warp), raw outputs to the scratch. With
//                      LSNIF_MLP_COOPMAT_NV as well: the workgroup's 64 slots together on
//                      cooperative matrices (lsnif_mlp_coopmat.glsl; unverified, opt-in).
//  LSNIF_BATCH_DECODE  1 invocation per batch slot: the heads (lsnif_head.glsl) and the acceptance
//                      against the ray's interval and culling flags, the texture coordinate of an
//                      accepted hit that reports one (lsnif_hit_uv); the hit to the ray's record.
// Layouts: LsnifQueryRay, LsnifQueryHit, LsnifBatchPushConstants and the scratch in
// src/lsnif/host_device.h; the batch rows and the per-slot steps are lsnif_batch_rows.glsl's (shared
// with the TLAS query, lsnif_query.comp).
#version 460
#extension GL_GOOGLE_include_directive : require
#if defined(LSNIF_BATCH_ORDER)
#define LSNIF_ROWS_ORDER_STAGE
#endif
#include "lsnif/shaders/lsnif_batch_rows.glsl"
#define LSNIF_HIT_DECODE_ONLY  // a compute shader: the packers of lsnif_hit.glsl only
#include "lsnif/lsnif_hit.glsl"
#if defined(LSNIF_MLP_COOPMAT_NV)
#include "lsnif/shaders/lsnif_mlp_coopmat.glsl"
#endif

layout(local_size_x = LSNIF_BATCH_GROUP_SIZE) in;

layout(push_constant, std430) uniform LsnifBatchPush { LsnifBatchPushConstants pc; };

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer LsnifQueryRaysRef {
  LsnifQueryRay r[];
};
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer LsnifQueryHitsRef {
  LsnifQueryHit h[];
};

LsnifScratchRef lsnif_scratch() { return LsnifScratchRef(lsnif_batch_address(pc.scratch_lo, pc.scratch_hi)); }

// The batch rows start after the header (word 0: the batch size).
LsnifBatchRows lsnif_batch_rows() {
  LsnifBatchRows r;
  r.scratch = lsnif_scratch();
  r.base = LSNIF_BATCH_HEADER_WORDS;
  r.stride = pc.stride;
  return r;
}

void lsnif_batch_write_hit(uint ray, LsnifHitInfo h) {
  LsnifQueryHit q;
  q.t = h.t;
  q.normal_x = h.normal.x;
  q.normal_y = h.normal.y;
  q.normal_z = h.normal.z;
  q.albedo_r = h.albedo.r;
  q.albedo_g = h.albedo.g;
  q.albedo_b = h.albedo.b;
  q.material = h.material;
  q.kind = h.hit ? LSNIF_QUERY_HIT_LSNIF : LSNIF_QUERY_HIT_NONE;
  q.points = h.points;
  q.occlusion_logit = h.occlusion_logit;
  q.surface = lsnif_pack_surface(h.surface_learned, h.metallic, h.roughness, h.ambient_occlusion);
  q.emission_r = h.emission.r;
  q.emission_g = h.emission.g;
  q.emission_b = h.emission.b;
  q.reports_uv = h.reports_uv ? 1u : 0u;
  q.uv_u = h.uv.x;
  q.uv_v = h.uv.y;
  q.reserved0 = 0u;
  q.reserved1 = 0u;
  LsnifQueryHitsRef(lsnif_batch_address(pc.hits_lo, pc.hits_hi)).h[ray] = q;
}

LsnifQueryRay lsnif_batch_ray(uint ray) {
  return LsnifQueryRaysRef(lsnif_batch_address(pc.rays_lo, pc.rays_hi)).r[ray];
}

void main() {
  LsnifScratchRef scratch = lsnif_scratch();
#if defined(LSNIF_BATCH_CLEAR)
  if (gl_GlobalInvocationID.x == 0u) scratch.w[0] = 0u;
#else
  LsnifModel m = lsnif_load_model(lsnif_batch_address(pc.model_lo, pc.model_hi));
  LsnifBatchRows rows = lsnif_batch_rows();
#if defined(LSNIF_BATCH_ORDER)
  lsnif_rows_order_by_points(rows, m, 0u, scratch.w[0]);
#elif defined(LSNIF_BATCH_NARROW)
  const uint ray = gl_GlobalInvocationID.x;
  if (ray >= pc.ray_count) return;
  const LsnifQueryRay q = lsnif_batch_ray(ray);
  const vec3 origin = vec3(q.origin_x, q.origin_y, q.origin_z);
  const vec3 direction = vec3(q.direction_x, q.direction_y, q.direction_z);
  const uint points = lsnif_intersect_walk(m, origin, direction, q.tmin, q.tmax);
  if (points == 0u) {
    lsnif_batch_write_hit(ray, lsnif_intersect_none());
    return;
  }
  lsnif_encode(m);
  lsnif_rows_store_narrow(rows, m, atomicAdd(scratch.w[0], 1u), ray, points);
#else
  // Only the first `count` slots hold work, and a CPU driver hands each thread one contiguous range
  // of workgroups (lavapipe does): the blocks of slots are spread over the workgroups by a stride
  // coprime to their count, so that every range gets its share of the work.
  const uint block = (gl_WorkGroupID.x * pc.block_step) % gl_NumWorkGroups.x;
#if defined(LSNIF_BATCH_MLP) && defined(LSNIF_MLP_COOPMAT_NV)
  lsnif_rows_mlp_block(rows, m, block * LSNIF_BATCH_GROUP_SIZE, scratch.w[0]);
#elif defined(LSNIF_BATCH_MLP)
  // The workgroup's columns of the order row two per invocation, by its first half of lanes.
  const uint pair = 2u * (block * LSNIF_BATCH_GROUP_SIZE + gl_LocalInvocationID.x);
  if (pair >= scratch.w[0]) return;
  lsnif_rows_mlp_ordered_pair(rows, m, pair, pair + 1u < scratch.w[0]);
#elif defined(LSNIF_BATCH_DECODE)
  const uint slot = block * LSNIF_BATCH_GROUP_SIZE + gl_LocalInvocationID.x;
  if (slot >= scratch.w[0]) return;
  const uint ray = lsnif_rows_load_item(rows, slot);
  const LsnifQueryRay q = lsnif_batch_ray(ray);
  const vec3 origin = vec3(q.origin_x, q.origin_y, q.origin_z);
  const vec3 direction = vec3(q.direction_x, q.direction_y, q.direction_z);
  LsnifHitInfo h = lsnif_rows_decode(rows, m, slot, direction, q.tmin, q.tmax, q.flags);
  lsnif_hit_uv(m, h, origin, direction);
  lsnif_batch_write_hit(ray, h);
#else
#error "compile with one of LSNIF_BATCH_CLEAR, LSNIF_BATCH_NARROW, LSNIF_BATCH_ORDER, LSNIF_BATCH_MLP, LSNIF_BATCH_DECODE"
#endif
#endif
#endif
}
