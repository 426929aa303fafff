// uv_materials.h -- which materials of a mesh report texture coordinates (Config::uv_materials) and
// the uv cells their hits read them from (src/lsnif/core/uv_cells.h). A material whose hits report a
// texture coordinate keeps its textures: the renderer samples them there, at full detail, instead of
// shading the colours a small network can hold. Where that cannot work the material stays on learned
// colours, and a warning names it and why.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/format/status.h"

namespace lsnif {

struct UvMaterialChoice {
  uint64_t materials = 0;  // bit m: material m reports the texture coordinate
  std::vector<std::string> warnings;      // a textured material left on learned colours, and why
};

// The choice under `texture_coordinates` (kTextureCoordinatesAuto / Off, settings_table.h). Auto:
// every material with a texture, unless the mesh has no uvs for it, one of its triangles' uvs is not
// finite or lies beyond +-LSNIF_MAX_UV, or its vertex colours tint it (the textures alone would not
// give its colour).
UvMaterialChoice choose_uv_materials(const Mesh& mesh, uint32_t texture_coordinates);

// The uv cells of `model` (its config's uv_materials and uv_cells, its voxels) from `mesh`, the mesh
// it is trained on: model.uv_cells and the config's uv_cell_voxels and uv_cell_maps. Each cell of an
// occupied voxel gets a map per surface piece of those materials' triangles in it (the triangles
// sampled every quarter cell, grouped by material and uv chart, uv_layout.h): the heaviest piece,
// and the heaviest one facing more than 60 degrees away from it (the far side of a thin part); the
// affine coordinate fitted to its samples by least squares (regularized: none along the normal).
// Nothing to do for a model without texture-coordinate materials.
Status build_uv_cells(const Mesh& mesh, Model& model);

// The measured half of the choice, after training (`model` trained on `mesh`, its uv cells built):
// each texture-coordinate material keeps its coordinates only where its hits shade at least as
// close to the reference with its own textures as with the learned colours (EvalReport's channel
// errors on kUvMaterialRays held-out rays, the textures' at most kUvMaterialGain times the
// colours'; a mean error favours a blur, so no more is asked); the others are cleared from the
// config's uv_materials, each named in a warning with both errors, and the cells are rebuilt for
// the materials left. A material with fewer than kUvMaterialMinHits hits keeps its coordinates.
inline constexpr size_t kUvMaterialRays = 16384;
inline constexpr double kUvMaterialGain = 1.0;  // the textures' error at most this times the colours'
inline constexpr uint64_t kUvMaterialMinHits = 64;
Status measure_uv_materials(const Mesh& mesh, Model& model, std::vector<std::string>& warnings);

}  // namespace lsnif
