// gltf_primitive.cpp -- see gltf_primitive.h.
#include "lsnif/import/gltf_primitive.h"

#include <cmath>

#include <glm/glm.hpp>

#include "lsnif/import/gltf_material.h"

namespace lsnif::gltf {

Status read_primitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, const PrimitiveReadOptions& options,
                      const std::string& where, PrimitiveRead& out) {
  out = PrimitiveRead();
  out.mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
  out.triangle_mode = is_triangle_mode(out.mode);
  if (!out.triangle_mode) return Status::ok();
  if (prim.extensions.count("KHR_draco_mesh_compression"))
    return Status::error("%s: Draco-compressed primitives are not supported", where.c_str());
  out.morph_targets = !prim.targets.empty();
  if (prim.material >= int(model.materials.size()))
    return Status::error("%s: material %d does not exist (%zu materials)", where.c_str(), prim.material,
                         model.materials.size());
  out.material = prim.material;

  const AccessorReader reader{model, kGltfMaxAccessorCount};
  if (Status s = reader.read_positions(prim, where, out.positions); !s) return s;
  const size_t n = out.positions.size() / 3;
  int components = 0;
  if (int acc = find_attribute(prim, "NORMAL"); acc >= 0) {
    if (Status s = reader.read_attribute(acc, "NORMAL", {TINYGLTF_TYPE_VEC3}, false, n, where, out.normals, components); !s)
      return s;
    for (size_t i = 0; i < n; ++i) {
      const double len = glm::length(glm::dvec3(out.normals[3 * i], out.normals[3 * i + 1], out.normals[3 * i + 2]));
      if (!std::isfinite(len) || !(len > 1e-20)) {
        out.bad_normal = int64_t(i);
        out.normals.clear();
        break;
      }
    }
  }
  out.uv_key = "TEXCOORD_" + std::to_string(options.uv_set);
  if (int acc = find_attribute(prim, out.uv_key); acc >= 0) {
    if (Status s = reader.read_attribute(acc, out.uv_key, {TINYGLTF_TYPE_VEC2}, false, n, where, out.uvs, components); !s)
      return s;
    out.has_uvs = true;
  }
  if (options.colors) {
    if (int acc = find_attribute(prim, "COLOR_0"); acc >= 0) {
      if (Status s = reader.read_attribute(acc, "COLOR_0", {TINYGLTF_TYPE_VEC3, TINYGLTF_TYPE_VEC4}, true, n, where,
                                           out.colors, out.color_components);
          !s)
        return s;
    }
  }
  std::vector<uint32_t> indices;
  if (prim.indices >= 0) {
    if (Status s = reader.read_indices(prim.indices, n, true, where, indices); !s) return s;
  } else {
    indices.resize(n);
    for (size_t i = 0; i < n; ++i) indices[i] = static_cast<uint32_t>(i);
  }
  out.index_count = indices.size();
  out.triangles = triangle_list(out.mode, indices);
  return Status::ok();
}

}  // namespace lsnif::gltf
