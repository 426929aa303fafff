// training_mesh.h -- the training mesh file (.lsmesh): a Mesh exactly as an importer or the scene
// converter's flattening left it, written so that load_mesh reads back the same mesh bit for bit
// (same mesh_hash, settings_io.h). What a cluster job of `lsnif convert --plan` trains on
// (docs/cluster.md): glTF would re-derive normals, texture transforms and material order on the
// way back, and a model is adopted only when it was trained on exactly the planned mesh.
//
// Layout (docs/cluster.md), little-endian, packed: "LSNIFMSH", u32 version (1), u32 flags (0), seven
// u64 counts (positions, normals, uvs, colours, triangles, materials, textures), the float arrays,
// the triangles' u32 corners and materials, each material (u32 name length, the name, its factors,
// texture indices, five uv transforms, u32 alpha mode, alpha and alpha cutoff), each texture (u32 width, height, the RGBA bytes), and a
// CRC-32 of everything before it.
#pragma once
#include <string>

#include "lsnif/format/status.h"
#include "lsnif/import/mesh.h"

namespace lsnif {

// The training mesh file's extension, as load_mesh recognizes it.
inline constexpr const char* kTrainingMeshExtension = ".lsmesh";

// The bytes of `mesh` in the training mesh format. The mesh must be finalized (finalize_mesh: every
// triangle valid, normals per vertex, at least one material): an error names what is not.
Status training_mesh_bytes(const Mesh& mesh, std::string& out);

// Writes `mesh` to `path` atomically (write_file_atomic). Errors name the path.
Status save_training_mesh(const Mesh& mesh, const std::string& path);

}  // namespace lsnif
