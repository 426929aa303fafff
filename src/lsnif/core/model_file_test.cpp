// model_file_test.cpp -- .lsnif files (src/lsnif/core/model_file.cpp, docs/model-format.md), CRC-32
// (src/lsnif/format/crc32.h) and the Model helpers (src/lsnif/core/model.cpp). Layout expectations are the offsets of the
// format document, written out by hand; the CRC is checked against a bit-by-bit implementation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include "lsnif/format/crc32.h"
#include "lsnif/core/half.h"
#include "lsnif/core/model.h"
#include "lsnif/core/rng.h"
#include "lsnif/core/uv_cells.h"
#include "lsnif/format/uv_cell_layout.h"

namespace lsnif {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<uint8_t>;

// ---- independent helpers -------------------------------------------------------------------------

// CRC-32 one bit at a time, straight from the definition (reflected 0xEDB88320).
uint32_t crc32_bitwise(const uint8_t* p, size_t n) {
  uint32_t r = 0xffffffffu;
  for (size_t i = 0; i < n; ++i) {
    r ^= p[i];
    for (int k = 0; k < 8; ++k) r = (r >> 1) ^ (0xEDB88320u & (0u - (r & 1u)));
  }
  return ~r;
}

uint32_t rd32(const Bytes& b, size_t off) {
  return uint32_t(b[off]) | uint32_t(b[off + 1]) << 8 | uint32_t(b[off + 2]) << 16 | uint32_t(b[off + 3]) << 24;
}
uint64_t rd64(const Bytes& b, size_t off) { return uint64_t(rd32(b, off)) | uint64_t(rd32(b, off + 4)) << 32; }
void wr32(Bytes& b, size_t off, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[off + i] = uint8_t(v >> (8 * i));
}
void wr64(Bytes& b, size_t off, uint64_t v) {
  wr32(b, off, uint32_t(v));
  wr32(b, off + 4, uint32_t(v >> 32));
}
void wrf32(Bytes& b, size_t off, float f) {
  uint32_t v;
  std::memcpy(&v, &f, 4);
  wr32(b, off, v);
}
// Recomputes the trailer so that only the structural checks can catch a change.
void fix_crc(Bytes& b) { wr32(b, b.size() - 4, crc32_bitwise(b.data(), b.size() - 4)); }
// `good` with `change` applied and the trailer recomputed.
Bytes changed(const Bytes& good, const std::function<void(Bytes&)>& change) {
  Bytes b = good;
  change(b);
  fix_crc(b);
  return b;
}

// Documented offsets (docs/model-format.md).
constexpr size_t kVersionAt = 8, kHeaderSizeAt = 12, kFileSizeAt = 16, kVAt = 24, kGridResAt = 36,
                 kMatCountAt = 68, kHitParamAt = 72, kLeakyAt = 76, kAabbAt = 80, kSectionsAt = 104;
enum { kMaterials = 0, kVoxels = 1, kGrid = 2, kMlp = 3 };
uint64_t section_offset(const Bytes& b, int s) { return rd64(b, kSectionsAt + 16 * s); }
uint64_t section_size(const Bytes& b, int s) { return rd64(b, kSectionsAt + 16 * s + 8); }

Config random_config(Rng& rng, uint32_t levels, uint32_t materials) {
  Config c;
  c.voxel_resolution = 1 + rng.next_u32() % 12u;
  c.max_points = 1 + rng.next_u32() % LSNIF_MAX_POINTS;
  c.grid_levels = levels;
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l)
    c.grid_resolution[l] = l < levels ? c.voxel_resolution * (1 + rng.next_u32() % 8u) : 0u;
  set_table_log2(c, 4 + rng.next_u32() % 7u);
  c.features = 1 + rng.next_u32() % LSNIF_MAX_FEATURES;
  c.hidden_width = 1 + rng.next_u32() % 40u;
  c.hidden_layers = 1 + rng.next_u32() % LSNIF_MAX_HIDDEN_LAYERS;
  c.material_count = materials;
  c.hit_param = (rng.next_u32() & 1u) ? HitParam::AabbInterval : HitParam::VoxelSegments;
  c.leaky_slope = rng.next_float() * 0.5f;
  return c;
}

// A model of random content that satisfies every rule of the format.
Model random_model(const Config& c, Rng& rng) {
  Model m;
  m.config = c;
  m.voxels.resolution = c.voxel_resolution;
  const glm::vec3 lo(rng.next_float() * 10 - 5, rng.next_float() * 10 - 5, rng.next_float() * 10 - 5);
  m.voxels.bounds.lo = lo;
  m.voxels.bounds.hi = lo + glm::vec3(0.1f + rng.next_float(), 0.1f + rng.next_float(), 0.1f + rng.next_float());
  m.voxels.bits.assign((c.voxel_count() + 31) / 32, 0u);
  for (uint32_t k = 0; k < c.voxel_resolution; ++k)
    for (uint32_t j = 0; j < c.voxel_resolution; ++j)
      for (uint32_t i = 0; i < c.voxel_resolution; ++i)
        if (rng.next_u32() % 3u == 0) m.voxels.set(i, j, k);
  m.materials.resize(c.material_count);
  for (uint32_t i = 0; i < c.material_count; ++i) {
    const size_t length = i == 0 ? 63 : rng.next_u32() % 64u;  // the longest allowed name included
    for (size_t k = 0; k < length; ++k) m.materials[i].name += char('a' + rng.next_u32() % 26u);
    m.materials[i].base_color = glm::vec3(rng.next_float(), rng.next_float(), rng.next_float());
  }
  auto value = [&rng] {
    const float u = rng.next_float() * 2.0f - 1.0f;
    return std::ldexp(u, int(rng.next_u32() % 20u) - 16);  // magnitudes down to fp16 subnormals
  };
  m.grid.resize(c.grid_parameter_count());
  for (float& v : m.grid) v = value();
  m.mlp.resize(c.mlp_parameter_count());
  for (float& v : m.mlp) v = value();
  return m;
}

Model small_model(uint64_t seed = 1) {
  Rng rng(seed, 0, 0);
  return random_model(random_config(rng, 2, 2), rng);
}

void expect_same_bits(const std::vector<float>& a, const std::vector<float>& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(std::memcmp(&a[i], &b[i], 4), 0) << what << " " << i;
}

void expect_equal(const Model& a, const Model& b) {
  EXPECT_EQ(a.config.describe(), b.config.describe());
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) EXPECT_EQ(a.config.grid_resolution[l], b.config.grid_resolution[l]);
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) EXPECT_EQ(a.config.table_log2[l], b.config.table_log2[l]);
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) {
    EXPECT_EQ(a.config.index_slots[l], b.config.index_slots[l]);
    EXPECT_EQ(a.config.index_buckets[l], b.config.index_buckets[l]);
  }
  EXPECT_EQ(a.grid_index, b.grid_index);
  EXPECT_EQ(a.config.leaky_slope, b.config.leaky_slope);
  EXPECT_EQ(a.voxels.resolution, b.voxels.resolution);
  EXPECT_EQ(a.voxels.bounds.lo, b.voxels.bounds.lo);
  EXPECT_EQ(a.voxels.bounds.hi, b.voxels.bounds.hi);
  EXPECT_EQ(a.voxels.bits, b.voxels.bits);
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t i = 0; i < a.materials.size(); ++i) {
    EXPECT_EQ(a.materials[i].name, b.materials[i].name);
    EXPECT_EQ(a.materials[i].base_color, b.materials[i].base_color);
  }
  expect_same_bits(a.grid, b.grid, "grid");
  expect_same_bits(a.mlp, b.mlp, "mlp");
  EXPECT_EQ(a.uv_cells, b.uv_cells);
}

Bytes saved(const Model& m) {
  Bytes b;
  Status s = save_model_to_memory(m, b);
  EXPECT_TRUE(s) << s.message();
  return b;
}

// Loads `b`, which `m` was saved as: the same model and record, saved again as the same bytes (one
// encoding per model). Returns the loaded model.
Model expect_round_trip(const Model& m, const Bytes& b) {
  Model back;
  Status s = load_model_from_memory(b.data(), b.size(), back);
  EXPECT_TRUE(s) << s.message();
  expect_equal(m, back);
  EXPECT_EQ(back.training, m.training);
  EXPECT_EQ(saved(back), b);
  return back;
}

// Loads `b`, expects failure with a message containing every key word; the target model must stay
// untouched.
void expect_load_error(const Bytes& b, std::initializer_list<const char*> keywords) {
  Model m = small_model(77);
  const Bytes before = saved(m);
  Status s = load_model_from_memory(b.data(), b.size(), m);
  ASSERT_FALSE(s) << "loaded a bad file of " << b.size() << " bytes";
  EXPECT_FALSE(s.message().empty());
  for (const char* k : keywords) EXPECT_NE(s.message().find(k), std::string::npos) << "message: " << s.message();
  EXPECT_EQ(saved(m), before) << "a failed load modified the model";
}

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() / ("lsnif_model_file_test_" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

// ---- CRC-32 -----------------------------------------------------------------------------------------

TEST(Crc32, StandardCheckValueAndBitwiseReference) {
  const char* check = "123456789";
  EXPECT_EQ(crc32(reinterpret_cast<const uint8_t*>(check), 9), 0xCBF43926u);
  EXPECT_EQ(crc32(nullptr, 0), 0u);
  const uint8_t zero = 0;
  EXPECT_EQ(crc32(&zero, 1), 0xD202EF8Du);
  Rng rng(5, 0, 0);
  for (int t = 0; t < 200; ++t) {
    Bytes b(rng.next_u32() % 300u);
    for (uint8_t& x : b) x = uint8_t(rng.next_u32());
    ASSERT_EQ(crc32(b.data(), b.size()), crc32_bitwise(b.data(), b.size()));
    const size_t cut = b.empty() ? 0 : rng.next_u32() % b.size();
    ASSERT_EQ(crc32(b.data() + cut, b.size() - cut, crc32(b.data(), cut)), crc32_bitwise(b.data(), b.size()));
  }
}

// ---- Model helpers ------------------------------------------------------------------------------------

TEST(Model, ValidateFlagsEverySizeMismatch) {
  const Model good = small_model();
  EXPECT_TRUE(good.validate()) << good.validate().message();
  auto expect_invalid = [](const Model& m, const char* keyword) {
    Status s = m.validate();
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find(keyword), std::string::npos) << s.message();
  };
  Model m = good;
  m.config.voxel_resolution = 0;
  expect_invalid(m, "voxel resolution");
  m = good;
  m.voxels.resolution += 1;
  expect_invalid(m, "resolution");
  m = good;
  m.voxels.bits.push_back(0);
  expect_invalid(m, "words");
  m = good;
  m.materials.pop_back();
  expect_invalid(m, "materials");
  m = good;
  m.grid.pop_back();
  expect_invalid(m, "hash grid");
  m = good;
  m.mlp.push_back(0.0f);
  expect_invalid(m, "MLP");
  m = good;  // V=5: 125 voxels, bits 125..127 of the last word must stay clear
  m.config.voxel_resolution = 5;
  for (uint32_t l = 0; l < m.config.grid_levels; ++l) m.config.grid_resolution[l] = 5u * (l + 1);
  m.voxels.resolution = 5;
  m.voxels.bits.assign(4, 0u);
  EXPECT_TRUE(m.validate()) << m.validate().message();
  m.voxels.bits[3] = 1u << 29;
  expect_invalid(m, "beyond");
}

