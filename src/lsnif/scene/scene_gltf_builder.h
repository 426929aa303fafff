// scene_gltf_builder.h -- internal to lsnif_scene: SceneBuilder, which turns a parsed glTF file
// (tinygltf::Model) into the renderer's Scene with the guarantees listed in scene_gltf.h. Its
// stages live in files of their own:
// - scene_gltf.cpp: run() (the order of the stages), warnings, the extension checks and the public
//   functions of scene_gltf.h;
// - scene_gltf_materials.cpp: materials and textures;
// - scene_gltf_meshes.cpp: meshes and their primitives;
// - scene_gltf_nodes.cpp: instances, cameras, LSNIF_neural_object and the --lsnif overrides (the
//   node walk itself is read_gltf_scene, lsnif/import/gltf_scene.h);
// - scene_gltf_environment.cpp: LSNIF_environment and its sun.
// Not installed; include it from those files only.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/format/numbers.h"
#include "lsnif/format/status.h"
#include "lsnif/import/gltf_access.h"
#include "lsnif/import/gltf_material.h"
#include "lsnif/import/gltf_scene.h"
#include "lsnif/scene/scene.h"
#include "lsnif/scene/scene_gltf.h"

namespace lsnif::scene::detail {

inline constexpr const char* kNodeExtension = "LSNIF_neural_object";
inline constexpr const char* kEnvironmentExtension = "LSNIF_environment";

// A finite number from a JSON value.
inline bool number_of(const tinygltf::Value& v, double& out) {
  if (!v.IsNumber()) return false;
  out = v.GetNumberAsDouble();
  return std::isfinite(out);
}

class SceneBuilder {
 public:
  // Builds into `scene` from `model`; `name` names the file in messages, `base_dir` resolves references.
  SceneBuilder(const tinygltf::Model& model, const std::string& name, const std::string& base_dir,
               const SceneLoadOptions& options, Scene& scene)
      : model_(model), name_(name), base_dir_(base_dir), options_(options), scene_(scene),
        mesh_map_(model.meshes.size(), -2), textures_(model, scene.textures),
        node_overrides_(model.nodes.size()) {}

  // All stages in order: extensions, materials, overrides, environment, the node walk, final checks.
  Status run();

 private:
  // ---- warnings (scene_gltf.cpp) ---------------------------------------------------------------

  // The file's name for messages.
  const char* file() const { return name_.c_str(); }
  // Adds a warning to Scene::warnings, prefixed with the file's name.
  void warn(const std::string& msg) { scene_.warnings.push_back(name_ + ": " + msg); }
  // Warnings of one kind: the first few are listed, the rest counted at the end.
  void warn_counted(const std::string& kind, const std::string& msg);
  // The end-of-load lines: how many warnings of each kind were not listed, the skipped primitives.
  void summarize_warnings();
  // "node 3 ('wheel')" for messages.
  std::string node_label(int index) const { return gltf_node_label(model_, index); }

  // ---- extensions (scene_gltf.cpp) -------------------------------------------------------------

  // Extension value types, extensionsRequired (unsupported: an error) and extensionsUsed (a warning).
  Status check_extensions();

  // ---- materials and textures (scene_gltf_materials.cpp) ---------------------------------------

  // Scene material i for every glTF material i.
  Status load_materials();
  // One glTF material through read_gltf_material (lsnif/import/gltf_material.h), its images decoded.
  Status load_material(size_t index);
  // The material with glTF defaults, appended after the file's on first use.
  uint32_t default_material();

  // ---- meshes (scene_gltf_meshes.cpp) ----------------------------------------------------------

  // Scene mesh for glTF mesh `gltf_mesh` (loaded on first use); -1 when it has no triangles.
  Status mesh_index(int gltf_mesh, int32_t& out);
  // One primitive read into `prim`; `keep` false when it is skipped (with a warning).
  Status load_primitive(const tinygltf::Primitive& gp, const std::string& where, Primitive& prim, bool& keep);

  // ---- nodes and overrides (scene_gltf_nodes.cpp) ----------------------------------------------

  // One node of the walk (read_gltf_scene: indices, hierarchy and transforms already checked).
  Status visit(int index, const glm::dmat4& world);
  // The node's perspective camera, if it has one.
  Status add_camera(int index, const glm::dmat4& world);
  // Material map entries must name scene materials from the file.
  Status parse_material_list(const tinygltf::Value& v, const std::string& where, std::vector<uint32_t>& out) const;
  // The node's Instance: its mesh and/or LSNIF object (LSNIF_neural_object or a --lsnif override).
  Status add_instance(int index, const glm::dmat4& world);
  // --lsnif overrides: each checked and attached to every node with its name.
  Status resolve_overrides();
  // Every --lsnif override reached a node of the rendered scene.
  Status check_overrides_used() const;

  // ---- environment (scene_gltf_environment.cpp) ------------------------------------------------

  // LSNIF_environment "sun" into Scene::sun.
  Status load_sun(const tinygltf::Value& v, const std::string& where);
  // LSNIF_environment with the --env overrides applied into Scene::environment.
  Status load_environment();

  const tinygltf::Model& model_;
  const std::string& name_;
  const std::string& base_dir_;
  const SceneLoadOptions& options_;
  Scene& scene_;
  std::vector<int32_t> mesh_map_;   // glTF mesh -> scene mesh (-2: not yet, -1: no triangles)
  GltfTextures textures_;           // glTF images -> Scene::textures
  std::vector<const LsnifOverride*> node_overrides_;
  std::vector<GltfMaterial> gltf_materials_;  // per glTF material, as read (its uv set, its images)
  std::vector<uint8_t> visited_;
  std::map<std::string, size_t> warn_counts_;
  std::map<int, size_t> skipped_by_mode_;
  int32_t default_material_ = -1;
  size_t skipped_primitives_ = 0;
};

}  // namespace lsnif::scene::detail
