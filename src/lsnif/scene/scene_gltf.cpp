// scene_gltf.cpp -- glTF 2.0 scene loader for the renderer (scene_gltf.h; the LSNIF extensions are
// specified in docs/scene-format.md). Unlike src/lsnif/import/mesh_gltf.cpp, which flattens a file into one
// object-space triangle soup for training, this keeps the node hierarchy's instancing: meshes stay
// in object space and every node becomes an Instance with its world transform.
//
// tinygltf 2.7 leaves most validation to the user, so every index, accessor and buffer range is
// checked before a byte is read: loading, accessor reads and image decoding go through
// src/lsnif/import/gltf_access.h and primitives are read by src/lsnif/import/gltf_primitive.h
// (library lsnif_import, shared with src/lsnif/import/mesh_gltf.cpp); the rest is checked here.
//
// SceneBuilder (scene_gltf_builder.h) does the work; this file holds its run(), warnings and
// extension checks, and the public functions of scene_gltf.h. Its other stages: materials and
// textures in scene_gltf_materials.cpp, meshes in scene_gltf_meshes.cpp, nodes and overrides in
// scene_gltf_nodes.cpp, the environment in scene_gltf_environment.cpp.
#include "lsnif/scene/scene_gltf.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <set>

#include "lsnif/import/gltf_access.h"
#include "lsnif/import/gltf_material.h"
#include "lsnif/import/gltf_scene.h"
#include "lsnif/import/json_text.h"
#include "lsnif/scene/scene_gltf_builder.h"

namespace lsnif::scene {

using detail::kEnvironmentExtension;
using detail::kNodeExtension;
using detail::SceneBuilder;

namespace {

constexpr size_t kMaxMessageChars = 600;  // of tinygltf's error and warning text
constexpr size_t kMaxListedWarnings = 8;  // per kind; the rest are counted in a summary line
constexpr uint8_t kLsnifMagic[8] = {'L', 'S', 'N', 'I', 'F', 0x00, '\r', '\n'};

// tinygltf keeps only extension values that are JSON objects and drops the others silently; the
// object's "extensions" text (kept with LoadOptions::keep_extension_json) tells whether `ext` had
// another value.
Status check_extension_object(const std::string& extensions_json, const char* ext, const std::string& where) {
  if (extensions_json.find(ext) == std::string::npos) return Status::ok();
  nlohmann::json j;
  if (Status s = json::parse(extensions_json, where, j); !s) return s;
  if (j.is_object() && j.contains(ext) && !j[ext].is_object())
    return Status::error("%s: %s must be a JSON object, not a %s (docs/scene-format.md)", where.c_str(), ext,
                         j[ext].type_name());
  return Status::ok();
}

}  // namespace

namespace detail {

Status SceneBuilder::run() {
  Status s = check_extensions();
  if (s) s = load_materials();
  if (s) s = resolve_overrides();
  if (s) s = load_environment();
  if (!s) return s;
  if (model_.scenes.empty() && model_.nodes.empty())
    return Status::error("%s: the file has no scenes and no nodes", file());
  GltfScene walk;  // the node graph's rules: lsnif/import/gltf_scene.h
  s = read_gltf_scene(model_, name_, walk);
  if (s) {  // each mesh is read once, however many nodes place it
    std::vector<int> meshes = gltf_placed_meshes(model_, walk);
    std::sort(meshes.begin(), meshes.end());
    meshes.erase(std::unique(meshes.begin(), meshes.end()), meshes.end());
    s = check_gltf_geometry(model_, meshes, false, name_);
  }
  if (!s) return s;
  if (walk.scene < 0) warn("no 'scenes': rendering every root node");
  visited_.assign(model_.nodes.size(), 0);
  for (const GltfSceneNode& n : walk.nodes) {
    s = visit(n.node, n.world);
    if (!s) return s;
  }
  s = check_overrides_used();
  if (!s) return s;
  summarize_warnings();
  if (scene_.instances.empty())
    return Status::error("%s: the scene has no instance to render (no node with a triangle mesh "
                         "or %s)%s", file(), kNodeExtension,
                         skipped_primitives_ ? " (primitives that draw no triangles were skipped)" : "");
  return Status::ok();
}

// Warnings of one kind: the first few are listed, the rest counted at the end.
void SceneBuilder::warn_counted(const std::string& kind, const std::string& msg) {
  if (++warn_counts_[kind] <= kMaxListedWarnings) warn(msg);
}

void SceneBuilder::summarize_warnings() {
  for (const auto& [kind, n] : warn_counts_)
    if (n > kMaxListedWarnings)
      warn(format("... %zu more warnings like the above (%s)", n - kMaxListedWarnings, kind.c_str()));
  if (skipped_primitives_) {
    std::string by_mode;
    for (const auto& [mode, n] : skipped_by_mode_)
      by_mode += format("%s%s: %zu", by_mode.empty() ? "" : ", ", gltf::mode_name(mode), n);
    warn(format("skipped %zu primitives that draw no triangles (%s)", skipped_primitives_,
                by_mode.c_str()));
  }
}

Status SceneBuilder::check_extensions() {
  if (Status s = check_extension_types(model_, name_); !s) return s;
  static const std::set<std::string> supported = {
      kNodeExtension, kEnvironmentExtension, "KHR_materials_emissive_strength", "KHR_texture_transform",
      "KHR_mesh_quantization"};
  for (const std::string& ext : model_.extensionsRequired)
    if (!supported.count(ext))
      return Status::error("%s: requires extension %s, which is not supported", file(),
                           excerpt(ext).c_str());
  std::string ignored;
  for (const std::string& ext : model_.extensionsUsed)
    if (!supported.count(ext)) ignored += (ignored.empty() ? "" : ", ") + excerpt(ext);
  if (!ignored.empty()) warn("extensions used by the file but ignored: " + ignored);
  return Status::ok();
}

}  // namespace detail

Status check_extension_types(const tinygltf::Model& model, const std::string& name) {
  if (Status s = check_extension_object(model.extensions_json_string, kEnvironmentExtension, name); !s) return s;
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    const tinygltf::Node& n = model.nodes[i];
    const std::string where = n.name.empty() ? format("%s: node %zu", name.c_str(), i)
                                             : format("%s: node %zu ('%s')", name.c_str(), i, excerpt(n.name).c_str());
    if (Status s = check_extension_object(n.extensions_json_string, kNodeExtension, where); !s) return s;
  }
  return Status::ok();
}