TEST(Model, QuantizeRoundsToNearestHalf) {
  Model m = small_model();
  m.grid[0] = 1.0f + 0x1.0p-11f;        // tie -> 1
  m.grid[1] = 1.0f + 0x1.8p-11f;        // -> 1 + 2^-10
  m.mlp[0] = 0.1f;
  const Model before = m;
  m.quantize();
  EXPECT_EQ(m.grid[0], 1.0f);
  EXPECT_EQ(m.grid[1], 1.0f + 0x1.0p-10f);
  for (size_t i = 0; i < m.mlp.size(); ++i) {
    // nearest: no half value lies strictly closer (checked against the neighbouring halves)
    const float q = m.mlp[i], x = before.mlp[i];
    const uint16_t h = float_to_half(q);
    ASSERT_EQ(half_to_float(h), q);
    const float up = half_to_float(uint16_t(h + 1)), down = half_to_float(uint16_t(h - 1));
    if (std::isfinite(up)) {
      ASSERT_LE(std::fabs(q - x), std::fabs(up - x));
    }
    if (std::isfinite(down)) {
      ASSERT_LE(std::fabs(q - x), std::fabs(down - x));
    }
  }
  Model again = m;
  again.quantize();
  expect_same_bits(again.grid, m.grid, "grid");
  expect_same_bits(again.mlp, m.mlp, "mlp");
}

// Brute force: per level the scale max|g| / 127 (fp32), each value the nearest of all 255
// code * scale products; an all-zero level keeps scale 0 and zero codes.
TEST(Model, QuantizeToInt8MatchesABruteForceReference) {
  Rng rng(31, 0, 0);
  Config c = random_config(rng, 3, 1);
  c.grid_bits = 8;
  const uint32_t sizes[3] = {6, 4, 5};  // tables of different sizes: level l's values start at first[l]
  set_table_log2(c, sizes, 3);
  Model m = random_model(c, rng);
  const size_t first[4] = {0, 64 * c.features, 80 * c.features, 112 * c.features};
  ASSERT_EQ(m.grid.size(), first[3]);
  for (size_t i = first[1]; i < first[2]; ++i) m.grid[i] *= 1000.0f;  // levels of different ranges
  for (size_t i = first[2]; i < first[3]; ++i) m.grid[i] = 0.0f;      // an all-zero level
  m.grid[5] = -std::fabs(m.grid[5]) - 8.0f;                                  // the extreme is negative
  const Model before = m;
  m.quantize();
  ASSERT_TRUE(m.validate()) << m.validate().message();
  ASSERT_EQ(m.grid_scales.size(), 3u);
  for (uint32_t l = 0; l < 3; ++l) {
    float max_abs = 0.0f;
    for (size_t e = first[l]; e < first[l + 1]; ++e) max_abs = std::max(max_abs, std::fabs(before.grid[e]));
    const float scale = max_abs / 127.0f;
    EXPECT_EQ(m.grid_scales[l], scale) << "level " << l;
    for (size_t e = first[l]; e < first[l + 1]; ++e) {
      const float x = before.grid[e];
      float best = 0.0f;
      for (int code = -127; code <= 127; ++code)
        if (std::fabs(float(code) * scale - x) < std::fabs(best - x)) best = float(code) * scale;
      ASSERT_EQ(std::memcmp(&m.grid[e], &best, 4), 0) << "element " << e << ": " << m.grid[e] << " vs " << best;
      ASSERT_EQ(float(m.grid_code(e)) * scale, m.grid[e]) << e;
    }
  }
  EXPECT_EQ(m.grid_scales[2], 0.0f);
  EXPECT_EQ(m.grid_code(5), -127);
  for (size_t i = 0; i < m.mlp.size(); ++i) ASSERT_EQ(m.mlp[i], round_to_half(before.mlp[i])) << i;
  Model again = m;  // idempotent
  again.quantize();
  expect_same_bits(again.grid, m.grid, "grid");
  EXPECT_EQ(again.grid_scales, m.grid_scales);
  // Back to 16 bits: fp16 values, no scales.
  m.config.grid_bits = 16;
  m.quantize();
  EXPECT_TRUE(m.grid_scales.empty());
  EXPECT_TRUE(m.validate());
}

// ---- Layout of the paper's default model (docs/model-format.md example) ---------------------------

TEST(ModelFile, DefaultModelLayoutMatchesTheDocument) {
  Model m;
  m.voxels.resolution = 32;
  m.voxels.bounds.lo = glm::vec3(-1.0f, -2.0f, -3.0f);
  m.voxels.bounds.hi = glm::vec3(1.0f, 2.0f, 3.0f);
  m.voxels.bits.assign(32 * 32 * 32 / 32, 0u);
  m.voxels.set(1, 0, 0);   // index 1 -> word 0 bit 1
  m.voxels.set(0, 1, 0);   // index 32 -> word 1 bit 0
  m.materials.resize(1);
  m.materials[0].name = "bunny";
  m.materials[0].base_color = glm::vec3(0.25f, 0.5f, 0.75f);
  EXPECT_EQ(m.config.mlp_parameter_count(), 108u * 128 + 128 + 128 * 128 + 128 + 128 * 9 + 9);
  EXPECT_EQ(m.config.mlp_parameter_count(), 31625u);
  m.grid.assign(m.config.grid_parameter_count(), 0.0f);
  m.mlp.assign(m.config.mlp_parameter_count(), 0.0f);
  m.grid[5] = 1.5f;        // fp16 0x3e00
  m.mlp[0] = -2.0f;        // fp16 0xc000
  m.mlp.back() = 65504.0f; // fp16 0x7bff

  const MemoryBreakdown mb = memory_breakdown(m);
  EXPECT_EQ(mb.voxel_bytes, 4096u);
  EXPECT_EQ(mb.grid_bytes, 1572864u);  // 1536 KiB
  EXPECT_EQ(mb.mlp_bytes, 63250u);
  EXPECT_EQ(mb.header_bytes, 274u);    // 168 header + 8 pad + 76 material + 4 pad + 14 pad + 4 CRC
  EXPECT_EQ(mb.total(), 1640484u);
  EXPECT_NEAR(double(mb.total()) / (1024.0 * 1024.0), 1.56, 0.01);  // paper: "about 1.56 MB"

  const Bytes b = saved(m);
  ASSERT_EQ(b.size(), 1640484u);
  const uint8_t magic[8] = {'L', 'S', 'N', 'I', 'F', 0, '\r', '\n'};
  EXPECT_EQ(std::memcmp(b.data(), magic, 8), 0);
  EXPECT_EQ(rd32(b, kVersionAt), 1u);
  EXPECT_EQ(rd32(b, kHeaderSizeAt), 168u);
  EXPECT_EQ(rd64(b, kFileSizeAt), 1640484u);
  const uint32_t config_fields[13] = {32, 18, 2, 64, 128, 0, 0, 17, 3, 128, 2, 1, LSNIF_HIT_PARAM_VOXEL_SEGMENTS};
  for (int i = 0; i < 13; ++i) EXPECT_EQ(rd32(b, kVAt + 4 * i), config_fields[i]) << "config field " << i;
  const float leaky = 0.01f;
  uint32_t leaky_bits;
  std::memcpy(&leaky_bits, &leaky, 4);
  EXPECT_EQ(rd32(b, kLeakyAt), leaky_bits);
  const float aabb[6] = {-1, -2, -3, 1, 2, 3};
  for (int i = 0; i < 6; ++i) {
    uint32_t bits;
    std::memcpy(&bits, &aabb[i], 4);
    EXPECT_EQ(rd32(b, kAabbAt + 4 * i), bits);
  }
  const uint64_t sections[4][2] = {{176, 76}, {256, 4096}, {4352, 1572864}, {1577216, 63250}};
  for (int s = 0; s < 4; ++s) {
    EXPECT_EQ(section_offset(b, s), sections[s][0]) << "section " << s;
    EXPECT_EQ(section_size(b, s), sections[s][1]) << "section " << s;
  }
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(&b[176])), "bunny");
  for (size_t i = 176 + 5; i < 176 + 64; ++i) EXPECT_EQ(b[i], 0u);
  EXPECT_EQ(rd32(b, 176 + 64), 0x3e800000u);  // 0.25f
  EXPECT_EQ(rd32(b, 176 + 72), 0x3f400000u);  // 0.75f
  EXPECT_EQ(rd32(b, 256), 2u);
  EXPECT_EQ(rd32(b, 260), 1u);
  EXPECT_EQ(b[4352 + 10], 0x00u);
  EXPECT_EQ(b[4352 + 11], 0x3eu);
  EXPECT_EQ(b[1577216], 0x00u);
  EXPECT_EQ(b[1577217], 0xc0u);
  EXPECT_EQ(b[1577216 + 63248], 0xffu);
  EXPECT_EQ(b[1577216 + 63249], 0x7bu);
  for (size_t i = 1577216 + 63250; i < 1640480; ++i) EXPECT_EQ(b[i], 0u) << "padding at " << i;
  EXPECT_EQ(rd32(b, 1640480), crc32_bitwise(b.data(), 1640480));

  Model back;
  Status s = load_model_from_memory(b.data(), b.size(), back);
  ASSERT_TRUE(s) << s.message();
  expect_equal(back, m);
}

