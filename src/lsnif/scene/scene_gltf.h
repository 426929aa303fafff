// scene_gltf.h -- loading the Scene (scene.h) from a glTF 2.0 file (.gltf / .glb) with
// tinygltf, plus the two LSNIF extensions (node `LSNIF_neural_object`, root `LSNIF_environment`,
// specified in docs/scene-format.md) and the command-line overrides equivalent to
// `--lsnif NODE=MODEL.lsnif` and `--env ...`.
//
// What load_scene produces (the guarantees the renderer may rely on when it returns ok):
// - Scene::materials: glTF material i is scene material i (so LSNIF_neural_object "materials"
//   indices are glTF material indices); one default material (glTF defaults) is appended after
//   them when a primitive names none or an LSNIF object needs a fallback.
// - Scene::meshes: one per glTF mesh used by a node of the rendered scene, in first-use order,
//   object space (untransformed). Only triangle primitives, read by the importer's primitive reader
//   (src/lsnif/import/gltf_primitive.h; strips and fans as triangle lists; the others are skipped and counted in
//   a warning); every primitive has >= 1 triangle, indices < positions.size(), finite positions,
//   normals either empty or one unit-length finite normal per vertex, uvs empty or one finite uv per
//   vertex, a valid material index. Meshes whose primitives were all skipped are not listed.
// - Scene::instances: one per node (hierarchy flattened, TRS or matrix) that has a mesh with
//   triangles and/or an LSNIF object, in depth-first order of the scene's node list. Several nodes
//   sharing a glTF mesh are several instances of one Scene mesh. object_to_world is finite and
//   invertible. At least one instance exists.
// - Scene::lsnif_objects: one per distinct (resolved model path, material map); each model file
//   exists and starts with the .lsnif magic.
// - Scene::cameras: one per node with a perspective camera (orthographic ones are skipped with a
//   warning), camera_to_world = the node's world transform (finite, invertible; it may contain
//   scale: normalize directions), 0 < yfov < pi, aspect = glTF aspectRatio or 0.
// - Scene::textures: one per glTF image used by a material, decoded to RGBA8 (PNG / JPEG, embedded
//   in a .glb, a data URI or an external file). Undecodable images are a warning and leave the
//   material slot untextured (-1); texture indices are -1 or valid.
// - Samplers, texture transforms, normal / occlusion maps, alpha modes, skins and morph targets
//   are ignored (with a warning where the file uses them).
// On error the Status names the file and the problem (broken JSON, missing buffer, index out of
// range, NaN in a transform or position, non-invertible transform, missing .lsnif file, unknown
// override node, ...) and `out` is left empty but for the warnings gathered until then. No input makes it crash, read out of bounds or throw.
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/scene/scene.h"
#include "lsnif/format/status.h"

namespace tinygltf {
class Model;
}

namespace lsnif::scene {

// `--lsnif NODE=MODEL.lsnif`: trace the node(s) named `node` through the LSNIF plugin with the given
// model. The node keeps its mesh as the reference geometry (reference mode). A node that already
// carries LSNIF_neural_object gets its model replaced (its "materials" map is kept unless
// `materials` is given). Every node with that name is affected; a name no node of the rendered
// scene has is an error, so is a node with neither a mesh nor the extension.
struct LsnifOverride {
  std::string node;                 // glTF node name
  std::string model_path;           // .lsnif file, used as given (relative to the working directory)
  std::vector<uint32_t> materials;  // optional model material -> scene material map; empty: the
                                    // extension's map if the node has one, else the default map
                                    // (model material i -> the material of the node mesh's
                                    // primitive i, or of its first primitive)
};

// Parses the CLI form "NODE=MODEL.lsnif" (the last '=' separates; both parts non-empty).
Status parse_lsnif_override(const std::string& arg, LsnifOverride& out);

// Replaces the scene's LSNIF_environment fields that are set; glTF has no environment, so this is
// how a scene without the extension gets one from the command line.
struct EnvironmentOverride {
  std::optional<std::string> hdr;          // image path as given (cwd-relative); "" = constant color
  std::optional<glm::vec3> color;          // linear RGB, >= 0
  std::optional<float> intensity;          // >= 0, multiplies color
  std::optional<float> rotation_degrees;   // about +y
};

struct SceneLoadOptions {
  std::vector<LsnifOverride> lsnif_overrides;
  EnvironmentOverride environment;
  // Files the scene refers to (buffers, images, models, the environment image) may lie outside
  // its folder (src/lsnif/import/resolve_path.h); default: such a reference is an error.
  bool allow_outside_refs = false;
  // Model files that do not exist yet but will (the converter validates the scene it is about to
  // write before training): resolved paths that need not exist; every other model file must.
  std::vector<std::string> pending_models;
  bool quiet = false;  // true: warnings only go to Scene::warnings, not to stderr
};

// Loads `path` (.gltf or .glb; a .glb is also recognized by its magic). External buffers, images,
// .lsnif models and the environment image resolve relative to the file's folder.
Status load_scene(const std::string& path, const SceneLoadOptions& options, Scene& out);

// The same from bytes already in memory (the fuzz test's entry point): `binary` = GLB container,
// `name` names the input in messages and becomes Scene::path, `base_dir` resolves relative URIs and
// paths. Override paths are used as given, as in load_scene.
Status load_scene_from_memory(std::string_view data, bool binary, const std::string& name,
                              const std::string& base_dir, const SceneLoadOptions& options,
                              Scene& out);

// The LSNIF extensions must be JSON objects where they appear (the root's LSNIF_environment, each
// node's LSNIF_neural_object); tinygltf drops other values silently, so this needs `model` loaded
// with gltf::LoadOptions::keep_extension_json. Errors name `name`, the node and the type found.
Status check_extension_types(const tinygltf::Model& model, const std::string& name);

// Checks that `path` is a regular file that starts with the 8-byte .lsnif magic "LSNIF\0\r\n"
// (docs/model-format.md); the rest of the model is not read.
Status check_lsnif_file(const std::string& path);

// World-space bounds of the triangle geometry of every instance with a mesh (LSNIF-only instances
// are not included: their bounds live in the model file). False when there is none.
bool scene_bounds(const Scene& scene, glm::vec3& lo, glm::vec3& hi);

// Total triangles of a mesh, and over all instances (instanced triangles counted per instance).
size_t triangle_count(const Mesh& mesh);
size_t instanced_triangle_count(const Scene& scene);

// Multi-line human-readable summary (counts, instances, cameras, LSNIF objects, environment).
std::string describe_scene(const Scene& scene);

}  // namespace lsnif::scene
