// voxel_grid.h -- the voxel grid of LSNIF local geometry (paper 3.1): binary occupancy of the object's
// surface on a V^3 grid over its padded AABB. Voxel (i,j,k) covers the unit-cube box
// [i/V,(i+1)/V] x [j/V,(j+1)/V] x [k/V,(k+1)/V]; unit space maps linearly onto the AABB.
#pragma once
#include <cstdint>
#include <vector>

#include "lsnif/core/geometry.h"

namespace lsnif {

struct VoxelGrid {
  uint32_t resolution = 0;   // V
  Aabb bounds;               // padded object AABB the grid spans
  std::vector<uint32_t> bits;  // V^3 bits, voxel index i + V*(j + V*k), bit (idx & 31) of word idx>>5

  bool occupied(int i, int j, int k) const {
    if (i < 0 || j < 0 || k < 0 || i >= int(resolution) || j >= int(resolution) || k >= int(resolution))
      return false;
    uint32_t idx = uint32_t(i) + resolution * (uint32_t(j) + resolution * uint32_t(k));
    return (bits[idx >> 5] >> (idx & 31u)) & 1u;
  }
  void set(uint32_t i, uint32_t j, uint32_t k) {
    uint32_t idx = i + resolution * (j + resolution * k);
    bits[idx >> 5] |= 1u << (idx & 31u);
  }
  uint32_t count_occupied() const;
  // Object space -> unit cube of the grid, and back.
  glm::vec3 to_unit(const glm::vec3& p) const { return (p - bounds.lo) / bounds.extent(); }
  glm::vec3 direction_to_unit(const glm::vec3& d) const { return d / bounds.extent(); }
};

}  // namespace lsnif