// The document's version 4 example: the same model with 8-bit features and tables of 2^15 + 2^17.
TEST(ModelFile, PerLevelTablesExampleMatchesTheDocument) {
  Model m;
  m.voxels.resolution = 32;
  m.voxels.bounds.lo = glm::vec3(-1.0f);
  m.voxels.bounds.hi = glm::vec3(1.0f);
  m.voxels.bits.assign(32 * 32 * 32 / 32, 0u);
  m.materials.resize(1);
  const uint32_t sizes[2] = {15, 17};
  set_table_log2(m.config, sizes, 2);
  m.config.grid_bits = 8;
  m.grid.assign(m.config.grid_parameter_count(), 0.0f);
  m.mlp.assign(m.config.mlp_parameter_count(), 0.0f);
  m.quantize();
  const Bytes b = saved(m);
  EXPECT_EQ(b.size(), 559204u);
  EXPECT_EQ(memory_breakdown(m).total(), 559204u);
  const uint64_t sections[6][2] = {{224, 76}, {304, 4096}, {4400, 491520}, {495920, 63250}, {559184, 0}, {559184, 8}};
  for (int sec = 0; sec < 6; ++sec) {
    EXPECT_EQ(section_offset(b, sec), sections[sec][0]) << "section " << sec;
    EXPECT_EQ(section_size(b, sec), sections[sec][1]) << "section " << sec;
  }
}

// ---- Round trips ------------------------------------------------------------------------------------

TEST(ModelFile, RoundTripOfRandomConfigs) {
  Rng rng(2024, 0, 0);
  int variants = 0;
  for (uint32_t levels = 1; levels <= 4; ++levels) {
    for (uint32_t materials = 1; materials <= 5; ++materials) {
      for (int rep = 0; rep < 2; ++rep, ++variants) {
        Config c = random_config(rng, levels, materials);
        c.hit_param = rep == 0 ? HitParam::AabbInterval : HitParam::VoxelSegments;
        // The second of each pair has tables of different sizes (from 2 levels on): a version 4 file.
        for (uint32_t l = 1; l < levels && rep == 1; ++l) c.table_log2[l] = 4 + (c.table_log2[0] + l) % 7u;
        ASSERT_TRUE(c.validate()) << c.validate().message();
        const Model original = random_model(c, rng);
        Model quantized = original;
        quantized.quantize();

        const Bytes b = saved(original);  // saving rounds to fp16 itself
        EXPECT_EQ(b.size(), memory_breakdown(original).total()) << c.describe();
        const MemoryBreakdown mb = memory_breakdown(original);
        EXPECT_EQ(mb.grid_bytes, 2 * c.grid_parameter_count());
        EXPECT_EQ(mb.mlp_bytes, 2 * c.mlp_parameter_count());
        EXPECT_EQ(mb.voxel_bytes, 4 * ((c.voxel_count() + 31) / 32));
        EXPECT_EQ(saved(quantized), b);
        EXPECT_EQ(rd32(b, kVersionAt), c.uniform_table_log2() ? 1u : 4u) << c.describe();

        Model loaded;
        Status s = load_model_from_memory(b.data(), b.size(), loaded);
        ASSERT_TRUE(s) << c.describe() << ": " << s.message();
        ASSERT_TRUE(loaded.validate());
        expect_equal(loaded, quantized);
        EXPECT_EQ(saved(loaded), b) << "load then save must reproduce the file";
      }
    }
  }
  EXPECT_EQ(variants, 40);
}

TEST(ModelFile, SaveAndLoadThroughAFile) {
  TempDir dir;
  Model m = small_model(3);
  m.quantize();
  const std::string path = dir.file("object.lsnif");
  Status s = save_model(m, path);
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(fs::file_size(path), memory_breakdown(m).total());
  EXPECT_EQ(std::distance(fs::directory_iterator(fs::path(path).parent_path()), fs::directory_iterator()), 1);
  Model back;
  s = load_model(path, back);
  ASSERT_TRUE(s) << s.message();
  expect_equal(back, m);
  // Overwriting an existing file works too.
  Model other = small_model(4);
  other.quantize();
  ASSERT_TRUE(save_model(other, path));
  ASSERT_TRUE(load_model(path, back));
  expect_equal(back, other);
}

// ---- Errors -------------------------------------------------------------------------------------------

TEST(ModelFileErrors, EmptyInput) {
  expect_load_error({}, {"empty"});
  Model m;
  Status s = load_model_from_memory(nullptr, 0, m);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("empty"), std::string::npos);
  s = load_model_from_memory(nullptr, 10, m);
  EXPECT_FALSE(s);
  TempDir dir;
  std::ofstream(dir.file("empty.lsnif")).close();
  s = load_model(dir.file("empty.lsnif"), m);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("empty"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("empty.lsnif"), std::string::npos) << s.message();
}

TEST(ModelFileErrors, TruncatedAtEveryBoundaryAndRandomLengths) {
  const Bytes b = saved(small_model());
  std::vector<size_t> cuts = {1, 7, 8, 12, 16, 23, 24, 80, 104, 167, 168, 176, b.size() - 4, b.size() - 1};
  for (int s = 0; s < 4; ++s) {
    cuts.push_back(section_offset(b, s));
    cuts.push_back(section_offset(b, s) + 1);
    cuts.push_back(section_offset(b, s) + section_size(b, s));
  }
  Rng rng(11, 0, 0);
  for (int i = 0; i < 200; ++i) cuts.push_back(1 + rng.next_u32() % (b.size() - 1));
  for (size_t cut : cuts) {
    ASSERT_LT(cut, b.size());
    const Bytes t(b.begin(), b.begin() + long(cut));
    if (cut >= 24) {
      // the message gives both the expected and the actual size
      expect_load_error(t, {"truncated", std::to_string(b.size()).c_str(), std::to_string(cut).c_str()});
    } else {
      expect_load_error(t, {"truncated"});
    }
  }
}

TEST(ModelFileErrors, TrailingBytes) {
  Bytes b = saved(small_model());
  b.push_back(0);
  expect_load_error(b, {"trailing"});
}

TEST(ModelFileErrors, WrongMagic) {
  const Bytes good = saved(small_model());
  for (size_t i = 0; i < 8; ++i) {
    Bytes b = good;
    b[i] ^= 0x20;
    expect_load_error(b, {"magic"});
  }
  // A text-mode copy that turned "\r\n" into "\n".
  Bytes b = good;
  b.erase(b.begin() + 6);
  expect_load_error(b, {"magic"});
  expect_load_error(Bytes{'P', 'K'}, {"magic"});
}

TEST(ModelFileErrors, FutureVersion) {
  Bytes b = saved(small_model());
  wr32(b, kVersionAt, 8);
  expect_load_error(b, {"version 8", "versions 1 to 7"});  // reported before the checksum
  fix_crc(b);
  expect_load_error(b, {"version 8", "versions 1 to 7"});
  wr32(b, kVersionAt, 0);
  fix_crc(b);
  expect_load_error(b, {"version 0"});
}

// ---- format version 2: the training record ----------------------------------------------------------

// A version 1 file written by the code before the training record existed (`lsnif train` of
// bunny00.off at commit f96392d: --voxels 4 --res-min 4 --res-max 8 --table-log2 4 --features 1
// --width 4 --layers 1 --points 2 --steps 2 --batch 64 --seed 3).
const uint8_t kVersion1Model[] = {
    0x4c, 0x53, 0x4e, 0x49, 0x46, 0x00, 0x0d, 0x0a, 0x01, 0x00, 0x00, 0x00, 0xa8, 0x00, 0x00, 0x00, 0xe4, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x04, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
    0x01, 0x00, 0x00, 0x00, 0x0a, 0xd7, 0x23, 0x3c, 0xf3, 0xd5, 0x03, 0xbf, 0xdd, 0x6b, 0x02, 0xbf, 0x5c, 0x16, 0xce, 0xbe, 0x0e, 0xe7, 0x03, 0x3f,
    0xb0, 0x81, 0x02, 0x3f, 0x68, 0xe1, 0xcd, 0x3e, 0xb0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x4c, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x50, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x82, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x64, 0x65, 0x66, 0x61, 0x75, 0x6c, 0x74, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x66, 0x11, 0xff, 0x7f, 0x9f, 0x3f, 0xff, 0x3f,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x50, 0x24, 0x4c, 0xa4, 0x43, 0xa4, 0x22, 0x25, 0x42, 0xa4, 0x4d, 0xa4, 0x4c, 0xa4, 0x41, 0xa4,
    0x4d, 0xa4, 0x41, 0x24, 0x4b, 0xa4, 0x64, 0xa4, 0x4b, 0xa4, 0x49, 0xa4, 0x42, 0x24, 0x55, 0xa4, 0x48, 0xa4, 0x49, 0x24, 0x48, 0xa4, 0x4a, 0xa4,
    0x1e, 0xa4, 0x4c, 0x24, 0x4b, 0xa4, 0x4a, 0xa4, 0x4b, 0x24, 0x44, 0x24, 0x45, 0x24, 0x45, 0x24, 0x49, 0x24, 0x42, 0x24, 0x4a, 0x24, 0x47, 0x24,
    0xd4, 0xbb, 0x79, 0x31, 0xe7, 0xbc, 0xd8, 0x39, 0xa1, 0xbd, 0x08, 0x39, 0x24, 0xb6, 0x8c, 0x3c, 0x9e, 0xb8, 0x25, 0x36, 0x8a, 0x31, 0x5c, 0xb9,
    0x90, 0x38, 0x3a, 0x2d, 0x44, 0x39, 0x44, 0xb7, 0x47, 0xa4, 0x48, 0x24, 0x47, 0x24, 0x48, 0xa4, 0x7e, 0xa5, 0x79, 0x34, 0x5e, 0xbb, 0x18, 0xb6,
    0x58, 0xb6, 0x64, 0x38, 0x07, 0xbb, 0xd6, 0xbb, 0x0a, 0x37, 0xda, 0x3d, 0xa0, 0x29, 0x43, 0xb3, 0x5a, 0xb3, 0xa6, 0xbc, 0xad, 0x38, 0x34, 0x33,
    0x1c, 0xb4, 0x2a, 0x31, 0x93, 0xae, 0x04, 0x39, 0x9b, 0x2c, 0x81, 0x32, 0x72, 0x3b, 0xc4, 0x3b, 0x13, 0x3c, 0x08, 0xbd, 0x28, 0x30, 0x70, 0x37,
    0xfc, 0x38, 0x2e, 0xb4, 0x1d, 0xb9, 0xf2, 0xaa, 0x54, 0x2b, 0x5f, 0xbf, 0x9d, 0xbe, 0xd0, 0xbb, 0x1f, 0xa5, 0xfd, 0x24, 0x48, 0xa4, 0x45, 0x24,
    0x48, 0xa4, 0x1a, 0x25, 0x1c, 0x25, 0x1c, 0x25, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x36, 0xf1, 0x44, 0xb7,
};

