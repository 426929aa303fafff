// perfect_hash.h -- a collision-free ("indexed") layout for one hash-grid level: a near-minimal
// perfect hash built once from the level's readable vertices (grid_usage.h: the vertices on faces
// of occupied voxels, the only ones the encoder reads with a non-zero weight).
//
// Contract ("hash and displace"): the N distinct keys are split into B = ceil(N / 4) buckets by
// bucket(v) = h1(v) mod B; the buckets are placed by decreasing size (ties by bucket index), each
// with the smallest displacement d in [0, 65535] for which slot(v, d) = mix(h2(v) + d * 0x9E3779B9)
// mod S is free and distinct for every key of the bucket. Afterwards every key has its own slot in
// [0, S). Any other vertex also maps into [0, S) (somewhere arbitrary: the encoder reads it only with
// weight zero). Deterministic: the same keys (in any order) and S give the same displacements.
// Integer math on 32-bit unsigned values only, so src/lsnif/shaders/lsnif_encoding.glsl computes the same.
#pragma once
#include <cstdint>
#include <vector>

#include "lsnif/format/status.h"

namespace lsnif {

struct GridVertex {
  uint32_t x = 0, y = 0, z = 0;
};

struct PerfectHash {
  uint32_t slots = 0;                  // S: the level's table entries
  std::vector<uint16_t> displacement;  // one per bucket (B = size)
};

// a % d for any 32-bit a and d >= 1, by two multiplications instead of a division, given magic =
// perfect_hash_mod_magic(d) (Lemire, Kaser and Kurz, "Faster remainder by direct computation", 2019):
// the high 64 bits of the 96-bit product (magic * a mod 2^64) * d.
inline uint64_t perfect_hash_mod_magic(uint32_t d) { return UINT64_MAX / d + 1; }
inline uint32_t perfect_hash_mod(uint32_t a, uint64_t magic, uint32_t d) {
  const uint64_t low = magic * a;
  const uint64_t lo = (low & 0xffffffffu) * d, hi = (low >> 32) * d;
  return uint32_t((hi + (lo >> 32)) >> 32);
}

// A perfect hash as stored in a model (Config::index_slots / index_buckets, Model::grid_index),
// with the magic numbers of its two remainders (perfect_hash_mod) for the encoder's lookups.
struct PerfectHashView {
  PerfectHashView() = default;
  PerfectHashView(uint32_t slots_, uint32_t buckets_, const uint16_t* displacement_)
      : slots(slots_), buckets(buckets_), displacement(displacement_),
        slots_magic(slots_ ? perfect_hash_mod_magic(slots_) : 0),
        buckets_magic(buckets_ ? perfect_hash_mod_magic(buckets_) : 0) {}
  uint32_t slots = 0, buckets = 0;
  const uint16_t* displacement = nullptr;  // `buckets` values; nullptr: no index
  uint64_t slots_magic = 0, buckets_magic = 0;
};
inline PerfectHashView view_of(const PerfectHash& hash) {
  return PerfectHashView(hash.slots, uint32_t(hash.displacement.size()), hash.displacement.data());
}

// The murmur3 32-bit finalizer (a bijection on 32 bits).
inline uint32_t perfect_hash_mix(uint32_t h) {
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  h *= 0xc2b2ae35u;
  h ^= h >> 16;
  return h;
}
// h1 (seed 0) and h2 (seed 1): hashes of the whole vertex, independent of each other.
inline uint32_t perfect_hash_key(uint32_t seed, uint32_t x, uint32_t y, uint32_t z) {
  return perfect_hash_mix(x ^ perfect_hash_mix(y ^ perfect_hash_mix(z ^ (seed * 0x27d4eb2fu + 0x165667b1u))));
}
inline uint32_t perfect_hash_bucket(uint32_t buckets, uint32_t x, uint32_t y, uint32_t z) {
  return perfect_hash_key(0, x, y, z) % buckets;
}
// slot(v, d) before its remainder: the mix of h2 displaced by d.
inline uint32_t perfect_hash_displaced(uint32_t h2, uint32_t d) { return perfect_hash_mix(h2 + d * 0x9e3779b9u); }
inline uint32_t perfect_hash_place(uint32_t h2, uint32_t d, uint32_t slots) {
  return perfect_hash_displaced(h2, d) % slots;
}
// The slot of any vertex, in [0, hash.slots) (src/lsnif/shaders/lsnif_perfect_hash.glsl: the GPU twin). The
// hash must have at least one bucket.
inline uint32_t perfect_hash_slot(const PerfectHashView& hash, uint32_t x, uint32_t y, uint32_t z) {
  // perfect_hash_bucket and perfect_hash_place with their remainders by perfect_hash_mod.
  const uint32_t b = perfect_hash_mod(perfect_hash_key(0, x, y, z), hash.buckets_magic, hash.buckets);
  return perfect_hash_mod(perfect_hash_displaced(perfect_hash_key(1, x, y, z), hash.displacement[b]),
                          hash.slots_magic, hash.slots);
}
inline uint32_t perfect_hash_slot(const PerfectHash& hash, uint32_t x, uint32_t y, uint32_t z) {
  return perfect_hash_slot(view_of(hash), x, y, z);
}

// Buckets for N keys: ceil(N / 4), at least 1.
uint32_t perfect_hash_buckets(uint64_t keys);
// The default table size for N keys: N plus 1% (near-minimal; S = N often leaves the last buckets
// without a free displacement), at least 1.
uint32_t perfect_hash_default_slots(uint64_t keys);

// Builds the hash of `keys` (distinct) into `slots` slots. Errors: slots < N or 0, N >= 2^32, a
// repeated key, or a bucket for which no displacement places all its keys (then a larger `slots`
// may succeed); `out` is left empty on error.
Status build_perfect_hash(const std::vector<GridVertex>& keys, uint32_t slots, PerfectHash& out);

// The index of one level: build_perfect_hash of `keys` into perfect_hash_default_slots(N) slots, and
// on failure into 1% more slots at a time (up to 8 tries); the last error otherwise.
Status build_level_index(const std::vector<GridVertex>& keys, PerfectHash& out);

}  // namespace lsnif
