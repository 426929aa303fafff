// scene_gltf_nodes.cpp -- SceneBuilder's nodes (scene_gltf_builder.h): for each node of the walk
// (read_gltf_scene, src/lsnif/import/gltf_scene.h) its Instance (mesh and/or LSNIF_neural_object)
// and its camera, and the command-line overrides `--lsnif NODE=MODEL.lsnif`.
#include "lsnif/scene/scene_gltf_builder.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "lsnif/import/gltf_scene.h"
#include "lsnif/import/resolve_path.h"

namespace lsnif::scene::detail {

// One node of the walk (read_gltf_scene: indices, hierarchy and transforms already checked).
Status SceneBuilder::visit(int index, const glm::dmat4& world) {
  visited_[size_t(index)] = 1;
  const tinygltf::Node& node = model_.nodes[size_t(index)];
  Status s = add_instance(index, world);
  if (s) s = add_camera(index, world);
  if (!s) return s;
  if (node.skin >= 0) warn_counted("skins", node_label(index) + ": skinning ignored (static mesh)");
  return Status::ok();
}

Status SceneBuilder::add_camera(int index, const glm::dmat4& world) {
  const tinygltf::Node& node = model_.nodes[size_t(index)];
  if (node.camera < 0) return Status::ok();
  const std::string who = node_label(index);
  if (size_t(node.camera) >= model_.cameras.size())
    return Status::error("%s: %s references missing camera %d (%zu cameras)", file(), who.c_str(),
                         node.camera, model_.cameras.size());
  const tinygltf::Camera& gc = model_.cameras[size_t(node.camera)];
  if (gc.type != "perspective") {
    warn_counted("cameras", format("%s: camera %d is %s, not perspective; skipped", who.c_str(),
                                   node.camera, excerpt(gc.type).c_str()));
    return Status::ok();
  }
  const double yfov = gc.perspective.yfov, aspect = gc.perspective.aspectRatio;
  if (!std::isfinite(yfov) || !(yfov >= 1e-6) || !(yfov < std::numbers::pi))
    return Status::error("%s: camera %d: yfov %g is not in (0, pi)", file(), node.camera, yfov);
  if (!std::isfinite(aspect) || aspect < 0.0 || aspect > 1e6 || (aspect > 0.0 && aspect < 1e-6))
    return Status::error("%s: camera %d: aspectRatio %g is not a positive number", file(),
                         node.camera, aspect);
  Camera cam;
  cam.name = !gc.name.empty() ? gc.name : !node.name.empty() ? node.name : format("camera_%d", node.camera);
  Status s = check_world_transform(world, cam.camera_to_world);
  if (!s) return s.context(format("%s: %s (camera)", file(), who.c_str()));
  cam.yfov = float(yfov);
  cam.aspect = float(aspect);
  scene_.cameras.push_back(std::move(cam));
  return Status::ok();
}

// Material map entries must name scene materials from the file.
Status SceneBuilder::parse_material_list(const tinygltf::Value& v, const std::string& where,
                                         std::vector<uint32_t>& out) const {
  out.clear();
  if (!v.IsArray()) return Status::error("%s: \"materials\" must be an array", where.c_str());
  if (v.ArrayLen() > 1024) return Status::error("%s: \"materials\" has too many entries", where.c_str());
  for (size_t i = 0; i < v.ArrayLen(); ++i) {
    double d = -1.0;
    const tinygltf::Value& e = v.Get(int(i));
    if (!number_of(e, d) || d != std::floor(d) || d < 0.0 || d >= double(model_.materials.size()))
      return Status::error("%s: \"materials\"[%zu] is not a material index (the file has %zu "
                           "materials)", where.c_str(), i, model_.materials.size());
    out.push_back(uint32_t(d));
  }
  return Status::ok();
}

Status SceneBuilder::add_instance(int index, const glm::dmat4& world) {
  const tinygltf::Node& node = model_.nodes[size_t(index)];
  const std::string who = format("%s: %s", file(), node_label(index).c_str());
  const auto ext_it = node.extensions.find(kNodeExtension);
  const tinygltf::Value* ext = ext_it == node.extensions.end() ? nullptr : &ext_it->second;
  const LsnifOverride* ov = node_overrides_[size_t(index)];
  if (node.mesh < 0 && !ext && !ov) return Status::ok();

  int32_t mesh = -1;
  if (node.mesh >= 0) {
    if (size_t(node.mesh) >= model_.meshes.size())
      return Status::error("%s references missing mesh %d (%zu meshes)", who.c_str(), node.mesh,
                           model_.meshes.size());
    Status s = mesh_index(node.mesh, mesh);
    if (!s) return s;
  }

  // The LSNIF extension: {"model": path, "materials": [...]}.
  std::string model_path, resolved;
  std::vector<uint32_t> materials;
  bool has_materials = false;
  if (ext) {
    if (!ext->IsObject())
      return Status::error("%s: %s must be a JSON object", who.c_str(), kNodeExtension);
    const std::string ext_where = who + ": " + kNodeExtension;
    for (const std::string& key : ext->Keys())
      if (key != "model" && key != "materials")
        warn(format("%s: %s: unknown property \"%s\" ignored", node_label(index).c_str(),
                    kNodeExtension, excerpt(key).c_str()));
    if (ext->Has("model")) {
      const tinygltf::Value& mv = ext->Get("model");
      if (!mv.IsString() || mv.Get<std::string>().empty())
        return Status::error("%s: \"model\" must be a non-empty string", ext_where.c_str());
      model_path = mv.Get<std::string>();
    }
    if (ext->Has("materials")) {
      Status s = parse_material_list(ext->Get("materials"), ext_where, materials);
      if (!s) return s;
      has_materials = !materials.empty();
    }
    if (!ov && !model_path.empty()) {
      Status s = resolve_reference(base_dir_, model_path, options_.allow_outside_refs, "model", resolved);
      const std::vector<std::string>& pending = options_.pending_models;
      if (s && std::find(pending.begin(), pending.end(), resolved) == pending.end()) s = check_lsnif_file(resolved);
      if (!s) return s.context(ext_where + ": model '" + excerpt(model_path) + "'");
    }
  }
  if (ov) {
    if (node.mesh < 0 && !ext)
      return Status::error("%s: --lsnif override '%s': the node has neither a mesh nor %s",
                           who.c_str(), excerpt(ov->node).c_str(), kNodeExtension);
    model_path = resolved = ov->model_path;  // checked in resolve_overrides()
    if (!ov->materials.empty()) {
      materials = ov->materials;
      has_materials = true;
    }
  }

  int32_t lsnif = -1;
  if (resolved.empty()) {
    if (ext && mesh < 0)
      return Status::error("%s: %s without a \"model\" and without a triangle mesh: nothing to "
                           "render", who.c_str(), kNodeExtension);
    if (ext)
      warn(node_label(index) + ": " + kNodeExtension +
           " has no \"model\" (none given by an override either); drawn as triangles");
  } else {
    if (!has_materials) {
      if (mesh >= 0) {
        for (const Primitive& p : scene_.meshes[size_t(mesh)].primitives) materials.push_back(p.material);
      } else {
        materials.push_back(default_material());
      }
    }
    LsnifObject obj;
    obj.model_path = model_path;
    obj.resolved_path = resolved;
    obj.material_map = std::move(materials);
    for (size_t i = 0; i < scene_.lsnif_objects.size() && lsnif < 0; ++i)
      if (scene_.lsnif_objects[i].resolved_path == obj.resolved_path &&
          scene_.lsnif_objects[i].material_map == obj.material_map)
        lsnif = int32_t(i);
    if (lsnif < 0) {
      lsnif = int32_t(scene_.lsnif_objects.size());
      scene_.lsnif_objects.push_back(std::move(obj));
    }
  }
  if (mesh < 0 && lsnif < 0) return Status::ok();  // a mesh without triangles (warned)

  Instance inst;
  inst.node_name = gltf_node_name(model_, index);
  Status s = check_world_transform(world, inst.object_to_world);
  if (!s) return s.context(who);
  inst.mesh = mesh;
  inst.lsnif = lsnif;
  scene_.instances.push_back(std::move(inst));
  return Status::ok();
}

// ---- overrides ------------------------------------------------------------------------------

Status SceneBuilder::resolve_overrides() {
  for (const LsnifOverride& ov : options_.lsnif_overrides) {
    const std::string what = "--lsnif " + excerpt(ov.node) + "=" + excerpt(ov.model_path);
    if (ov.node.empty()) return Status::error("%s: empty node name", what.c_str());
    Status s = check_lsnif_file(ov.model_path);
    if (!s) return s.context(what);
    for (uint32_t m : ov.materials)
      if (m >= model_.materials.size())
        return Status::error("%s: material %u out of range (%s has %zu materials)", what.c_str(), m,
                             file(), model_.materials.size());
    bool found = false;
    for (size_t i = 0; i < model_.nodes.size(); ++i)
      if (model_.nodes[i].name == ov.node) {
        node_overrides_[i] = &ov;  // a later override of the same name wins
        found = true;
      }
    if (!found) {
      std::string names;
      size_t listed = 0;
      for (const tinygltf::Node& n : model_.nodes)
        if (!n.name.empty() && listed++ < 12) names += (names.empty() ? "" : ", ") + excerpt(n.name);
      return Status::error("%s: %s has no node named '%s' (named nodes: %s%s)", what.c_str(),
                           file(), excerpt(ov.node).c_str(), names.empty() ? "none" : names.c_str(),
                           listed > 12 ? ", ..." : "");
    }
  }
  return Status::ok();
}

Status SceneBuilder::check_overrides_used() const {
  for (const LsnifOverride& ov : options_.lsnif_overrides) {
    bool used = false;
    for (size_t i = 0; i < model_.nodes.size() && !used; ++i)
      used = node_overrides_[i] && node_overrides_[i]->node == ov.node && visited_[i];
    if (!used)
      return Status::error("--lsnif %s: %s: the node(s) named '%s' are not part of the rendered scene",
                           excerpt(ov.node).c_str(), file(), excerpt(ov.node).c_str());
  }
  return Status::ok();
}

}  // namespace lsnif::scene::detail
