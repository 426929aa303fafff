// lsnif_batch_rows.glsl -- the steps of lsnif_intersect (lsnif_intersect.glsl) over a dense batch in
// the scratch, shared by the batched stages of one model (lsnif_batch.comp) and of the TLAS query
// (lsnif_query.comp). A batch is a table of rows of `stride` words (host_device.h): row 0 the item of
// each slot (a ray or a candidate), the walk (count, t_enter, t_exit, t[0 .. H-1]: 3 + H rows), the
// network input (2 x LSNIF_GPU_ROW_WORDS(input) rows) and the raw network output
// (8 x LSNIF_GPU_ROW_BLOCKS(output) rows), then the order row (the slots by walk length, in which the
// portable MLP stage takes them: lsnif_rows_order_by_points). Lane i of a dispatch reads word i of a
// row, so neighbouring lanes read neighbouring words.
#ifndef LSNIF_BATCH_ROWS_GLSL
#define LSNIF_BATCH_ROWS_GLSL

#include "lsnif/shaders/lsnif_intersect.glsl"

layout(buffer_reference, std430, buffer_reference_align = 4) coherent buffer LsnifScratchRef {
  uint w[];
};

uint64_t lsnif_batch_address(uint lo, uint hi) { return packUint2x32(uvec2(lo, hi)); }

// The rows of a batch: row k starts at word base + k x stride of the scratch.
struct LsnifBatchRows {
  LsnifScratchRef scratch;
  uint base;
  uint stride;
};

uint lsnif_rows_item(LsnifBatchRows r, uint slot) { return r.base + slot; }
uint lsnif_rows_walk(LsnifBatchRows r, uint k, uint slot) { return r.base + (1u + k) * r.stride + slot; }
uint lsnif_rows_input(LsnifBatchRows r, LsnifModel m, uint i, uint slot) {
  return r.base + (4u + m.h.max_points + i) * r.stride + slot;
}
uint lsnif_rows_output(LsnifBatchRows r, LsnifModel m, uint k, uint slot) {
  const uint input_rows = 2u * LSNIF_GPU_ROW_WORDS(lsnif_input_dim(m));
  return r.base + (4u + m.h.max_points + input_rows + k) * r.stride + slot;
}

// Column k of the order row, the row after the last output row.
uint lsnif_rows_order(LsnifBatchRows r, LsnifModel m, uint k) {
  return lsnif_rows_output(r, m, LSNIF_GPU_ROW_BLOCK * LSNIF_GPU_ROW_BLOCKS(lsnif_output_dim(m)), k);
}

// Narrow phase, after lsnif_intersect_walk found `points` > 0 boundary points and lsnif_encode ran:
// the item, the walk and the network input to `slot`.
void lsnif_rows_store_narrow(LsnifBatchRows r, LsnifModel m, uint slot, uint item, uint points) {
  r.scratch.w[lsnif_rows_item(r, slot)] = item;
  r.scratch.w[lsnif_rows_walk(r, 0u, slot)] = points;
  r.scratch.w[lsnif_rows_walk(r, 1u, slot)] = floatBitsToUint(lsnif_walk.t_enter);
  r.scratch.w[lsnif_rows_walk(r, 2u, slot)] = floatBitsToUint(lsnif_walk.t_exit);
  for (uint j = 0u; j < points; ++j) r.scratch.w[lsnif_rows_walk(r, 3u + j, slot)] = floatBitsToUint(lsnif_walk.t[j]);
  const uint inputs = 2u * LSNIF_GPU_ROW_WORDS(lsnif_input_dim(m));
  for (uint i = 0u; i < inputs; ++i) r.scratch.w[lsnif_rows_input(r, m, i, slot)] = floatBitsToUint(lsnif_act[i]);
}

// The MLP of `slot`: the input rows its walk filled in (lsnif_mlp_used_pairs), raw output rows out.
void lsnif_rows_mlp(LsnifBatchRows r, LsnifModel m, uint slot) {
  const uint points = r.scratch.w[lsnif_rows_walk(r, 0u, slot)];
  const uint inputs = 2u * lsnif_mlp_used_pairs(m, points);
  for (uint i = 0u; i < inputs; ++i) lsnif_act[i] = uintBitsToFloat(r.scratch.w[lsnif_rows_input(r, m, i, slot)]);
  const uint base = lsnif_mlp_forward(m, points);
  const uint outputs = LSNIF_GPU_ROW_BLOCK * LSNIF_GPU_ROW_BLOCKS(lsnif_output_dim(m));
  for (uint k = 0u; k < outputs; ++k)
    r.scratch.w[lsnif_rows_output(r, m, k, slot)] = floatBitsToUint(lsnif_act[base + k]);
}

