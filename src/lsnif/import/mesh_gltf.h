// mesh_gltf.h -- the glTF importer's flattening step for callers that already hold a parsed glTF
// model and choose which meshes to flatten (the scene converter, src/lsnif/apps/convert): chosen meshes
// under chosen transforms become one object-space training mesh, as load_mesh does for a whole
// file's default scene. Part of lsnif_import (tinygltf is compiled in gltf_access.cpp).
#pragma once
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/import/gltf_access.h"
#include "lsnif/import/mesh.h"

namespace lsnif {

// One glTF mesh placed with `transform` (object space of the mesh -> the flattened mesh's space).
struct GltfMeshPart {
  int mesh = -1;
  glm::dmat4 transform{1.0};
};

// Appends every triangle primitive (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN; other modes are
// skipped with a warning) of each part's mesh, transformed as load_mesh transforms node meshes,
// into `mesh` (cleared first), then finalize_mesh. Materials are created on first use in part and
// primitive order; `material_sources[i]` is the glTF material index mesh material i came from (-1
// for the default material). Errors name `name`, the mesh, the primitive and the problem.
// `allow_dropping_most` is finalize_mesh's.
Status flatten_gltf_meshes(const tinygltf::Model& model, const std::vector<GltfMeshPart>& parts,
                           const std::string& name, Mesh& mesh, std::vector<int>& material_sources,
                           MeshImportReport* report = nullptr, bool allow_dropping_most = false);

}  // namespace lsnif
