// model_file_fuzz_test.cpp -- deterministic mutation fuzzing of load_model_from_memory: random
// bit flips, byte and field overwrites, truncations, extensions, insertions and deletions of small
// valid .lsnif files, each tried as-is and with the size field and CRC-32 repaired so that the
// parser behind the checksum is exercised too. The loader must never crash (CI runs this under
// ASan/UBSan), every error must carry a message, and every accepted file must be a valid model
// whose re-encoding is byte-identical to the input (the format has one encoding per model).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <iterator>
#include <vector>

#include "lsnif/format/crc32.h"
#include "lsnif/core/grid_usage.h"
#include "lsnif/core/model.h"
#include "lsnif/core/rng.h"

namespace lsnif {
namespace {

using Bytes = std::vector<uint8_t>;

// Every level's table has 2^4 entries, or (unequal) level l 2^(4 + l): a version 4 file.
Model base_model(uint32_t V, uint32_t levels, uint32_t materials, uint64_t seed, bool unequal = false) {
  Rng rng(seed, 1, 0);
  Model m;
  Config& c = m.config;
  c.voxel_resolution = V;
  c.max_points = 2;
  c.grid_levels = levels;
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) c.grid_resolution[l] = l < levels ? V * (l + 1) : 0u;
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) c.table_log2[l] = l < levels ? 4u + (unequal ? l : 0u) : 0u;
  c.features = 2;
  c.hidden_width = 3;
  c.hidden_layers = 2;
  c.material_count = materials;
  m.voxels.resolution = V;
  m.voxels.bounds.lo = glm::vec3(-1.0f);
  m.voxels.bounds.hi = glm::vec3(2.0f, 1.0f, 0.5f);
  m.voxels.bits.assign((c.voxel_count() + 31) / 32, 0u);
  for (uint32_t k = 0; k < V; ++k)
    for (uint32_t j = 0; j < V; ++j)
      for (uint32_t i = 0; i < V; ++i)
        if (rng.next_u32() & 1u) m.voxels.set(i, j, k);
  m.materials.resize(materials);
  for (uint32_t i = 0; i < materials; ++i) m.materials[i].name = "material_" + std::to_string(i);
  m.grid.resize(c.grid_parameter_count());
  for (float& v : m.grid) v = rng.next_float() - 0.5f;
  m.mlp.resize(c.mlp_parameter_count());
  for (float& v : m.mlp) v = 4.0f * rng.next_float() - 2.0f;
  return m;
}

// The same with 8-bit grid features (a version 3 file).
Model base_8bit_model(uint32_t V, uint32_t levels, uint32_t materials, uint64_t seed) {
  Model m = base_model(V, levels, materials, seed);
  m.config.grid_bits = 8;
  m.quantize();
  return m;
}

// The same with its last level indexed for its voxels (a version 5 file).
Model base_indexed_model(uint32_t V, uint32_t levels, uint32_t materials, uint64_t seed) {
  Model m = base_model(V, levels, materials, seed);
  bool indexed[LSNIF_MAX_LEVELS] = {};
  indexed[levels - 1] = true;
  const Status s = index_grid_levels(m.voxels, indexed, m.config, m.grid_index);
  EXPECT_TRUE(s) << s.message();
  Rng rng(seed, 2, 0);
  m.grid.resize(m.config.grid_parameter_count());
  for (float& v : m.grid) v = rng.next_float() - 0.5f;
  return m;
}

void put_u32(Bytes& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = uint8_t(v >> (8 * i));
}
void put_u64(Bytes& b, size_t at, uint64_t v) {
  put_u32(b, at, uint32_t(v));
  put_u32(b, at + 4, uint32_t(v >> 32));
}

// Makes the declared size (offset 16) and the trailing CRC agree with the bytes, when possible.
Bytes repaired(Bytes b) {
  if (b.size() >= 24) put_u64(b, 16, b.size());
  if (b.size() >= 4) put_u32(b, b.size() - 4, crc32(b.data(), b.size() - 4));
  return b;
}

