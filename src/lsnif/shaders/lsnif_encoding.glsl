// lsnif_encoding.glsl -- sparse hash-grid encoding of a walk (src/lsnif/core/hash_grid.cpp: face_corners,
// hash_vertex, encode): each boundary point is interpolated bilinearly from the 4 corners of the
// face cell containing it, per level; an indexed level addresses its table through its perfect hash
// (lsnif_perfect_hash.glsl). Writes the network input into lsnif_act[0, input_dim),
// layout [point][level][feature], zero for points j >= walk.count.
#ifndef LSNIF_ENCODING_GLSL
#define LSNIF_ENCODING_GLSL

#include "lsnif/shaders/lsnif_perfect_hash.glsl"
#include "lsnif/shaders/lsnif_walk.glsl"

// The MLP's private activation storage: the input (up to LSNIF_MAX_INPUT values) lives at
// [0, LSNIF_MAX_INPUT), layers alternate between the two regions (see lsnif_mlp.glsl). One slot
// beyond an odd-sized vector is kept zero, so weight rows can be read as fp16 pairs.
#define LSNIF_MAX_INPUT (LSNIF_MAX_POINTS * LSNIF_MAX_LEVELS * LSNIF_MAX_FEATURES)
#define LSNIF_ACT_SIZE (LSNIF_MAX_INPUT + LSNIF_MAX_HIDDEN_WIDTH)
float lsnif_act[LSNIF_ACT_SIZE];

// hash_vertex.
uint lsnif_hash_vertex(uvec3 v, uint log2_size) {
  const uint h = (v.x * LSNIF_HASH_PRIME_X) ^ (v.y * LSNIF_HASH_PRIME_Y) ^ (v.z * LSNIF_HASH_PRIME_Z);
  return h & ((1u << log2_size) - 1u);
}

// encode + face_corners: accumulates point j's features at every level into lsnif_act.
void lsnif_encode_point(LsnifModel m, uint j) {
  const uint L = m.h.grid_levels, F = m.h.features;
  const vec3 p = lsnif_walk.p[j];
  const uint a = lsnif_walk.axis[j], b = (a + 1u) % 3u, c = (a + 2u) % 3u;
  uint offset = 0u;       // entries of the levels before l
  uint index_first = 0u;  // displacements of the indexed levels before l
  for (uint l = 0u; l < L; ++l) {
    const uint R = lsnif_grid_resolution(m, l), M = LSNIF_GPU_TABLE_LOG2(m.h.table_log2, l);
    const uint slots = lsnif_index_slots(m, l), buckets = lsnif_index_buckets(m, l);
    const float Rf = float(R);
    // The plane coordinate is (up to rounding) an integer; std::lround of a non-negative value.
    const float xa = clamp(p[a] * Rf, 0.0, Rf);
    uint ia = uint(xa);
    if (xa - float(ia) >= 0.5) ia += 1u;
    const float xb = clamp(p[b] * Rf, 0.0, Rf), xc = clamp(p[c] * Rf, 0.0, Rf);
    const uint ib = min(uint(xb), R - 1u), ic = min(uint(xc), R - 1u);
    const float wb = xb - float(ib), wc = xc - float(ic);
    const uint out_base = (j * L + l) * F;
    for (uint k = 0u; k < 4u; ++k) {
      uvec3 v;
      v[a] = ia;
      v[b] = ib + (k & 1u);
      v[c] = ic + (k >> 1);
      const uint entry =
          offset + (slots != 0u ? lsnif_perfect_hash_slot(m, index_first, slots, buckets, v) : lsnif_hash_vertex(v, M));
      const float weight = ((k & 1u) != 0u ? wb : 1.0 - wb) * ((k >> 1) != 0u ? wc : 1.0 - wc);
      for (uint f = 0u; f < F; ++f)
        lsnif_act[out_base + f] += weight * lsnif_grid_value(m, l, entry * F + f);
    }
    offset += slots != 0u ? slots : 1u << M;
    index_first += buckets;
  }
}

// encode: the whole input vector (input_dim values, plus a zero pad slot when input_dim is odd).
void lsnif_encode(LsnifModel m) {
  const uint dim = lsnif_input_dim(m);
  for (uint i = 0u; i < 2u * LSNIF_GPU_ROW_WORDS(dim); ++i) lsnif_act[i] = 0.0;
  const uint n = min(lsnif_walk.count, m.h.max_points);
  for (uint j = 0u; j < n; ++j) lsnif_encode_point(m, j);
}

#endif
