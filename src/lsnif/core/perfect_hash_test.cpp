// build_perfect_hash against brute force: every key of random key sets and of the readable vertices
// of a voxelized sphere gets its own slot in [0, S) (checked by marking every slot), the result does
// not depend on the keys' order, and the error paths (too few slots, a repeated key, no
// displacement) report instead of returning a hash with collisions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "lsnif/core/grid_usage.h"
#include "lsnif/core/perfect_hash.h"
#include "lsnif/train/voxelizer.h"

namespace lsnif {
namespace {

std::vector<GridVertex> random_keys(uint32_t n, uint32_t range, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<uint32_t> u(0, range);
  std::set<std::tuple<uint32_t, uint32_t, uint32_t>> seen;
  std::vector<GridVertex> keys;
  while (keys.size() < n) {
    GridVertex v{u(rng), u(rng), u(rng)};
    if (seen.insert({v.x, v.y, v.z}).second) keys.push_back(v);
  }
  return keys;
}

// Every key's slot lies in [0, S) and no two keys share one.
void expect_collision_free(const std::vector<GridVertex>& keys, const PerfectHash& hash) {
  ASSERT_EQ(hash.displacement.size(), perfect_hash_buckets(keys.size()));
  std::vector<int> owner(hash.slots, -1);
  for (size_t i = 0; i < keys.size(); ++i) {
    const uint32_t s = perfect_hash_slot(hash, keys[i].x, keys[i].y, keys[i].z);
    ASSERT_LT(s, hash.slots);
    ASSERT_EQ(owner[s], -1) << "keys " << owner[s] << " and " << i << " share slot " << s;
    owner[s] = int(i);
  }
}

// The lookups' remainder by multiplication against the % operator: the extremes of both operands,
// powers of two and their neighbours, and random pairs.
TEST(PerfectHash, RemainderByMultiplicationIsTheRemainder) {
  std::vector<uint32_t> values = {0u, 1u, 2u, 3u, 5u, 7u, 1000u, 65535u, 65536u, 65537u, 0x7fffffffu, 0x80000000u,
                                  0x80000001u, 0xfffffffeu, 0xffffffffu};
  for (uint32_t k = 2; k < 32; ++k)
    for (int64_t d : {-1, 0, 1}) values.push_back(uint32_t(int64_t(1) << k) + uint32_t(d));
  std::mt19937 rng(7);
  for (int i = 0; i < 64; ++i) values.push_back(uint32_t(rng()));
  size_t checked = 0;
  for (uint32_t d : values) {
    if (d == 0) continue;
    const uint64_t magic = perfect_hash_mod_magic(d);
    for (uint32_t a : values) {
      ASSERT_EQ(perfect_hash_mod(a, magic, d), a % d) << a << " mod " << d;
      ++checked;
    }
    for (int i = 0; i < 2000; ++i) {
      const uint32_t a = uint32_t(rng());
      ASSERT_EQ(perfect_hash_mod(a, magic, d), a % d) << a << " mod " << d;
    }
  }
  EXPECT_GT(checked, 10000u);
}

TEST(PerfectHash, RandomKeySetsGetDistinctSlots) {
  for (const uint32_t n : {1u, 2u, 7u, 100u, 5000u, 40000u}) {
    const std::vector<GridVertex> keys = random_keys(n, 4096, n);
    PerfectHash hash;
    const Status s = build_perfect_hash(keys, perfect_hash_default_slots(n), hash);
    ASSERT_TRUE(s.is_ok()) << s.message();
    EXPECT_EQ(hash.slots, perfect_hash_default_slots(n));
    expect_collision_free(keys, hash);
  }
}

TEST(PerfectHash, MinimalTableForSmallSets) {
  // S = N exactly: every slot is used.
  const std::vector<GridVertex> keys = random_keys(500, 300, 3);
  PerfectHash hash;
  const Status s = build_perfect_hash(keys, 500, hash);
  ASSERT_TRUE(s.is_ok()) << s.message();
  expect_collision_free(keys, hash);
}

TEST(PerfectHash, VoxelizedSphereReadableVertices) {
  Mesh mesh;
  const uint32_t rings = 24, segments = 48;
  const float pi = 3.14159265f;
  for (uint32_t i = 0; i <= rings; ++i)
    for (uint32_t j = 0; j < segments; ++j) {
      const float th = pi * float(i) / float(rings), ph = 2.0f * pi * float(j) / float(segments);
      mesh.positions.emplace_back(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
    }
  for (uint32_t i = 0; i < rings; ++i)
    for (uint32_t j = 0; j < segments; ++j) {
      const uint32_t a = i * segments + j, b = i * segments + (j + 1) % segments;
      mesh.triangles.emplace_back(a, a + segments, b);
      mesh.triangles.emplace_back(b, a + segments, b + segments);
    }
  const VoxelGrid voxels = voxelize(mesh, 32, pad_aabb(Aabb{glm::vec3(-1.0f), glm::vec3(1.0f)}));
  ASSERT_GT(voxels.count_occupied(), 1000u);
  for (const uint32_t R : {64u, 128u}) {
    const std::vector<GridVertex> keys = readable_vertices(voxels, R);
    ASSERT_GT(keys.size(), 10000u);
    PerfectHash hash;
    const Status s = build_perfect_hash(keys, perfect_hash_default_slots(keys.size()), hash);
    ASSERT_TRUE(s.is_ok()) << s.message();
    expect_collision_free(keys, hash);
  }
}

TEST(PerfectHash, DeterministicAndIndependentOfKeyOrder) {
  std::vector<GridVertex> keys = random_keys(3000, 1000, 11);
  PerfectHash a, b, c;
  ASSERT_TRUE(build_perfect_hash(keys, 3100, a).is_ok());
  ASSERT_TRUE(build_perfect_hash(keys, 3100, b).is_ok());
  std::reverse(keys.begin(), keys.end());
  ASSERT_TRUE(build_perfect_hash(keys, 3100, c).is_ok());
  EXPECT_EQ(a.displacement, b.displacement);
  EXPECT_EQ(a.displacement, c.displacement);
  // Not all zero: the displacements do work.
  EXPECT_TRUE(std::any_of(a.displacement.begin(), a.displacement.end(), [](uint16_t d) { return d != 0; }));
}

TEST(PerfectHash, Errors) {
  PerfectHash hash;
  std::vector<GridVertex> keys = random_keys(10, 50, 5);
  Status s = build_perfect_hash(keys, 9, hash);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("9 slots for 10 keys"), std::string::npos) << s.message();
  EXPECT_TRUE(hash.displacement.empty());
  EXPECT_FALSE(build_perfect_hash({}, 0, hash).is_ok());
  keys.push_back(keys[3]);
  s = build_perfect_hash(keys, 100, hash);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("given twice"), std::string::npos) << s.message();
  EXPECT_EQ(hash.slots, 0u);
  // Two keys whose h2 agree in all 32 bits (found by search) share a bucket (B = 1) and then a slot
  // for every displacement.
  std::unordered_map<uint32_t, GridVertex> by_h2;
  std::vector<GridVertex> pair;
  for (uint32_t i = 0; pair.empty(); ++i) {
    const GridVertex v{i & 1023u, (i >> 10) & 1023u, i >> 20};
    const auto [it, fresh] = by_h2.emplace(perfect_hash_key(1, v.x, v.y, v.z), v);
    if (!fresh) pair = {it->second, v};
  }
  s = build_perfect_hash(pair, 2, hash);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("no displacement in [0, 65535] places the 2 keys of bucket 0"), std::string::npos)
      << s.message();
  EXPECT_TRUE(hash.displacement.empty());
}

}  // namespace
}  // namespace lsnif