TEST(ModelFile, Version1FilesOfTheOldWriterStillLoad) {
  const Bytes old(std::begin(kVersion1Model), std::end(kVersion1Model));
  ASSERT_EQ(rd32(old, kVersionAt), 1u);
  Model m;
  Status s = load_model_from_memory(old.data(), old.size(), m);
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(m.config.describe(), "V=4 H=2 L=2 res=4,8 M=4 F=1 W=4x1 Nmat=1 hit=segments leaky=0.01");
  EXPECT_EQ(m.voxels.count_occupied(), 47u);
  EXPECT_TRUE(m.training.empty());
  EXPECT_EQ(memory_breakdown(m).total(), old.size());
  EXPECT_EQ(saved(m), old);  // written back as the same version 1 bytes
}

TEST(ModelFile, TrainingRecordMakesAVersion2File) {
  Model m = small_model();
  m.quantize();
  const Bytes v1 = saved(m);
  m.training = R"({"settings":{"seed":7},"mesh":{"name":"café.obj"}})";
  const Bytes b = saved(m);
  EXPECT_EQ(rd32(b, kVersionAt), 2u);
  EXPECT_EQ(rd32(b, kHeaderSizeAt), 184u);
  EXPECT_EQ(rd64(b, kFileSizeAt), b.size());
  EXPECT_EQ(section_offset(b, kMaterials), 192u);  // the 184-byte header padded to 16 bytes
  // The training section follows mlp (16-byte aligned) and holds the text as it is, no NUL.
  const uint64_t mlp_end = section_offset(b, kMlp) + section_size(b, kMlp);
  const uint64_t at = section_offset(b, 4), size = section_size(b, 4);
  EXPECT_EQ(at, (mlp_end + 15) / 16 * 16);
  EXPECT_EQ(size, m.training.size());
  EXPECT_EQ(std::string(b.begin() + long(at), b.begin() + long(at + size)), m.training);
  EXPECT_EQ(b.size(), (at + size + 15) / 16 * 16 + 4);
  // The sections themselves are those of the version 1 file, 16 bytes later.
  for (int sec = kMaterials; sec <= kMlp; ++sec) {
    EXPECT_EQ(section_offset(b, sec), section_offset(v1, sec) + 16);
    EXPECT_EQ(section_size(b, sec), section_size(v1, sec));
  }
  const Model back = expect_round_trip(m, b);
  EXPECT_EQ(memory_breakdown(back).total(), v1.size());  // the record never reaches the GPU
}

// ---- format version 3: 8-bit grid features -------------------------------------------------------

constexpr size_t kGridBitsAt = 200, kV3ReservedAt = 204;
enum { kTraining = 4, kGridScales = 5 };

Model small_8bit_model(uint64_t seed = 1) {
  Model m = small_model(seed);
  m.config.grid_bits = 8;
  m.quantize();
  return m;
}

TEST(ModelFile, EightBitGridIsAVersion3FileWithCodesAndScales) {
  for (const bool record : {false, true}) {
    Model m = small_8bit_model();
    if (record) m.training = R"({"settings":{"grid-bits":"8"}})";
    const Bytes b = saved(m);
    const Config& c = m.config;
    EXPECT_EQ(rd32(b, kVersionAt), 3u);
    EXPECT_EQ(rd32(b, kHeaderSizeAt), 208u);
    EXPECT_EQ(rd64(b, kFileSizeAt), b.size());
    EXPECT_EQ(rd32(b, kGridBitsAt), 8u);
    EXPECT_EQ(rd32(b, kV3ReservedAt), 0u);
    EXPECT_EQ(section_offset(b, kMaterials), 208u);
    // The grid: one byte per value, the two's complement code; the scales: fp32 per level after
    // the (possibly empty) training section.
    ASSERT_EQ(section_size(b, kGrid), c.grid_parameter_count());
    const uint64_t grid_at = section_offset(b, kGrid);
    for (uint64_t e = 0; e < c.grid_parameter_count(); ++e)
      ASSERT_EQ(int8_t(b[grid_at + e]), m.grid_code(e)) << e;
    EXPECT_EQ(section_size(b, kTraining), m.training.size());
    const uint64_t training_end = section_offset(b, kTraining) + section_size(b, kTraining);
    ASSERT_EQ(section_size(b, kGridScales), 4u * c.grid_levels);
    EXPECT_EQ(section_offset(b, kGridScales), (training_end + 15) / 16 * 16);
    for (uint32_t l = 0; l < c.grid_levels; ++l) {
      float scale;
      const uint32_t bits = rd32(b, section_offset(b, kGridScales) + 4 * l);
      std::memcpy(&scale, &bits, 4);
      EXPECT_EQ(scale, m.grid_scales[l]);
      EXPECT_GT(scale, 0.0f);
    }
    const Model back = expect_round_trip(m, b);
    EXPECT_EQ(back.config.grid_bits, 8u);
    EXPECT_EQ(back.grid_scales, m.grid_scales);
    if (!record) {
      EXPECT_EQ(memory_breakdown(back).total(), b.size());
      EXPECT_EQ(memory_breakdown(back).grid_bytes, c.grid_parameter_count() + 4u * c.grid_levels);
    }
    // The same model with fp16 features is written exactly as before (version 1 or 2).
    Model wide = m;
    wide.config.grid_bits = 16;
    wide.quantize();
    EXPECT_EQ(rd32(saved(wide), kVersionAt), record ? 2u : 1u);
  }
}

TEST(ModelFileErrors, EightBitGrid) {
  const Model m = small_8bit_model();
  const Bytes good = saved(m);
  const uint64_t grid_at = section_offset(good, kGrid), scales_at = section_offset(good, kGridScales);
  const uint64_t per_level = uint64_t(m.config.table_size(0)) * m.config.features;
  const auto with = [&](const std::function<void(Bytes&)>& change) { return changed(good, change); };
  expect_load_error(with([&](Bytes& b) { b[grid_at + 3] = 0x80; }), {"grid section code 3", "-128"});
  expect_load_error(with([&](Bytes& b) { wrf32(b, scales_at + 4, std::nanf("")); }),
                    {"grid scale of level 1", "nan"});
  expect_load_error(with([&](Bytes& b) { wrf32(b, scales_at, -1.0f); }), {"grid scale of level 0", "-1"});
  expect_load_error(with([&](Bytes& b) { wrf32(b, scales_at, -0.0f); }), {"grid scale of level 0"});
  expect_load_error(with([&](Bytes& b) { wrf32(b, scales_at, std::numeric_limits<float>::infinity()); }),
                    {"grid scale of level 0", "inf"});
  expect_load_error(with([&](Bytes& b) { wrf32(b, scales_at, std::numeric_limits<float>::max()); }),
                    {"grid scale of level 0"});  // 127 times it overflows
  expect_load_error(with([&](Bytes& b) {
                      wrf32(b, scales_at + 4, 0.0f);
                      b[grid_at + per_level] = 1;
                    }),
                    {"scale is 0"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kGridBitsAt, 16); }), {"grid bits 16", "version 3"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kGridBitsAt, 4); }), {"grid bits 4"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kV3ReservedAt, 1); }), {"reserved", "204"});
  expect_load_error(with([&](Bytes& b) { wr64(b, kSectionsAt + 16 * kGridScales + 8, 4); }),
                    {"section grid scales has size 4"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kHeaderSizeAt, 184); }), {"header size 184", "208"});
  // A version 2 file claiming version 3 (or the reverse) does not parse.
  Model wide = m;
  wide.config.grid_bits = 16;
  wide.quantize();
  wide.training = "{}";
  Bytes v2 = saved(wide);
  wr32(v2, kVersionAt, 3);
  fix_crc(v2);
  expect_load_error(v2, {"header size 184", "208"});

  // Saving refuses what loading would.
  Model unquantized = small_model();
  unquantized.config.grid_bits = 8;
  unquantized.grid_scales = m.grid_scales;
  Bytes out;
  Status s = save_model_to_memory(unquantized, out);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("quantize"), std::string::npos) << s.message();
  Model bad = m;
  bad.grid_scales[0] = std::nanf("");
  s = save_model_to_memory(bad, out);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("grid scale of level 0"), std::string::npos) << s.message();
  bad = m;
  bad.grid_scales.pop_back();
  s = save_model_to_memory(bad, out);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("grid scales"), std::string::npos) << s.message();
}

// ---- format version 4: hash tables of different sizes per level ---------------------------------

constexpr size_t kTableLog2At = 208, kConfigMAt = 52;

// A random model of 3 levels with tables of 2^5, 2^7 and 2^4 entries.
Model unequal_model(uint32_t grid_bits, uint64_t seed = 1) {
  Rng rng(seed, 0, 0);
  Config c = random_config(rng, 3, 2);
  const uint32_t sizes[3] = {5, 7, 4};
  set_table_log2(c, sizes, 3);
  c.grid_bits = grid_bits;
  Model m = random_model(c, rng);
  m.quantize();
  return m;
}

