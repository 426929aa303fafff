// gpu_block.cpp -- the packer of gpu_block.h. The layout itself is documented (once) in
// src/lsnif/host_device.h; this file and src/lsnif/shaders/lsnif_model.glsl / lsnif_mlp.glsl follow it.
#include "lsnif/format/gpu_block.h"

#include <algorithm>
#include <bit>
#include <cstring>

#include "lsnif/format/uv_cell_layout.h"

namespace lsnif {

static_assert(sizeof(LsnifGpuModelHeader) == LSNIF_GPU_HEADER_WORDS * 4, "header must be LSNIF_GPU_HEADER_WORDS words");
static_assert(sizeof(LsnifReferenceRay) == 32 && sizeof(LsnifReferenceHit) == 80, "test structs");

std::vector<GpuLayerLayout> gpu_layer_layout(const Config& config) {
  std::vector<GpuLayerLayout> layers;
  uint32_t in = config.input_dim(), word = 0;
  for (uint32_t l = 0; l <= config.hidden_layers; ++l) {
    GpuLayerLayout g;
    g.in = in;
    g.out = l < config.hidden_layers ? config.hidden_width : config.output_dim();
    g.row_words = LSNIF_GPU_ROW_WORDS(g.in);
    g.blocks = LSNIF_GPU_ROW_BLOCKS(g.out);
    g.weight_word = word;
    g.bias_word = word + g.blocks * LSNIF_GPU_ROW_BLOCK * g.row_words;
    g.end_word = g.bias_word + g.blocks * LSNIF_GPU_ROW_BLOCK;  // 8 words of bias per block
    static_assert(LSNIF_GPU_ROW_BLOCK == 8, "lsnif_mlp.glsl computes 8 rows per block");
    word = g.end_word;
    in = g.out;
    layers.push_back(g);
  }
  return layers;
}

namespace {

uint16_t get_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint32_t get_u32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// Stores fp16 bits `h` as element `element` of the fp16 pairs starting at word `word_base`.
// The header's four per-level fields from the levels' values.
template <class T>
void set_levels(T& level0, T& level1, T& level2, T& level3, const T (&values)[LSNIF_MAX_LEVELS]) {
  level0 = values[0];
  level1 = values[1];
  level2 = values[2];
  level3 = values[3];
}

void put_half(std::vector<uint32_t>& words, uint64_t word_base, uint64_t element, uint16_t h) {
  words[size_t(word_base + (element >> 1))] |= uint32_t(h) << ((element & 1u) * 16u);
}

}  // namespace

// Contract: see gpu_block.h.
Status pack_gpu_block(const ModelFileView& view, std::vector<uint32_t>& words) {
  words.clear();
  const Config& c = view.config;
  if (Status s = c.validate(); !s) return s.context("packing GPU block");
  const std::vector<GpuLayerLayout> layers = gpu_layer_layout(c);
  const uint64_t voxel_words = model_voxel_words(c);
  const uint64_t per_word = 32u / c.grid_bits;  // fp16 pairs or 4 int8 codes
  // The grid padded to 8 words: the mlp section stays 32-byte aligned.
  const uint64_t grid_words = ((c.grid_parameter_count() + per_word - 1) / per_word + 7) / 8 * 8;
  const uint64_t mlp_words = layers.back().end_word;
  // The displacements, two per word, padded to 8 words (none without an indexed level).
  const uint64_t index_words = ((c.grid_index_count() + 1) / 2 + 7) / 8 * 8;
  const uint64_t voxel_offset = LSNIF_GPU_HEADER_WORDS;
  const uint64_t grid_offset = voxel_offset + (voxel_words + 7) / 8 * 8;
  const uint64_t index_offset = grid_offset + grid_words;
  const uint64_t mlp_offset = index_offset + index_words;
  // The uv cells: the rank table (a word per voxel word), the voxel records and the maps, each
  // starting at a multiple of 8 words.
  const bool uv = c.texture_coordinates();
  const uint64_t rank_offset = (mlp_offset + mlp_words + 7) / 8 * 8;
  const uint64_t record_offset = (rank_offset + voxel_words + 7) / 8 * 8;
  const uint64_t map_offset = (record_offset + uint64_t(kUvVoxelWords) * c.uv_cell_voxels + 7) / 8 * 8;
  const uint64_t total = uv ? map_offset + uint64_t(kUvMapWords) * c.uv_cell_maps : mlp_offset + mlp_words;
  if (total > 0xffffffffull)
    return Status::error("packing GPU block: %llu words exceed the 32-bit word addressing",
                         static_cast<unsigned long long>(total));
  words.assign(size_t(total), 0u);

  LsnifGpuModelHeader h{};
  h.magic = LSNIF_GPU_MAGIC;
  h.version = LSNIF_GPU_VERSION;
  h.total_words = uint32_t(total);
  h.voxel_resolution = c.voxel_resolution;
  h.max_points = c.max_points;
  h.grid_levels = c.grid_levels;
  set_levels(h.grid_resolution0, h.grid_resolution1, h.grid_resolution2, h.grid_resolution3, c.grid_resolution);
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) h.table_log2 |= c.table_log2[l] << (8u * l);
  h.features = c.features;
  h.hidden_width = c.hidden_width;
  h.hidden_layers = c.hidden_layers;
  h.material_count = c.material_count;
  h.hit_param = static_cast<uint32_t>(c.hit_param);
  h.leaky_slope = c.leaky_slope;
  h.bounds_lo_x = view.bounds_lo[0];
  h.bounds_lo_y = view.bounds_lo[1];
  h.bounds_lo_z = view.bounds_lo[2];
  h.bounds_hi_x = view.bounds_hi[0];
  h.bounds_hi_y = view.bounds_hi[1];
  h.bounds_hi_z = view.bounds_hi[2];
  h.voxel_offset = uint32_t(voxel_offset);
  h.grid_offset = uint32_t(grid_offset);
  h.mlp_offset = uint32_t(mlp_offset);
  h.grid_bits = c.grid_bits;
  if (c.any_indexed()) h.index_offset = uint32_t(index_offset);
  set_levels(h.index_slots0, h.index_slots1, h.index_slots2, h.index_slots3, c.index_slots);
  set_levels(h.index_buckets0, h.index_buckets1, h.index_buckets2, h.index_buckets3, c.index_buckets);
  h.surface_channels = c.surface_channels;
  h.emission_scale = c.emission_scale;
  h.uv_materials_lo = uint32_t(c.uv_materials);
  h.uv_materials_hi = uint32_t(c.uv_materials >> 32);
  if (uv) {
    h.uv_cells = c.uv_cells;
    h.uv_rank_offset = uint32_t(rank_offset);
    h.uv_record_offset = uint32_t(record_offset);
    h.uv_map_offset = uint32_t(map_offset);
  }
  if (c.grid_bits == 8)
    set_levels(h.grid_scale0, h.grid_scale1, h.grid_scale2, h.grid_scale3, view.grid_scales);
  std::memcpy(words.data(), &h, sizeof h);

