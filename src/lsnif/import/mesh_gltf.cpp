// mesh_gltf.cpp -- glTF 2.0 (.gltf / .glb) reader on top of tinygltf. The default scene's nodes
// (walked by read_gltf_scene, gltf_scene.h: the same rules as the renderer's scene loader) are
// flattened into one object-space triangle soup: world transforms are applied to positions, their
// inverse transpose to normals, and the winding flips under mirroring transforms. Primitives are
// read by gltf::read_primitive (gltf_primitive.h), the renderer's scene loader's reader too: the
// same triangles of TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN primitives (others are skipped with
// a warning); a primitive without usable normals gets flat ones, as the renderer shades it (glTF).
#include <algorithm>

#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "lsnif/import/gltf_access.h"
#include "lsnif/import/gltf_material.h"
#include "lsnif/import/gltf_primitive.h"
#include "lsnif/import/gltf_scene.h"
#include "lsnif/import/mesh_formats.h"
#include "lsnif/import/mesh_gltf.h"

namespace lsnif::mesh_io {
namespace {


class GltfFlattener {
 public:
  GltfFlattener(const tinygltf::Model& model, const std::string& name, Mesh& mesh,
                MeshImportReport& report)
      : model_(model), name_(name), mesh_(mesh), report_(report),
        material_map_(model.materials.size(), -1), textures_(model, mesh.textures),
        warned_mesh_(model.meshes.size(), 0) {}

  // Flattens the given parts only (flatten_gltf_meshes).
  Status run_parts(const std::vector<GltfMeshPart>& parts) {
    std::vector<int> placed;
    for (const GltfMeshPart& part : parts) placed.push_back(part.mesh);
    if (Status s = check_gltf_geometry(model_, placed, true, name_); !s) return s;
    if (Status s = read_materials(); !s) return s;
    for (const GltfMeshPart& part : parts) {
      if (part.mesh < 0 || size_t(part.mesh) >= model_.meshes.size())
        return Status::error("%s: mesh %d does not exist", file(), part.mesh);
      Status s = add_mesh(part.mesh, part.transform);
      if (!s) return s;
    }
    if (skipped_primitives_)
      report_.warnings.push_back(format("%s: skipped %u non-triangle primitives (points/lines)",
                                        file(), skipped_primitives_));
    if (mesh_.triangles.empty()) return Status::error("%s: no triangle primitives", file());
    return Status::ok();
  }

  // glTF material index of every mesh material so far (-1: the default material).
  std::vector<int> material_sources() const {
    std::vector<int> out(mesh_.materials.size(), -1);
    for (size_t g = 0; g < material_map_.size(); ++g)
      if (material_map_[g] >= 0) out[size_t(material_map_[g])] = int(g);
    return out;
  }

  Status run() {
    GltfScene walk;  // the node graph's rules: gltf_scene.h
    Status s = read_gltf_scene(model_, name_, walk);
    const bool every_mesh = model_.scenes.empty() && model_.nodes.empty();
    std::vector<int> placed = gltf_placed_meshes(model_, walk);
    if (every_mesh)
      for (size_t m = 0; m < model_.meshes.size(); ++m) placed.push_back(int(m));
    if (s) s = check_gltf_geometry(model_, placed, true, name_);
    if (s) s = read_materials();
    if (!s) return s;
    if (every_mesh) {
      report_.warnings.push_back(format("%s: no scene and no nodes; importing every mesh untransformed",
                                        file()));
      for (size_t m = 0; m < model_.meshes.size(); ++m) {
        s = add_mesh(int(m), glm::dmat4(1.0));
        if (!s) return s;
      }
    }
    for (const GltfSceneNode& n : walk.nodes) {
      const tinygltf::Node& node = model_.nodes[size_t(n.node)];
      if (node.mesh < 0) continue;
      if (size_t(node.mesh) >= model_.meshes.size())
        return Status::error("%s: %s references missing mesh %d (%zu meshes)", file(),
                             gltf_node_label(model_, n.node).c_str(), node.mesh, model_.meshes.size());
      s = add_mesh(node.mesh, n.world);
      if (!s) return s;
    }
    if (skipped_primitives_)
      report_.warnings.push_back(format("%s: skipped %u non-triangle primitives (points/lines)",
                                        file(), skipped_primitives_));
    if (mesh_.triangles.empty())
      return Status::error("%s: the scene contains no triangle primitives%s", file(),
                           skipped_primitives_ ? " (only points/lines)" : "");
    return Status::ok();
  }

