// mesh.h -- an object's triangle soup in object space, as the importers produce it and the
// voxelizer, the ground-truth ray caster and the model's material table consume it.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/core/geometry.h"
#include "lsnif/format/status.h"

namespace lsnif {

struct Texture {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;  // 8-bit sRGB-encoded RGBA, row-major, top row first
  // Bilinear lookup with repeat wrapping at uv; returns linear RGB (sRGB decoded).
  glm::vec3 sample(glm::vec2 uv) const;
};

struct Material {
  std::string name;
  glm::vec3 base_color{1.0f};  // linear RGB factor (glTF baseColorFactor.rgb)
  int texture = -1;            // index into Mesh::textures or -1 (glTF baseColorTexture)
};

struct Mesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;    // per vertex; empty -> computed by compute_vertex_normals()
  std::vector<glm::vec2> uvs;        // per vertex; may be empty
  std::vector<glm::vec3> colors;     // per vertex linear RGB; may be empty (white)
  std::vector<glm::uvec3> triangles; // vertex indices
  std::vector<uint32_t> triangle_material;  // per triangle, index into materials
  std::vector<Material> materials;   // at least one after import
  std::vector<Texture> textures;

  Aabb bounds() const;
  // Reference albedo at a hit: base color * texture(uv) * vertex color, barycentrics (u, v) as in
  // Embree (p = (1-u-v) p0 + u p1 + v p2).
  glm::vec3 albedo(uint32_t triangle, float u, float v) const;
  // Interpolated shading normal (normalized) at a hit; falls back to the face normal if the
  // interpolated one degenerates.
  glm::vec3 shading_normal(uint32_t triangle, float u, float v) const;
};

struct MeshImportReport {
  uint32_t dropped_degenerate = 0;  // zero-area or repeated-index triangles removed
  uint32_t dropped_invalid = 0;     // triangles referencing NaN/Inf positions or bad indices
  uint32_t fixed_normals = 0;       // vertex normals that were missing/NaN and were recomputed
  std::vector<std::string> warnings;
};

// What the user allows an import to do beyond the safe defaults.
struct MeshImportOptions {
  // Files the mesh refers to (OBJ mtllib, glTF buffers and images) may lie outside the mesh file's
  // folder (`..` escapes, absolute paths). Default: refused (resolve_path.h).
  bool allow_outside_refs = false;
  // Import a mesh of which more than kMaxDroppedFraction of the triangles are dropped as
  // degenerate or invalid (default: an error, since the rest is rarely the object meant).
  bool allow_dropping_most = false;
};

// More than this fraction of a mesh's triangles dropped is an error unless allow_dropping_most.
inline constexpr double kMaxDroppedFraction = 0.5;

// Loads .off, .obj, .ply, .gltf or .glb by extension (case-insensitive). glTF node transforms are
// flattened into object space; every triangle primitive of every mesh in the default scene is kept.
// Degenerate and invalid triangles are dropped and counted in `report`; a mesh with no valid
// triangle left (or, without options.allow_dropping_most, with most of them dropped), an unreadable
// file, a reference leaving the file's folder or an unsupported format is an error naming the file.
Status load_mesh(const std::string& path, Mesh& mesh, MeshImportReport* report = nullptr,
                 const MeshImportOptions& options = {});

// Cleans a mesh in place (the step load_mesh ends with): drops degenerate/invalid triangles,
// recomputes missing or non-finite vertex normals (area-weighted), fills a default material.
// A triangle is degenerate when it repeats a vertex or its area is not above both an absolute
// bound (the area float coordinates can resolve: 1e-30, below which the ray math underflows) and a
// bound relative to the triangle's own longest edge (area <= 1e-7 * edge^2: collinear corners).
// Vertices no kept triangle uses are removed. Dropping more than kMaxDroppedFraction of the
// triangles is an error unless `allow_dropping_most`.
Status finalize_mesh(Mesh& mesh, MeshImportReport* report, const std::string& name,
                     bool allow_dropping_most = false);

void compute_vertex_normals(Mesh& mesh);

}  // namespace lsnif
