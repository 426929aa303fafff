// grid_usage.h -- how a model's sparse hash grid is used (paper 3.2): a boundary point lies on a
// face of an occupied voxel, so the encoding only ever reads the grid vertices on those faces (the
// corners with a non-zero bilinear weight). Per level, how many such vertices there are, how many
// of the level's 2^M_l table entries they hash to, and how many entries two or more of them share (hash
// collisions: those vertices are forced to the same features). The numbers a smaller table has to
// be judged by.
#pragma once
#include <cstdint>
#include <vector>

#include "lsnif/format/config.h"
#include "lsnif/core/perfect_hash.h"
#include "lsnif/core/voxel_grid.h"

namespace lsnif {

struct GridLevelUsage {
  uint32_t resolution = 0;         // R_l
  uint64_t vertices = 0;           // distinct vertices on faces of occupied voxels
  uint64_t table_entries = 0;      // 2^M_l
  uint64_t entries_used = 0;       // entries at least one of those vertices hashes to
  uint64_t entries_shared = 0;     // entries two or more of them hash to
  uint64_t vertices_in_shared = 0; // vertices that hash to a shared entry
  // The collision-free alternative (perfect_hash.h, build_level_index of the vertices): its table
  // entries and its displacements (2 bytes each); 0 when it could not be built.
  uint64_t indexed_slots = 0, indexed_buckets = 0;
};

// The distinct grid vertices of resolution R (a multiple of voxels.resolution) on faces of occupied
// voxels, sorted by (z, y, x): the only vertices the encoder reads with a non-zero weight. Memory:
// the list itself (12 bytes a vertex; readable_vertex_count says how many first).
std::vector<GridVertex> readable_vertices(const VoxelGrid& voxels, uint32_t resolution);
// How many readable_vertices there are, without listing them: time O(V^3), memory about V^3 / 2
// bytes (8 MiB at V = 256) whatever R is.
uint64_t readable_vertex_count(const VoxelGrid& voxels, uint32_t resolution);
// The most readable vertices an indexed level can take: its table (perfect_hash_default_slots of
// them) may have at most 2^max(table-log2) entries (Config::validate).
uint64_t max_indexed_vertices();

// One record per level of `config`, for the occupancy `voxels` (resolution config.voxel_resolution).
// The vertices are counted and hashed without being listed, so the memory is that of the largest
// level's table (a byte per entry) whatever the resolution and occupancy; only a level whose
// vertices an index can take (max_indexed_vertices) has them listed to build that index. Time:
// proportional to the vertices. A hashed level's record says what its own index would cost
// (indexed_slots, indexed_buckets; 0 when it has more vertices than an index takes); an
// indexed level's (Config::indexed) is its index: table_entries = entries_used = index_slots would
// hold every vertex, no entry shared (by construction, checked in grid_usage_test).
std::vector<GridLevelUsage> grid_usage(const Config& config, const VoxelGrid& voxels);

// Makes the levels l < config.grid_levels with indexed[l] indexed for `voxels`: builds each one's
// perfect hash of its readable vertices (build_level_index), sets config.index_slots[l] and
// index_buckets[l], and replaces `grid_index` with the displacements in level order (Model::grid_index).
// Every other level is left hashed. On error (naming the level; a level with more vertices than
// max_indexed_vertices is refused before any is listed) config and grid_index are unchanged.
Status index_grid_levels(const VoxelGrid& voxels, const bool* indexed, Config& config,
                         std::vector<uint16_t>& grid_index);

}  // namespace lsnif