 private:
  const char* file() const { return name_.c_str(); }

  // Every glTF material through the one material reader (gltf_material.h), as the renderer reads
  // them: a material the renderer refuses is refused here too, used or not.
  Status read_materials() {
    materials_.resize(model_.materials.size());
    for (size_t i = 0; i < model_.materials.size(); ++i) {
      std::vector<GltfWarning> warnings;
      Status s = read_gltf_material(model_, i, name_, materials_[i], warnings);
      for (const GltfWarning& w : warnings) report_.warnings.push_back(name_ + ": " + w.text);
      if (!s) return s;
    }
    return Status::ok();
  }

  Status add_mesh(int mesh_index, const glm::dmat4& world) {
    const tinygltf::Mesh& m = model_.meshes[size_t(mesh_index)];
    for (size_t p = 0; p < m.primitives.size(); ++p) {
      const std::string where = format("%s: mesh %d ('%s') primitive %zu", file(), mesh_index,
                                       excerpt(m.name).c_str(), p);
      Status s = add_primitive(m.primitives[p], world, where, mesh_index);
      if (!s) return s;
    }
    warned_mesh_[size_t(mesh_index)] = 1;
    return Status::ok();
  }

  Status add_primitive(const tinygltf::Primitive& prim, const glm::dmat4& world,
                       const std::string& where, int mesh_index) {
    const bool first_time = !warned_mesh_[size_t(mesh_index)];
    gltf::PrimitiveReadOptions options;
    options.colors = true;
    if (prim.material >= 0 && size_t(prim.material) < materials_.size()) options.uv_set = materials_[size_t(prim.material)].uv_set;
    gltf::PrimitiveRead read;
    if (Status s = gltf::read_primitive(model_, prim, options, where, read); !s) return s;
    if (!read.triangle_mode) {
      if (first_time) {
        ++skipped_primitives_;
        report_.warnings.push_back(format("%s: mode %d (%s) is not triangles; skipped", where.c_str(),
                                          read.mode, gltf::mode_name(read.mode)));
      }
      return Status::ok();
    }
    const std::vector<double>& pos = read.positions;
    const std::vector<double>& nrm = read.normals;
    const std::vector<double>& uv = read.uvs;
    const std::vector<double>& col = read.colors;
    const int color_components = read.color_components;
    const size_t n = pos.size() / 3;
    if (mesh_.positions.size() + n >= kInvalidIndex)
      return Status::error("%s: too many vertices in the flattened scene", where.c_str());
    if (read.bad_normal >= 0 && first_time)
      report_.warnings.push_back(format("%s: NORMAL %lld is NaN, infinite or zero; the primitive uses face normals",
                                        where.c_str(), static_cast<long long>(read.bad_normal)));
    int material = -1;
    if (Status s = material_index(read.material, where, material); !s) return s;
    if (!read.has_uvs && first_time && mesh_.materials[size_t(material)].has_textures())
      report_.warnings.push_back(format("%s: textured material but no %s; texture unused there",
                                        where.c_str(), read.uv_key.c_str()));
    if (read.mode == TINYGLTF_MODE_TRIANGLES && read.index_count % 3 != 0 && first_time)
      report_.warnings.push_back(format("%s: %zu indices is not a multiple of 3; ignored the last %zu",
                                        where.c_str(), read.index_count, read.index_count % 3));
    std::vector<glm::uvec3> tris;
    const std::vector<uint32_t>& list = read.triangles;
    for (size_t i = 0; i + 2 < list.size(); i += 3) tris.emplace_back(list[i], list[i + 1], list[i + 2]);

    // Append in object space.
    const bool mirror = glm::determinant(glm::dmat3(world)) < 0.0;
    if (nrm.empty()) {
      if (mesh_.positions.size() + 3 * tris.size() >= kInvalidIndex)
        return Status::error("%s: too many vertices in the flattened scene", where.c_str());
      append_flat(pos, uv, col, color_components, tris, world, mirror, material);
      return Status::ok();
    }
    const uint32_t base = static_cast<uint32_t>(mesh_.positions.size());
    const glm::dmat3 normal_matrix = glm::inverseTranspose(glm::dmat3(world));
    if (!uv.empty() && mesh_.uvs.empty()) mesh_.uvs.resize(base, glm::vec2(0.0f));
    if (!col.empty() && mesh_.colors.empty()) mesh_.colors.resize(base, glm::vec3(1.0f));
    // Every primitive appends a normal per vertex (given here, flat in append_flat), so the mesh's
    // normals stay aligned with its positions.
    for (size_t i = 0; i < n; ++i) {
      glm::dvec4 p = world * glm::dvec4(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2], 1.0);
      mesh_.positions.emplace_back(to_float(p.x), to_float(p.y), to_float(p.z));
      glm::dvec3 q = normal_matrix * glm::dvec3(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]);
      double len = glm::length(q);
      q = len > 0.0 ? q / len : q;  // zero stays zero: finalize_mesh recomputes it
      mesh_.normals.emplace_back(to_float(q.x), to_float(q.y), to_float(q.z));
      append_uv_and_color(i, uv, col, color_components);
    }
    for (glm::uvec3 t : tris) {
      if (mirror) std::swap(t.y, t.z);
      mesh_.triangles.push_back(t + glm::uvec3(base));
      mesh_.triangle_material.push_back(static_cast<uint32_t>(material));
    }
    return Status::ok();
  }

