// gltf_primitive.h -- the one reader of a glTF mesh primitive: its mode, material, vertex attributes
// and the triangles it draws, read through the checked accessor reader (gltf_access.h). The
// training mesh importer (mesh_gltf.cpp: `lsnif train`, `eval`, the converter's flattening) and the
// renderer's scene loader (src/lsnif/scene/scene_gltf_meshes.cpp: `render`, `view`, `bench`)
// both read primitives here, so a file gives every tool the same triangles. What each does with
// what it reads (transforms, where a NaN position is an error or a dropped triangle, how it words
// a warning) stays the caller's. Part of lsnif_import.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/format/status.h"
#include "lsnif/import/gltf_access.h"

namespace lsnif::gltf {

// What read_primitive takes besides the primitive.
struct PrimitiveReadOptions {
  int uv_set = 0;       // the TEXCOORD_<uv_set> attribute read as the uvs (the material's set)
  bool colors = false;  // read COLOR_0 as well
};

// One primitive as stored (object space, the file's values as doubles).
struct PrimitiveRead {
  int mode = TINYGLTF_MODE_TRIANGLES;  // the primitive's mode (absent: TRIANGLES)
  bool triangle_mode = true;           // TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN; else nothing below is read
  bool morph_targets = false;          // the primitive has morph targets (the base shape is read)
  int material = -1;                   // glTF material index (checked to exist), -1: none named
  std::vector<double> positions;       // 3 per vertex
  // 3 per vertex, or empty: the primitive has no NORMAL, or one of them is NaN, infinite or zero
  // (bad_normal names the first), and then the primitive is shaded with face normals (glTF).
  std::vector<double> normals;
  int64_t bad_normal = -1;
  std::string uv_key;                  // "TEXCOORD_<uv_set>"
  bool has_uvs = false;                // the primitive has that attribute
  std::vector<double> uvs;             // 2 per vertex when has_uvs
  std::vector<double> colors;          // COLOR_0, color_components per vertex (options.colors)
  int color_components = 0;
  size_t index_count = 0;              // indices read (or vertices, without an index accessor)
  // The triangles the primitive draws (triangle_list of its mode): 3 vertex indices per triangle,
  // each < positions.size() / 3. A TRIANGLES primitive ignores a remainder of index_count % 3.
  std::vector<uint32_t> triangles;
};

// Reads `prim` of `model`. Errors are prefixed `where` (e.g. "FILE: mesh 2 ('wheel') primitive 0"):
// a Draco-compressed primitive, a material that does not exist, a missing or unreadable POSITION,
// an attribute whose count differs from POSITION's, an index accessor that is not an unsigned
// SCALAR, normalized, or holding an index >= the vertex count (glTF's rules; gltf_access.h).
// A primitive of another mode is not an error: triangle_mode is false and nothing else is read.
Status read_primitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, const PrimitiveReadOptions& options,
                      const std::string& where, PrimitiveRead& out);

}  // namespace lsnif::gltf
