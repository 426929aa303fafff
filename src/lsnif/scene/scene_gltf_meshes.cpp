// scene_gltf_meshes.cpp -- SceneBuilder's meshes (scene_gltf_builder.h): a glTF mesh becomes one
// object-space scene mesh on first use by a node; its triangle primitives are read by the importer's
// primitive reader (src/lsnif/import/gltf_primitive.h, the training mesh's too), the others are
// skipped and counted.
#include "lsnif/scene/scene_gltf_builder.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "lsnif/import/gltf_access.h"
#include "lsnif/import/gltf_primitive.h"

namespace lsnif::scene::detail {

// Scene mesh for glTF mesh `gltf_mesh` (loaded on first use); -1 when it has no triangles.
Status SceneBuilder::mesh_index(int gltf_mesh, int32_t& out) {
  int32_t& mapped = mesh_map_[size_t(gltf_mesh)];
  if (mapped != -2) {
    out = mapped;
    return Status::ok();
  }
  const tinygltf::Mesh& gm = model_.meshes[size_t(gltf_mesh)];
  Mesh mesh;
  mesh.name = gltf_mesh_name(model_, gltf_mesh);
  for (size_t p = 0; p < gm.primitives.size(); ++p) {
    const std::string where = format("%s: mesh %d ('%s') primitive %zu", file(), gltf_mesh,
                                     excerpt(mesh.name).c_str(), p);
    Primitive prim;
    bool keep = false;
    Status s = load_primitive(gm.primitives[p], where, prim, keep);
    if (!s) return s;
    if (keep) mesh.primitives.push_back(std::move(prim));
  }
  if (mesh.primitives.empty()) {
    warn(format("mesh %d ('%s') has no primitive with triangles; nodes using it draw "
                "no triangles", gltf_mesh, excerpt(mesh.name).c_str()));
    mapped = -1;
  } else {
    mapped = int32_t(scene_.meshes.size());
    scene_.meshes.push_back(std::move(mesh));
  }
  out = mapped;
  return Status::ok();
}

Status SceneBuilder::load_primitive(const tinygltf::Primitive& gp, const std::string& where, Primitive& prim,
                                    bool& keep) {
  keep = false;
  const std::string short_where = where.substr(name_.size() + 2);
  // The material's uv set; read_primitive checks that the material exists.
  gltf::PrimitiveReadOptions options;
  if (gp.material >= 0 && gp.material < int(model_.materials.size())) options.uv_set = gltf_materials_[size_t(gp.material)].uv_set;
  gltf::PrimitiveRead read;
  if (Status s = gltf::read_primitive(model_, gp, options, where, read); !s) return s;
  if (!read.triangle_mode) {
    ++skipped_primitives_;
    ++skipped_by_mode_[read.mode];
    warn_counted("non-triangle primitives",
                 format("%s: mode %d (%s) draws no triangles; skipped", short_where.c_str(), read.mode,
                        gltf::mode_name(read.mode)));
    return Status::ok();
  }
  if (read.morph_targets) warn_counted("morph targets", short_where + ": morph targets ignored (base shape used)");
  prim.material = read.material >= 0 ? uint32_t(read.material) : default_material();

  // Positions: finite in float, or the primitive is an error.
  const size_t n = read.positions.size() / 3;
  for (size_t i = 0; i < read.positions.size(); ++i)
    if (!std::isfinite(to_float(read.positions[i])))
      return Status::error("%s: POSITION (accessor %d) vertex %zu is NaN or infinite", where.c_str(),
                           gltf::find_attribute(gp, "POSITION"), i / 3);
  prim.positions.resize(n);
  for (size_t i = 0; i < n; ++i)
    prim.positions[i] = glm::vec3(to_float(read.positions[3 * i]), to_float(read.positions[3 * i + 1]),
                                  to_float(read.positions[3 * i + 2]));

  // Normals: unit length (a NaN or zero one and read_primitive dropped them: face normals).
  if (read.bad_normal >= 0)
    warn_counted("bad normals", short_where + format(": NORMAL %lld is NaN, infinite or zero; "
                                                     "the primitive uses face normals",
                                                     static_cast<long long>(read.bad_normal)));
  if (!read.normals.empty()) {
    prim.normals.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const glm::dvec3 q(read.normals[3 * i], read.normals[3 * i + 1], read.normals[3 * i + 2]);
      const glm::dvec3 u = q / glm::length(q);
      prim.normals[i] = glm::vec3(float(u.x), float(u.y), float(u.z));
    }
  }

  // Texture coordinates of the material's uv set.
  if (read.has_uvs) {
    if (!std::all_of(read.uvs.begin(), read.uvs.end(), [](double d) { return std::isfinite(to_float(d)); })) {
      warn_counted("bad uvs", short_where + ": " + read.uv_key + " has NaN or infinite values; untextured");
    } else {
      prim.uvs.resize(n);
      for (size_t i = 0; i < n; ++i) prim.uvs[i] = glm::vec2(to_float(read.uvs[2 * i]), to_float(read.uvs[2 * i + 1]));
    }
  } else {
    const Material& m = scene_.materials[prim.material];
    if (m.has_textures())
      warn_counted("missing uvs", short_where + ": textured material but no " + read.uv_key +
                                      "; textures read at uv (0, 0)");
  }

  // The triangles (strips and fans as triangle lists).
  if (read.mode == TINYGLTF_MODE_TRIANGLES && read.index_count % 3 != 0)
    warn_counted("index counts", short_where + format(": %zu indices is not a multiple of 3; the "
                                                      "last %zu ignored", read.index_count,
                                                      read.index_count % 3));
  prim.indices = std::move(read.triangles);
  if (prim.indices.empty()) {
    warn_counted("empty primitives", short_where + ": no triangles; skipped");
    return Status::ok();
  }
  keep = true;
  return Status::ok();
}

}  // namespace lsnif::scene::detail