  // Appends the uv and colour of the primitive's vertex `i` to the mesh's arrays, defaults (uv 0,
  // white) where the primitive has none but the mesh has the array.
  void append_uv_and_color(size_t i, const std::vector<double>& uv, const std::vector<double>& col,
                           int color_components) {
    if (!uv.empty())
      mesh_.uvs.emplace_back(to_float(uv[2 * i]), to_float(uv[2 * i + 1]));
    else if (!mesh_.uvs.empty())
      mesh_.uvs.emplace_back(0.0f);
    if (!col.empty()) {
      const size_t o = i * size_t(color_components);
      mesh_.colors.emplace_back(to_float(col[o]), to_float(col[o + 1]), to_float(col[o + 2]));
    } else if (!mesh_.colors.empty()) {
      mesh_.colors.emplace_back(1.0f);
    }
  }

  // Appends the triangles `tris` of a primitive without usable normals as glTF shades it: flat,
  // every triangle with three vertices of its own carrying its face normal (after the winding fix
  // of a mirroring transform, so the normal faces the front side); a degenerate triangle's normal is
  // NaN, for finalize_mesh to drop the triangle or repair the normal.
  void append_flat(const std::vector<double>& pos, const std::vector<double>& uv, const std::vector<double>& col,
                   int color_components, const std::vector<glm::uvec3>& tris, const glm::dmat4& world, bool mirror,
                   int material) {
    const glm::vec3 nan(std::numeric_limits<float>::quiet_NaN());
    const size_t base = mesh_.positions.size();
    if (!uv.empty() && mesh_.uvs.empty()) mesh_.uvs.resize(base, glm::vec2(0.0f));
    if (!col.empty() && mesh_.colors.empty()) mesh_.colors.resize(base, glm::vec3(1.0f));
    for (glm::uvec3 t : tris) {
      if (mirror) std::swap(t.y, t.z);
      glm::dvec3 p[3];
      for (int k = 0; k < 3; ++k)
        p[k] = glm::dvec3(world * glm::dvec4(pos[3 * t[k]], pos[3 * t[k] + 1], pos[3 * t[k] + 2], 1.0));
      const glm::dvec3 c = glm::cross(p[1] - p[0], p[2] - p[0]);
      const double len = glm::length(c);
      const glm::vec3 face = std::isfinite(len) && len > 0.0 ? glm::vec3(c / len) : nan;
      const uint32_t first = static_cast<uint32_t>(mesh_.positions.size());
      for (int k = 0; k < 3; ++k) {
        const size_t i = t[k];
        mesh_.positions.emplace_back(to_float(p[k].x), to_float(p[k].y), to_float(p[k].z));
        mesh_.normals.push_back(face);
        append_uv_and_color(i, uv, col, color_components);
      }
      mesh_.triangles.emplace_back(first, first + 1, first + 2);
      mesh_.triangle_material.push_back(static_cast<uint32_t>(material));
    }
  }

