// perfect_hash.cpp -- see perfect_hash.h.
#include "lsnif/core/perfect_hash.h"

#include <algorithm>
#include <numeric>

namespace lsnif {

uint32_t perfect_hash_buckets(uint64_t keys) { return uint32_t(std::max<uint64_t>(1, (keys + 3) / 4)); }

uint32_t perfect_hash_default_slots(uint64_t keys) { return uint32_t(std::max<uint64_t>(1, keys + (keys + 99) / 100)); }

Status build_perfect_hash(const std::vector<GridVertex>& keys, uint32_t slots, PerfectHash& out) {
  out = PerfectHash{};
  const uint64_t n = keys.size();
  if (n >= (uint64_t(1) << 32)) return Status::error("perfect hash: %llu keys, at most 2^32 - 1", (unsigned long long)n);
  if (slots == 0 || slots < n)
    return Status::error("perfect hash: %u slots for %llu keys (need at least one per key)", slots, (unsigned long long)n);
  const uint32_t B = perfect_hash_buckets(n);
  // Keys grouped by bucket: members[first[b] .. first[b + 1]).
  std::vector<uint32_t> first(size_t(B) + 1, 0), members(n);
  for (const GridVertex& v : keys) ++first[perfect_hash_bucket(B, v.x, v.y, v.z) + 1];
  std::partial_sum(first.begin(), first.end(), first.begin());
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (uint32_t i = 0; i < n; ++i) members[fill[perfect_hash_bucket(B, keys[i].x, keys[i].y, keys[i].z)]++] = i;
  }
  std::vector<uint32_t> order(B);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return first[a + 1] - first[a] > first[b + 1] - first[b]; });
  std::vector<uint32_t> h2(n);
  for (uint32_t i = 0; i < n; ++i) h2[i] = perfect_hash_key(1, keys[i].x, keys[i].y, keys[i].z);
  std::vector<uint8_t> taken(slots, 0);
  std::vector<uint16_t> displacement(B, 0);
  std::vector<uint32_t> placed;
  for (const uint32_t b : order) {
    const uint32_t begin = first[b], end = first[b + 1];
    if (begin == end) break;  // the rest are empty
    bool found = false;
    for (uint32_t d = 0; d <= 0xffffu && !found; ++d) {
      placed.clear();
      bool ok = true;
      for (uint32_t m = begin; m < end && ok; ++m) {
        const uint32_t s = perfect_hash_place(h2[members[m]], d, slots);
        ok = !taken[s] && std::find(placed.begin(), placed.end(), s) == placed.end();
        placed.push_back(s);
      }
      if (!ok) continue;
      for (const uint32_t s : placed) taken[s] = 1;
      displacement[b] = uint16_t(d);
      found = true;
    }
    if (found) continue;
    for (uint32_t m = begin; m < end; ++m)
      for (uint32_t o = m + 1; o < end; ++o) {
        const GridVertex &p = keys[members[m]], &q = keys[members[o]];
        if (p.x == q.x && p.y == q.y && p.z == q.z)
          return Status::error("perfect hash: key (%u, %u, %u) given twice", p.x, p.y, p.z);
      }
    return Status::error(
        "perfect hash: no displacement in [0, 65535] places the %u keys of bucket %u (%llu keys in %u slots); "
        "more slots may succeed",
        end - begin, b, (unsigned long long)n, slots);
  }
  out.slots = slots;
  out.displacement = std::move(displacement);
  return Status::ok();
}

Status build_level_index(const std::vector<GridVertex>& keys, PerfectHash& out) {
  uint64_t slots = perfect_hash_default_slots(keys.size());
  Status s = Status::ok();
  for (int attempt = 0; attempt < 8; ++attempt, slots += (keys.size() + 99) / 100) {
    if (slots >= (uint64_t(1) << 32)) break;
    s = build_perfect_hash(keys, uint32_t(slots), out);
    if (s.is_ok()) return s;
  }
  return s;
}

}  // namespace lsnif