  for (uint64_t w = 0; w < voxel_words; ++w) words[size_t(voxel_offset + w)] = get_u32(view.voxels + 4 * w);
  if (c.grid_bits == 8) {
    for (uint64_t e = 0; e < c.grid_parameter_count(); ++e)
      words[size_t(grid_offset + (e >> 2))] |= uint32_t(view.grid[e]) << ((e & 3u) * 8u);
  } else {
    for (uint64_t e = 0; e < c.grid_parameter_count(); ++e)
      put_half(words, grid_offset, e, get_u16(view.grid + 2 * e));
  }

  for (uint64_t i = 0; i < c.grid_index_count(); ++i) put_half(words, index_offset, i, get_u16(view.grid_index + 2 * i));

  if (uv) {
    uint32_t rank = 0;
    for (uint64_t w = 0; w < voxel_words; ++w) {
      words[size_t(rank_offset + w)] = rank;
      rank += uint32_t(std::popcount(get_u32(view.voxels + 4 * w)));
    }
    const size_t records = size_t(kUvVoxelWords) * c.uv_cell_voxels;
    std::copy(view.uv_cells.begin(), view.uv_cells.begin() + long(records), words.begin() + long(record_offset));
    std::copy(view.uv_cells.begin() + long(records), view.uv_cells.end(), words.begin() + long(map_offset));
  }

  const std::vector<LayerView> views = mlp_layers(c);
  for (size_t l = 0; l < layers.size(); ++l) {
    const GpuLayerLayout& g = layers[l];
    const LayerView& v = views[l];
    for (uint32_t r = 0; r < g.out; ++r) {
      for (uint32_t i = 0; i < g.in; ++i) {
        const size_t src = v.weight_offset + size_t(r) * v.in + i;
        put_half(words, mlp_offset + g.weight_word_of(r, i), i & 1u, get_u16(view.mlp + 2 * src));
      }
      const size_t src = v.bias_offset + r;
      const uint64_t bias_word = mlp_offset + g.bias_word + (r / LSNIF_GPU_ROW_BLOCK) * LSNIF_GPU_ROW_BLOCK;
      put_half(words, bias_word, r % LSNIF_GPU_ROW_BLOCK, get_u16(view.mlp + 2 * src));
    }
  }
  return Status::ok();
}

LsnifGpuModelHeader gpu_block_header(const std::vector<uint32_t>& words) {
  LsnifGpuModelHeader h{};
  if (words.size() >= LSNIF_GPU_HEADER_WORDS) std::memcpy(&h, words.data(), sizeof h);
  return h;
}

Status check_gpu_block_header(const std::vector<uint32_t>& words) {
  if (words.size() < LSNIF_GPU_HEADER_WORDS)
    return Status::error("GPU block of %zu words is shorter than its %u-word header", words.size(),
                         LSNIF_GPU_HEADER_WORDS);
  const LsnifGpuModelHeader h = gpu_block_header(words);
  if (h.magic != LSNIF_GPU_MAGIC)
    return Status::error("GPU block magic 0x%08x is not LSNIF's 0x%08x", h.magic, LSNIF_GPU_MAGIC);
  if (h.version != LSNIF_GPU_VERSION)
    return Status::error("GPU block layout version %u, this build reads version %u", h.version, LSNIF_GPU_VERSION);
  if (h.total_words != words.size())
    return Status::error("GPU block header says %u words, the block has %zu", h.total_words, words.size());
  return Status::ok();
}

}  // namespace lsnif