  // Mesh material index for a glTF material index (-1: the default material) in `out`, created on
  // first use from the material read by read_materials.
  Status material_index(int gltf_material, const std::string& where, int& out) {
    if (gltf_material >= 0 && size_t(gltf_material) >= model_.materials.size())
      return Status::error("%s: material %d does not exist (%zu materials)", where.c_str(), gltf_material,
                           model_.materials.size());
    if (gltf_material < 0) {
      if (default_material_ < 0) {
        default_material_ = int(mesh_.materials.size());
        Material m;
        m.name = "default";
        mesh_.materials.push_back(std::move(m));
      }
      out = default_material_;
      return Status::ok();
    }
    int& mapped = material_map_[size_t(gltf_material)];
    if (mapped < 0) {
      const GltfMaterial& gm = materials_[size_t(gltf_material)];
      Material mat = textures_.material(gm, [&](int source, const std::string& why) {
        report_.warnings.push_back(format("%s: image %d could not be used (%s); material '%s' untextured", file(),
                                          source, why.c_str(), excerpt(gm.material.name).c_str()));
      });
      mapped = int(mesh_.materials.size());
      mesh_.materials.push_back(std::move(mat));
    }
    out = mapped;
    return Status::ok();
  }

  const tinygltf::Model& model_;
  const std::string& name_;
  Mesh& mesh_;
  MeshImportReport& report_;
  std::vector<GltfMaterial> materials_;  // per glTF material (read_materials)
  std::vector<int> material_map_;  // glTF material -> mesh material (-1: not yet)
  GltfTextures textures_;          // glTF images -> Mesh::textures
  std::vector<uint8_t> warned_mesh_;
  int default_material_ = -1;
  uint32_t skipped_primitives_ = 0;
};

}  // namespace
}  // namespace lsnif::mesh_io

namespace lsnif {

Status flatten_gltf_meshes(const tinygltf::Model& model, const std::vector<GltfMeshPart>& parts,
                           const std::string& name, Mesh& mesh, std::vector<int>& material_sources,
                           MeshImportReport* report, bool allow_dropping_most) {
  MeshImportReport local;
  MeshImportReport& rep = report ? *report : local;
  mesh = Mesh();
  material_sources.clear();
  mesh_io::GltfFlattener flattener(model, name, mesh, rep);
  if (Status s = flattener.run_parts(parts); !s) {
    mesh = Mesh();
    return s;
  }
  material_sources = flattener.material_sources();
  // finalize_mesh only appends a default material when there is none (never here: every
  // primitive got one), so the sources stay aligned with mesh.materials.
  Status s = finalize_mesh(mesh, &rep, name, allow_dropping_most);
  material_sources.resize(mesh.materials.size(), -1);
  return s;
}

}  // namespace lsnif

namespace lsnif::mesh_io {

Status parse_gltf(std::string_view data, bool binary, const std::string& name,
                  const std::string& base_dir, const MeshImportOptions& import_options, Mesh& mesh,
                  MeshImportReport& report) {
  const char* file = name.c_str();
  gltf::LoadOptions options;
  options.max_pixels = kGltfMaxImagePixels;
  options.allow_outside_refs = import_options.allow_outside_refs;
  tinygltf::Model model;
  Status s = gltf::load_model(data, binary, name, base_dir, options, model, report.warnings);
  if (!s) return s;
  for (const std::string& ext : model.extensionsRequired)
    if (ext == "KHR_draco_mesh_compression")
      return Status::error("%s: requires KHR_draco_mesh_compression, which is not supported", file);
  return GltfFlattener(model, name, mesh, report).run();
}

}  // namespace lsnif::mesh_io
