// voxel_grid.cpp -- the occupancy grid of voxel_grid.h (the voxelizer is src/lsnif/train/voxelizer.cpp).
#include "lsnif/core/voxel_grid.h"

#include <bit>

namespace lsnif {

uint32_t VoxelGrid::count_occupied() const {
  uint32_t n = 0;
  for (uint32_t word : bits) n += static_cast<uint32_t>(std::popcount(word));
  return n;
}

}  // namespace lsnif
