// scene_mesh.cpp -- primitive_from and mesh_from (scene.h): the importer's meshes in the scene.
#include <map>

#include "lsnif/scene/scene.h"

namespace lsnif::scene {

Primitive primitive_from(const lsnif::Mesh& mesh, uint32_t material) {
  Primitive p;
  p.positions = mesh.positions;
  p.normals = mesh.normals;
  p.uvs = mesh.uvs;
  p.indices.reserve(3 * mesh.triangles.size());
  for (const glm::uvec3& t : mesh.triangles) p.indices.insert(p.indices.end(), {t.x, t.y, t.z});
  p.material = material;
  return p;
}

Mesh mesh_from(const std::string& name, const lsnif::Mesh& mesh, const std::vector<uint32_t>& materials) {
  Mesh out;
  out.name = name;
  for (size_t mat = 0; mat < mesh.materials.size(); ++mat) {
    Primitive p;
    p.material = materials[mat];
    std::map<uint32_t, uint32_t> remap;
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      if (mesh.triangle_material[t] != mat) continue;
      for (int c = 0; c < 3; ++c) {
        const uint32_t v = mesh.triangles[t][c];
        auto [it, added] = remap.emplace(v, uint32_t(p.positions.size()));
        if (added) {
          p.positions.push_back(mesh.positions[v]);
          if (!mesh.normals.empty()) p.normals.push_back(mesh.normals[v]);
          if (!mesh.uvs.empty()) p.uvs.push_back(mesh.uvs[v]);
        }
        p.indices.push_back(it->second);
      }
    }
    if (!p.indices.empty()) out.primitives.push_back(std::move(p));
  }
  return out;
}

}  // namespace lsnif::scene
