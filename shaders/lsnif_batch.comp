// lsnif_batch.comp -- the batched (wavefront) path of one model: the steps of lsnif_intersect
// (lsnif_intersect.glsl) as separate passes over many rays, so that the network runs on a dense
// batch with the model's weights at one address for the whole dispatch (paper section 4: narrow
// phase, batched inference, resolve). Compiled once per stage (glslangValidator -D):
//  LSNIF_BATCH_CLEAR   1 invocation: the batch size (scratch word 0) = 0.
//  LSNIF_BATCH_NARROW  1 invocation per ray: the walk (tmax = inf) and the hash-grid encoding; rays
//                      without boundary points get their miss written here, the others take a batch
//                      slot (atomic counter) and leave their walk and network input in the scratch.
//  LSNIF_BATCH_MLP     1 invocation per batch slot: the MLP (lsnif_mlp.glsl) with the weights read at
//                      addresses uniform over the dispatch (one load serves every lane: on lavapipe
//                      a SIMD register of rays, on a GPU a warp), raw outputs to the scratch.
//  LSNIF_BATCH_DECODE  1 invocation per batch slot: the heads (lsnif_head.glsl) and the acceptance
//                      against the ray's interval and culling flags; the hit to the ray's record.
// Layouts: LsnifQueryRay, LsnifQueryHit, LsnifBatchPushConstants and the scratch in
// shaders/host_device.h. The scratch rows are structure-of-arrays: lane i of a dispatch reads word
// i of a row, so neighbouring lanes read neighbouring words.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "lsnif_intersect.glsl"

layout(local_size_x = LSNIF_BATCH_GROUP_SIZE) in;

layout(push_constant, std430) uniform LsnifBatchPush { LsnifBatchPushConstants pc; };

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer LsnifQueryRaysRef {
  LsnifQueryRay r[];
};
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer LsnifQueryHitsRef {
  LsnifQueryHit h[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) coherent buffer LsnifScratchRef {
  uint w[];
};

uint64_t lsnif_batch_address(uint lo, uint hi) { return packUint2x32(uvec2(lo, hi)); }
LsnifScratchRef lsnif_scratch() { return LsnifScratchRef(lsnif_batch_address(pc.scratch_lo, pc.scratch_hi)); }

// First word of each scratch section (host_device.h).
uint lsnif_batch_slots_row() { return LSNIF_BATCH_HEADER_WORDS; }
uint lsnif_batch_walk_row(uint k) { return LSNIF_BATCH_HEADER_WORDS + (1u + k) * pc.stride; }
uint lsnif_batch_input_row(LsnifModel m, uint i) {
  return LSNIF_BATCH_HEADER_WORDS + (4u + m.h.max_points + i) * pc.stride;
}
uint lsnif_batch_output_row(LsnifModel m, uint k) {
  const uint input_rows = 2u * LSNIF_GPU_ROW_WORDS(lsnif_input_dim(m));
  return LSNIF_BATCH_HEADER_WORDS + (4u + m.h.max_points + input_rows + k) * pc.stride;
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
  q.reserved = 0u;
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
#if defined(LSNIF_BATCH_NARROW)
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
  const uint slot = atomicAdd(scratch.w[0], 1u);
  scratch.w[lsnif_batch_slots_row() + slot] = ray;
  scratch.w[lsnif_batch_walk_row(0u) + slot] = points;
  scratch.w[lsnif_batch_walk_row(1u) + slot] = floatBitsToUint(lsnif_walk.t_enter);
  scratch.w[lsnif_batch_walk_row(2u) + slot] = floatBitsToUint(lsnif_walk.t_exit);
  for (uint j = 0u; j < points; ++j) scratch.w[lsnif_batch_walk_row(3u + j) + slot] = floatBitsToUint(lsnif_walk.t[j]);
  const uint inputs = 2u * LSNIF_GPU_ROW_WORDS(lsnif_input_dim(m));
  for (uint i = 0u; i < inputs; ++i) scratch.w[lsnif_batch_input_row(m, i) + slot] = floatBitsToUint(lsnif_act[i]);
#else
  // Only the first `count` slots hold work, and a CPU driver hands each thread one contiguous range
  // of workgroups (lavapipe does): the blocks of slots are spread over the workgroups by a stride
  // coprime to their count, so that every range gets its share of the work.
  const uint block = (gl_WorkGroupID.x * pc.block_step) % gl_NumWorkGroups.x;
  const uint slot = block * LSNIF_BATCH_GROUP_SIZE + gl_LocalInvocationID.x;
  if (slot >= scratch.w[0]) return;
#if defined(LSNIF_BATCH_MLP)
  const uint inputs = 2u * LSNIF_GPU_ROW_WORDS(lsnif_input_dim(m));
  for (uint i = 0u; i < inputs; ++i) lsnif_act[i] = uintBitsToFloat(scratch.w[lsnif_batch_input_row(m, i) + slot]);
  const uint base = lsnif_mlp_forward(m);
  const uint outputs = LSNIF_GPU_ROW_BLOCK * LSNIF_GPU_ROW_BLOCKS(lsnif_output_dim(m));
  for (uint k = 0u; k < outputs; ++k) scratch.w[lsnif_batch_output_row(m, k) + slot] = floatBitsToUint(lsnif_act[base + k]);
#elif defined(LSNIF_BATCH_DECODE)
  const uint ray = scratch.w[lsnif_batch_slots_row() + slot];
  const uint points = scratch.w[lsnif_batch_walk_row(0u) + slot];
  lsnif_walk.count = points;
  lsnif_walk.t_enter = uintBitsToFloat(scratch.w[lsnif_batch_walk_row(1u) + slot]);
  lsnif_walk.t_exit = uintBitsToFloat(scratch.w[lsnif_batch_walk_row(2u) + slot]);
  for (uint j = 0u; j < points; ++j) lsnif_walk.t[j] = uintBitsToFloat(scratch.w[lsnif_batch_walk_row(3u + j) + slot]);
  const uint outputs = lsnif_output_dim(m);
  for (uint k = 0u; k < outputs; ++k) lsnif_act[k] = uintBitsToFloat(scratch.w[lsnif_batch_output_row(m, k) + slot]);
  const LsnifQueryRay q = lsnif_batch_ray(ray);
  const vec3 direction = vec3(q.direction_x, q.direction_y, q.direction_z);
  lsnif_batch_write_hit(ray, lsnif_intersect_accept(lsnif_decode(m, 0u), points, direction, q.tmin, q.tmax, q.flags));
#else
#error "compile with one of LSNIF_BATCH_CLEAR, LSNIF_BATCH_NARROW, LSNIF_BATCH_MLP, LSNIF_BATCH_DECODE"
#endif
#endif
#endif
}