TEST(ModelFile, TablesOfDifferentSizesAreAVersion4File) {
  for (const uint32_t bits : {16u, 8u}) {
    for (const bool record : {false, true}) {
      SCOPED_TRACE(testing::Message() << bits << "-bit grid, record " << record);
      Model m = unequal_model(bits);
      if (record) m.training = R"({"settings":{"table-log2":[5,7,4]}})";
      const Bytes b = saved(m);
      const Config& c = m.config;
      EXPECT_EQ(rd32(b, kVersionAt), 4u);
      EXPECT_EQ(rd32(b, kHeaderSizeAt), 224u);
      EXPECT_EQ(rd32(b, kConfigMAt), 0u);  // the per-level sizes replace the one M
      EXPECT_EQ(rd32(b, kGridBitsAt), bits);
      EXPECT_EQ(rd32(b, kV3ReservedAt), 0u);
      const uint32_t sizes[4] = {5, 7, 4, 0};
      for (uint32_t l = 0; l < 4; ++l) EXPECT_EQ(rd32(b, kTableLog2At + 4 * l), sizes[l]) << "level " << l;
      EXPECT_EQ(section_offset(b, kMaterials), 224u);
      // The levels' tables one after another: 32 + 128 + 16 entries of F values.
      EXPECT_EQ(c.grid_parameter_count(), (32u + 128u + 16u) * c.features);
      EXPECT_EQ(section_size(b, kGrid), c.grid_parameter_count() * bits / 8);
      EXPECT_EQ(section_size(b, kTraining), m.training.size());
      EXPECT_EQ(section_size(b, kGridScales), bits == 8 ? 12u : 0u);
      if (bits == 8) {
        const uint64_t grid_at = section_offset(b, kGrid);
        for (uint64_t e = 0; e < c.grid_parameter_count(); ++e) ASSERT_EQ(int8_t(b[grid_at + e]), m.grid_code(e)) << e;
      }
      const Model back = expect_round_trip(m, b);
      EXPECT_EQ(back.grid_scales, m.grid_scales);
      if (!record) {
        EXPECT_EQ(memory_breakdown(back).total(), b.size());
      }
      // The same model with every table of one size is written as before.
      Model same = m;
      set_table_log2(same.config, 5);
      same.grid.assign(same.config.grid_parameter_count(), 0.0f);
      same.quantize();
      EXPECT_EQ(rd32(saved(same), kVersionAt), bits == 8 ? 3u : record ? 2u : 1u);
    }
  }
}

TEST(ModelFileErrors, TablesOfDifferentSizes) {
  const Model m = unequal_model(8);
  const Bytes good = saved(m);
  const auto with = [&](const std::function<void(Bytes&)>& change) { return changed(good, change); };
  expect_load_error(with([&](Bytes& b) { wr32(b, kConfigMAt, 5); }), {"M", "version 4", "must be 0"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kTableLog2At + 4, 25); }), {"M=25 of level 1", "out of range"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kTableLog2At + 4, 3); }), {"M=3 of level 1", "out of range"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kTableLog2At + 12, 5); }), {"unused level 3"});
  // A size changed to another valid one no longer matches the grid section.
  expect_load_error(with([&](Bytes& b) { wr32(b, kTableLog2At + 8, 6); }), {"section grid has size"});
  // Every level the same size: such a model is written as version 1 to 3, never 4.
  expect_load_error(with([&](Bytes& b) {
                      for (uint32_t l = 0; l < 3; ++l) wr32(b, kTableLog2At + 4 * l, 5);
                    }),
                    {"version 4", "all have 2^5"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kHeaderSizeAt, 208); }), {"header size 208", "224"});
  // A version 3 file claiming version 4 (or the reverse) does not parse.
  Bytes v3 = saved(small_8bit_model());
  wr32(v3, kVersionAt, 4);
  fix_crc(v3);
  expect_load_error(v3, {"header size 208", "224"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kVersionAt, 3); }), {"header size 224", "208"});
}

// ---- format version 5: indexed levels ------------------------------------------------------------

constexpr size_t kGridIndexEntryAt = 224, kIndexSlotsAt = 240, kIndexBucketsAt = 256;

// unequal_model with level 1 indexed: 50 slots, 13 random displacements (the format does not
// require them to be a perfect hash of anything: any displacement addresses a slot).
Model indexed_model(uint32_t grid_bits, uint64_t seed = 2) {
  Model m = unequal_model(grid_bits, seed);
  Rng rng(seed, 1, 0);
  m.config.index_slots[1] = 50;
  m.config.index_buckets[1] = 13;
  m.grid.resize(m.config.grid_parameter_count());
  for (float& v : m.grid) v = rng.next_float() - 0.5f;
  m.grid_index.resize(13);
  for (uint16_t& d : m.grid_index) d = uint16_t(rng.next_u32());
  m.quantize();
  return m;
}

TEST(ModelFile, IndexedLevelIsAVersion5File) {
  for (const uint32_t bits : {16u, 8u}) {
    SCOPED_TRACE(testing::Message() << bits << "-bit grid");
    const Model m = indexed_model(bits);
    ASSERT_TRUE(m.validate()) << m.validate().message();
    const Bytes b = saved(m);
    const Config& c = m.config;
    EXPECT_EQ(rd32(b, kVersionAt), 5u);
    EXPECT_EQ(rd32(b, kHeaderSizeAt), 272u);
    EXPECT_EQ(rd32(b, kConfigMAt), 0u);
    const uint32_t slots[4] = {0, 50, 0, 0}, buckets[4] = {0, 13, 0, 0};
    for (uint32_t l = 0; l < 4; ++l) {
      EXPECT_EQ(rd32(b, kIndexSlotsAt + 4 * l), slots[l]) << "level " << l;
      EXPECT_EQ(rd32(b, kIndexBucketsAt + 4 * l), buckets[l]) << "level " << l;
    }
    // Level 1's table has its 50 slots between level 0's 2^5 entries and level 2's 2^4.
    EXPECT_EQ(c.grid_parameter_count(), (32u + 50u + 16u) * c.features);
    EXPECT_EQ(section_size(b, kGrid), c.grid_parameter_count() * bits / 8);
    // The grid index section: last, after the grid scales, 16-byte aligned, 13 little-endian u16.
    const uint64_t index_at = rd64(b, kGridIndexEntryAt);
    EXPECT_EQ(rd64(b, kGridIndexEntryAt + 8), 26u);
    EXPECT_EQ(index_at % 16, 0u);
    EXPECT_EQ(index_at, (section_offset(b, 5) + section_size(b, 5) + 15) / 16 * 16);
    for (size_t i = 0; i < 13; ++i) EXPECT_EQ(uint16_t(b[index_at + 2 * i] | b[index_at + 2 * i + 1] << 8), m.grid_index[i]);
    EXPECT_EQ(b.size(), (index_at + 26 + 15) / 16 * 16 + 4);
    expect_round_trip(m, b);
    EXPECT_EQ(memory_breakdown(m).total(), b.size());
    // Without the index the same model is a version 4 file again.
    Model hashed = m;
    hashed.config.index_slots[1] = hashed.config.index_buckets[1] = 0;
    hashed.grid_index.clear();
    hashed.grid.assign(hashed.config.grid_parameter_count(), 0.0f);
    hashed.quantize();
    EXPECT_EQ(rd32(saved(hashed), kVersionAt), 4u);
  }
}

TEST(ModelFileErrors, IndexedLevels) {
  const Model m = indexed_model(8);
  const Bytes good = saved(m);
  const auto with = [&](const std::function<void(Bytes&)>& change) { return changed(good, change); };
  expect_load_error(with([&](Bytes& b) { wr32(b, kIndexBucketsAt + 4, 0); }), {"level 1", "50 slots and 0 buckets"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kIndexBucketsAt + 4, 51); }), {"level 1", "one bucket per slot"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kIndexSlotsAt + 4, (1u << 24) + 1); }), {"level 1", "at most 2^24"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kIndexSlotsAt + 12, 1); wr32(b, kIndexBucketsAt + 12, 1); }),
                    {"unused level 3", "index"});
  // Sizes changed to other valid ones no longer match the sections.
  expect_load_error(with([&](Bytes& b) { wr32(b, kIndexSlotsAt + 4, 49); }), {"section grid has size"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kIndexBucketsAt + 4, 12); }), {"section grid index has size"});
  expect_load_error(with([&](Bytes& b) { wr64(b, kGridIndexEntryAt, 8); }), {"section grid index", "outside"});
  // No indexed level: such a model is written as version 1 to 4, never 5.
  expect_load_error(with([&](Bytes& b) {
                      wr32(b, kIndexSlotsAt + 4, 0);
                      wr32(b, kIndexBucketsAt + 4, 0);
                    }),
                    {"version 5", "without an indexed grid level"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kVersionAt, 4); }), {"header size 272", "224"});
  // A model whose index does not match its config is not saved.
  Model short_index = m;
  short_index.grid_index.pop_back();
  Bytes out;
  const Status s = save_model_to_memory(short_index, out);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("grid index"), std::string::npos) << s.message();
}

// ---- format version 6: surface channels ------------------------------------------------------------

constexpr size_t kSurfaceChannelsAt = 272, kEmissionScaleAt = 276, kV6ReservedAt = 280;

// `m` with surface channels and emission scale `scale`: the MLP LSNIF_OUT_SURFACE_COUNT outputs
// taller, its parameters drawn again (any values are a valid file).
Model with_surface_channels(Model m, float scale, uint64_t seed = 6) {
  Rng rng(seed, 2, 0);
  m.config.surface_channels = 1;
  m.config.emission_scale = scale;
  m.mlp.resize(m.config.mlp_parameter_count());
  for (float& v : m.mlp) v = rng.next_float() - 0.5f;
  m.quantize();
  return m;
}

