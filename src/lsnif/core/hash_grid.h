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
  // Optional, per indexed level: the slot of every vertex (x, y, z) of its (R + 1)^3 lattice at
  // [(z * (R + 1) + y) * (R + 1) + x], the perfect hash's own values looked up instead of computed
  // (DenseGridIndex fills it; nullptr: computed).
  const uint16_t* dense_slot[LSNIF_MAX_LEVELS] = {};
};

// The dense slot tables of a layout's indexed levels with at most 2^16 slots and kMaxVertices
// lattice vertices (the trainer's: its encoder looks a corner's slot up, 2 bytes that mostly stay
// in the core's cache, instead of hashing it; the same slots). Must outlive the layouts it was
// attached to.
class DenseGridIndex {
 public:
  static constexpr uint64_t kMaxVertices = uint64_t(1) << 22;
  DenseGridIndex(const Config& config, GridLayout& layout);

 private:
  std::vector<uint16_t> slots_[LSNIF_MAX_LEVELS];
};

struct FaceCorners {
  uint32_t entry[4];  // table entries (already offset by the level's offset_l)
  float weight[4];    // bilinear weights, sum to 1
};

// The face cell at `level` that contains unit-cube point p lying on a grid plane of `axis`: the
// vertex of its first corner (the plane coordinate rounded to the nearest grid plane, the two
// in-plane coordinates clamped to [0, R]), the unit steps to the other corners along its in-plane
// axes b = axis + 1 and c = axis + 2 (mod 3), and the weights along them. Every array is indexed by
// constants only (the axes are resolved by a switch), so that it lives in registers.
struct FaceCell {
  uint32_t v[3];               // the first corner
  uint32_t step_b[3], step_c[3];  // the unit vectors of axes b and c
  float wb, wc;
};
inline FaceCell face_cell(const Config& config, uint32_t level, const glm::vec3& p, uint32_t axis) {
  const uint32_t R = config.grid_resolution[level];
  const float Rf = float(R);
  const uint32_t a = axis, b = (axis + 1) % 3, c = (axis + 2) % 3;
  // The plane coordinate is (up to rounding) an integer: voxel faces lie on grid planes.
  const float xa = std::clamp(p[a] * Rf, 0.0f, Rf);
  const float xb = std::clamp(p[b] * Rf, 0.0f, Rf), xc = std::clamp(p[c] * Rf, 0.0f, Rf);
  // std::lround of the non-negative xa (halves away from zero), written out as the shader's
  // lsnif_encoding.glsl does: inline, where the library call was not.
  uint32_t ia = uint32_t(xa);
  if (xa - float(ia) >= 0.5f) ++ia;
  const uint32_t ib = std::min(uint32_t(xb), R - 1), ic = std::min(uint32_t(xc), R - 1);
  FaceCell cell;
  cell.wb = xb - float(ib);
  cell.wc = xc - float(ic);
  switch (a) {
    case 0:
      cell.v[0] = ia; cell.v[1] = ib; cell.v[2] = ic;
      cell.step_b[0] = 0; cell.step_b[1] = 1; cell.step_b[2] = 0;
      cell.step_c[0] = 0; cell.step_c[1] = 0; cell.step_c[2] = 1;
      break;
    case 1:
      cell.v[0] = ic; cell.v[1] = ia; cell.v[2] = ib;
      cell.step_b[0] = 0; cell.step_b[1] = 0; cell.step_b[2] = 1;
      cell.step_c[0] = 1; cell.step_c[1] = 0; cell.step_c[2] = 0;
      break;
    default:
      cell.v[0] = ib; cell.v[1] = ic; cell.v[2] = ia;
      cell.step_b[0] = 1; cell.step_b[1] = 0; cell.step_b[2] = 0;
      cell.step_c[0] = 0; cell.step_c[1] = 1; cell.step_c[2] = 0;
      break;
  }
  return cell;
}

// Corner k (0-3: +b for bit 0, +c for bit 1) of a face cell, into x, y, z.
inline void face_cell_corner(const FaceCell& cell, uint32_t k, uint32_t& x, uint32_t& y, uint32_t& z) {
  const uint32_t kb = k & 1u, kc = k >> 1;
  x = cell.v[0] + kb * cell.step_b[0] + kc * cell.step_c[0];
  y = cell.v[1] + kb * cell.step_b[1] + kc * cell.step_c[1];
  z = cell.v[2] + kb * cell.step_b[2] + kc * cell.step_c[2];
}

// Index of vertex (x, y, z) in a level's dense slot table (GridLayout::dense_slot), R the level's
// resolution.
inline size_t dense_slot_index(uint32_t x, uint32_t y, uint32_t z, uint32_t R) {
  return (size_t(z) * (R + 1) + y) * (R + 1) + x;
}

// The 4 corners of the face cell (face_cell) of point p at `level`.
// Entries follow `layout` (offsets included), which must be the GridLayout of `config` and the
// model's displacements.
// Inline: the encoder's inner loop calls it once per point and level.
inline void face_corners(const Config& config, uint32_t level, const glm::vec3& p, uint32_t axis,
                         FaceCorners& out, const GridLayout& layout) {
  const FaceCell cell = face_cell(config, level, p, axis);
  const uint32_t R = config.grid_resolution[level];
  const uint32_t offset = layout.level_offset[level], M = config.table_log2[level];
  const PerfectHashView& indexed = layout.indexed[level];
  const uint16_t* dense = layout.dense_slot[level];
  for (uint32_t k = 0; k < 4; ++k) {
    uint32_t x, y, z;
    face_cell_corner(cell, k, x, y, z);
    out.entry[k] = offset + (dense                  ? dense[dense_slot_index(x, y, z, R)]
                             : indexed.displacement ? perfect_hash_slot(indexed, x, y, z)
                                                    : hash_vertex(x, y, z, M));
    out.weight[k] = ((k & 1u) ? cell.wb : 1.0f - cell.wb) * ((k >> 1) ? cell.wc : 1.0f - cell.wc);
  }
}

// Prefetches the dense slots (GridLayout::dense_slot) that face_corners will read for point p at
// `level`; nothing for a level without a dense table.
inline void prefetch_face_corners(const Config& config, uint32_t level, const glm::vec3& p, uint32_t axis,
                                  const GridLayout& layout) {
  const uint16_t* dense = layout.dense_slot[level];
  if (!dense) return;
  const FaceCell cell = face_cell(config, level, p, axis);
  const uint32_t R = config.grid_resolution[level];
  for (uint32_t k = 0; k < 4; ++k) {
    uint32_t x, y, z;
    face_cell_corner(cell, k, x, y, z);
    __builtin_prefetch(dense + dense_slot_index(x, y, z, R));
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
