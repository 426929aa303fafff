// Sparse hash-grid encoding vs an independent dense computation: a point on a voxel face, looked up
// trilinearly over the 8 corners of its cell in a dense hashed grid, must give the same features
// as the 4-corner face lookup; and encode_backward must match finite differences. Each with every
// level's table of one size and with tables of different sizes per level.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "lsnif/core/grid_usage.h"
#include "lsnif/core/hash_grid.h"

namespace lsnif {
namespace {

// Level l's table has 2^log2[l] entries.
Config small_config(const uint32_t (&log2)[3] = {10, 10, 10}) {
  Config c;
  c.voxel_resolution = 8;
  c.max_points = 5;
  c.grid_levels = 3;
  c.grid_resolution[0] = 8;
  c.grid_resolution[1] = 16;
  c.grid_resolution[2] = 32;
  for (uint32_t l = 0; l < 3; ++l) c.table_log2[l] = log2[l];
  c.features = 3;
  return c;
}

// Unequal sizes: the middle level smallest, so no level's offset is a multiple of its own size.
constexpr uint32_t kUnequal[3] = {9, 5, 11};

// Where level `level`'s table starts: the entries of the levels before it, counted here.
uint32_t first_entry(const Config& c, uint32_t level) {
  uint32_t first = 0;
  for (uint32_t l = 0; l < level; ++l) first += 1u << c.table_log2[l];
  return first;
}

// Dense trilinear interpolation over the 8 corners of p's cell, weights from all three fractions;
// corner(v) gives vertex v's F features (it is asked only for corners of non-zero weight).
template <class Corner>
std::vector<float> dense_trilinear(const Config& c, uint32_t level, const glm::vec3& p, Corner corner) {
  const uint32_t R = c.grid_resolution[level];
  std::vector<float> out(c.features, 0.0f);
  double x[3];
  int i0[3];
  for (int a = 0; a < 3; ++a) {
    x[a] = double(p[a]) * R;
    i0[a] = std::min(int(std::floor(x[a])), int(R) - 1);
  }
  for (int k = 0; k < 8; ++k) {
    double w = 1.0;
    uint32_t v[3];
    for (int a = 0; a < 3; ++a) {
      int bit = (k >> a) & 1;
      double f = x[a] - i0[a];
      w *= bit ? f : 1.0 - f;
      v[a] = uint32_t(i0[a] + bit);
    }
    if (w == 0.0) continue;
    const float* t = corner(v);
    for (uint32_t f = 0; f < c.features; ++f) out[f] += float(w) * t[f];
  }
  return out;
}

// Dense trilinear lookup with the same hash; the level's table starts at entry `first` (default:
// first_entry, every level hashed).
std::vector<float> dense_lookup(const Config& c, const std::vector<float>& table, uint32_t level,
                                const glm::vec3& p, uint32_t first = ~0u) {
  if (first == ~0u) first = first_entry(c, level);
  return dense_trilinear(c, level, p, [&](const uint32_t* v) {
    const uint32_t h = (v[0] * LSNIF_HASH_PRIME_X) ^ (v[1] * LSNIF_HASH_PRIME_Y) ^ (v[2] * LSNIF_HASH_PRIME_Z);
    const uint32_t e = first + h % (1u << c.table_log2[level]);
    return table.data() + size_t(e) * c.features;
  });
}

RayWalk random_walk(const Config& c, std::mt19937& rng, uint32_t count) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::uniform_int_distribution<int> axis(0, 2), plane(0, int(c.voxel_resolution));
  RayWalk w;
  w.count = count;
  for (uint32_t j = 0; j < count; ++j) {
    glm::vec3 p(u(rng), u(rng), u(rng));
    int a = axis(rng);
    p[a] = float(plane(rng)) / float(c.voxel_resolution);
    w.p[j] = p;
    w.axis[j] = uint8_t(a);
    w.t[j] = float(j);
  }
  return w;
}

void expect_face_lookup_equals_dense(const Config& c) {
  ASSERT_TRUE(c.validate()) << c.validate().message();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> table(c.grid_parameter_count());
  for (float& v : table) v = u(rng);
  std::vector<float> features(c.input_dim());
  for (int trial = 0; trial < 2000; ++trial) {
    RayWalk w = random_walk(c, rng, 1 + uint32_t(trial) % c.max_points);
    encode(c, table.data(), w, features.data(), GridLayout(c, nullptr));
    for (uint32_t j = 0; j < c.max_points; ++j)
      for (uint32_t l = 0; l < c.grid_levels; ++l) {
        std::vector<float> expect(c.features, 0.0f);
        if (j < w.count) expect = dense_lookup(c, table, l, w.p[j]);
        for (uint32_t f = 0; f < c.features; ++f)
          ASSERT_NEAR(features[(j * c.grid_levels + l) * c.features + f], expect[f], 1e-5f)
              << "point " << j << " level " << l;
      }
  }
}

TEST(HashGrid, FaceLookupEqualsDenseTrilinearOnFaces) { expect_face_lookup_equals_dense(small_config()); }

TEST(HashGrid, FaceLookupEqualsDenseTrilinearWithTablesOfDifferentSizes) {
  const Config c = small_config(kUnequal);
  EXPECT_EQ(c.grid_parameter_count(), uint64_t(512 + 32 + 2048) * c.features);
  expect_face_lookup_equals_dense(c);
}

void expect_corners_in_own_level(const Config& c) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 1000; ++trial) {
    RayWalk w = random_walk(c, rng, 1);
    for (uint32_t l = 0; l < c.grid_levels; ++l) {
      FaceCorners fc;
      face_corners(c, l, w.p[0], w.axis[0], fc, GridLayout(c, nullptr));
      float sum = 0;
      for (float x : fc.weight) {
        EXPECT_GE(x, 0.0f);
        sum += x;
      }
      EXPECT_NEAR(sum, 1.0f, 1e-6f);
      for (uint32_t e : fc.entry) {
        EXPECT_GE(e, first_entry(c, l));
        EXPECT_LT(e, first_entry(c, l + 1));
      }
    }
  }
}

