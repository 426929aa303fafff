// gpu_model.cpp -- the packer of gpu_model.h. The layout itself is documented (once) in
// shaders/host_device.h; this file and shaders/lsnif_model.glsl / lsnif_mlp.glsl follow it.
#include "gpu_model.h"

#include <cstring>

#include "half.h"
#include "network.h"

namespace lsnif {

static_assert(sizeof(LsnifGpuModelHeader) == LSNIF_GPU_HEADER_WORDS * 4, "header must be 32 words");
static_assert(sizeof(LsnifReferenceRay) == 32 && sizeof(LsnifReferenceHit) == 52, "test structs");

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

// fp16 bits of v, or false when v is not exactly representable.
bool exact_half(float v, uint16_t& h) {
  h = float_to_half(v);
  const float back = half_to_float(h);
  return std::memcmp(&back, &v, sizeof v) == 0;
}

Status put_half(std::vector<uint32_t>& words, uint64_t word_base, uint64_t element, float v,
                const char* what, uint64_t index) {
  uint16_t h;
  if (!exact_half(v, h))
    return Status::error("%s value %llu (%.9g) is not an fp16 value: quantize the model first", what,
                         static_cast<unsigned long long>(index), double(v));
  words[size_t(word_base + (element >> 1))] |= uint32_t(h) << ((element & 1u) * 16u);
  return Status::ok();
}

}  // namespace

// Contract: see gpu_model.h. On failure `words` is left empty.
Status pack_gpu_model(const Model& model, std::vector<uint32_t>& words) {
  words.clear();
  if (Status s = model.validate(); !s) return s.context("packing GPU model");
  const Config& c = model.config;
  const std::vector<GpuLayerLayout> layers = gpu_layer_layout(c);
  const uint64_t voxel_words = model.voxels.bits.size();
  const uint64_t grid_words = ((c.grid_parameter_count() + 1) / 2 + 7) / 8 * 8;  // mlp 32-byte aligned
  const uint64_t mlp_words = layers.back().end_word;
  const uint64_t voxel_offset = LSNIF_GPU_HEADER_WORDS;
  const uint64_t grid_offset = voxel_offset + (voxel_words + 7) / 8 * 8;
  const uint64_t mlp_offset = grid_offset + grid_words;
  const uint64_t total = mlp_offset + mlp_words;
  if (total > 0xffffffffull)
    return Status::error("packing GPU model: %llu words exceed the 32-bit word addressing",
                         static_cast<unsigned long long>(total));
  words.assign(size_t(total), 0u);

  LsnifGpuModelHeader h{};
  h.magic = LSNIF_GPU_MAGIC;
  h.version = LSNIF_GPU_VERSION;
  h.total_words = uint32_t(total);
  h.voxel_resolution = c.voxel_resolution;
  h.max_points = c.max_points;
  h.grid_levels = c.grid_levels;
  h.grid_resolution0 = c.grid_resolution[0];
  h.grid_resolution1 = c.grid_resolution[1];
  h.grid_resolution2 = c.grid_resolution[2];
  h.grid_resolution3 = c.grid_resolution[3];
  h.log2_table_size = c.log2_table_size;
  h.features = c.features;
  h.hidden_width = c.hidden_width;
  h.hidden_layers = c.hidden_layers;
  h.material_count = c.material_count;
  h.hit_param = static_cast<uint32_t>(c.hit_param);
  h.leaky_slope = c.leaky_slope;
  const Aabb& b = model.bounds();
  h.bounds_lo_x = b.lo.x;
  h.bounds_lo_y = b.lo.y;
  h.bounds_lo_z = b.lo.z;
  h.bounds_hi_x = b.hi.x;
  h.bounds_hi_y = b.hi.y;
  h.bounds_hi_z = b.hi.z;
  h.voxel_offset = uint32_t(voxel_offset);
  h.grid_offset = uint32_t(grid_offset);
  h.mlp_offset = uint32_t(mlp_offset);
  std::memcpy(words.data(), &h, sizeof h);

  std::memcpy(words.data() + voxel_offset, model.voxels.bits.data(), voxel_words * 4);

  for (uint64_t e = 0; e < model.grid.size(); ++e) {
    if (Status s = put_half(words, grid_offset, e, model.grid[size_t(e)], "hash grid", e); !s) {
      words.clear();
      return s.context("packing GPU model");
    }
  }

  const std::vector<LayerView> views = mlp_layers(c);
  for (size_t l = 0; l < layers.size(); ++l) {
    const GpuLayerLayout& g = layers[l];
    const LayerView& v = views[l];
    for (uint32_t r = 0; r < g.out; ++r) {
      for (uint32_t i = 0; i < g.in; ++i) {
        const size_t src = v.weight_offset + size_t(r) * v.in + i;
        const uint64_t word = mlp_offset + g.weight_word_of(r, i);
        if (Status s = put_half(words, word, i & 1u, model.mlp[src], "MLP", src); !s) {
          words.clear();
          return s.context("packing GPU model");
        }
      }
      const size_t src = v.bias_offset + r;
      const uint64_t bias_word = mlp_offset + g.bias_word + (r / LSNIF_GPU_ROW_BLOCK) * LSNIF_GPU_ROW_BLOCK;
      if (Status s = put_half(words, bias_word, r % LSNIF_GPU_ROW_BLOCK, model.mlp[src], "MLP", src); !s) {
        words.clear();
        return s.context("packing GPU model");
      }
    }
  }
  return Status::ok();
}

LsnifGpuModelHeader gpu_model_header(const std::vector<uint32_t>& words) {
  LsnifGpuModelHeader h{};
  if (words.size() >= LSNIF_GPU_HEADER_WORDS) std::memcpy(&h, words.data(), sizeof h);
  return h;
}

}  // namespace lsnif
