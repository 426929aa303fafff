// model_format.cpp -- reading and writing .lsnif files at the byte level (model_format.h). The byte layout is specified in
// docs/model-format.md; in short (all little-endian, packed byte by byte, no struct copies):
//
//   0    magic "LSNIF\0\r\n" (8 bytes)      8   u32 format version (1 to 7)
//   12   u32 header size (168, 184, 208, 224, 272, 288, 336) 16 u64 total file size
//   24   Config (13 x u32, leaky slope f32) 80  AABB lo.xyz, hi.xyz (6 x f32)
//   104  section table: {u64 offset, u64 size} for materials, voxels, grid, mlp (and, in version 2,
//        training at 168; in versions 3 and 4 training, possibly empty, at 168 and grid scales at 184)
//   versions 3 and 4: 200 u32 grid bits (8; version 4: 8 or 16), 204 u32 zero
//   versions 4 and 5: 208 u32 table_log2 of each of the 4 levels (0 for unused levels; the Config's
//        M field at 52 is 0): the levels' tables differ in size. Equal sizes are written as before.
//   version 5 only: 224 {u64 offset, u64 size} of the grid index section, 240 u32 index slots of
//        each of the 4 levels, 256 u32 index buckets of each (0 for hashed and unused levels): at
//        least one level is indexed (Config::index_slots); the grid index section after the grid
//        scales holds the indexed levels' displacements (u16 each, level order).
//   version 6: the layout of version 5 (the grid index section possibly empty, index sizes 0 when no
//        level is indexed) plus 272 u32 surface channels (1), 276 f32 emission scale, 280 two u32
//        zero: the network has surface channels (Config::surface_channels).
//   version 7: the layout of version 6 (surface channels 0 or 1, the emission scale 0 without them)
//        plus 288 u64 texture-coordinate materials (Config::uv_materials, not 0), 296 u32 uv cells
//        per voxel, 300 u32 uv cell voxels, 304 u32 uv cell maps, 308 u32 zero, 312 {u64 offset, u64
//        size} of the uv cells section (after the grid index; uv_cell_layout.h's words), 328 two u32
//        zero: the model has uv cells.
//   then zero padding to a multiple of 16, then the sections in that order, each at a 16-byte
//        aligned offset with zero padding between them, then (16-byte aligned) u32 CRC-32 of all
//        bytes before. Grid values are fp16 (versions 1, 2) or int8 codes in [-127, 127] (version 3,
//        with one f32 scale per level in the grid scales section; version 4: either).
//
// The loader trusts nothing: every size is compared with the file length before it is used, and
// memory is allocated only once the whole layout has been checked against the validated config.
#include "lsnif/format/model_format.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "lsnif/format/crc32.h"
#include "lsnif/format/file_io.h"
#include "lsnif/format/training_record.h"
#include "lsnif/format/uv_cell_layout.h"