TEST(HashGrid, CornerWeightsArePartitionOfUnityAndTouchOnlyFaceVertices) {
  expect_corners_in_own_level(small_config());
  expect_corners_in_own_level(small_config(kUnequal));
}

void expect_backward_matches_finite_differences(const Config& c, const GridLayout& layout) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> table(c.grid_entry_count() * c.features);
  for (float& v : table) v = u(rng);
  RayWalk w = random_walk(c, rng, c.max_points);
  std::vector<float> coeff(c.input_dim());
  for (float& v : coeff) v = u(rng);
  auto loss = [&](const std::vector<float>& t) {
    std::vector<float> f(c.input_dim());
    encode(c, t.data(), w, f.data(), layout);
    double s = 0;
    for (size_t i = 0; i < f.size(); ++i) s += double(coeff[i]) * f[i];
    return s;
  };
  std::vector<float> grad(table.size(), 0.0f);
  encode_backward(c, w, coeff.data(), grad.data(), layout);
  // The loss is linear in the table: check every touched entry and a sample of untouched ones.
  int checked = 0;
  for (size_t i = 0; i < table.size(); ++i) {
    if (grad[i] == 0.0f && i % 97 != 0) continue;
    std::vector<float> tp = table, tm = table;
    tp[i] += 1e-2f;
    tm[i] -= 1e-2f;
    double fd = (loss(tp) - loss(tm)) / 2e-2;
    ASSERT_NEAR(grad[i], fd, 2e-3) << "entry " << i;
    ++checked;
  }
  EXPECT_GT(checked, 50);
}

TEST(HashGrid, BackwardMatchesFiniteDifferences) {
  for (const Config& c : {small_config(), small_config(kUnequal)})
    expect_backward_matches_finite_differences(c, GridLayout(c, nullptr));
}