uint32_t interesting_u32(Rng& rng, size_t file_size) {
  const uint32_t choices[] = {0u, 1u, 2u, 4u, 16u, 31u, 32u, 64u, 168u, 255u, 256u, 4096u, 0x7fffffffu,
                              0x80000000u, 0xffffffffu, uint32_t(file_size), uint32_t(file_size - 1)};
  constexpr uint32_t kChoices = uint32_t(sizeof(choices) / sizeof(choices[0]));
  const uint32_t pick = rng.next_u32() % (kChoices + 1u);
  return pick < kChoices ? choices[pick] : rng.next_u32();
}

// One random mutation of `original` (which may be shorter than a header, or empty).
Bytes mutate(const Bytes& original, Rng& rng) {
  Bytes b = original;
  uint32_t kind = rng.next_u32() % 8u;
  if (b.empty()) kind = 5;                          // only extension applies
  if ((kind == 2 || kind == 3) && b.size() < 168) kind = 0;  // no complete header to edit
  switch (kind) {
    case 0: {  // flip 1..8 random bits
      const uint32_t n = 1 + rng.next_u32() % 8u;
      for (uint32_t i = 0; i < n; ++i) b[rng.next_u32() % b.size()] ^= uint8_t(1u << (rng.next_u32() % 8u));
      break;
    }
    case 1: {  // overwrite 1..4 random bytes with random or extreme values
      const uint32_t n = 1 + rng.next_u32() % 4u;
      const uint8_t extremes[] = {0x00, 0xff, 0x7f, 0x80, 0x7c, 0xfc, 0x7e};
      for (uint32_t i = 0; i < n; ++i)
        b[rng.next_u32() % b.size()] = (rng.next_u32() & 1u) ? uint8_t(rng.next_u32()) : extremes[rng.next_u32() % 7u];
      break;
    }
    case 2: {  // a header field (aligned u32 among the first 272 bytes, within the file) gets an interesting value
      const size_t at = 4 * (rng.next_u32() % 68u);
      if (at + 4 <= b.size()) put_u32(b, at, interesting_u32(rng, b.size()));
      break;
    }
    case 3: {  // a section table entry (u64) gets an interesting value
      const size_t at = 104 + 8 * (rng.next_u32() % 8u);
      const uint64_t v = (rng.next_u32() & 1u) ? uint64_t(interesting_u32(rng, b.size()))
                                                : (uint64_t(rng.next_u32()) << 32 | rng.next_u32());
      put_u64(b, at, v);
      break;
    }
    case 4:  // truncate
      b.resize(rng.next_u32() % b.size());
      break;
    case 5: {  // extend with 1..64 random bytes
      const uint32_t n = 1 + rng.next_u32() % 64u;
      for (uint32_t i = 0; i < n; ++i) b.push_back(uint8_t(rng.next_u32()));
      break;
    }
    case 6: {  // insert 1..32 bytes somewhere
      const size_t at = rng.next_u32() % (b.size() + 1);
      const uint32_t n = 1 + rng.next_u32() % 32u;
      b.insert(b.begin() + long(at), n, uint8_t(rng.next_u32()));
      break;
    }
    default: {  // delete 1..32 bytes somewhere
      const size_t at = rng.next_u32() % b.size();
      const size_t n = std::min<size_t>(1 + rng.next_u32() % 32u, b.size() - at);
      b.erase(b.begin() + long(at), b.begin() + long(at + n));
      break;
    }
  }
  return b;
}

struct Tally {
  int accepted = 0, rejected = 0;
};

// Loads `b`; on success the model must be valid and re-encode to exactly `b`.
void check_load(const Bytes& b, Tally& tally) {
  Model m;
  Status s = load_model_from_memory(b.data(), b.size(), m);
  if (!s) {
    ASSERT_FALSE(s.message().empty());
    ++tally.rejected;
    return;
  }
  ++tally.accepted;
  Status v = m.validate();
  ASSERT_TRUE(v) << v.message();
  for (float x : m.grid) ASSERT_TRUE(std::isfinite(x));
  for (float x : m.mlp) ASSERT_TRUE(std::isfinite(x));
  ASSERT_TRUE(m.bounds().valid());
  Bytes again;
  Status w = save_model_to_memory(m, again);
  ASSERT_TRUE(w) << w.message();
  ASSERT_EQ(again, b) << "an accepted file is not the canonical encoding of its model";
}

