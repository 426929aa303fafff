// hash_grid.h -- sparse multi-resolution hash-grid encoding (paper 3.2). Level l has resolution
// R_l (a multiple of V, so voxel faces lie on grid planes) and a table of 2^M_l entries
// (Config::table_log2[l]) of F features. A boundary point lies on a plane of one axis, so it is interpolated bilinearly from
// the 4 corners of the face cell that contains it (not the 8 of a dense grid): only vertices on
// voxel faces are ever touched.
//
// Layouts (shared with the .lsnif file and the shaders):
//   table:    [level][entry][feature]  -> table[(offset_l + entry) * F + f], offset_l the entries of
//             the levels before l (Config::level_entry_offset: the sum of their table sizes)
//   features: [point][level][feature]  -> in[(j * L + l) * F + f], zero for j >= walk.count
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "lsnif/format/config.h"
#include "lsnif/core/perfect_hash.h"
#include "lsnif/core/ray_walk.h"

namespace lsnif {

// Spatial hash of an integer grid vertex, reduced to 2^log2_size entries.
inline uint32_t hash_vertex(uint32_t x, uint32_t y, uint32_t z, uint32_t log2_size) {
  uint32_t h = (x * LSNIF_HASH_PRIME_X) ^ (y * LSNIF_HASH_PRIME_Y) ^ (z * LSNIF_HASH_PRIME_Z);
  return h & ((1u << log2_size) - 1u);
}

// How each level's table is addressed: hashed (hash_vertex into 2^M_l entries) or indexed
// (Config::indexed: the perfect hash of the level's readable vertices, perfect_hash.h, every
// readable vertex its own entry). The levels' tables lie one after another either way
// (Config::level_entry_offset).
// Computed once per model, so that face_corners (the encoder's inner loop) only reads it.
struct GridLayout {
  // The layout of a model with this config and displacements `grid_index` (Model::grid_index:
  // config.grid_index_count() values, the indexed levels' in level order; may be null when no level
  // is indexed).
  GridLayout(const Config& config, const uint16_t* grid_index);
  uint32_t level_offset[LSNIF_MAX_LEVELS] = {};  // Config::level_entry_offset of each level
  PerfectHashView indexed[LSNIF_MAX_LEVELS];     // per level: displacement nullptr = hashed
};

struct FaceCorners {
  uint32_t entry[4];  // table entries (already offset by the level's offset_l)
  float weight[4];    // bilinear weights, sum to 1
};

// The 4 corners of the face cell at `level` that contains unit-cube point p lying on a grid plane
// of `axis`. The plane coordinate is rounded to the nearest grid plane; the two in-plane
// coordinates are clamped to [0, R].
// Entries follow `layout` (offsets included), which must be the GridLayout of `config` and the
// model's displacements.
// Inline: the encoder's inner loop calls it once per point and level.
inline void face_corners(const Config& config, uint32_t level, const glm::vec3& p, uint32_t axis,
                         FaceCorners& out, const GridLayout& layout) {
  const uint32_t R = config.grid_resolution[level];
  const float Rf = float(R);
  const uint32_t a = axis, b = (axis + 1) % 3, c = (axis + 2) % 3;
  // The plane coordinate is (up to rounding) an integer: voxel faces lie on grid planes.
  float xa = std::clamp(p[a] * Rf, 0.0f, Rf);
  uint32_t ia = uint32_t(std::lround(xa));
  float xb = std::clamp(p[b] * Rf, 0.0f, Rf), xc = std::clamp(p[c] * Rf, 0.0f, Rf);
  uint32_t ib = std::min(uint32_t(xb), R - 1), ic = std::min(uint32_t(xc), R - 1);
  float wb = xb - float(ib), wc = xc - float(ic);
  const uint32_t offset = layout.level_offset[level], M = config.table_log2[level];
  const PerfectHashView& indexed = layout.indexed[level];
  for (uint32_t k = 0; k < 4; ++k) {
    uint32_t v[3];
    v[a] = ia;
    v[b] = ib + (k & 1u);
    v[c] = ic + (k >> 1);
    out.entry[k] = offset + (indexed.displacement ? perfect_hash_slot(indexed, v[0], v[1], v[2])
                                                  : hash_vertex(v[0], v[1], v[2], M));
    out.weight[k] = ((k & 1u) ? wb : 1.0f - wb) * ((k >> 1) ? wc : 1.0f - wc);
  }
}

// The leading rows of a walk's encoding that can be non-zero: those of its first
// min(walk.count, max_points) points (the rest are zero; mlp_forward's `input_rows`).
inline uint32_t encoded_rows(const Config& config, const RayWalk& walk) {
  const uint32_t n = walk.count < config.max_points ? walk.count : config.max_points;
  return n * config.grid_levels * config.features;
}

// Reorders `columns` (indices into `walks`) by descending min(count, max_points), equal counts
// keeping their order, and sets rows[k] to the encoded_rows of walks[columns[k]]: the column order
// in which a batch goes through mlp_forward with `input_rows`, so that whole column chunks skip the
// zero slots of short walks.
void order_by_point_count(const Config& config, const std::vector<RayWalk>& walks, std::vector<size_t>& columns,
                          std::vector<uint32_t>& rows);

// Encodes a walk into config.input_dim() floats (layout above).
void encode(const Config& config, const float* table, const RayWalk& walk, float* features,
            const GridLayout& layout);

// Accumulates d(loss)/d(table) given d(loss)/d(features) for one walk (not thread-safe).
void encode_backward(const Config& config, const RayWalk& walk, const float* d_features,
                     float* d_table, const GridLayout& layout);

}  // namespace lsnif
