#include "lsnif/core/hash_grid.h"

#include <algorithm>
#include <cmath>

namespace lsnif {

GridLayout::GridLayout(const Config& config, const uint16_t* grid_index) {
  uint64_t at = 0;
  for (uint32_t l = 0; l < config.grid_levels && l < LSNIF_MAX_LEVELS; ++l) {
    level_offset[l] = uint32_t(config.level_entry_offset(l));
    if (!config.indexed(l)) continue;
    indexed[l] = {config.index_slots[l], config.index_buckets[l], grid_index + at};
    at += config.index_buckets[l];
  }
}

DenseGridIndex::DenseGridIndex(const Config& config, GridLayout& layout) {
  for (uint32_t l = 0; l < config.grid_levels && l < LSNIF_MAX_LEVELS; ++l) {
    const PerfectHashView& hash = layout.indexed[l];
    const uint32_t R = config.grid_resolution[l];
    const uint64_t n = uint64_t(R) + 1;
    if (!hash.displacement || hash.slots > 65536u || n * n * n > kMaxVertices) continue;
    std::vector<uint16_t>& slots = slots_[l];
    slots.resize(size_t(n * n * n));
#pragma omp parallel for schedule(static)
    for (long z = 0; z <= long(R); ++z)
      for (uint32_t y = 0; y <= R; ++y)
        for (uint32_t x = 0; x <= R; ++x)
          slots[dense_slot_index(x, y, uint32_t(z), R)] = uint16_t(perfect_hash_slot(hash, x, y, uint32_t(z)));
    layout.dense_slot[l] = slots.data();
  }
}

void order_by_point_count(const Config& config, const std::vector<RayWalk>& walks, std::vector<size_t>& columns,
                          std::vector<uint32_t>& rows) {
  const uint32_t H = config.max_points;
  auto key = [&](size_t column) { return size_t(H - std::min(walks[column].count, H)); };  // 0: the longest
  std::vector<size_t> start(size_t(H) + 2, 0);  // a stable counting sort on key
  for (size_t column : columns) ++start[key(column) + 1];
  for (size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
  std::vector<size_t> sorted(columns.size());
  rows.resize(columns.size());
  for (size_t column : columns) {
    const size_t at = start[key(column)]++;
    sorted[at] = column;
    rows[at] = encoded_rows(config, walks[column]);
  }
  columns.swap(sorted);
}

void encode(const Config& config, const float* table, const RayWalk& walk, float* features,
            const GridLayout& layout) {
  const uint32_t L = config.grid_levels, F = config.features;
  const uint32_t n = std::min(walk.count, config.max_points);
  std::fill(features, features + config.input_dim(), 0.0f);
  FaceCorners fc;
  for (uint32_t j = 0; j < n; ++j) {
    for (uint32_t l = 0; l < L; ++l) {
      face_corners(config, l, walk.p[j], walk.axis[j], fc, layout);
      float* out = features + (j * L + l) * F;
      for (uint32_t k = 0; k < 4; ++k)
        for (uint32_t f = 0; f < F; ++f) out[f] += fc.weight[k] * table[size_t(fc.entry[k]) * F + f];
    }
  }
}

void encode_backward(const Config& config, const RayWalk& walk, const float* d_features,
                     float* d_table, const GridLayout& layout) {
  const uint32_t L = config.grid_levels, F = config.features;
  const uint32_t n = std::min(walk.count, config.max_points);
  FaceCorners fc;
  for (uint32_t j = 0; j < n; ++j) {
    for (uint32_t l = 0; l < L; ++l) {
      face_corners(config, l, walk.p[j], walk.axis[j], fc, layout);
      const float* d = d_features + (j * L + l) * F;
      for (uint32_t k = 0; k < 4; ++k)
        for (uint32_t f = 0; f < F; ++f) d_table[size_t(fc.entry[k]) * F + f] += fc.weight[k] * d[f];
    }
  }
}

}  // namespace lsnif