// Random occupancy of c's voxels (about a third occupied).
VoxelGrid random_voxels(const Config& c, std::mt19937& rng) {
  VoxelGrid g;
  g.resolution = c.voxel_resolution;
  g.bounds = Aabb{glm::vec3(0.0f), glm::vec3(1.0f)};
  g.bits.assign((c.voxel_count() + 31) / 32, 0u);
  for (uint64_t i = 0; i < c.voxel_count(); ++i)
    if (rng() % 3 == 0) g.bits[i / 32] |= 1u << (i % 32);
  return g;
}

// Points on faces of occupied voxels: the only points a walk records.
RayWalk walk_on_occupied_faces(const VoxelGrid& g, std::mt19937& rng, uint32_t count) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const int V = int(g.resolution);
  RayWalk w;
  w.count = count;
  for (uint32_t j = 0; j < count; ++j) {
    int cell[3];
    do {
      for (int& x : cell) x = int(rng() % uint32_t(V));
    } while (!g.occupied(cell[0], cell[1], cell[2]));
    const uint32_t a = uint32_t(rng() % 3);
    glm::vec3 p;
    for (uint32_t b = 0; b < 3; ++b) p[b] = (float(cell[b]) + (b == a ? float(rng() % 2) : u(rng))) / float(V);
    w.p[j] = p;
    w.axis[j] = uint8_t(a);
    w.t[j] = float(j);
  }
  return w;
}

// small_config(kUnequal) with level 1 indexed: the perfect hash of the readable vertices of
// random voxels (drawn from `rng`).
struct IndexedLevel {
  Config config;
  VoxelGrid voxels;
  std::vector<GridVertex> keys;
  PerfectHash hash;
};
void index_level_one(std::mt19937& rng, IndexedLevel& out) {
  out.config = small_config(kUnequal);
  out.voxels = random_voxels(out.config, rng);
  out.keys = readable_vertices(out.voxels, out.config.grid_resolution[1]);
  ASSERT_TRUE(build_perfect_hash(out.keys, perfect_hash_default_slots(out.keys.size()), out.hash).is_ok());
  out.config.index_slots[1] = out.hash.slots;
  out.config.index_buckets[1] = uint32_t(out.hash.displacement.size());
  ASSERT_TRUE(out.config.validate().is_ok());
}

// An indexed level against brute force: each readable vertex's features kept in a map keyed by the
// vertex (no hashing), the table filled from the map through the perfect hash. The encoding of points
// on faces of occupied voxels must equal trilinear interpolation over the map, which holds only when
// no two readable vertices share a slot and every corner read with a non-zero weight is readable.
TEST(HashGrid, IndexedLevelEqualsPerVertexFeatures) {
  std::mt19937 rng(21);
  IndexedLevel level;
  ASSERT_NO_FATAL_FAILURE(index_level_one(rng, level));
  const Config& c = level.config;
  const VoxelGrid& voxels = level.voxels;
  const std::vector<GridVertex>& keys = level.keys;
  const PerfectHash& hash = level.hash;
  const GridLayout layout(c, hash.displacement.data());
  ASSERT_EQ(c.grid_entry_count(), 512u + hash.slots + 2048u);
  EXPECT_LT(hash.slots, 17u * 17u * 17u);  // below the dense grid's vertices
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> table(c.grid_entry_count() * c.features);
  for (float& v : table) v = u(rng);
  std::map<std::array<uint32_t, 3>, std::vector<float>> own;
  for (const GridVertex& v : keys) {
    std::vector<float>& f = own[{v.x, v.y, v.z}];
    for (uint32_t i = 0; i < c.features; ++i) {
      f.push_back(u(rng));
      table[(512u + perfect_hash_slot(hash, v.x, v.y, v.z)) * c.features + i] = f.back();
    }
  }
  std::vector<float> features(c.input_dim());
  for (int trial = 0; trial < 2000; ++trial) {
    const RayWalk w = walk_on_occupied_faces(voxels, rng, 1 + uint32_t(trial) % c.max_points);
    encode(c, table.data(), w, features.data(), layout);
    for (uint32_t j = 0; j < w.count; ++j)
      for (uint32_t l = 0; l < c.grid_levels; ++l) {
        const std::vector<float> expect =
            l != 1 ? dense_lookup(c, table, l, w.p[j], l == 0 ? 0u : 512u + hash.slots) : dense_trilinear(c, l, w.p[j], [&](const uint32_t* v) {
              const auto it = own.find({v[0], v[1], v[2]});
              EXPECT_NE(it, own.end()) << "vertex " << v[0] << "," << v[1] << "," << v[2] << " is not readable";
              return it == own.end() ? table.data() : it->second.data();
            });
        for (uint32_t f = 0; f < c.features; ++f)
          ASSERT_NEAR(features[(j * c.grid_levels + l) * c.features + f], expect[f], 1e-5f)
              << "point " << j << " level " << l;
      }
  }
  expect_backward_matches_finite_differences(c, layout);
}