void fuzz(const Model& model, uint64_t seed, int iterations, Tally& raw, Tally& fixed) {
  Bytes base;
  ASSERT_TRUE(save_model_to_memory(model, base));
  Rng rng(seed, 2, 0);
  for (int i = 0; i < iterations; ++i) {
    Bytes b = mutate(base, rng);
    if (rng.next_u32() % 4u == 0) b = mutate(b, rng);  // sometimes two mutations
    check_load(b, raw);
    if (::testing::Test::HasFatalFailure()) return;
    check_load(repaired(b), fixed);
    if (::testing::Test::HasFatalFailure()) return;
  }
}

TEST(ModelFileFuzz, MutationsNeverCrashAndAcceptedFilesAreCanonical) {
  const Model models[] = {
      base_model(5, 2, 3, 1),  // V^3 = 125: the last voxel word has unused bits
      base_model(1, 1, 1, 2),  // the smallest possible model
      base_model(4, 4, 2, 3),
      base_8bit_model(3, 2, 1, 5),
      base_model(3, 3, 1, 6, true),  // tables of different sizes: version 4
      base_indexed_model(4, 2, 1, 7),  // level 1 indexed: version 5
  };
  const int iterations = 15000;  // per model
  Tally raw, fixed;
  for (size_t i = 0; i < std::size(models); ++i) {
    fuzz(models[i], 100 + i, iterations, raw, fixed);
    if (HasFatalFailure()) return;
  }
  // Without repair almost nothing survives the checksum; with repair, mutations of parameter bytes
  // produce valid models, so both outcomes must occur for the fuzzing to reach the deep checks.
  const int total = int(std::size(models)) * iterations;
  EXPECT_GT(raw.rejected, total * 9 / 10);
  EXPECT_GT(fixed.accepted, total / 100);
  EXPECT_GT(fixed.rejected, total / 2);
  std::printf("without repair: %d accepted, %d rejected; with repair: %d accepted, %d rejected\n", raw.accepted,
              raw.rejected, fixed.accepted, fixed.rejected);
}

TEST(ModelFileFuzz, EveryTruncationAndEveryByteOfTheHeader) {
  for (const Model& model : {base_model(5, 2, 3, 4), base_8bit_model(5, 2, 3, 4), base_model(5, 2, 3, 4, true),
                             base_indexed_model(5, 2, 3, 4)}) {
    Bytes base;
    ASSERT_TRUE(save_model_to_memory(model, base));
    Tally t;
    for (size_t n = 0; n < base.size(); ++n) {
      const Bytes cut(base.begin(), base.begin() + long(n));
      check_load(cut, t);
      check_load(repaired(cut), t);
      if (HasFatalFailure()) return;
    }
    // Every header byte set to each of a few values, CRC repaired.
    const uint8_t values[] = {0x00, 0x01, 0x10, 0x7f, 0x80, 0xff};
    // 168, for 8-bit grids 208, for tables of different sizes 224, with an indexed level 272
    const size_t header_bytes = size_t(base[12]) | size_t(base[13]) << 8;
    for (size_t at = 0; at < header_bytes; ++at) {
      for (uint8_t v : values) {
        Bytes b = base;
        if (b[at] == v) continue;
        b[at] = v;
        check_load(repaired(b), t);
        if (HasFatalFailure()) return;
      }
    }
    EXPECT_EQ(t.accepted > 0, true);  // e.g. AABB or leaky-slope bytes that stay valid
    EXPECT_GT(t.rejected, 2 * int(base.size()) - 2);
  }
}

}  // namespace
}  // namespace lsnif
