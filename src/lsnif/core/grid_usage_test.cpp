// grid_usage against brute force: the vertices on faces of occupied voxels counted by testing every
// lattice point of the grid geometrically, the entry counts by hashing that set, the identity
// vertices = used - shared + in-shared; and the claim the count rests on: every corner the encoder
// reads with a non-zero weight along random walks is one of those vertices.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "lsnif/core/grid_usage.h"
#include "lsnif/core/hash_grid.h"
#include "lsnif/core/ray_walk.h"

namespace lsnif {
namespace {

VoxelGrid grid_of(uint32_t V) {
  VoxelGrid g;
  g.resolution = V;
  g.bounds = Aabb{glm::vec3(0.0f), glm::vec3(1.0f)};
  g.bits.assign((V * V * V + 31) / 32, 0u);
  return g;
}

// A V^3 grid with each voxel occupied with probability 1 / one_in.
VoxelGrid random_grid(std::mt19937& rng, uint32_t V, uint32_t one_in) {
  VoxelGrid g = grid_of(V);
  for (uint32_t k = 0; k < V; ++k)
    for (uint32_t j = 0; j < V; ++j)
      for (uint32_t i = 0; i < V; ++i)
        if (rng() % one_in == 0) g.set(i, j, k);
  return g;
}

// Level 0 has 2^log2_entries table entries, level 1 2^log2_entries1 (the same when 0).
Config config_of(uint32_t V, uint32_t n0, uint32_t n1, uint32_t log2_entries, uint32_t log2_entries1 = 0) {
  Config c;
  c.voxel_resolution = V;
  c.grid_levels = 2;
  c.grid_resolution[0] = V * n0;
  c.grid_resolution[1] = V * n1;
  c.table_log2[0] = log2_entries;
  c.table_log2[1] = log2_entries1 ? log2_entries1 : log2_entries;
  return c;
}

// Brute force: lattice point (x, y, z) of level resolution R lies on a face of an occupied voxel
// when it is inside that voxel's closed box and on one of its six planes.
std::vector<glm::uvec3> face_vertices(const VoxelGrid& g, uint32_t R) {
  const uint32_t V = g.resolution, n = R / V;
  std::vector<glm::uvec3> out;
  for (uint32_t z = 0; z <= R; ++z)
    for (uint32_t y = 0; y <= R; ++y)
      for (uint32_t x = 0; x <= R; ++x) {
        bool on = false;
        for (uint32_t k = 0; k < V && !on; ++k)
          for (uint32_t j = 0; j < V && !on; ++j)
            for (uint32_t i = 0; i < V && !on; ++i) {
              if (!g.occupied(int(i), int(j), int(k))) continue;
              const uint32_t lo[3] = {i * n, j * n, k * n}, p[3] = {x, y, z};
              bool inside = true, on_plane = false;
              for (int a = 0; a < 3; ++a) {
                inside = inside && p[a] >= lo[a] && p[a] <= lo[a] + n;
                on_plane = on_plane || p[a] == lo[a] || p[a] == lo[a] + n;
              }
              on = inside && on_plane;
            }
        if (on) out.emplace_back(x, y, z);
      }
  return out;
}

void expect_matches_brute_force(const Config& c, const VoxelGrid& g) {
  const std::vector<GridLevelUsage> usage = grid_usage(c, g);
  ASSERT_EQ(usage.size(), c.grid_levels);
  for (uint32_t l = 0; l < c.grid_levels; ++l) {
    SCOPED_TRACE(testing::Message() << "level " << l);
    const std::vector<glm::uvec3> truth = face_vertices(g, c.grid_resolution[l]);
    std::vector<uint32_t> per_entry(size_t(1) << c.table_log2[l], 0);
    for (const glm::uvec3& v : truth) ++per_entry[hash_vertex(v.x, v.y, v.z, c.table_log2[l])];
    uint64_t used = 0, shared = 0, in_shared = 0;
    for (uint32_t k : per_entry) {
      used += k > 0;
      shared += k > 1;
      in_shared += k > 1 ? k : 0;
    }
    const GridLevelUsage& u = usage[l];
    EXPECT_EQ(u.resolution, c.grid_resolution[l]);
    EXPECT_EQ(u.vertices, truth.size());
    EXPECT_EQ(u.table_entries, uint64_t(1) << c.table_log2[l]);
    EXPECT_EQ(u.entries_used, used);
    EXPECT_EQ(u.entries_shared, shared);
    EXPECT_EQ(u.vertices_in_shared, in_shared);
    std::vector<GridVertex> readable = readable_vertices(g, c.grid_resolution[l]);
    ASSERT_EQ(readable.size(), truth.size());
    std::set<std::array<uint32_t, 3>> truth_set;
    for (const glm::uvec3& v : truth) truth_set.insert({v.x, v.y, v.z});
    for (const GridVertex& v : readable) EXPECT_EQ(truth_set.count({v.x, v.y, v.z}), 1u);
    // The indexed alternative: one slot per vertex, all distinct.
    PerfectHash index;
    ASSERT_TRUE(build_level_index(readable, index).is_ok());
    EXPECT_EQ(u.indexed_slots, index.slots);
    EXPECT_EQ(u.indexed_buckets, perfect_hash_buckets(truth.size()));
    EXPECT_GE(u.indexed_slots, truth.size());
    EXPECT_LE(u.indexed_slots, truth.size() + truth.size() / 10 + 1);
    std::set<uint32_t> slots;
    for (const glm::uvec3& v : truth) slots.insert(perfect_hash_slot(index, v.x, v.y, v.z));
    EXPECT_EQ(slots.size(), truth.size());
    EXPECT_EQ(u.vertices, u.entries_used - u.entries_shared + u.vertices_in_shared);
  }
}

TEST(GridUsage, OneVoxelIsTheSurfaceOfItsCells) {
  VoxelGrid g = grid_of(4);
  g.set(1, 2, 1);
  const Config c = config_of(4, 2, 4, 20);
  const std::vector<GridLevelUsage> u = grid_usage(c, g);
  ASSERT_EQ(u.size(), 2u);
  // The lattice points on the surface of an n x n x n block: (n + 1)^3 - (n - 1)^3.
  EXPECT_EQ(u[0].vertices, 27u - 1u);
  EXPECT_EQ(u[1].vertices, 125u - 27u);
  expect_matches_brute_force(c, g);
}

TEST(GridUsage, NeighboursShareTheirFacesAndTinyTablesCollide) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 4; ++trial) {
    const VoxelGrid g = random_grid(rng, 6, 3);
    expect_matches_brute_force(config_of(6, 1, 2, 16), g);
    expect_matches_brute_force(config_of(6, 2, 3, 3), g);  // 8 entries: nearly all shared
    expect_matches_brute_force(config_of(6, 1, 2, 4, 12), g);  // level 0 small, level 1 large
    expect_matches_brute_force(config_of(6, 1, 2, 12, 5), g);
  }
}