TEST(ModelFile, SurfaceChannelsAreAVersion6File) {
  // On a plain model (else version 1), an 8-bit grid (else 3), per-level tables (else 4) and an
  // indexed level (else 5): version 6 holds every layout of the versions before it.
  const std::pair<Model, uint32_t> cases[] = {
      {small_model(5), 1u}, {unequal_model(8), 4u}, {indexed_model(16), 5u}, {indexed_model(8), 5u}};
  for (const auto& [plain, plain_version] : cases) {
    SCOPED_TRACE(plain.config.describe());
    EXPECT_EQ(rd32(saved(plain), kVersionAt), plain_version);
    const Model m = with_surface_channels(plain, 12.5f);
    ASSERT_TRUE(m.validate()) << m.validate().message();
    EXPECT_EQ(m.config.output_dim(), LSNIF_OUT_FIXED + m.config.material_count + LSNIF_OUT_SURFACE_COUNT);
    const Bytes b = saved(m);
    EXPECT_EQ(rd32(b, kVersionAt), 6u);
    EXPECT_EQ(rd32(b, kHeaderSizeAt), 288u);
    EXPECT_EQ(rd32(b, kSurfaceChannelsAt), 1u);
    float scale;
    const uint32_t scale_bits = rd32(b, kEmissionScaleAt);
    std::memcpy(&scale, &scale_bits, 4);
    EXPECT_EQ(scale, 12.5f);
    EXPECT_EQ(rd32(b, kV6ReservedAt), 0u);
    EXPECT_EQ(rd32(b, kV6ReservedAt + 4), 0u);
    EXPECT_EQ(section_offset(b, kMaterials), 288u);  // the sections right after the (aligned) header
    EXPECT_EQ(section_size(b, kMlp), 2 * m.config.mlp_parameter_count());
    EXPECT_EQ(memory_breakdown(m).total(), b.size());
    const Model back = expect_round_trip(m, b);
    EXPECT_EQ(back.config.surface_channels, 1u);
    EXPECT_EQ(back.config.emission_scale, 12.5f);
  }
  // The emission scale's ends: 0 (no emission learned) and LSNIF_MAX_EMISSION_SCALE.
  for (const float scale : {0.0f, float(LSNIF_MAX_EMISSION_SCALE)}) {
    const Model m = with_surface_channels(small_model(5), scale);
    expect_round_trip(m, saved(m));
  }
}

TEST(ModelFileErrors, SurfaceChannels) {
  const Model m = with_surface_channels(indexed_model(8), 3.0f);
  const Bytes good = saved(m);
  const auto with = [&](const std::function<void(Bytes&)>& change) { return changed(good, change); };
  // Version 6 is the format of a model with surface channels: 0 is refused, as is any other value.
  expect_load_error(with([&](Bytes& b) { wr32(b, kSurfaceChannelsAt, 0); }), {"surface channels 0", "version 6"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kSurfaceChannelsAt, 2); }), {"surface channels 2"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kV6ReservedAt, 1); }), {"reserved header word", "offset 280"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kV6ReservedAt + 4, 0x80000000u); }),
                    {"reserved header word", "offset 284"});
  for (const float bad : {-1.0f, 65536.0f, std::numeric_limits<float>::quiet_NaN(),
                          std::numeric_limits<float>::infinity()})
    expect_load_error(with([&](Bytes& b) { wrf32(b, kEmissionScaleAt, bad); }), {"emission scale"});
  // The header size belongs to the version.
  expect_load_error(with([&](Bytes& b) { wr32(b, kVersionAt, 5); }), {"header size 288", "272"});
  // A model with surface channels saved without them (or the reverse) is refused by the writer.
  Model no_scale = small_model(5);
  no_scale.config.emission_scale = 2.0f;
  Bytes out;
  const Status s = save_model_to_memory(no_scale, out);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("emission scale"), std::string::npos) << s.message();
}

TEST(ModelFileErrors, TrainingSection) {
  Model m = small_model();
  m.training = R"({"settings":{}})";
  const Bytes good = saved(m);
  const size_t size_at = kSectionsAt + 16 * 4 + 8, at = size_t(section_offset(good, 4));
  Bytes b = good;
  wr64(b, size_at, 0);
  fix_crc(b);
  expect_load_error(b, {"section training", "size 0"});
  b = good;
  wr64(b, size_at, 65537);
  fix_crc(b);
  expect_load_error(b, {"section training", "65537"});
  b = good;
  wr64(b, size_at, section_size(good, 4) + 16);
  fix_crc(b);
  expect_load_error(b, {"section training", "outside the file"});
  b = good;
  b[at + 1] = '\n';
  fix_crc(b);
  expect_load_error(b, {"training section", "control characters"});
  b = good;
  b[at + 1] = 0xff;
  fix_crc(b);
  expect_load_error(b, {"training section", "UTF-8", "\\xff"});
  b = good;
  wr32(b, kHeaderSizeAt, 168);  // a version 2 file with the version 1 header size
  fix_crc(b);
  expect_load_error(b, {"header size 168", "version 2", "184"});
  b = good;
  b[185] = 1;  // header padding
  fix_crc(b);
  expect_load_error(b, {"padding", "185"});
  // The writer refuses what the reader would.
  Bytes out;
  m.training = std::string(65537, 'x');
  Status s = save_model_to_memory(m, out);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("training record"), std::string::npos) << s.message();
  m.training = "line\nbreak";
  s = save_model_to_memory(m, out);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("control characters"), std::string::npos) << s.message();
}

// A record edited in the file (same length, the checksum recomputed, as a person or a tool can) to
// settings its header contradicts or out of range is a load error naming the setting, both values
// and the file; the header's own values, or settings the header does not hold, load.
TEST(ModelFileErrors, TrainingRecordAgainstTheHeader) {
  TempDir dir;
  Model m = small_model();
  m.quantize();
  const uint32_t V = m.config.voxel_resolution;
  ASSERT_LT(V, 100u);  // the edits below keep the record's length
  m.training = format(R"({"settings":{"voxels":%3u,"width":%3u,"seed":555}})", V, m.config.hidden_width);
  const Bytes good = saved(m);
  expect_round_trip(m, good);
  const size_t at = size_t(section_offset(good, 4));
  const auto edited = [&](const char* from, const char* to) {
    Bytes b = good;
    const size_t k = m.training.find(from);
    EXPECT_NE(k, std::string::npos) << from;
    EXPECT_EQ(std::strlen(from), std::strlen(to));
    std::memcpy(b.data() + at + k, to, std::strlen(to));
    fix_crc(b);
    return b;
  };
  const std::string voxels = format("\"voxels\":%3u", V);
  const std::string other = format("\"voxels\":%3u", V + 1);
  const std::string v_text = std::to_string(V), other_text = std::to_string(V + 1);
  expect_load_error(edited(voxels.c_str(), other.c_str()),
                    {"training record", "voxels", other_text.c_str(), "voxel resolution", v_text.c_str()});
  expect_load_error(edited(voxels.c_str(), "\"voxels\": -5"), {"training record", "voxels", "-5", "unsigned"});
  expect_load_error(edited(voxels.c_str(), "\"voxels\":999"), {"training record", "voxels", "999", "[1, 256]"});
  expect_load_error(edited("\"seed\":555", "\"seed\":\"x\""), {"training record", "seed", "unsigned"});
  expect_load_error(edited("{\"settings\"", "[\"settings\""), {"training record", "not valid JSON"});
  // A training setting, which the header does not hold: the edit loads (as the edited record).
  Model reseeded = m;
  reseeded.training.replace(reseeded.training.find("555"), 3, "777");
  expect_round_trip(reseeded, edited("\"seed\":555", "\"seed\":777"));

  // Through a file: the message names it.
  const std::string path = dir.file("edited.lsnif");
  const Bytes b = edited(voxels.c_str(), other.c_str());
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
  Model loaded;
  const Status s = load_model(path, loaded);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("voxels is " + other_text), std::string::npos) << s.message();
}

TEST(ModelFileErrors, WrongHeaderSize) {
  Bytes b = saved(small_model());
  wr32(b, kHeaderSizeAt, 176);
  fix_crc(b);
  expect_load_error(b, {"header size", "176", "168"});
}

TEST(ModelFileErrors, ChecksumMismatch) {
  const Bytes good = saved(small_model());
  Bytes b = good;
  b[b.size() - 2] ^= 1;  // the stored CRC itself
  expect_load_error(b, {"checksum mismatch"});
  Rng rng(9, 0, 0);
  for (int i = 0; i < 50; ++i) {  // any flipped bit in the header (past the checks before the CRC) or data
    b = good;
    const size_t at = 24 + rng.next_u32() % (b.size() - 28);
    b[at] ^= uint8_t(1u << (rng.next_u32() % 8u));
    expect_load_error(b, {"checksum mismatch"});
  }
}

// Changes one field, recomputes the CRC and expects the structural checks to catch it.
struct FieldCase {
  const char* name;
  std::function<void(Bytes&)> change;
  std::vector<const char*> keywords;
};