namespace lsnif {

namespace {

constexpr uint8_t kMagic[8] = {'L', 'S', 'N', 'I', 'F', 0x00, '\r', '\n'};
constexpr uint32_t kHeaderSizeV1 = 168;
constexpr uint32_t kHeaderSizeV2 = kHeaderSizeV1 + 16;  // + the training section's {offset, size}
constexpr uint32_t kHeaderSizeV3 = kHeaderSizeV2 + 24;  // + grid scales {offset, size}, grid bits, zero
constexpr uint32_t kHeaderSizeV4 = kHeaderSizeV3 + 4 * LSNIF_MAX_LEVELS;  // + table_log2 per level
// + the grid index {offset, size}, index slots and buckets per level
constexpr uint32_t kHeaderSizeV5 = kHeaderSizeV4 + 16 + 8 * LSNIF_MAX_LEVELS;
// + surface channels, emission scale, two reserved words
constexpr uint32_t kHeaderSizeV6 = kHeaderSizeV5 + 16;
// + texture-coordinate materials, uv cells per voxel, voxels and maps, the uv cells {offset, size}
constexpr uint32_t kHeaderSizeV7 = kHeaderSizeV6 + 48;
constexpr uint64_t kNameBytes = kModelMaterialNameBytes;
constexpr uint64_t kMaterialRecordSize = kNameBytes + 3 * 4;  // name + base_color[3]
constexpr uint64_t kAlignment = 16;
constexpr uint64_t kCrcSize = 4;

// Header field offsets.
constexpr size_t kOffVersion = 8, kOffHeaderSize = 12, kOffFileSize = 16, kOffConfig = 24,
                 kOffAabb = 80, kOffSections = 104, kOffGridBits = 200, kOffReserved = 204, kOffTableLog2 = 208,
                 kOffGridIndexEntry = 224, kOffIndexSlots = 240, kOffIndexBuckets = 256,
                 kOffSurfaceChannels = 272, kOffEmissionScale = 276, kOffReservedV6 = 280,
                 kOffUvMaterials = 288, kOffUvCells = 296, kOffUvCellVoxels = 300, kOffUvCellMaps = 304,
                 kOffReservedV7 = 308, kOffUvCellsEntry = 312, kOffReservedV7b = 328;
// The Config's M field (offset 52 of the file): the size of every level's table in versions 1 to 3.
constexpr size_t kConfigTableLog2 = 28;

enum Section { kMaterials = 0, kVoxels, kGrid, kMlp, kTraining, kGridScales, kGridIndex, kUvCells, kSectionCount };
constexpr const char* kSectionName[kSectionCount] = {"materials", "voxels",      "grid",      "mlp",
                                                     "training",  "grid scales", "grid index", "uv cells"};
// Where section s's {offset, size} entry lies in the header.
size_t section_entry(int s) {
  return s == kGridIndex ? kOffGridIndexEntry : s == kUvCells ? kOffUvCellsEntry : kOffSections + 16 * size_t(s);
}

uint64_t align16(uint64_t n) { return (n + kAlignment - 1) & ~(kAlignment - 1); }

uint32_t header_size_of(uint32_t version) {
  return version == 1 ? kHeaderSizeV1
       : version == 2 ? kHeaderSizeV2
       : version == 3 ? kHeaderSizeV3
       : version == 4 ? kHeaderSizeV4
       : version == 5 ? kHeaderSizeV5
       : version == 6 ? kHeaderSizeV6
                      : kHeaderSizeV7;
}

// Where everything lives in the file of a model with this (valid) config and a training record of
// `training_bytes`: version 7 with texture coordinates, else version 6 with surface channels, else version 5 when a level is indexed, else
// version 4 when the levels' tables differ
// in size, else version 3 for 8-bit grid features, else version 1 (no record) or 2.
struct Layout {
  uint32_t version = 1, header_size = kHeaderSizeV1;
  int sections = kTraining;  // kTraining in version 1, kGridScales in 2, kGridIndex in 3 and 4, kUvCells in 5 and
                             // 6, all in 7
  uint64_t offset[kSectionCount] = {};
  uint64_t size[kSectionCount] = {};
  uint64_t crc_offset = 0, file_size = 0;
};

Layout layout_of(const Config& c, uint64_t training_bytes) {
  Layout l;
  if (c.texture_coordinates()) {
    l.version = 7;
    l.sections = kSectionCount;
  } else if (c.surface_channels) {
    l.version = 6;
    l.sections = kUvCells;
  } else if (c.any_indexed()) {
    l.version = 5;
    l.sections = kUvCells;
  } else if (!c.uniform_table_log2()) {
    l.version = 4;
    l.sections = kGridIndex;
  } else if (c.grid_bits == 8) {
    l.version = 3;
    l.sections = kGridIndex;
  } else if (training_bytes) {
    l.version = 2;
    l.sections = kGridScales;
  }
  l.header_size = header_size_of(l.version);
  l.size[kMaterials] = kMaterialRecordSize * c.material_count;
  l.size[kVoxels] = 4u * ((c.voxel_count() + 31u) / 32u);
  l.size[kGrid] = (c.grid_bits / 8u) * c.grid_parameter_count();
  l.size[kMlp] = 2u * c.mlp_parameter_count();
  l.size[kTraining] = training_bytes;
  l.size[kGridScales] = c.grid_bits == 8 ? 4u * c.grid_levels : 0u;
  l.size[kGridIndex] = 2u * c.grid_index_count();
  l.size[kUvCells] = 4u * uv_cell_words(c);
  uint64_t end = l.header_size;
  for (int s = 0; s < l.sections; ++s) {
    l.offset[s] = align16(end);
    end = l.offset[s] + l.size[s];
  }
  l.crc_offset = align16(end);
  l.file_size = l.crc_offset + kCrcSize;
  return l;
}

// The largest file any valid config implies (every limit at its maximum): a cheap bound that keeps
// load_model from reading an arbitrarily large file into memory.
uint64_t max_file_size() {
  Config c;
  c.voxel_resolution = max_u32(SettingId::Voxels);
  c.max_points = max_u32(SettingId::Points);
  c.grid_levels = max_u32(SettingId::Levels);
  set_table_log2(c, max_u32(SettingId::TableLog2));
  c.features = max_u32(SettingId::Features);
  c.hidden_width = max_u32(SettingId::Width);
  c.hidden_layers = max_u32(SettingId::Layers);
  c.material_count = LSNIF_MAX_MATERIALS;
  c.surface_channels = 1;
  c.uv_materials = ~uint64_t(0);
  c.uv_cells = max_u32(SettingId::UvCells);
  c.uv_cell_voxels = uint32_t(c.voxel_count());
  c.uv_cell_maps = LSNIF_MAX_UV_CELL_MAPS;
  const uint64_t largest = layout_of(c, kMaxTrainingRecordBytes).file_size;
  // Indexed levels: tables of at most 2^M entries (as hashed ones), plus a displacement per slot.
  return largest + 2u * c.grid_levels * (uint64_t(1) << max_u32(SettingId::TableLog2)) + kHeaderSizeV7;
}

// ---- little-endian packing ----------------------------------------------------------------------

void put_u16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
void put_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
void put_u64(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
void put_f32(uint8_t* p, float f) {
  uint32_t v;
  std::memcpy(&v, &f, 4);
  put_u32(p, v);
}
uint16_t get_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint32_t get_u32(const uint8_t* p) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
uint64_t get_u64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
float get_f32(const uint8_t* p) {
  uint32_t v = get_u32(p);
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}

unsigned long long ull(uint64_t v) { return static_cast<unsigned long long>(v); }

bool half_is_finite(uint16_t h) { return (h & 0x7c00u) != 0x7c00u; }
const char* half_non_finite_kind(uint16_t h) { return (h & 0x3ffu) ? "NaN" : "infinite"; }

// Finite and non-empty on every axis.
// Finite, non-empty, and within +-kMaxModelCoordinate (beyond, the squared distances of float ray
// math overflow).
bool aabb_usable(const float lo[3], const float hi[3]) {
  for (int a = 0; a < 3; ++a)
    if (!(std::abs(lo[a]) <= kMaxModelCoordinate) || !(std::abs(hi[a]) <= kMaxModelCoordinate) || !(lo[a] < hi[a]))
      return false;
  return true;
}

// Config fields in file order (docs/model-format.md, offsets 24..79) of a file of `version`; M is 0
// in versions 4 to 7 (they store the tables' sizes per level, also when all levels' are equal, as a
// version 6 file of a model with surface channels may have).
void write_config(uint8_t* p, const Config& c, uint32_t version) {
  const uint32_t M = version <= 3 ? c.table_log2[0] : 0;
  const uint32_t fields[13] = {c.voxel_resolution, c.max_points,        c.grid_levels,
                               c.grid_resolution[0], c.grid_resolution[1], c.grid_resolution[2],
                               c.grid_resolution[3], M,                   c.features,
                               c.hidden_width,      c.hidden_layers,     c.material_count,
                               static_cast<uint32_t>(c.hit_param)};
  for (int i = 0; i < 13; ++i) put_u32(p + 4 * i, fields[i]);
  put_f32(p + 52, c.leaky_slope);
}

// The fields but the table sizes (table_log2 left 0: the version decides where they are).
Config read_config(const uint8_t* p) {
  Config c;
  for (uint32_t& m : c.table_log2) m = 0;
  c.voxel_resolution = get_u32(p + 0);
  c.max_points = get_u32(p + 4);
  c.grid_levels = get_u32(p + 8);
  for (int l = 0; l < 4; ++l) c.grid_resolution[l] = get_u32(p + 12 + 4 * l);
  c.features = get_u32(p + 32);
  c.hidden_width = get_u32(p + 36);
  c.hidden_layers = get_u32(p + 40);
  c.material_count = get_u32(p + 44);
  c.hit_param = static_cast<HitParam>(get_u32(p + 48));  // fixed uint32_t underlying type: any value ok
  c.leaky_slope = get_f32(p + 52);
  return c;
}

// The first non-finite fp16 value among `count` little-endian values at p, or `count`.
uint64_t first_non_finite_half(const uint8_t* p, uint64_t count) {
  for (uint64_t i = 0; i < count; ++i)
    if (!half_is_finite(get_u16(p + 2 * i))) return i;
  return count;
}

// Checks of the fixed header that need neither the CRC nor the config: magic, version, header
// size, and the declared total size against the actual one. Sets `version`.
Status check_preamble(const uint8_t* data, size_t size, uint32_t& version) {
  if (size == 0) return Status::error("file is empty (0 bytes)");
  const size_t magic_bytes = size < sizeof(kMagic) ? size : sizeof(kMagic);
  if (std::memcmp(data, kMagic, magic_bytes) != 0)
    return Status::error("bad magic: not an .lsnif file (the first 8 bytes must be \"LSNIF\\0\\r\\n\")");
  if (size < kOffFileSize + 8)
    return Status::error("truncated: %zu bytes, the .lsnif header alone is %u bytes", size, kHeaderSizeV1);
  version = get_u32(data + kOffVersion);
  if (version < 1 || version > kModelFormatVersion)
    return Status::error("unsupported format version %u (this build supports versions 1 to %u)", version,
                         kModelFormatVersion);
  const uint32_t expected_header = header_size_of(version);
  const uint32_t header_size = get_u32(data + kOffHeaderSize);
  if (header_size != expected_header)
    return Status::error("header size %u is wrong: format version %u has a %u-byte header", header_size, version,
                         expected_header);
  const uint64_t declared = get_u64(data + kOffFileSize);
  if (size < declared)
    return Status::error("truncated: expected %llu bytes (from the header), got %zu", ull(declared), size);
  if (size > declared)
    return Status::error("trailing data: the header says the file has %llu bytes, got %zu", ull(declared),
                         size);
  if (declared < expected_header + kCrcSize)
    return Status::error("truncated: the header declares %llu bytes, less than the %llu-byte header and checksum",
                         ull(declared), ull(expected_header + kCrcSize));
  return Status::ok();
}

// Every byte in [begin, end) must be zero padding.
Status check_padding(const uint8_t* data, uint64_t begin, uint64_t end) {
  for (uint64_t i = begin; i < end; ++i)
    if (data[i] != 0) return Status::error("padding byte at offset %llu is 0x%02x, not zero", ull(i), data[i]);
  return Status::ok();
}

// The header's config: its fields, then the table sizes, index sizes and grid bits where `version`
// stores them (the reserved word checked); validated, and an error when the version does not fit it.
Status read_header_config(const uint8_t* data, uint32_t version, Config& config) {
  config = read_config(data + kOffConfig);
  const uint32_t stored_m = get_u32(data + kOffConfig + kConfigTableLog2);
  if (version <= 3) {
    // One size for every level; a level count out of range is reported by validate().
    if (config.grid_levels <= LSNIF_MAX_LEVELS) set_table_log2(config, stored_m);
  } else {
    if (stored_m != 0)
      return Status::error("config field M (offset %zu) is %u in a version %u file: versions 4 to 7 store the "
                           "table sizes per level at offset %zu, M must be 0", kOffConfig + kConfigTableLog2,
                           stored_m, version, kOffTableLog2);
    for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) config.table_log2[l] = get_u32(data + kOffTableLog2 + 4 * l);
  }
  if (version >= 5)
    for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) {
      config.index_slots[l] = get_u32(data + kOffIndexSlots + 4 * l);
      config.index_buckets[l] = get_u32(data + kOffIndexBuckets + 4 * l);
    }
  if (version >= 3) {
    config.grid_bits = get_u32(data + kOffGridBits);
    if (version == 3 && config.grid_bits != 8)
      return Status::error("grid bits %u in a version 3 file: version 3 stores 8-bit grid features",
                           config.grid_bits);
    if (get_u32(data + kOffReserved) != 0)
      return Status::error("reserved header word at offset %zu is 0x%08x, not zero", kOffReserved,
                           get_u32(data + kOffReserved));
  }
  if (version >= 6) {
    config.surface_channels = get_u32(data + kOffSurfaceChannels);
    config.emission_scale = get_f32(data + kOffEmissionScale);
    if (version == 6 && config.surface_channels != 1)
      return Status::error("surface channels %u in a version 6 file: version 6 stores a model with surface channels "
                           "(1)", config.surface_channels);
    for (size_t off = kOffReservedV6; off < kHeaderSizeV6; off += 4)
      if (get_u32(data + off) != 0)
        return Status::error("reserved header word at offset %zu is 0x%08x, not zero", off, get_u32(data + off));
  }
  if (version >= 7) {
    config.uv_materials = get_u64(data + kOffUvMaterials);
    config.uv_cells = get_u32(data + kOffUvCells);
    config.uv_cell_voxels = get_u32(data + kOffUvCellVoxels);
    config.uv_cell_maps = get_u32(data + kOffUvCellMaps);
    if (config.uv_materials == 0)
      return Status::error("no texture-coordinate material in a version 7 file: version 7 stores a model with "
                           "uv cells");
    for (size_t off : {kOffReservedV7, kOffReservedV7b, kOffReservedV7b + 4})
      if (get_u32(data + off) != 0)
        return Status::error("reserved header word at offset %zu is 0x%08x, not zero", off, get_u32(data + off));
  }
  if (Status s = config.validate(); !s) return s.context("invalid config in header");
  const Config& c = config;
  if (version == 4 && c.uniform_table_log2())
    return Status::error("version 4 file whose %u levels all have 2^%u table entries (such a model is stored as "
                         "version 1, 2 or 3)", c.grid_levels, c.table_log2[0]);
  if (version == 5 && !c.any_indexed())
    return Status::error("version 5 file without an indexed grid level (such a model is stored as version 1 to 4)");
  return Status::ok();
}

// The header's object AABB into v.bounds_lo and v.bounds_hi; an error when it is not usable.
Status read_bounds(const uint8_t* data, ModelFileView& v) {
  for (int a = 0; a < 3; ++a) {
    v.bounds_lo[a] = get_f32(data + kOffAabb + 4 * a);
    v.bounds_hi[a] = get_f32(data + kOffAabb + 12 + 4 * a);
  }
  if (!aabb_usable(v.bounds_lo, v.bounds_hi))
    return Status::error("object AABB lo=(%g, %g, %g) hi=(%g, %g, %g) is not finite, is empty or exceeds +-%g",
                         double(v.bounds_lo[0]), double(v.bounds_lo[1]), double(v.bounds_lo[2]),
                         double(v.bounds_hi[0]), double(v.bounds_hi[1]), double(v.bounds_hi[2]),
                         kMaxModelCoordinate);
  return Status::ok();
}

// The layout the config (valid) and the training record's declared size imply, into `expected`;
// an error when the section table or the file size differs from it.
Status check_section_table(const uint8_t* data, size_t size, uint32_t version, const Config& c, Layout& expected) {
  const uint64_t crc_offset = size - kCrcSize;
  // Section table: inside the file, then exactly the sizes and offsets the config (and the training
  // record's size) implies.
  uint64_t training_bytes = 0;
  if (version >= 2) {
    training_bytes = get_u64(data + kOffSections + 16 * kTraining + 8);
    const uint64_t least = version == 2 ? 1 : 0;  // versions 3 and 4: the record is optional
    if (training_bytes < least || training_bytes > kMaxTrainingRecordBytes)
      return Status::error("section training has size %llu bytes, expected %llu to %llu", ull(training_bytes),
                           ull(least), ull(kMaxTrainingRecordBytes));
  }
  expected = layout_of(c, training_bytes);
  const uint32_t header_size = expected.header_size;
  for (int s = 0; s < expected.sections; ++s) {
    const uint64_t offset = get_u64(data + section_entry(s));
    const uint64_t bytes = get_u64(data + section_entry(s) + 8);
    if (offset < header_size || offset > crc_offset || bytes > crc_offset - offset)
      return Status::error("section %s [offset %llu, size %llu] lies outside the file's data bytes [%u, %llu)",
                           kSectionName[s], ull(offset), ull(bytes), header_size, ull(crc_offset));
    if (bytes != expected.size[s])
      return Status::error("section %s has size %llu bytes, the config implies %llu", kSectionName[s],
                           ull(bytes), ull(expected.size[s]));
    if (offset != expected.offset[s])
      return Status::error("section %s is at offset %llu, expected %llu (sections follow the header in order, "
                           "16-byte aligned)",
                           kSectionName[s], ull(offset), ull(expected.offset[s]));
  }
  if (expected.file_size != size)
    return Status::error("file size %zu does not match the %llu bytes the config implies", size,
                         ull(expected.file_size));
  return Status::ok();
}

// Padding between header, sections and checksum: zero bytes only.
Status check_layout_padding(const uint8_t* data, const Layout& expected) {
  uint64_t end = expected.header_size;
  for (int s = 0; s < expected.sections; ++s) {
    if (Status st = check_padding(data, end, expected.offset[s]); !st) return st;
    end = expected.offset[s] + expected.size[s];
  }
  if (Status st = check_padding(data, end, expected.crc_offset); !st) return st;
  return Status::ok();
}

// The materials section into v.materials: NUL-terminated clean UTF-8 names (zero bytes after the
// NUL), finite base colors.
Status read_materials(const uint8_t* data, const Layout& expected, ModelFileView& v) {
  const Config& c = v.config;
  const uint8_t* p = data + expected.offset[kMaterials];
  v.materials.resize(c.material_count);
  for (uint32_t i = 0; i < c.material_count; ++i, p += kMaterialRecordSize) {
    const void* nul = std::memchr(p, 0, kNameBytes);
    if (!nul) return Status::error("material %u name is not NUL-terminated within %llu bytes", i, ull(kNameBytes));
    const size_t length = static_cast<size_t>(static_cast<const uint8_t*>(nul) - p);
    for (size_t k = length; k < kNameBytes; ++k)
      if (p[k] != 0) return Status::error("material %u name has non-zero bytes after its NUL terminator", i);
    v.materials[i].name.assign(reinterpret_cast<const char*>(p), length);
    if (!is_clean_utf8(v.materials[i].name))
      return Status::error("material %u name \"%s\" is not valid UTF-8 or contains control characters", i,
                           printable(v.materials[i].name).c_str());
    for (int k = 0; k < 3; ++k) {
      const float value = get_f32(p + kNameBytes + 4 * k);
      if (!std::isfinite(value)) return Status::error("material %u base color component %d is not finite", i, k);
      v.materials[i].base_color[k] = value;
    }
  }
  return Status::ok();
}

// The voxels section into v.voxels: no bit beyond V^3.
Status read_voxels(const uint8_t* data, const Layout& expected, ModelFileView& v) {
  const Config& c = v.config;
  v.voxels = data + expected.offset[kVoxels];
  const uint64_t words = expected.size[kVoxels] / 4u;
  const uint32_t used_bits = static_cast<uint32_t>(c.voxel_count() % 32u);
  if (used_bits != 0 && (get_u32(v.voxels + 4 * (words - 1)) >> used_bits) != 0)
    return Status::error("voxels section has bits set beyond voxel %llu (V^3 = %u^3)", ull(c.voxel_count()),
                         c.voxel_resolution);
  return Status::ok();
}

// An 8-bit grid's scales into v.grid_scales (usable ones only) and its codes in v.grid checked:
// in [-127, 127], and 0 in a level of scale 0.
Status read_int8_grid(const uint8_t* data, const Layout& expected, ModelFileView& v) {
  const Config& c = v.config;
  for (uint32_t l = 0; l < c.grid_levels; ++l) {
    const float scale = get_f32(data + expected.offset[kGridScales] + 4 * l);
    if (!grid_scale_usable(scale))
      return Status::error("grid scale of level %u is %g, not a finite number >= +0 (with 127 times it finite)", l,
                           double(scale));
    v.grid_scales[l] = scale;
  }
  for (uint32_t l = 0; l < c.grid_levels; ++l) {
    const uint64_t first = c.level_entry_offset(l) * c.features, last = c.level_entry_offset(l + 1) * c.features;
    for (uint64_t i = first; i < last; ++i) {
      if (v.grid[i] == 0x80)
        return Status::error("grid section code %llu (of %llu) is -128, outside the int8 codes [-127, 127]", ull(i),
                             ull(c.grid_parameter_count()));
      // One encoding per model: a level of scale 0 holds only zero codes.
      if (v.grid[i] != 0 && v.grid_scales[l] == 0.0f)
        return Status::error("grid section code %llu is %d in level %u, whose scale is 0 (codes must be 0)", ull(i),
                             int(static_cast<int8_t>(v.grid[i])), l);
    }
  }
  return Status::ok();
}

// The parameter sections into v.grid, v.mlp and (version 5) v.grid_index. Parameters: finite fp16
// values only; 8-bit grids: codes in [-127, 127] and usable scales.
Status read_parameters(const uint8_t* data, uint32_t version, const Layout& expected, ModelFileView& v) {
  const Config& c = v.config;
  v.grid = data + expected.offset[kGrid];
  v.mlp = data + expected.offset[kMlp];
  // Any displacement is valid: a slot is taken modulo the level's slots.
  v.grid_index = version >= 5 ? data + expected.offset[kGridIndex] : nullptr;
  if (c.grid_bits == 8)
    if (Status s = read_int8_grid(data, expected, v); !s) return s;
  const struct {
    const uint8_t* p;
    uint64_t count;
    const char* name;
  } params[2] = {{v.grid, c.grid_bits == 8 ? 0 : c.grid_parameter_count(), "grid"},
                 {v.mlp, c.mlp_parameter_count(), "mlp"}};
  for (const auto& section : params) {
    const uint64_t i = first_non_finite_half(section.p, section.count);
    if (i == section.count) continue;
    const uint16_t bits = get_u16(section.p + 2 * i);
    return Status::error("%s section value %llu (of %llu) is %s (fp16 bits 0x%04x)", section.name, ull(i),
                         ull(section.count), half_non_finite_kind(bits), bits);
  }
  return Status::ok();
}

// The training record into v.training (when there is one): text for people and tools, checked like
// the material names.
Status read_training(const uint8_t* data, const Layout& expected, ModelFileView& v) {
  const uint64_t training_bytes = expected.size[kTraining];
  if (training_bytes) {
    v.training.assign(reinterpret_cast<const char*>(data + expected.offset[kTraining]), training_bytes);
    if (!is_clean_utf8(v.training))
      return Status::error("training section is not valid UTF-8 or contains control characters: \"%s\"",
                           printable(v.training.substr(0, 200)).c_str());
  }
  return Status::ok();
}

// The uv cells (version 7) into v.uv_cells: one voxel record per occupied voxel, the words checked
// (check_uv_cells).
Status read_uv_cells(const uint8_t* data, const Layout& expected, ModelFileView& v) {
  const Config& c = v.config;
  if (!c.texture_coordinates()) return Status::ok();
  uint64_t occupied = 0;
  for (uint64_t w = 0; w < model_voxel_words(c); ++w) occupied += uint64_t(std::popcount(get_u32(v.voxels + 4 * w)));
  if (occupied != c.uv_cell_voxels)
    return Status::error("uv cells: the header says %u voxel records, the voxels section has %llu occupied voxels",
                         c.uv_cell_voxels, ull(occupied));
  const uint8_t* p = data + expected.offset[kUvCells];
  v.uv_cells.resize(size_t(uv_cell_words(c)));
  for (size_t i = 0; i < v.uv_cells.size(); ++i) v.uv_cells[i] = get_u32(p + 4 * i);
  return check_uv_cells(c, v.uv_cells.data());
}

Status parse(const uint8_t* data, size_t size, ModelFileView& view) {
  uint32_t version = 0;
  if (Status s = check_preamble(data, size, version); !s) return s;
  const uint64_t crc_offset = size - kCrcSize;
  const uint32_t stored_crc = get_u32(data + crc_offset), actual_crc = crc32(data, crc_offset);
  if (stored_crc != actual_crc)
    return Status::error("checksum mismatch: stored CRC-32 0x%08x, computed 0x%08x (file corrupted)",
                         stored_crc, actual_crc);

  ModelFileView v;
  if (Status s = read_header_config(data, version, v.config); !s) return s;
  if (Status s = read_bounds(data, v); !s) return s;
  Layout expected;
  if (Status s = check_section_table(data, size, version, v.config, expected); !s) return s;
  if (Status s = check_layout_padding(data, expected); !s) return s;
  if (Status s = read_materials(data, expected, v); !s) return s;
  if (Status s = read_voxels(data, expected, v); !s) return s;
  if (Status s = read_parameters(data, version, expected, v); !s) return s;
  if (Status s = read_uv_cells(data, expected, v); !s) return s;
  v.version = version;
  if (Status s = read_training(data, expected, v); !s) return s;
  if (Status s = check_training_record(v.training, v.config); !s) return s;
  view = std::move(v);
  return Status::ok();
}

}  // namespace