// readable_vertex_count against the list and the geometric brute force, and the list ordered by
// (z, y, x) without repeats, for one to four cells per voxel edge.
TEST(GridUsage, TheCountWithoutAListMatchesTheListAndTheBruteForce) {
  std::mt19937 rng(7);
  for (uint32_t n = 1; n <= 4; ++n)
    for (uint32_t one_in : {1u, 2u, 5u, 40u}) {
      SCOPED_TRACE(testing::Message() << "n " << n << " one in " << one_in);
      const VoxelGrid g = random_grid(rng, 5, one_in);
      const std::vector<GridVertex> list = readable_vertices(g, 5 * n);
      EXPECT_EQ(readable_vertex_count(g, 5 * n), list.size());
      EXPECT_EQ(list.size(), face_vertices(g, 5 * n).size());
      const auto key = [](const GridVertex& v) { return std::array<uint32_t, 3>{v.z, v.y, v.x}; };
      for (size_t i = 1; i < list.size(); ++i) EXPECT_LT(key(list[i - 1]), key(list[i])) << i;
    }
}

// A full grid: every lattice point but the (n - 1)^3 inside each voxel, (R + 1)^3 - (V (n - 1))^3,
// counted in O(V^3) even where listing them would take hundreds of gigabytes (V = 256, R = 4096).
TEST(GridUsage, AFullGridCountsEveryPointButTheVoxelInteriors) {
  for (const auto& [V, n] : {std::pair<uint32_t, uint32_t>{7, 1}, {7, 3}, {16, 8}, {256, 16}}) {
    SCOPED_TRACE(testing::Message() << "V " << V << " n " << n);
    VoxelGrid g = grid_of(V);
    std::fill(g.bits.begin(), g.bits.end(), ~0u);
    const uint64_t R = uint64_t(V) * n, inside = uint64_t(V) * (n - 1);
    EXPECT_EQ(readable_vertex_count(g, V * n), (R + 1) * (R + 1) * (R + 1) - inside * inside * inside);
  }
}

// More vertices than an index takes: grid_usage hashes them without listing them (every one of 16
// entries shared), reports no index, and index_grid_levels refuses the level before listing it.
TEST(GridUsage, LevelsTooLargeForAnIndexAreHashedWithoutAList) {
  VoxelGrid g = grid_of(128);
  std::fill(g.bits.begin(), g.bits.end(), ~0u);
  Config c = config_of(128, 1, 3, 4);
  const uint64_t vertices = 385ull * 385 * 385 - 256ull * 256 * 256;
  ASSERT_GT(vertices, max_indexed_vertices());
  const std::vector<GridLevelUsage> u = grid_usage(c, g);
  ASSERT_EQ(u.size(), 2u);
  EXPECT_EQ(u[1].vertices, vertices);
  EXPECT_EQ(u[1].entries_used, 16u);
  EXPECT_EQ(u[1].entries_shared, 16u);
  EXPECT_EQ(u[1].vertices_in_shared, vertices);
  EXPECT_EQ(u[1].indexed_slots, 0u);
  EXPECT_EQ(u[0].vertices, 129ull * 129 * 129);
  EXPECT_GE(u[0].indexed_slots, u[0].vertices);  // 2.1 million: an index takes them
  const bool indexed[LSNIF_MAX_LEVELS] = {false, true};
  std::vector<uint16_t> index;
  const Status s = index_grid_levels(g, indexed, c, index);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("level 1: its " + std::to_string(vertices) + " readable vertices are more than an "
                             "indexed level holds"), std::string::npos) << s.message();
  EXPECT_FALSE(c.indexed(1));
}

