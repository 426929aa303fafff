// uv_cell_layout.cpp -- check_uv_cells (uv_cell_layout.h).
#include "lsnif/format/uv_cell_layout.h"

#include <bit>
#include <cmath>

namespace lsnif {

namespace {
bool half_finite(uint32_t h) { return (h & 0x7c00u) != 0x7c00u; }
}  // namespace

Status check_uv_cells(const Config& c, const uint32_t* words) {
  const uint32_t cells = c.uv_cells * c.uv_cells * c.uv_cells;
  const uint64_t allowed = cells >= 64 ? ~uint64_t(0) : (uint64_t(1) << cells) - 1;
  uint64_t total = 0;
  for (uint32_t v = 0; v < c.uv_cell_voxels; ++v) {
    const uint32_t* r = words + size_t(v) * kUvVoxelWords;
    const uint64_t first = uint64_t(r[1]) | uint64_t(r[2]) << 32, second = uint64_t(r[3]) | uint64_t(r[4]) << 32;
    if (r[0] != total)
      return Status::error("uv cells: voxel record %u's first map is %u, the maps before it number %llu", v, r[0],
                           (unsigned long long)total);
    if ((first & ~allowed) || (second & ~first))
      return Status::error("uv cells: voxel record %u's masks (0x%016llx, 0x%016llx) name cells beyond its %u or "
                           "second maps without a first", v, (unsigned long long)first, (unsigned long long)second,
                           cells);
    total += uint64_t(std::popcount(first)) + uint64_t(std::popcount(second));
  }
  if (total != c.uv_cell_maps)
    return Status::error("uv cells: the voxel records hold %llu maps, the header says %u", (unsigned long long)total,
                         c.uv_cell_maps);
  const uint32_t* maps = words + size_t(c.uv_cell_voxels) * kUvVoxelWords;
  for (uint32_t m = 0; m < c.uv_cell_maps; ++m) {
    const uint32_t* w = maps + size_t(m) * kUvMapWords;
    for (int a = 0; a < 2; ++a)
      if (!(std::fabs(std::bit_cast<float>(w[a])) <= float(LSNIF_MAX_UV)))
        return Status::error("uv cells: map %u's texture coordinate %g is not finite within +-%g", m,
                             double(std::bit_cast<float>(w[a])), LSNIF_MAX_UV);
    for (int k = 2; k < 5; ++k)
      if (!half_finite(w[k] & 0xffffu) || !half_finite(w[k] >> 16))
        return Status::error("uv cells: map %u has a gradient that is not a finite fp16 value", m);
  }
  return Status::ok();
}

}  // namespace lsnif