Status parse_lsnif_override(const std::string& arg, LsnifOverride& out) {
  const size_t eq = arg.rfind('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == arg.size())
    return Status::error("--lsnif '%s': expected NODE_NAME=MODEL.lsnif", excerpt(arg).c_str());
  out = LsnifOverride();
  out.node = arg.substr(0, eq);
  out.model_path = arg.substr(eq + 1);
  return Status::ok();
}

Status check_lsnif_file(const std::string& path) {
  if (path.empty() || path.find('\0') != std::string::npos)
    return Status::error("invalid .lsnif path");
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    return Status::error("model file '%s' does not exist", path.c_str());
  if (!std::filesystem::is_regular_file(path, ec))
    return Status::error("model file '%s' is not a regular file", path.c_str());
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  if (!in || in.gcount() != 8)
    return Status::error("model file '%s' cannot be read or is shorter than 8 bytes", path.c_str());
  if (std::memcmp(magic, kLsnifMagic, 8) != 0)
    return Status::error("'%s' is not an .lsnif model (bad magic; expected \"LSNIF\\0\\r\\n\")",
                         path.c_str());
  return Status::ok();
}

Status load_scene_from_memory(std::string_view data, bool binary, const std::string& name,
                              const std::string& base_dir, const SceneLoadOptions& options,
                              Scene& out) {
  out = Scene();
  Status s;
  try {
    tinygltf::Model model;
    gltf::LoadOptions load_options;
    load_options.max_pixels = kGltfMaxImagePixels;
    load_options.max_message_chars = kMaxMessageChars;
    load_options.allow_outside_refs = options.allow_outside_refs;
    load_options.keep_extension_json = true;
    s = gltf::load_model(data, binary, name, base_dir, load_options, model, out.warnings);
    if (s) s = SceneBuilder(model, name, base_dir, options, out).run();
  } catch (const std::exception& e) {
    s = Status::error("%s: %s while loading the scene", name.c_str(), e.what());
  }
  if (!options.quiet)
    for (const std::string& w : out.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  if (!s) {
    std::vector<std::string> warnings = std::move(out.warnings);
    out = Scene();
    out.warnings = std::move(warnings);
    return s;
  }
  out.path = name;
  return s;
}

Status load_scene(const std::string& path, const SceneLoadOptions& options, Scene& out) {
  out = Scene();
  std::vector<unsigned char> bytes;
  std::string err;
  if (!gltf::read_whole_file(&bytes, &err, path, nullptr))
    return Status::error("%s: cannot read the scene (%s)", path.c_str(),
                         gltf::trim_message(err, kMaxMessageChars).c_str());
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const bool magic = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  if (ext != ".gltf" && ext != ".glb" && !magic)
    return Status::error("%s: not a glTF scene (expected a .gltf or .glb file)", path.c_str());
  const bool binary = magic || ext == ".glb";
  std::string base_dir = std::filesystem::path(path).parent_path().string();
  if (base_dir.empty()) base_dir = ".";
  return load_scene_from_memory(
      std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()), binary, path,
      base_dir, options, out);
}

size_t triangle_count(const Mesh& mesh) {
  size_t n = 0;
  for (const Primitive& p : mesh.primitives) n += p.indices.size() / 3;
  return n;
}

size_t instanced_triangle_count(const Scene& scene) {
  size_t n = 0;
  for (const Instance& inst : scene.instances)
    if (inst.mesh >= 0 && size_t(inst.mesh) < scene.meshes.size())
      n += triangle_count(scene.meshes[size_t(inst.mesh)]);
  return n;
}

bool scene_bounds(const Scene& scene, glm::vec3& lo, glm::vec3& hi) {
  lo = glm::vec3(std::numeric_limits<float>::infinity());
  hi = -lo;
  bool any = false;
  for (const Instance& inst : scene.instances) {
    if (inst.mesh < 0 || size_t(inst.mesh) >= scene.meshes.size()) continue;
    for (const Primitive& p : scene.meshes[size_t(inst.mesh)].primitives)
      for (uint32_t i : p.indices) {
        const glm::vec3 w = glm::vec3(inst.object_to_world * glm::vec4(p.positions[i], 1.0f));
        lo = glm::min(lo, w);
        hi = glm::max(hi, w);
        any = true;
      }
  }
  return any;
}

std::string describe_scene(const Scene& scene) {
  std::string s = format("scene      %s\n", scene.path.c_str());
  size_t prims = 0;
  for (const Mesh& m : scene.meshes) prims += m.primitives.size();
  s += format("meshes     %zu (%zu primitives), %zu instances, %zu triangles instanced\n",
              scene.meshes.size(), prims, scene.instances.size(), instanced_triangle_count(scene));
  s += format("materials  %zu, textures %zu\n", scene.materials.size(), scene.textures.size());
  glm::vec3 lo, hi;
  if (scene_bounds(scene, lo, hi))
    s += format("bounds     [%g %g %g] - [%g %g %g]\n", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
  for (const Camera& c : scene.cameras) {
    const glm::vec3 p(c.camera_to_world[3]);
    s += format("camera     '%s' at (%g %g %g), yfov %.3f rad, aspect %g\n", c.name.c_str(), p.x, p.y,
                p.z, c.yfov, c.aspect);
  }
  for (size_t i = 0; i < scene.lsnif_objects.size(); ++i) {
    const LsnifObject& o = scene.lsnif_objects[i];
    std::string map;
    for (uint32_t m : o.material_map) map += format("%s%u", map.empty() ? "" : ",", m);
    s += format("lsnif %-4zu %s (materials %s)\n", i, o.resolved_path.c_str(), map.c_str());
  }
  size_t lsnif_instances = 0;
  for (const Instance& inst : scene.instances) lsnif_instances += inst.lsnif >= 0;
  s += format("lsnif      %zu objects, %zu instances\n", scene.lsnif_objects.size(), lsnif_instances);
  const Environment& e = scene.environment;
  s += format("environment %s, color (%g %g %g), rotation %g deg\n",
              e.path.empty() ? "constant" : e.path.c_str(), e.color.x, e.color.y, e.color.z,
              double(e.rotation) * 180.0 / std::numbers::pi);
  if (!scene.warnings.empty()) s += format("warnings   %zu\n", scene.warnings.size());
  return s;
}

}  // namespace lsnif::scene