TEST(ModelFileErrors, StructuralChecksBehindTheChecksum) {
  const Model model = small_model();
  const Bytes good = saved(model);
  const uint32_t V = model.config.voxel_resolution;
  const std::vector<FieldCase> cases = {
      {"V=0", [](Bytes& b) { wr32(b, kVAt, 0); }, {"voxel resolution"}},
      {"V too large", [](Bytes& b) { wr32(b, kVAt, 100000); }, {"voxel resolution"}},
      {"grid res not multiple", [V](Bytes& b) { wr32(b, kGridResAt, V * 2 + 1); }, {"multiple"}},
      {"unused level non-zero", [](Bytes& b) { wr32(b, kGridResAt + 12, 64); }, {"unused level"}},
      {"M huge", [](Bytes& b) { wr32(b, 52, 31); }, {"hash table size"}},
      {"material count 0", [](Bytes& b) { wr32(b, kMatCountAt, 0); }, {"material count"}},
      {"material count 3", [](Bytes& b) { wr32(b, kMatCountAt, 3); }, {"section materials", "size"}},
      {"hit param", [](Bytes& b) { wr32(b, kHitParamAt, 7); }, {"hit"}},
      {"leaky NaN", [](Bytes& b) { wrf32(b, kLeakyAt, std::nanf("")); }, {"leaky"}},
      {"AABB NaN", [](Bytes& b) { wrf32(b, kAabbAt, std::nanf("")); }, {"AABB"}},
      {"AABB inf", [](Bytes& b) { wrf32(b, kAabbAt + 16, std::numeric_limits<float>::infinity()); }, {"AABB"}},
      {"AABB empty", [](Bytes& b) { wrf32(b, kAabbAt, 100.0f); }, {"AABB"}},
      {"grid size", [](Bytes& b) { wr64(b, kSectionsAt + 16 * kGrid + 8, section_size(b, kGrid) - 2); },
       {"section grid", "size"}},
      {"mlp size huge", [](Bytes& b) { wr64(b, kSectionsAt + 16 * kMlp + 8, ~uint64_t(0) - 7); },
       {"section mlp", "outside"}},
      {"voxel offset huge", [](Bytes& b) { wr64(b, kSectionsAt + 16 * kVoxels, ~uint64_t(0)); },
       {"section voxels", "outside"}},
      {"grid offset shifted", [](Bytes& b) { wr64(b, kSectionsAt + 16 * kGrid, section_offset(b, kGrid) + 16); },
       {"section grid", "offset"}},
      {"materials inside header", [](Bytes& b) { wr64(b, kSectionsAt, 100); }, {"section materials", "outside"}},
      {"NaN weight", [](Bytes& b) { b[section_offset(b, kMlp) + 14] = 0x00; b[section_offset(b, kMlp) + 15] = 0x7e; },
       {"mlp", "NaN", "value 7 "}},
      {"Inf in grid", [](Bytes& b) { b[section_offset(b, kGrid) + 2 * 3] = 0x00; b[section_offset(b, kGrid) + 2 * 3 + 1] = 0xfc; },
       {"grid", "infinite", "value 3 "}},
      {"name without NUL", [](Bytes& b) { std::memset(&b[section_offset(b, kMaterials)], 'x', 64); },
       {"material 0", "NUL"}},
      {"bytes after NUL", [](Bytes& b) { const size_t at = section_offset(b, kMaterials) + 76; b[at] = 0; b[at + 5] = 'q'; },
       {"material 1", "NUL"}},
      {"color NaN", [](Bytes& b) { wrf32(b, section_offset(b, kMaterials) + 64, std::nanf("")); }, {"material 0", "color"}},
      // Finite but beyond float ray math (1e38: its squared distances overflow).
      {"AABB 1e38", [](Bytes& b) { wrf32(b, kAabbAt, -1e38f); wrf32(b, kAabbAt + 12, 1e38f); }, {"AABB", "exceeds +-1e+18"}},
      {"name not UTF-8", [](Bytes& b) { b[section_offset(b, kMaterials)] = 0xff; }, {"material 0 name", "\\xff", "UTF-8"}},
      {"name with a control character", [](Bytes& b) { b[section_offset(b, kMaterials)] = 0x1b; },
       {"material 0 name", "\\x1b", "control"}},
      {"header padding", [](Bytes& b) { b[170] = 1; }, {"padding", "170"}},
  };
  for (const FieldCase& fc : cases) {
    SCOPED_TRACE(fc.name);
    Bytes b = good;
    fc.change(b);
    ASSERT_NE(b, good);
    fix_crc(b);
    Model m = model;
    Status s = load_model_from_memory(b.data(), b.size(), m);
    ASSERT_FALSE(s);
    for (const char* k : fc.keywords) EXPECT_NE(s.message().find(k), std::string::npos) << s.message();
  }
}

TEST(ModelFileErrors, NonZeroPaddingInEveryGap) {
  // Gaps: header end .. materials, between sections, mlp end .. CRC. Test the first and last byte
  // of each; the small model's 2 materials (152 bytes) guarantee a gap before the voxels.
  const Bytes good = saved(small_model());
  std::vector<uint64_t> positions;
  uint64_t end = 168;
  for (int s = 0; s <= 4; ++s) {
    const uint64_t next = s < 4 ? section_offset(good, s) : good.size() - 4;
    if (next > end) {
      positions.push_back(end);
      positions.push_back(next - 1);
    }
    if (s < 4) end = section_offset(good, s) + section_size(good, s);
  }
  ASSERT_GE(positions.size(), 4u);
  for (uint64_t at : positions) {
    ASSERT_EQ(good[at], 0u);
    Bytes b = good;
    b[at] = 0x80;
    fix_crc(b);
    expect_load_error(b, {"padding", std::to_string(at).c_str()});
  }
}

TEST(ModelFileErrors, DeclaredSizeMatchingAResizedFile) {
  // Cut the file inside the mlp section and make the header and CRC agree with the cut: the
  // section table must catch it.
  const Bytes good = saved(small_model());
  Bytes b(good.begin(), good.begin() + long(section_offset(good, kMlp) + 6));
  b.resize(b.size() + 4);
  wr64(b, kFileSizeAt, b.size());
  fix_crc(b);
  expect_load_error(b, {"section mlp", "outside"});
  // Extra zero bytes before the CRC: every section is where the config puts it, but the file is
  // longer than the config implies.
  Bytes longer(good.begin(), good.end() - 4);
  longer.resize(longer.size() + 16 + 4, 0);
  wr64(longer, kFileSizeAt, longer.size());
  fix_crc(longer);
  expect_load_error(longer, {"file size", std::to_string(longer.size()).c_str(), std::to_string(good.size()).c_str()});
  // A declared size below the header itself.
  Bytes tiny(good.begin(), good.begin() + 100);
  wr64(tiny, kFileSizeAt, tiny.size());
  expect_load_error(tiny, {"truncated"});
}

TEST(ModelFileErrors, VoxelBitsBeyondTheGrid) {
  Model m = small_model();
  m.config.voxel_resolution = 5;
  for (uint32_t l = 0; l < m.config.grid_levels; ++l) m.config.grid_resolution[l] = 5u * (l + 1);
  m.voxels.resolution = 5;
  m.voxels.bits.assign(4, 0xffffffffu);
  m.voxels.bits[3] = 0x1fffffffu;  // voxels 96..124
  Bytes b = saved(m);
  Model back;
  ASSERT_TRUE(load_model_from_memory(b.data(), b.size(), back));
  EXPECT_EQ(back.voxels.bits, m.voxels.bits);
  b[section_offset(b, kVoxels) + 15] |= 0x20;  // bit 125
  fix_crc(b);
  expect_load_error(b, {"beyond"});
}

TEST(ModelFileErrors, Paths) {
  Model m;
  Status s = load_model("/nonexistent/dir/object.lsnif", m);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("no such file"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("/nonexistent/dir/object.lsnif"), std::string::npos);

  TempDir dir;
  const std::string folder = dir.file("folder.lsnif");
  fs::create_directories(folder);
  s = load_model(folder, m);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("directory"), std::string::npos) << s.message();

  const Model good = small_model();
  s = save_model(good, folder);  // cannot replace a directory
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find(folder), std::string::npos) << s.message();
  EXPECT_TRUE(fs::is_directory(folder));
  s = save_model(good, "/nonexistent/dir/object.lsnif");
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("the folder '/nonexistent/dir' does not exist"), std::string::npos) << s.message();

  // A (sparse) file larger than any valid model is refused by its header before it is read: one of
  // zeros has no model's magic; one with a model's header declaring its 4 GiB declares more than any
  // valid model; one whose header declares another size is truncated or has trailing data.
  const std::string huge = dir.file("huge.lsnif");
  std::ofstream(huge).close();
  std::error_code ec;
  fs::resize_file(huge, uint64_t(1) << 32, ec);
  if (!ec) {
    s = load_model(huge, m);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("bad magic"), std::string::npos) << s.message();
    std::vector<uint8_t> header;
    ASSERT_TRUE(save_model_to_memory(good, header));
    header.resize(256);
    for (const auto& [declared, words] :
         {std::pair<uint64_t, std::string>{uint64_t(1) << 32, "its header declares 4294967296 bytes, more than any valid "
                                                              ".lsnif file"},
          {4096, "trailing data: the header says the file has 4096 bytes"}}) {
      for (int i = 0; i < 8; ++i) header[size_t(16 + i)] = uint8_t(declared >> (8 * i));
      std::ofstream(huge, std::ios::binary).write(reinterpret_cast<const char*>(header.data()), 256);
      fs::resize_file(huge, uint64_t(1) << 32, ec);
      ASSERT_FALSE(ec) << ec.message();
      s = load_model(huge, m);
      ASSERT_FALSE(s);
      EXPECT_NE(s.message().find(words), std::string::npos) << s.message();
    }
  }
}

TEST(ModelFileErrors, SaveRefusesWhatTheLoaderWouldReject) {
  const Model good = small_model();
  Bytes b;
  auto expect_save_error = [&b](const Model& m, const char* keyword) {
    Status s = save_model_to_memory(m, b);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find(keyword), std::string::npos) << s.message();
  };
  Model m = good;
  m.grid.pop_back();
  expect_save_error(m, "hash grid");
  m = good;
  m.materials[0].name = std::string(64, 'n');
  expect_save_error(m, "material 0 name");
  m = good;
  m.materials[1].name = std::string("a\0b", 3);
  expect_save_error(m, "NUL");
  m = good;
  m.materials[0].base_color.y = std::numeric_limits<float>::infinity();
  expect_save_error(m, "color");
  m = good;
  m.mlp[4] = 1e6f;  // overflows fp16
  expect_save_error(m, "fp16");
  m = good;
  m.grid[2] = std::nanf("");
  expect_save_error(m, "grid value 2");
  m = good;
  m.voxels.bounds = Aabb();
  expect_save_error(m, "AABB");
  m = good;
  m.materials[0].name = "bad\xc3";  // a truncated UTF-8 sequence
  expect_save_error(m, "not valid UTF-8");
  m = good;
  m.voxels.bounds.hi.x = 1e30f;
  expect_save_error(m, "AABB");
  m = good;
  m.materials[0].name = std::string(63, 'n');
  EXPECT_TRUE(save_model_to_memory(m, b));
  m.materials[1].name = "caf\xc3\xa9 \xe2\x9c\x93";  // UTF-8 text is fine
  EXPECT_TRUE(save_model_to_memory(m, b));
  m.mlp[4] = 65504.0f;
  EXPECT_TRUE(save_model_to_memory(m, b));
}


// ---- format version 7: uv cells ----------------------------------------------------------------------

constexpr size_t kUvMaterialsAt = 288, kUvCellsAt = 296, kUvCellVoxelsAt = 300, kUvCellMapsAt = 304,
                 kV7ReservedAt = 308, kUvCellsEntryAt = 312, kV7Reserved2At = 328;