// Every corner the encoder reads with a non-zero weight, along random walks, is an entry that a
// vertex counted by grid_usage hashes to (the vertices are the encoder's whole domain).
TEST(GridUsage, TheEncoderReadsOnlyCountedVertices) {
  std::mt19937 rng(5);
  const VoxelGrid g = random_grid(rng, 8, 4);
  Config c = config_of(8, 2, 4, 14, 18);  // level 1 starts after level 0's 2^14 entries
  c.max_points = LSNIF_MAX_POINTS;
  const GridLayout layout(c, nullptr);
  std::set<uint32_t> domain[2];
  for (uint32_t l = 0; l < 2; ++l)
    for (const glm::uvec3& v : face_vertices(g, c.grid_resolution[l]))
      domain[l].insert((l ? 1u << c.table_log2[0] : 0u) + hash_vertex(v.x, v.y, v.z, c.table_log2[l]));
  std::uniform_real_distribution<float> u(-0.5f, 1.5f);
  size_t reads = 0;
  for (int r = 0; r < 3000; ++r) {
    Ray ray;
    ray.origin = glm::vec3(u(rng), u(rng), u(rng));
    ray.direction = glm::vec3(u(rng), u(rng), u(rng)) - ray.origin;
    if (r % 3 == 0) ray.direction.x = 0.0f;  // rays along grid planes and edges too
    RayWalk walk;
    walk_ray(g, ray, c.max_points, walk);
    for (uint32_t j = 0; j < walk.count; ++j)
      for (uint32_t l = 0; l < 2; ++l) {
        FaceCorners fc;
        face_corners(c, l, walk.p[j], walk.axis[j], fc, layout);
        for (int k = 0; k < 4; ++k) {
          if (fc.weight[k] == 0.0f) continue;
          ++reads;
          EXPECT_TRUE(domain[l].count(fc.entry[k])) << "ray " << r << " point " << j << " level " << l;
        }
      }
  }
  EXPECT_GT(reads, 10000u);
}

// index_grid_levels against brute force: every vertex on a face of an occupied voxel (face_vertices)
// gets its own slot of its level, the config and the displacements agree, hashed levels stay hashed.
TEST(GridUsage, IndexedLevelsGiveEveryReadableVertexItsOwnEntry) {
  std::mt19937 rng(9);
  const VoxelGrid g = random_grid(rng, 6, 3);
  for (const bool level0 : {true, false}) {
    SCOPED_TRACE(level0);
    Config c = config_of(6, 1, 2, 4);
    const bool indexed[LSNIF_MAX_LEVELS] = {level0, true};
    std::vector<uint16_t> index(3, 7);  // replaced
    ASSERT_TRUE(index_grid_levels(g, indexed, c, index));
    EXPECT_EQ(c.indexed(0), level0);
    ASSERT_TRUE(c.indexed(1));
    EXPECT_EQ(index.size(), c.grid_index_count());
    const GridLayout layout(c, index.data());
    for (uint32_t l = 0; l < 2; ++l) {
      if (!c.indexed(l)) {
        EXPECT_EQ(layout.indexed[l].displacement, nullptr);
        EXPECT_EQ(c.table_size(l), 16u);
        continue;
      }
      const std::vector<glm::uvec3> truth = face_vertices(g, c.grid_resolution[l]);
      EXPECT_GE(c.index_slots[l], truth.size());
      EXPECT_EQ(c.index_buckets[l], (truth.size() + 3) / 4);
      std::set<uint32_t> slots;
      for (const glm::uvec3& v : truth) {
        const uint32_t slot = perfect_hash_slot(layout.indexed[l], v.x, v.y, v.z);
        EXPECT_LT(slot, c.index_slots[l]);
        slots.insert(slot);
      }
      EXPECT_EQ(slots.size(), truth.size()) << "level " << l << ": two readable vertices share a slot";
    }
    const std::vector<GridLevelUsage> u = grid_usage(c, g);
    EXPECT_EQ(u[1].entries_shared, 0u);
    EXPECT_EQ(u[1].table_entries, c.index_slots[1]);
    EXPECT_EQ(u[1].indexed_slots, c.index_slots[1]);
  }
}

}  // namespace
}  // namespace lsnif
