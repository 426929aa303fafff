// triangle_order.h -- BLAS input order. Lavapipe builds its BVH by splitting the primitive list in
// input order without spatial sorting, so a mesh in file order can trace ~100x slower than the
// same mesh sorted (measured: docs/bench-trace.md). GPU drivers sort by themselves; sorting the
// input costs them nothing.
#pragma once
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace lsnif::vk {

// The triangles (3 indices each into `positions`, every index valid) in the order of the 30-bit
// Morton code of their centroids in the positions' bounding box; ties keep input order.
std::vector<uint32_t> morton_triangle_order(const std::vector<glm::vec3>& positions,
                                            const std::vector<uint32_t>& indices);

}  // namespace lsnif::vk
