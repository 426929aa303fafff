// voxelizer.h -- LSNIF local geometry voxelization (paper 3.1): the surface of a mesh onto a V^3
// occupancy grid (src/lsnif/core/voxel_grid.h) over its padded AABB, with an exact triangle/box test.
#pragma once
#include <cstdint>

#include "lsnif/import/mesh.h"
#include "lsnif/core/voxel_grid.h"

namespace lsnif {

// Marks every voxel whose closed box overlaps at least one triangle (exact separating-axis
// triangle/box test; polygon soup, no topology assumed). `bounds` is normally pad_aabb(mesh.bounds()).
VoxelGrid voxelize(const Mesh& mesh, uint32_t resolution, const Aabb& bounds);

// Exact triangle / axis-aligned box overlap test (separating axis theorem, 13 axes). Touching
// counts as overlap.
bool triangle_box_overlap(const glm::vec3& box_center, const glm::vec3& box_half,
                          const glm::vec3& a, const glm::vec3& b, const glm::vec3& c);

}  // namespace lsnif