// `m` with material 0 reporting texture coordinates: in each occupied voxel, cell 0 has a map and
// every third voxel's cell 7 two (random values, any of which is a valid file).
Model with_uv_cells(Model m, uint64_t seed = 7) {
  Rng rng(seed, 3, 0);
  Config& c = m.config;
  c.uv_materials = 1;
  c.uv_cells = 2;
  c.uv_cell_voxels = m.voxels.count_occupied();
  std::vector<uint32_t> records, maps;
  for (uint32_t v = 0; v < c.uv_cell_voxels; ++v) {
    const bool two = v % 3 == 0;
    records.insert(records.end(), {uint32_t(maps.size() / kUvMapWords), two ? 0x81u : 1u, 0u, two ? 0x80u : 0u, 0u});
    for (int k = 0; k < (two ? 3 : 1); ++k) {
      UvMap map;
      map.uv0 = {rng.next_float() * 8 - 4, rng.next_float() * 8 - 4};
      map.du = {rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f};
      map.dv = {rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f};
      map.normal = {rng.next_float() - 0.5f, rng.next_float() - 0.5f, 1.0f};
      map.offset = rng.next_float() - 0.5f;
      uint32_t w[kUvMapWords];
      pack_uv_map(map, w);
      maps.insert(maps.end(), w, w + kUvMapWords);
    }
  }
  c.uv_cell_maps = uint32_t(maps.size() / kUvMapWords);
  m.uv_cells = records;
  m.uv_cells.insert(m.uv_cells.end(), maps.begin(), maps.end());
  m.quantize();
  return m;
}

TEST(ModelFile, UvCellsAreAVersion7File) {
  for (const Model& plain : {small_model(5), with_surface_channels(indexed_model(8), 2.0f)}) {
    SCOPED_TRACE(plain.config.describe());
    const Model m = with_uv_cells(plain);
    ASSERT_TRUE(m.validate()) << m.validate().message();
    ASSERT_GT(m.config.uv_cell_voxels, 0u);
    const Bytes b = saved(m);
    EXPECT_EQ(rd32(b, kVersionAt), 7u);
    EXPECT_EQ(rd32(b, kHeaderSizeAt), 336u);
    EXPECT_EQ(rd64(b, kUvMaterialsAt), 1u);
    EXPECT_EQ(rd32(b, kUvCellsAt), 2u);
    EXPECT_EQ(rd32(b, kUvCellVoxelsAt), m.config.uv_cell_voxels);
    EXPECT_EQ(rd32(b, kUvCellMapsAt), m.config.uv_cell_maps);
    EXPECT_EQ(rd64(b, kUvCellsEntryAt + 8), 4 * uv_cell_words(m.config));
    const uint64_t end = rd64(b, kUvCellsEntryAt) + rd64(b, kUvCellsEntryAt + 8);
    EXPECT_EQ((end + 15) / 16 * 16, b.size() - 4) << "the uv cells section is the last before the checksum";
    EXPECT_EQ(section_offset(b, kMaterials), 336u);
    EXPECT_EQ(memory_breakdown(m).uv_cell_bytes, 4 * uv_cell_words(m.config));
    EXPECT_EQ(memory_breakdown(m).total(), b.size());
    const Model back = expect_round_trip(m, b);
    EXPECT_EQ(back.config.uv_cell_maps, m.config.uv_cell_maps);
  }
}

TEST(ModelFileErrors, UvCells) {
  const Model m = with_uv_cells(small_model(5));
  const Bytes good = saved(m);
  const auto with = [&](const std::function<void(Bytes&)>& change) { return changed(good, change); };
  const size_t at = size_t(rd64(good, kUvCellsEntryAt)), maps_at = at + 4 * kUvVoxelWords * m.config.uv_cell_voxels;
  expect_load_error(with([&](Bytes& b) { wr32(b, kUvMaterialsAt, 0); }), {"no texture-coordinate material", "version 7"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kUvMaterialsAt, 1u << m.config.material_count); }),
                    {"texture-coordinate materials 0x", "beyond the"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kUvCellsAt, 5); }), {"uv cells per voxel 5"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kV7ReservedAt, 1); }), {"reserved header word", "offset 308"});
  expect_load_error(with([&](Bytes& b) { wr32(b, kV7Reserved2At + 4, 1); }), {"reserved header word", "offset 332"});
  // The voxel records: one per occupied voxel, first maps in order, masks within the voxel's cells.
  expect_load_error(with([&](Bytes& b) { wr32(b, kUvCellVoxelsAt, m.config.uv_cell_voxels - 1); }), {"section uv cells"});
  expect_load_error(with([&](Bytes& b) { wr32(b, at + 4 * kUvVoxelWords, 7); }), {"voxel record 1's first map is 7"});
  expect_load_error(with([&](Bytes& b) { wr32(b, at + 4, 1u << 8); }), {"voxel record 0's masks"});
  expect_load_error(with([&](Bytes& b) { wr32(b, at + 12, 2u); }), {"voxel record 0's masks", "second maps"});
  // The maps: finite coordinates within reach, finite fp16 gradients.
  expect_load_error(with([&](Bytes& b) { wrf32(b, maps_at, std::numeric_limits<float>::quiet_NaN()); }),
                    {"map 0's texture coordinate"});
  expect_load_error(with([&](Bytes& b) { wrf32(b, maps_at + 4, 4096.0f); }), {"map 0's texture coordinate 4096"});
  expect_load_error(with([&](Bytes& b) { wr32(b, maps_at + 8, 0x7c00u); }), {"map 0 has a gradient"});
  // The writer refuses what the loader would.
  Model bad = m;
  bad.uv_cells[1] = 1u << 8;
  Bytes out;
  const Status s = save_model_to_memory(bad, out);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("voxel record 0's masks"), std::string::npos) << s.message();
}

// The packed map is what every reader sees: exact coordinates, fp16 gradients, a unit normal within
// snorm8's steps and the offset within one step.
TEST(UvCells, PackedMapsKeepTheirValuesToTheirPrecision) {
  for (uint32_t i = 0; i < 200; ++i) {
    Rng rng(9, 4, i);
    UvMap m;
    m.uv0 = {rng.next_float() * 100 - 50, rng.next_float() * 2};
    m.du = {rng.next_float() - 0.5f, rng.next_float() * 4, -rng.next_float()};
    m.dv = {rng.next_float(), rng.next_float() - 0.5f, rng.next_float() * 0.01f};
    m.normal = glm::normalize(glm::vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
    m.offset = (rng.next_float() - 0.5f) * 1.7f;
    uint32_t w[kUvMapWords];
    pack_uv_map(m, w);
    const UvMap back = unpack_uv_map(w);
    EXPECT_EQ(back.uv0, m.uv0);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(back.du[k], round_to_half(m.du[k]));
      EXPECT_EQ(back.dv[k], round_to_half(m.dv[k]));
    }
    EXPECT_NEAR(glm::length(back.normal), 1.0f, 1e-6f);
    EXPECT_GT(glm::dot(back.normal, m.normal), std::cos(0.02f)) << i;  // within ~1 degree
    EXPECT_NEAR(back.offset, m.offset, 0.8660254f / 127.0f * 0.51f);
  }
}

// A hand-made model: V = 2 over [0, 2]^3, 2 cells per voxel edge (cells of 0.5), voxel (1, 0, 0)
// occupied, one map in its cell (0, 1, 1) (the grid's cell (2, 1, 1), centre (1.25, 0.75, 0.75)):
// the plane z = centre, uv = (0.3, 0.7) + (0.1 x, 0.2 y) in cell units from the centre.
TEST(UvCells, ALookupFindsTheCellsPieceFacingTheNormalWhereTheRayMeetsIt) {
  Model m;
  Config& c = m.config;
  c.voxel_resolution = 2;
  c.uv_materials = 1;
  c.uv_cells = 2;
  c.uv_cell_voxels = 1;
  c.uv_cell_maps = 1;
  m.voxels.resolution = 2;
  m.voxels.bounds = {glm::vec3(0.0f), glm::vec3(2.0f)};
  m.voxels.bits = {1u << 1};
  UvMap map;
  map.uv0 = {0.3f, 0.7f};
  map.du = {0.1f, 0.0f, 0.0f};
  map.dv = {0.0f, 0.2f, 0.0f};
  map.normal = {0.0f, 0.0f, 1.0f};
  m.uv_cells = {0u, 1u << (0 + 2 * (1 + 2 * 1)), 0u, 0u, 0u};
  m.uv_cells.resize(kUvVoxelWords + kUvMapWords);
  pack_uv_map(map, m.uv_cells.data() + kUvVoxelWords);
  const UvCells cells(m);
  const glm::vec3 centre(1.25f, 0.75f, 0.75f), up(0.0f, 0.0f, 1.0f), down(0.0f, 0.0f, -1.0f);
  glm::vec2 uv;
  // On the plane: the affine coordinate (0.1 cell units right, 0.2 down).
  ASSERT_TRUE(cells.lookup(centre + glm::vec3(0.05f, -0.1f, 0.0f), up, down, uv));
  EXPECT_NEAR(uv.x, 0.3f + round_to_half(0.1f) * 0.1f, 1e-6f);  // the gradients are fp16
  EXPECT_NEAR(uv.y, 0.7f - round_to_half(0.2f) * 0.2f, 1e-6f);
  // A slanted ray's point past the plane reads where the ray meets it.
  const glm::vec3 slant = glm::normalize(glm::vec3(1.0f, 0.0f, -1.0f));
  ASSERT_TRUE(cells.lookup(centre + 0.1f * slant, up, slant, uv));
  EXPECT_NEAR(uv.x, 0.3f, 1e-6f);
  EXPECT_NEAR(uv.y, 0.7f, 1e-6f);
  // From a neighbouring cell (the point's own holds nothing); not from two cells away.
  ASSERT_TRUE(cells.lookup(centre + glm::vec3(0.0f, 0.0f, 0.4f), up, down, uv));
  EXPECT_NEAR(uv.x, 0.3f, 1e-6f);
  EXPECT_FALSE(cells.lookup(centre + glm::vec3(-1.1f, 0.0f, 0.0f), up, down, uv));
  // A normal facing away from the piece finds nothing; so does a model without uv cells.
  EXPECT_FALSE(cells.lookup(centre, down, up, uv));
  Model plain = m;
  plain.config.uv_materials = 0;
  EXPECT_FALSE(UvCells(plain).lookup(centre, up, down, uv));
}

}  // namespace
}  // namespace lsnif