uint64_t model_voxel_words(const Config& config) { return (config.voxel_count() + 31u) / 32u; }

bool grid_scale_usable(float scale) { return scale >= 0.0f && !std::signbit(scale) && std::isfinite(scale * 127.0f); }

ModelFileSizes model_file_sizes(const Config& config, uint64_t training_bytes) {
  const Layout l = layout_of(config, training_bytes);
  ModelFileSizes out;
  out.voxels = l.size[kVoxels];
  out.grid = l.size[kGrid] + l.size[kGridScales] + l.size[kGridIndex];
  out.mlp = l.size[kMlp];
  out.uv_cells = l.size[kUvCells];
  out.file = l.file_size;
  out.version = l.version;
  return out;
}

Status parse_model_file(const uint8_t* data, size_t size, ModelFileView& out) {
  if (!data && size != 0) return Status::error("no data (null pointer with size %zu)", size);
  if (size == 0) return Status::error("file is empty (0 bytes)");
  return parse(data, size, out);
}

Status write_model_file(const ModelFileContents& contents, std::vector<uint8_t>& bytes) {
  const Config& c = contents.config;
  if (Status s = c.validate(); !s) return s.context("cannot save model");
  if (!aabb_usable(contents.bounds_lo, contents.bounds_hi))
    return Status::error("cannot save model: its AABB is not finite, is empty or exceeds +-%g", kMaxModelCoordinate);
  if (contents.materials.size() != c.material_count)
    return Status::error("cannot save model: %zu materials, the config has %u", contents.materials.size(),
                         c.material_count);
  if (!contents.voxels || !contents.mlp || (c.grid_bits == 8 ? !contents.grid_codes : !contents.grid) ||
      (c.any_indexed() && !contents.grid_index) || (c.texture_coordinates() && !contents.uv_cells))
    return Status::error("cannot save model: a section has no data");
  if (c.texture_coordinates()) {
    uint64_t occupied = 0;
    for (uint64_t w = 0; w < model_voxel_words(c); ++w) occupied += uint64_t(std::popcount(contents.voxels[w]));
    if (occupied != c.uv_cell_voxels)
      return Status::error("cannot save model: %u uv cell voxel records for %llu occupied voxels", c.uv_cell_voxels,
                           ull(occupied));
    if (Status s = check_uv_cells(c, contents.uv_cells); !s) return s.context("cannot save model");
  }
  if (contents.training.size() > kMaxTrainingRecordBytes)
    return Status::error("cannot save model: the training record is %zu bytes, at most %llu allowed",
                         contents.training.size(), ull(kMaxTrainingRecordBytes));
  if (!is_clean_utf8(contents.training))
    return Status::error("cannot save model: the training record is not valid UTF-8 or contains control characters");
  for (size_t i = 0; i < contents.materials.size(); ++i) {
    const ModelFileMaterial& mat = contents.materials[i];
    if (mat.name.size() >= kNameBytes)
      return Status::error("cannot save model: material %zu name \"%s\" is %zu bytes, at most %llu allowed", i,
                           mat.name.c_str(), mat.name.size(), ull(kNameBytes - 1));
    if (mat.name.find('\0') != std::string::npos)
      return Status::error("cannot save model: material %zu name contains a NUL byte", i);
    if (!is_clean_utf8(mat.name))
      return Status::error("cannot save model: material %zu name \"%s\" is not valid UTF-8 or contains control "
                           "characters", i, printable(mat.name).c_str());
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(mat.base_color[k]))
        return Status::error("cannot save model: material %zu base color is not finite", i);
  }
  const uint64_t voxel_words = model_voxel_words(c);
  const uint32_t used_bits = static_cast<uint32_t>(c.voxel_count() % 32u);
  if (used_bits != 0 && (contents.voxels[voxel_words - 1] >> used_bits) != 0)
    return Status::error("cannot save model: voxel bits set beyond voxel %llu", ull(c.voxel_count()));
  const struct {
    const uint16_t* values;
    uint64_t count;
    const char* name;
  } params[2] = {{contents.grid, c.grid_bits == 8 ? 0 : c.grid_parameter_count(), "grid"},
                 {contents.mlp, c.mlp_parameter_count(), "mlp"}};
  if (c.grid_bits == 8) {
    for (uint32_t l = 0; l < c.grid_levels; ++l)
      if (!grid_scale_usable(contents.grid_scales[l]))
        return Status::error("cannot save model: grid scale of level %u is %g, not a finite non-negative number", l,
                             double(contents.grid_scales[l]));
    for (uint32_t lv = 0; lv < c.grid_levels; ++lv)
      for (uint64_t i = c.level_entry_offset(lv) * c.features; i < c.level_entry_offset(lv + 1) * c.features; ++i) {
        if (contents.grid_codes[i] < -127)
          return Status::error("cannot save model: grid code %llu is -128, outside [-127, 127]", ull(i));
        if (contents.grid_codes[i] != 0 && contents.grid_scales[lv] == 0.0f)
          return Status::error("cannot save model: grid code %llu is not 0 in a level of scale 0", ull(i));
      }
  }
  for (const auto& section : params)
    for (uint64_t i = 0; i < section.count; ++i)
      if (!half_is_finite(section.values[i]))
        return Status::error("cannot save model: %s value %llu is %s, not a finite fp16 value", section.name, ull(i),
                             half_non_finite_kind(section.values[i]));

  const Layout l = layout_of(c, contents.training.size());
  std::vector<uint8_t> out(l.file_size, 0);  // zero-filled: all padding is already in place
  uint8_t* d = out.data();
  std::memcpy(d, kMagic, sizeof(kMagic));
  put_u32(d + kOffVersion, l.version);
  put_u32(d + kOffHeaderSize, l.header_size);
  put_u64(d + kOffFileSize, l.file_size);
  write_config(d + kOffConfig, c, l.version);
  if (l.version >= 3) put_u32(d + kOffGridBits, c.grid_bits);
  if (l.version >= 4)
    for (uint32_t lv = 0; lv < LSNIF_MAX_LEVELS; ++lv) put_u32(d + kOffTableLog2 + 4 * lv, c.table_log2[lv]);
  if (l.version >= 5)
    for (uint32_t lv = 0; lv < LSNIF_MAX_LEVELS; ++lv) {
      put_u32(d + kOffIndexSlots + 4 * lv, c.index_slots[lv]);
      put_u32(d + kOffIndexBuckets + 4 * lv, c.index_buckets[lv]);
    }
  if (l.version >= 6) {
    put_u32(d + kOffSurfaceChannels, c.surface_channels);
    put_f32(d + kOffEmissionScale, c.emission_scale);
  }
  if (l.version >= 7) {
    put_u64(d + kOffUvMaterials, c.uv_materials);
    put_u32(d + kOffUvCells, c.uv_cells);
    put_u32(d + kOffUvCellVoxels, c.uv_cell_voxels);
    put_u32(d + kOffUvCellMaps, c.uv_cell_maps);
  }
  for (int a = 0; a < 3; ++a) {
    put_f32(d + kOffAabb + 4 * a, contents.bounds_lo[a]);
    put_f32(d + kOffAabb + 12 + 4 * a, contents.bounds_hi[a]);
  }
  for (int s = 0; s < l.sections; ++s) {
    put_u64(d + section_entry(s), l.offset[s]);
    put_u64(d + section_entry(s) + 8, l.size[s]);
  }
  uint8_t* p = d + l.offset[kMaterials];
  for (const ModelFileMaterial& mat : contents.materials) {
    std::memcpy(p, mat.name.data(), mat.name.size());
    for (int k = 0; k < 3; ++k) put_f32(p + kNameBytes + 4 * k, mat.base_color[k]);
    p += kMaterialRecordSize;
  }
  p = d + l.offset[kVoxels];
  for (uint64_t w = 0; w < voxel_words; ++w) put_u32(p + 4 * w, contents.voxels[w]);
  p = d + l.offset[kGrid];
  if (c.grid_bits == 8) {
    for (uint64_t i = 0; i < c.grid_parameter_count(); ++i) p[i] = static_cast<uint8_t>(contents.grid_codes[i]);
    for (uint32_t lv = 0; lv < c.grid_levels; ++lv)
      put_f32(d + l.offset[kGridScales] + 4 * lv, contents.grid_scales[lv]);
  } else {
    for (uint64_t i = 0; i < c.grid_parameter_count(); ++i) put_u16(p + 2 * i, contents.grid[i]);
  }
  p = d + l.offset[kMlp];
  for (uint64_t i = 0; i < c.mlp_parameter_count(); ++i) put_u16(p + 2 * i, contents.mlp[i]);
  if (!contents.training.empty())
    std::memcpy(d + l.offset[kTraining], contents.training.data(), contents.training.size());
  p = d + l.offset[kGridIndex];
  for (uint64_t i = 0; i < c.grid_index_count(); ++i) put_u16(p + 2 * i, contents.grid_index[i]);
  p = d + l.offset[kUvCells];
  for (uint64_t i = 0; c.texture_coordinates() && i < uv_cell_words(c); ++i) put_u32(p + 4 * i, contents.uv_cells[i]);
  put_u32(d + l.crc_offset, crc32(d, l.crc_offset));
  bytes = std::move(out);
  return Status::ok();
}

