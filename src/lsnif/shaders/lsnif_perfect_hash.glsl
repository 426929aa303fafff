// lsnif_perfect_hash.glsl -- the slot of a grid vertex in an indexed level (src/lsnif/core/perfect_hash.h:
// perfect_hash_mix, perfect_hash_key, perfect_hash_slot), the same 32-bit integer math.
#ifndef LSNIF_PERFECT_HASH_GLSL
#define LSNIF_PERFECT_HASH_GLSL

#include "lsnif/shaders/lsnif_model.glsl"

// perfect_hash_mix: the murmur3 32-bit finalizer.
uint lsnif_perfect_hash_mix(uint h) {
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  h *= 0xc2b2ae35u;
  h ^= h >> 16;
  return h;
}

// perfect_hash_key.
uint lsnif_perfect_hash_key(uint seed, uvec3 v) {
  return lsnif_perfect_hash_mix(
      v.x ^ lsnif_perfect_hash_mix(v.y ^ lsnif_perfect_hash_mix(v.z ^ (seed * 0x27d4eb2fu + 0x165667b1u))));
}

// perfect_hash_slot of vertex v in a level of `slots` slots whose `buckets` displacements start at
// element `first` of the model's index section (u16, two per word).
uint lsnif_perfect_hash_slot(LsnifModel m, uint first, uint slots, uint buckets, uvec3 v) {
  const uint i = first + lsnif_perfect_hash_key(0u, v) % buckets;
  const uint d = (m.words.w[m.h.index_offset + (i >> 1)] >> ((i & 1u) * 16u)) & 0xffffu;
  return lsnif_perfect_hash_mix(lsnif_perfect_hash_key(1u, v) + d * 0x9e3779b9u) % slots;
}

#endif
