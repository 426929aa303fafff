// uv_cell_layout.h -- the words of a model's uv cells (Config::uv_materials; src/lsnif/core/uv_cells.h
// reads them, src/lsnif/train/uv_materials.h builds them), the same in the .lsnif file (version 7),
// in memory (Model::uv_cells) and in the GPU block: where the texture coordinate of a hit is read.
//
// The cells are a grid of V x S per axis over the model's padded AABB (S = Config::uv_cells); only
// cells inside occupied voxels hold anything. Words, little-endian:
//  voxel records: one per occupied voxel, in voxel index order (i + V (j + V k)), kUvVoxelWords
//    words: the index of its first map, then two 64-bit masks over its S^3 cells (cell
//    x + S (y + S z) of the voxel, low word first): cells with a map, cells with a second map.
//    A voxel's maps follow one another, cell by cell, a cell's two maps together.
//  maps: config.uv_cell_maps of kUvMapWords words each, one surface piece of one chart in one cell:
//    the plane n . (x - centre) = h and the affine texture coordinate uv(x) = uv0 + G (x - centre)
//    with x in cell units from the cell's centre:
//     0, 1  uv0 (fp32): the coordinate at the cell's centre
//     2     du/dx, du/dy (fp16 pair, low half first): the coordinate's change across one cell edge
//     3     du/dz, dv/dx
//     4     dv/dy, dv/dz
//     5     bytes 0-2 the plane's normal n (snorm8, in cell units; any length), byte 3 h (snorm8,
//           in half cell diagonals: h x sqrt(3) / 2 / 127 cell edges)
#pragma once
#include <cstddef>
#include <cstdint>

#include "lsnif/format/config.h"
#include "lsnif/format/status.h"

namespace lsnif {

constexpr uint32_t kUvVoxelWords = 5;
constexpr uint32_t kUvMapWords = 6;

// Words of the uv cells of a model with this config: voxel records and maps.
inline uint64_t uv_cell_words(const Config& c) {
  return uint64_t(kUvVoxelWords) * c.uv_cell_voxels + uint64_t(kUvMapWords) * c.uv_cell_maps;
}

// Checks `words` (uv_cell_words(config) of them, host order) against the config: first-map indices
// in order, masks only over the S^3 cells with second maps only where there are first maps, the maps'
// count the config's, every coordinate finite within +-LSNIF_MAX_UV and every gradient a finite
// fp16 value. The message names the voxel record or map.
Status check_uv_cells(const Config& config, const uint32_t* words);

}  // namespace lsnif
