// scene_gltf_meshes.cpp -- SceneBuilder's meshes (scene_gltf_builder.h): a glTF mesh becomes one
// object-space scene mesh on first use by a node; its TRIANGLES primitives are read through the
// checked accessor reader of src/lsnif/import/gltf_access.h, the others are skipped and counted.
#include "lsnif/renderer/scene_gltf_builder.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "lsnif/import/gltf_access.h"
#include "lsnif/import/gltf_material.h"

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
  const int mode = gp.mode < 0 ? TINYGLTF_MODE_TRIANGLES : gp.mode;
  if (!gltf::is_triangle_mode(mode)) {
    ++skipped_primitives_;
    ++skipped_by_mode_[mode];
    warn_counted("non-triangle primitives",
                 format("%s: mode %d (%s) draws no triangles; skipped", short_where.c_str(), mode,
                        gltf::mode_name(mode)));
    return Status::ok();
  }
  if (gp.extensions.count("KHR_draco_mesh_compression"))
    return Status::error("%s: Draco-compressed primitives are not supported", where.c_str());
  if (!gp.targets.empty())
    warn_counted("morph targets", short_where + ": morph targets ignored (base shape used)");

  // Material.
  if (gp.material >= int(model_.materials.size()))
    return Status::error("%s: material %d does not exist (%zu materials)", where.c_str(),
                         gp.material, model_.materials.size());
  prim.material = gp.material >= 0 ? uint32_t(gp.material) : default_material();

  // Positions.
  std::vector<double> pos, nrm, uv;
  int nc = 0;
  const gltf::AccessorReader reader{model_, kGltfMaxAccessorCount};
  Status s = reader.read_positions(gp, where, pos);
  if (!s) return s;
  const size_t n = pos.size() / 3;
  for (size_t i = 0; i < pos.size(); ++i)
    if (!std::isfinite(to_float(pos[i])))
      return Status::error("%s: POSITION (accessor %d) vertex %zu is NaN or infinite", where.c_str(),
                           gltf::find_attribute(gp, "POSITION"), i / 3);
  prim.positions.resize(n);
  for (size_t i = 0; i < n; ++i)
    prim.positions[i] = glm::vec3(to_float(pos[3 * i]), to_float(pos[3 * i + 1]), to_float(pos[3 * i + 2]));

  // Normals: unit length; a NaN or zero normal drops the primitive's normals (face normals used).
  if (int acc = gltf::find_attribute(gp, "NORMAL"); acc >= 0) {
    s = reader.read_attribute(acc, "NORMAL", {TINYGLTF_TYPE_VEC3}, false, n, where, nrm, nc);
    if (!s) return s;
    prim.normals.resize(n);
    for (size_t i = 0; i < n && !prim.normals.empty(); ++i) {
      glm::dvec3 q(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]);
      const double len = glm::length(q);
      if (!std::isfinite(len) || !(len > 1e-20)) {
        warn_counted("bad normals", short_where + format(": NORMAL %zu is NaN, infinite or zero; "
                                                         "the primitive uses face normals", i));
        prim.normals.clear();
        break;
      }
      q /= len;
      prim.normals[i] = glm::vec3(float(q.x), float(q.y), float(q.z));
    }
  }

  // Texture coordinates of the material's uv set.
  const int set = material_uv_set_[prim.material];
  const std::string uv_key = "TEXCOORD_" + std::to_string(set);
  if (int acc = gltf::find_attribute(gp, uv_key); acc >= 0) {
    s = reader.read_attribute(acc, uv_key, {TINYGLTF_TYPE_VEC2}, false, n, where, uv, nc);
    if (!s) return s;
    if (!std::all_of(uv.begin(), uv.end(), [](double d) { return std::isfinite(to_float(d)); })) {
      warn_counted("bad uvs", short_where + ": " + uv_key + " has NaN or infinite values; untextured");
    } else {
      prim.uvs.resize(n);
      for (size_t i = 0; i < n; ++i) prim.uvs[i] = glm::vec2(to_float(uv[2 * i]), to_float(uv[2 * i + 1]));
    }
  } else {
    const Material& m = scene_.materials[prim.material];
    if (m.base_color_texture >= 0 || m.metallic_roughness_texture >= 0 || m.emission_texture >= 0 ||
        m.occlusion_texture >= 0 || m.normal_texture >= 0)
      warn_counted("missing uvs", short_where + ": textured material but no " + uv_key +
                                      "; textures read at uv (0, 0)");
  }

  // Indices.
  if (gp.indices >= 0) {
    s = reader.read_indices(gp.indices, n, true, where, prim.indices);
    if (!s) return s;
  } else {
    prim.indices.resize(n);
    for (size_t i = 0; i < n; ++i) prim.indices[i] = static_cast<uint32_t>(i);
  }
  if (mode == TINYGLTF_MODE_TRIANGLES && prim.indices.size() % 3 != 0)
    warn_counted("index counts", short_where + format(": %zu indices is not a multiple of 3; the "
                                                      "last %zu ignored", prim.indices.size(),
                                                      prim.indices.size() % 3));
  prim.indices = gltf::triangle_list(mode, prim.indices);  // strips and fans as triangle lists
  if (prim.indices.empty()) {
    warn_counted("empty primitives", short_where + ": no triangles; skipped");
    return Status::ok();
  }
  keep = true;
  return Status::ok();
}

}  // namespace lsnif::scene::detail
