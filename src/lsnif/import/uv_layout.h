// uv_layout.h -- what a material's texture-coordinate layout looks like, measured on the mesh:
// its charts and seams, mirrored pieces, texels covered more than once, coordinates outside
// [0, 1] (tiling). A model that learns where to sample a texture (instead of the texture's colours)
// must land on the right side of every seam and cannot tell overlapping pieces apart; this is what
// decides whether a material's layout allows that, and names what does not. Part of lsnif_import.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/import/mesh.h"

namespace lsnif {

struct UvLayout {
  uint32_t triangles = 0;       // of the material, with uvs
  uint32_t charts = 0;          // pieces connected across edges whose two sides have the same uvs
  uint32_t seam_edges = 0;      // edges of the surface (welded by position) whose sides' uvs differ
  uint32_t mirrored_triangles = 0;  // uv winding opposite to the material's majority
  double overlap_fraction = 0;  // of the covered uv area, the share covered more than once
  bool tiling = false;          // a coordinate outside [0, 1]
  glm::vec2 uv_min{0.0f}, uv_max{0.0f};
  // Per triangle of the mesh: its chart in [0, charts), or kNoChart for another material's (or one
  // without uvs); empty when the material has no triangle with uvs.
  std::vector<uint32_t> triangle_chart;
  static constexpr uint32_t kNoChart = ~0u;
  // "3 charts, 12 seam edges, 0 mirrored, 0.0% overlap, uv in [0, 1] x [0, 1]", and " (tiling)"
  std::string describe() const;
};

// The layout of the triangles of `material` (Mesh::triangle_material) that have uvs; an empty
// layout (triangles 0) when the mesh has none. Positions are welded on a grid of cells `weld` times
// the mesh's bounding-box diagonal wide (two positions in one cell are one point; a non-finite one
// is a point of its own), uvs compared within `uv_tolerance`; overlap is measured on a
// `grid` x `grid` raster of the uv bounding box (cell centres covered by two or more triangles).
UvLayout analyze_uv_layout(const Mesh& mesh, uint32_t material, float weld = 1e-6f, float uv_tolerance = 1e-5f,
                           uint32_t grid = 256);

// Where a material's charts lie in uv space, to tell whether a uv point lands on a given chart: the
// material's triangles (of a layout from analyze_uv_layout) bucketed in a grid over its uv box.
class UvChartMap {
 public:
  UvChartMap(const Mesh& mesh, const UvLayout& layout, uint32_t grid = 256);
  // Whether `uv` lies within `tolerance` (uv units, per axis) of a triangle of chart `chart`.
  bool on_chart(glm::vec2 uv, uint32_t chart, float tolerance) const;

 private:
  const Mesh& mesh_;
  const UvLayout& layout_;
  uint32_t grid_;
  glm::vec2 lo_, cell_;
  std::vector<uint32_t> first_, triangles_;  // triangles_[first_[c] .. first_[c + 1]) overlap cell c
};

}  // namespace lsnif
