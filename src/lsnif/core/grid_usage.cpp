// grid_usage.cpp -- see grid_usage.h. The vertices are never listed with repeats: a lattice point of
// level resolution R = n V lies on a face of an occupied voxel exactly when one of its coordinates
// is a multiple of n (it is on a voxel plane) and one of the voxels whose closed box holds it is
// occupied (each of those has it on its boundary). Along an axis, coordinate c is of class 2 (c / n)
// when c % n == 0 (the plane between voxels c / n - 1 and c / n) and 2 (c / n) + 1 otherwise (inside
// voxel c / n): 2 V + 1 classes. A row of lattice points (fixed y, z) depends only on the classes of
// y and z, through the voxels of x that some voxel of those classes makes occupied (a bit set per
// class pair). Counting needs one pass over the class pairs; listing or hashing the vertices one
// pass over the rows, with memory independent of R.
#include "lsnif/core/grid_usage.h"

#include <algorithm>

#include "lsnif/core/hash_grid.h"
#include "lsnif/format/settings_table.h"

namespace lsnif {
namespace {

class ReadableLattice {
 public:
  ReadableLattice(const VoxelGrid& voxels, uint32_t resolution)
      : V_(voxels.resolution), n_(resolution / voxels.resolution), words_((V_ + 63) / 64), classes_(2 * V_ + 1),
        rows_(size_t(classes_) * classes_ * words_, 0) {
    // plain[(k V + j) words + w]: the occupied voxels of row (j, k).
    std::vector<uint64_t> plain(size_t(V_) * V_ * words_, 0);
    for (uint32_t k = 0; k < V_; ++k)
      for (uint32_t j = 0; j < V_; ++j)
        for (uint32_t i = 0; i < V_; ++i)
          if (voxels.occupied(int(i), int(j), int(k))) plain[(size_t(k) * V_ + j) * words_ + i / 64] |= uint64_t(1) << (i % 64);
    for (uint32_t kc = 0; kc < classes_; ++kc)
      for (uint32_t jc = 0; jc < classes_; ++jc) {
        uint64_t* row = &rows_[(size_t(kc) * classes_ + jc) * words_];
        for (uint32_t k = first_voxel(kc); k <= last_voxel(kc); ++k)
          for (uint32_t j = first_voxel(jc); j <= last_voxel(jc); ++j)
            for (uint32_t w = 0; w < words_; ++w) row[w] |= plain[(size_t(k) * V_ + j) * words_ + w];
      }
  }

  // The number of readable vertices.
  uint64_t count() const {
    uint64_t total = 0;
    for (uint32_t kc = 0; kc < classes_; ++kc)
      for (uint32_t jc = 0; jc < classes_; ++jc) {
        const uint64_t rows = multiplicity(kc) * multiplicity(jc);
        if (rows == 0) continue;
        const uint64_t* bits = row(jc, kc);
        const bool plane = kc % 2 == 0 || jc % 2 == 0;
        uint64_t in_row = 0;
        bool previous = false;  // voxel i - 1 occupied
        for (uint32_t i = 0; i < V_; ++i) {
          const bool occupied = bit(bits, i);
          // On a plane: x in [i n, (i + 1) n], the left end shared with an occupied voxel i - 1.
          // Off the planes: x = i n and (i + 1) n, the former shared likewise.
          if (occupied) in_row += (plane ? n_ : 1) + (previous ? 0 : 1);
          previous = occupied;
        }
        total += rows * in_row;
      }
    return total;
  }

  // Calls emit(x, y, z) for every readable vertex, ordered by (z, y, x).
  template <typename Emit>
  void for_each(Emit&& emit) const {
    const uint32_t R = V_ * n_;
    for (uint32_t z = 0; z <= R; ++z)
      for (uint32_t y = 0; y <= R; ++y) {
        const uint32_t kc = class_of(z), jc = class_of(y);
        const uint64_t* bits = row(jc, kc);
        if (std::all_of(bits, bits + words_, [](uint64_t w) { return w == 0; })) continue;
        const bool plane = kc % 2 == 0 || jc % 2 == 0;
        uint64_t next = 0;  // the first x not emitted yet
        for (uint32_t i = 0; i < V_; ++i) {
          if (!bit(bits, i)) continue;
          const uint32_t step = plane ? 1 : n_;
          uint64_t x = uint64_t(i) * n_;
          if (x < next) x = plane ? next : x + n_;  // voxel i - 1 emitted x = i n already
          for (; x <= uint64_t(i + 1) * n_; x += step) emit(uint32_t(x), y, z);
          next = uint64_t(i + 1) * n_ + 1;
        }
      }
  }

