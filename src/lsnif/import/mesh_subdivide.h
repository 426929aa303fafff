// mesh_subdivide.h -- uniform 1-to-4 midpoint subdivision of a triangle mesh, used to make
// heavier versions of a mesh for the memory benchmark (`lsnif bench-memory`). Every edge gets one
// new vertex at its midpoint, shared by the triangles on both sides, so a watertight mesh stays
// watertight; each triangle (a, b, c) becomes (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)
// with the parent's winding. The surface does not change shape (it is not a smoothing scheme).
#pragma once
#include <cstdint>

#include "lsnif/import/mesh.h"
#include "lsnif/format/status.h"

namespace lsnif {

// One level of subdivision of `in` into `out` (replaced; `in` and `out` may be the same object).
// Counts: out has V + E vertices (the V originals first, in order, then one per distinct
// undirected edge) and 4F triangles, the four children of triangle i at 4i .. 4i+3. Per-vertex
// attributes present for every vertex are carried over: a midpoint's uv and color are the averages
// of its edge's ends, its normal the normalized sum (the first end's normal when the sum
// vanishes); triangle_material is repeated for the children; materials and textures are copied.
// Attributes whose count does not match the vertex (triangle) count are dropped. Fails, naming
// the first offending vertex or triangle, on an empty mesh, an index out of range, a repeated
// index or a zero-area triangle, a non-finite position, or when the result would not fit 32-bit
// indices.
Status subdivide_midpoint(const Mesh& in, Mesh& out);

// `levels` levels of subdivide_midpoint (levels = 0 copies `in`). Same failures.
Status subdivide_midpoint(const Mesh& in, uint32_t levels, Mesh& out);

// The level L in [0, max_level] whose triangle count triangles * 4^L is closest to `target`
// (absolute difference; the lower level on a tie). 0 when triangles is 0.
uint32_t subdivision_level_for(uint64_t triangles, uint64_t target, uint32_t max_level = 16);

}  // namespace lsnif