namespace {

// The preamble of the file at `path` (magic, version, header size, declared size) against its size on
// disk, read before its body: ok (`declared` set) when it is a model's preamble of that size; an
// error naming the problem (check_preamble's words) when not; ok with `declared` 0 when the file
// cannot be looked at this way (missing, not a regular file, unreadable: read_file names it).
Status peek_model_preamble(const std::string& path, uint64_t& declared) {
  declared = 0;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return Status::ok();
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return Status::ok();
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return Status::ok();
  uint8_t head[kOffFileSize + 8] = {};
  const size_t got = std::fread(head, 1, sizeof head, f);
  std::fclose(f);
  uint32_t version = 0;
  // Fewer bytes than the preamble: the size says so (check_preamble reads no further than it).
  if (Status s = check_preamble(head, got < sizeof head ? got : size_t(size), version); !s) return s;
  declared = get_u64(head + kOffFileSize);
  return Status::ok();
}

}  // namespace

Status read_model_file(const std::string& path, std::vector<uint8_t>& out, uint64_t max_bytes, ReadFailure* failure) {
  ReadFailure f;
  if (failure) *failure = f;
  const std::string shown = printable(path);
  const char* p = shown.c_str();
  const uint64_t limit = max_bytes ? std::min(max_bytes, max_file_size()) : max_file_size();
  uint64_t declared = 0;
  if (Status s = peek_model_preamble(path, declared); !s) return Status::error("loading %s: %s", p, s.message().c_str());
  if (declared > limit)
    return Status::error("loading %s: its header declares %llu bytes, more than %s (%llu bytes)", p, ull(declared),
                         max_bytes ? "a model of these settings can have" : "any valid .lsnif file", ull(limit));
  const bool read = read_file(path, out, declared ? declared : limit, &f).is_ok();
  if (failure) *failure = f;
  if (read) return Status::ok();
  switch (f.problem) {
    case ReadProblem::Missing: return Status::error("loading %s: no such file", p);
    case ReadProblem::CannotAccess: return Status::error("loading %s: cannot access: %s", p, f.reason.c_str());
    case ReadProblem::Directory: return Status::error("loading %s: is a directory, not an .lsnif file", p);
    case ReadProblem::NotRegular: return Status::error("loading %s: not a regular file", p);
    case ReadProblem::SizeUnknown: return Status::error("loading %s: cannot read its size: %s", p, f.reason.c_str());
    case ReadProblem::TooLarge:
      return declared ? Status::error("loading %s: it grew beyond the %llu bytes its header declares", p, ull(declared))
                      : Status::error("loading %s: %llu bytes is larger than %s (at most %llu bytes)", p, ull(f.size),
                                      max_bytes ? "a model of these settings can have" : "any valid .lsnif file",
                                      ull(limit));
    case ReadProblem::OutOfMemory: return Status::error("loading %s: out of memory for its %llu bytes", p, ull(f.size));
    case ReadProblem::CannotOpen: return Status::error("loading %s: cannot open: %s", p, f.reason.c_str());
    case ReadProblem::ReadError: return Status::error("loading %s: read error", p);
    case ReadProblem::None:
    case ReadProblem::ChangedSize: break;
  }
  return Status::error("loading %s: the file changed size while it was read", p);
}

}  // namespace lsnif