 private:
  uint32_t class_of(uint32_t c) const { return 2 * (c / n_) + (c % n_ != 0); }
  // Lattice coordinates of a class: 1 on a plane, n - 1 inside a voxel.
  uint64_t multiplicity(uint32_t cls) const { return cls % 2 == 0 ? 1 : n_ - 1; }
  // The voxels whose closed extent holds the coordinates of a class.
  uint32_t first_voxel(uint32_t cls) const { return cls % 2 ? cls / 2 : cls / 2 - (cls > 0); }
  uint32_t last_voxel(uint32_t cls) const { return std::min(cls / 2, V_ - 1); }
  const uint64_t* row(uint32_t jc, uint32_t kc) const { return &rows_[(size_t(kc) * classes_ + jc) * words_]; }
  static bool bit(const uint64_t* bits, uint32_t i) { return bits[i / 64] >> (i % 64) & 1u; }

  uint32_t V_, n_, words_, classes_;
  std::vector<uint64_t> rows_;  // per class pair (jc, kc): the voxels of x made occupied
};

}  // namespace

uint64_t readable_vertex_count(const VoxelGrid& voxels, uint32_t resolution) {
  return ReadableLattice(voxels, resolution).count();
}

std::vector<GridVertex> readable_vertices(const VoxelGrid& voxels, uint32_t resolution) {
  const ReadableLattice lattice(voxels, resolution);
  std::vector<GridVertex> out;
  out.reserve(size_t(lattice.count()));
  lattice.for_each([&](uint32_t x, uint32_t y, uint32_t z) { out.push_back(GridVertex{x, y, z}); });
  return out;
}

uint64_t max_indexed_vertices() {
  const uint64_t max_slots = uint64_t(1) << max_u32(SettingId::TableLog2);
  // The most keys whose default table size (N plus 1%) fits: just below 100 / 101 of the slots.
  uint64_t n = max_slots * 100 / 101 + 2;
  while (n > 0 && perfect_hash_default_slots(n) > max_slots) --n;
  return n;
}

std::vector<GridLevelUsage> grid_usage(const Config& config, const VoxelGrid& voxels) {
  std::vector<GridLevelUsage> out;
  for (uint32_t level = 0; level < config.grid_levels; ++level) {
    GridLevelUsage u;
    u.resolution = config.grid_resolution[level];
    u.table_entries = config.table_size(level);
    const ReadableLattice lattice(voxels, u.resolution);
    u.vertices = lattice.count();
    if (config.indexed(level)) {
      u.entries_used = u.vertices;
      u.indexed_slots = config.index_slots[level];
      u.indexed_buckets = config.index_buckets[level];
      out.push_back(u);
      continue;
    }
    // Per entry: 0, 1 or 2 for two or more vertices (the vertices of shared entries are all the
    // vertices but those alone in theirs).
    std::vector<uint8_t> per_entry(size_t(u.table_entries), 0);
    const uint32_t log2 = config.table_log2[level];
    lattice.for_each([&](uint32_t x, uint32_t y, uint32_t z) {
      uint8_t& n = per_entry[hash_vertex(x, y, z, log2)];
      n = uint8_t(n + (n < 2));
    });
    uint64_t alone = 0;
    for (const uint8_t n : per_entry) {
      u.entries_used += n > 0;
      u.entries_shared += n > 1;
      alone += n == 1;
    }
    u.vertices_in_shared = u.vertices - alone;
    PerfectHash index;
    if (u.vertices <= max_indexed_vertices() && build_level_index(readable_vertices(voxels, u.resolution), index).is_ok()) {
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
    const uint64_t count = readable_vertex_count(voxels, config.grid_resolution[l]);
    if (count > max_indexed_vertices())
      return Status::error("indexing grid level %u: its %llu readable vertices are more than an indexed level holds "
                           "(%llu: at most 2^%u entries); leave the level hashed or lower its resolution", l,
                           (unsigned long long)count, (unsigned long long)max_indexed_vertices(),
                           max_u32(SettingId::TableLog2));
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
