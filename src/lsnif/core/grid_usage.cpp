// grid_usage.cpp -- see grid_usage.h. Every face of every occupied voxel contributes its
// (n + 1)^2 grid vertices, n = R_l / V cells per voxel edge; a sorted list of packed coordinates
// removes the vertices that neighbouring faces share.
#include "lsnif/core/grid_usage.h"

#include <algorithm>

#include "lsnif/core/hash_grid.h"

namespace lsnif {

std::vector<GridVertex> readable_vertices(const VoxelGrid& voxels, uint32_t resolution) {
  const uint32_t V = voxels.resolution, n = resolution / V;
  auto pack = [](uint64_t x, uint64_t y, uint64_t z) { return x | y << 21 | z << 42; };
  std::vector<uint64_t> found;
  for (uint32_t k = 0; k < V; ++k)
    for (uint32_t j = 0; j < V; ++j)
      for (uint32_t i = 0; i < V; ++i) {
        if (!voxels.occupied(int(i), int(j), int(k))) continue;
        const uint32_t cell[3] = {i, j, k};
        for (uint32_t a = 0; a < 3; ++a) {
          const uint32_t b = (a + 1) % 3, c = (a + 2) % 3;
          for (uint32_t side = 0; side < 2; ++side) {  // the voxel's two faces of axis a
            uint32_t v[3];
            v[a] = (cell[a] + side) * n;
            for (uint32_t db = 0; db <= n; ++db)
              for (uint32_t dc = 0; dc <= n; ++dc) {
                v[b] = cell[b] * n + db;
                v[c] = cell[c] * n + dc;
                found.push_back(pack(v[0], v[1], v[2]));
              }
          }
        }
      }
  std::sort(found.begin(), found.end());
  found.erase(std::unique(found.begin(), found.end()), found.end());
  std::vector<GridVertex> out(found.size());
  for (size_t i = 0; i < found.size(); ++i)
    out[i] = GridVertex{uint32_t(found[i] & 0x1fffff), uint32_t(found[i] >> 21 & 0x1fffff), uint32_t(found[i] >> 42)};
  return out;
}

std::vector<GridLevelUsage> grid_usage(const Config& config, const VoxelGrid& voxels) {
  std::vector<GridLevelUsage> out;
  for (uint32_t level = 0; level < config.grid_levels; ++level) {
    GridLevelUsage u;
    u.resolution = config.grid_resolution[level];
    u.table_entries = config.table_size(level);
    const std::vector<GridVertex> found = readable_vertices(voxels, u.resolution);
    u.vertices = found.size();
    if (config.indexed(level)) {
      u.entries_used = u.vertices;
      u.indexed_slots = config.index_slots[level];
      u.indexed_buckets = config.index_buckets[level];
      out.push_back(u);
      continue;
    }
    std::vector<uint32_t> per_entry(size_t(u.table_entries), 0);
    for (const GridVertex& v : found) ++per_entry[hash_vertex(v.x, v.y, v.z, config.table_log2[level])];
    for (const uint32_t count : per_entry) {
      u.entries_used += count > 0;
      if (count > 1) {
        ++u.entries_shared;
        u.vertices_in_shared += count;
      }
    }
    PerfectHash index;
    if (build_level_index(found, index).is_ok()) {
      u.indexed_slots = index.slots;
      u.indexed_buckets = index.displacement.size();
    }
    out.push_back(u);
  }
  return out;
}

Status index_grid_levels(const VoxelGrid& voxels, const bool* indexed, Config& config,
                         std::vector<uint16_t>& grid_index) {
  Config c = config;
  std::vector<uint16_t> index;
  for (uint32_t l = 0; l < config.grid_levels && l < LSNIF_MAX_LEVELS; ++l) {
    c.index_slots[l] = c.index_buckets[l] = 0;
    if (!indexed[l]) continue;
    PerfectHash hash;
    const std::vector<GridVertex> keys = readable_vertices(voxels, config.grid_resolution[l]);
    if (Status s = build_level_index(keys, hash); !s) return s.context(format("indexing grid level %u", l));
    c.index_slots[l] = hash.slots;
    c.index_buckets[l] = uint32_t(hash.displacement.size());
    index.insert(index.end(), hash.displacement.begin(), hash.displacement.end());
  }
  if (Status s = c.validate(); !s) return s.context("indexing the grid");
  config = c;
  grid_index = std::move(index);
  return Status::ok();
}

}  // namespace lsnif
