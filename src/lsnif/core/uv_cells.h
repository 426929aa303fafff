// uv_cells.h -- where an LSNIF hit of a texture-coordinate material (Config::uv_materials) reads its
// texture coordinate: the model's uv cells (words: src/lsnif/format/uv_cell_layout.h; built from the
// mesh by build_uv_cells, src/lsnif/train/uv_materials.h). The network predicts the hit (its
// distance and normal); the uv cells hold, per cell of a grid finer than the voxels, the plane and
// the affine texture coordinate of up to two surface pieces (facing apart). The coordinate of a hit
// is that of the piece nearest the predicted point among the 3 x 3 x 3 cells around it, facing the
// predicted normal's way, read where the ray meets the piece's plane: a hit point off along the ray
// by the network's distance error still lands on the texel the ray sees. Measured better than the
// network learning the coordinate itself (docs/convert.md, "Textures at full detail").
// The one C++ definition; mirrored by src/lsnif/shaders/lsnif_uv_cells.glsl.
#pragma once
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/core/model.h"

namespace lsnif {

// One map of uv_cell_layout.h, decoded: in cell units from the cell's centre.
struct UvMap {
  glm::vec2 uv0{0.0f};                 // the coordinate at the cell's centre
  glm::vec3 du{0.0f}, dv{0.0f};        // its change across one cell edge along x, y, z
  glm::vec3 normal{0.0f, 0.0f, 1.0f};  // the plane's normal (unit after unpacking; in cell units)
  float offset = 0.0f;                 // the plane: dot(normal, r) = offset, r from the cell's centre
};

// The 6 words of a map (quantized as uv_cell_layout.h says: fp16 gradients, snorm8 normal and
// offset; the offset clamped to +-sqrt(3)/2) and back. unpack(pack(m)) is what every reader sees.
void pack_uv_map(const UvMap& m, uint32_t* words);
UvMap unpack_uv_map(const uint32_t* words);

// A model's uv cells ready for lookups: the rank of each occupied voxel (its voxel record).
class UvCells {
 public:
  explicit UvCells(const Model& model);
  // The texture coordinate for a hit predicted at object-space point `x` with object-space normal
  // `normal` by a ray of object-space direction `direction`; false (uv untouched) when no piece lies
  // within the cells around x facing the normal's way, or the model has no uv cells.
  bool lookup(glm::vec3 x, glm::vec3 normal, glm::vec3 direction, glm::vec2& uv) const;

 private:
  const Model& model_;
  uint32_t cells_per_axis_ = 0;
  glm::vec3 cell_size_{1.0f};
  std::vector<uint32_t> rank_;  // occupied voxels in the words before each voxel word
};

}  // namespace lsnif