// The trainer's dense slot tables (DenseGridIndex) hold the perfect hash's own slot of every lattice
// vertex, so face corners and encodings through them equal those through the hash, bit for bit.
TEST(HashGrid, DenseSlotTableEqualsThePerfectHash) {
  std::mt19937 rng(23);
  IndexedLevel level;
  ASSERT_NO_FATAL_FAILURE(index_level_one(rng, level));
  const Config& c = level.config;
  const VoxelGrid& voxels = level.voxels;
  const PerfectHash& hash = level.hash;
  const GridLayout hashed(c, hash.displacement.data());
  GridLayout looked_up(c, hash.displacement.data());
  const DenseGridIndex dense(c, looked_up);
  EXPECT_EQ(looked_up.dense_slot[0], nullptr);  // a hashed level has no index
  ASSERT_NE(looked_up.dense_slot[1], nullptr);
  EXPECT_EQ(looked_up.dense_slot[2], nullptr);
  const uint32_t R = c.grid_resolution[1];
  for (uint32_t z = 0; z <= R; ++z)
    for (uint32_t y = 0; y <= R; ++y)
      for (uint32_t x = 0; x <= R; ++x)
        ASSERT_EQ(looked_up.dense_slot[1][dense_slot_index(x, y, z, R)], perfect_hash_slot(hash, x, y, z))
            << x << "," << y << "," << z;
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> table(c.grid_entry_count() * c.features);
  for (float& v : table) v = u(rng);
  std::vector<float> a(c.input_dim()), b(c.input_dim());
  for (int trial = 0; trial < 500; ++trial) {
    const RayWalk w = walk_on_occupied_faces(voxels, rng, 1 + uint32_t(trial) % c.max_points);
    encode(c, table.data(), w, a.data(), hashed);
    encode(c, table.data(), w, b.data(), looked_up);
    ASSERT_EQ(a, b) << "trial " << trial;
    for (uint32_t j = 0; j < w.count; ++j)
      for (uint32_t l = 0; l < c.grid_levels; ++l) {
        FaceCorners fa, fb;
        face_corners(c, l, w.p[j], w.axis[j], fa, hashed);
        face_corners(c, l, w.p[j], w.axis[j], fb, looked_up);
        for (int k = 0; k < 4; ++k) {
          ASSERT_EQ(fa.entry[k], fb.entry[k]);
          ASSERT_EQ(fa.weight[k], fb.weight[k]);
        }
      }
  }
}

TEST(HashGrid, DefaultConfigMemoryMatchesPaper) {
  Config c;  // paper defaults
  EXPECT_EQ(c.input_dim(), 108u);
  EXPECT_EQ(c.grid_parameter_count() * 2, 1536u * 1024u);  // 1536 KB of fp16 features
}

}  // namespace
}  // namespace lsnif
