#include "lsnif/core/model.h"

#include <algorithm>
#include <cmath>

#include "lsnif/core/half.h"
#include "lsnif/format/model_format.h"
#include "lsnif/format/uv_cell_layout.h"

namespace lsnif {

namespace {

// Words of VoxelGrid::bits for a V^3 grid: ceil(V^3 / 32).
uint64_t voxel_word_count(const Config& config) { return (config.voxel_count() + 31u) / 32u; }

}  // namespace

Status Model::validate() const {
  Status s = config.validate();
  if (!s) return s.context("model config");
  const uint32_t V = config.voxel_resolution;
  if (voxels.resolution != V)
    return Status::error("voxel grid resolution %u does not match the config's V=%u", voxels.resolution, V);
  const uint64_t words = voxel_word_count(config);
  if (voxels.bits.size() != words)
    return Status::error("voxel grid has %zu words of occupancy bits, V=%u needs %llu", voxels.bits.size(), V,
                         static_cast<unsigned long long>(words));
  const uint32_t used_bits = static_cast<uint32_t>(config.voxel_count() % 32u);
  if (used_bits != 0 && (voxels.bits.back() >> used_bits) != 0)
    return Status::error("voxel grid has bits set beyond voxel %llu (V^3) in its last word",
                         static_cast<unsigned long long>(config.voxel_count()));
  if (materials.size() != config.material_count)
    return Status::error("model has %zu materials, the config's material count is %u", materials.size(),
                         config.material_count);
  if (grid.size() != config.grid_parameter_count())
    return Status::error("hash grid has %zu values, the config needs %llu (sum of 2^M_l, times F)", grid.size(),
                         static_cast<unsigned long long>(config.grid_parameter_count()));
  if (grid_index.size() != config.grid_index_count())
    return Status::error("model has %zu grid index displacements, its indexed levels need %llu", grid_index.size(),
                         static_cast<unsigned long long>(config.grid_index_count()));
  const size_t scales = config.grid_bits == 8 ? config.grid_levels : 0;
  if (grid_scales.size() != scales)
    return Status::error("model has %zu grid scales, %u-bit grid features need %zu", grid_scales.size(),
                         config.grid_bits, scales);
  for (size_t l = 0; l < grid_scales.size(); ++l)
    if (!grid_scale_usable(grid_scales[l]))
      return Status::error("grid scale of level %zu is %g, not a finite number >= +0 (with 127 times it finite)", l,
                           double(grid_scales[l]));
  if (uv_cells.size() != uv_cell_words(config))
    return Status::error("model has %zu uv cell words, the config needs %llu", uv_cells.size(),
                         static_cast<unsigned long long>(uv_cell_words(config)));
  if (config.texture_coordinates()) {
    if (config.uv_cell_voxels != voxels.count_occupied())
      return Status::error("model has %u uv cell voxel records for %u occupied voxels", config.uv_cell_voxels,
                           voxels.count_occupied());
    if (Status cells = check_uv_cells(config, uv_cells.data()); !cells) return cells;
  }
  if (mlp.size() != config.mlp_parameter_count())
    return Status::error("MLP has %zu parameters, the config needs %llu", mlp.size(),
                         static_cast<unsigned long long>(config.mlp_parameter_count()));
  return Status::ok();
}

void Model::quantize() {
  for (float& v : mlp) v = round_to_half(v);
  grid_scales.clear();
  if (config.grid_bits != 8) {
    for (float& v : grid) v = round_to_half(v);
    return;
  }
  for (uint32_t l = 0; l < config.grid_levels && config.level_entry_offset(l + 1) * config.features <= grid.size();
       ++l) {
    const size_t per_level = size_t(config.table_size(l)) * config.features;
    float* level = grid.data() + config.level_entry_offset(l) * config.features;
    float max_abs = 0.0f;
    for (size_t i = 0; i < per_level; ++i) max_abs = std::max(max_abs, std::abs(level[i]));
    const float scale = max_abs / 127.0f;
    grid_scales.push_back(scale);
    for (size_t i = 0; i < per_level; ++i) {
      const int32_t code =
          scale > 0.0f ? static_cast<int32_t>(std::clamp(std::nearbyint(level[i] / scale), -127.0f, 127.0f)) : 0;
      level[i] = float(code) * scale;  // +0 for code 0, never -0: the file stores codes
    }
  }
}

int32_t Model::grid_code(uint64_t e) const {
  const float scale = grid_scales[config.level_of_entry(e / config.features)];
  if (!(scale > 0.0f)) return 0;
  return static_cast<int32_t>(std::clamp(std::nearbyint(grid[size_t(e)] / scale), -127.0f, 127.0f));
}

// The sizes of the file layout (src/lsnif/format/model_format.h) without a training record;
// model_file_test checks that the file size equals total().
MemoryBreakdown memory_breakdown(const Model& model) {
  MemoryBreakdown out;
  const Config& c = model.config;
  if (!c.validate()) return out;  // sizes of an invalid config are meaningless (and may overflow)
  const ModelFileSizes sizes = model_file_sizes(c, 0);
  out.voxel_bytes = sizes.voxels;
  out.grid_bytes = sizes.grid;
  out.mlp_bytes = sizes.mlp;
  out.uv_cell_bytes = sizes.uv_cells;
  out.header_bytes = sizes.file - sizes.voxels - sizes.grid - sizes.mlp - sizes.uv_cells;
  return out;
}

}  // namespace lsnif
