// voxelizer.h -- LSNIF local geometry voxelization (paper 3.1): the surface of a mesh onto a V^3
// occupancy grid (src/lsnif/core/voxel_grid.h) over its padded AABB, with an exact triangle/box test.
#pragma once
#include <cstdint>

#include "lsnif/import/mesh.h"
#include "lsnif/core/voxel_grid.h"

namespace lsnif {

// Marks every voxel whose closed box overlaps at least one triangle (exact separating-axis
// triangle/box test; polygon soup, no topology assumed). `bounds` is normally pad_aabb(mesh.bounds()).
// With `opaque_cells_only`, a triangle of an alpha cut-out material marks only the voxels its
// possibly-opaque parts overlap: it is cut into sub-triangles of about half a texel (at most 64 per
// edge) and one whose texels' largest alpha (times the factor alpha) is below the cutoff marks
// nothing. Conservative: a voxel holding a point where Mesh::opaque_at is true is always marked.
VoxelGrid voxelize(const Mesh& mesh, uint32_t resolution, const Aabb& bounds, bool opaque_cells_only = false);

// Exact triangle / axis-aligned box overlap test (separating axis theorem, 13 axes). Touching
// counts as overlap.
bool triangle_box_overlap(const glm::vec3& box_center, const glm::vec3& box_half,
                          const glm::vec3& a, const glm::vec3& b, const glm::vec3& c);

}  // namespace lsnif