// The MLP of slots `a` and `b` together (lsnif_mlp_forward_pair); without `has_b`, of `a` alone
// (B's arrays then hold a copy of A's, and its outputs are not written).
void lsnif_rows_mlp_pair(LsnifBatchRows r, LsnifModel m, uint a, uint b, bool has_b) {
  const uint points_a = r.scratch.w[lsnif_rows_walk(r, 0u, a)];
  const uint points_b = has_b ? r.scratch.w[lsnif_rows_walk(r, 0u, b)] : points_a;
  const uint inputs = 2u * lsnif_mlp_used_pairs(m, max(points_a, points_b));
  for (uint i = 0u; i < inputs; ++i) {
    lsnif_act[i] = uintBitsToFloat(r.scratch.w[lsnif_rows_input(r, m, i, a)]);
    lsnif_act_b[i] = has_b ? uintBitsToFloat(r.scratch.w[lsnif_rows_input(r, m, i, b)]) : lsnif_act[i];
  }
  const uint base = lsnif_mlp_forward_pair(m, points_a, points_b);
  const uint outputs = LSNIF_GPU_ROW_BLOCK * LSNIF_GPU_ROW_BLOCKS(lsnif_output_dim(m));
  for (uint k = 0u; k < outputs; ++k) {
    r.scratch.w[lsnif_rows_output(r, m, k, a)] = floatBitsToUint(lsnif_act[base + k]);
    if (has_b) r.scratch.w[lsnif_rows_output(r, m, k, b)] = floatBitsToUint(lsnif_act_b[base + k]);
  }
}

#if defined(LSNIF_ROWS_ORDER_STAGE)
// The order of the MLP stage: the pair kernel's first layer runs over the inputs of the longer walk
// of its two rays, and a group of invocations (a SIMD group of a CPU driver, a GPU's warp) over those
// of its longest ray, while a walk has 5 of 18 points on average; taken in order of point count, the
// rays of a group have walks of like length. The results are the same bits in any order (each ray's
// sums are its own; the shorter walk's inputs beyond its points are zero).
shared uint lsnif_rows_bins[LSNIF_MAX_POINTS + 1u];

uint lsnif_rows_points(LsnifBatchRows r, uint slot) {
  return min(r.scratch.w[lsnif_rows_walk(r, 0u, slot)], LSNIF_MAX_POINTS);
}

// One workgroup (every invocation calls it, `count` uniform): the slots first .. first + count - 1 by
// point count (a counting sort) into the order row's columns first .. first + count - 1.
void lsnif_rows_order_by_points(LsnifBatchRows r, LsnifModel m, uint first, uint count) {
  const uint lid = gl_LocalInvocationID.x;
  for (uint p = lid; p <= LSNIF_MAX_POINTS; p += LSNIF_BATCH_GROUP_SIZE) lsnif_rows_bins[p] = 0u;
  barrier();
  for (uint s = lid; s < count; s += LSNIF_BATCH_GROUP_SIZE) atomicAdd(lsnif_rows_bins[lsnif_rows_points(r, first + s)], 1u);
  barrier();
  if (lid == 0u) {
    uint sum = 0u;
    for (uint p = 0u; p <= LSNIF_MAX_POINTS; ++p) {
      const uint c = lsnif_rows_bins[p];
      lsnif_rows_bins[p] = sum;
      sum += c;
    }
  }
  barrier();
  for (uint s = lid; s < count; s += LSNIF_BATCH_GROUP_SIZE) {
    const uint k = atomicAdd(lsnif_rows_bins[lsnif_rows_points(r, first + s)], 1u);
    r.scratch.w[lsnif_rows_order(r, m, first + k)] = first + s;
  }
}
#endif

// The MLP of the slots in columns k and k + 1 of the order row (lsnif_rows_mlp_pair); without
// `has_b`, of column k's alone.
void lsnif_rows_mlp_ordered_pair(LsnifBatchRows r, LsnifModel m, uint k, bool has_b) {
  const uint a = r.scratch.w[lsnif_rows_order(r, m, k)];
  lsnif_rows_mlp_pair(r, m, a, has_b ? r.scratch.w[lsnif_rows_order(r, m, k + 1u)] : a, has_b);
}

// The item of `slot`.
uint lsnif_rows_load_item(LsnifBatchRows r, uint slot) { return r.scratch.w[lsnif_rows_item(r, slot)]; }

// The decode of `slot` (heads, then the acceptance against the item's interval and ray flags).
LsnifHitInfo lsnif_rows_decode(LsnifBatchRows r, LsnifModel m, uint slot, vec3 direction, float tmin, float tmax,
                               uint ray_flags) {
  const uint points = r.scratch.w[lsnif_rows_walk(r, 0u, slot)];
  lsnif_walk.count = points;
  lsnif_walk.t_enter = uintBitsToFloat(r.scratch.w[lsnif_rows_walk(r, 1u, slot)]);
  lsnif_walk.t_exit = uintBitsToFloat(r.scratch.w[lsnif_rows_walk(r, 2u, slot)]);
  for (uint j = 0u; j < points; ++j) lsnif_walk.t[j] = uintBitsToFloat(r.scratch.w[lsnif_rows_walk(r, 3u + j, slot)]);
  const uint outputs = lsnif_output_dim(m);
  for (uint k = 0u; k < outputs; ++k) lsnif_act[k] = uintBitsToFloat(r.scratch.w[lsnif_rows_output(r, m, k, slot)]);
  return lsnif_intersect_accept(lsnif_decode(m, 0u), points, direction, tmin, tmax, ray_flags);
}

#endif
