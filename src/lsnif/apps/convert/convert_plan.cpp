// convert_plan.cpp -- reading the input glTF and deciding what to convert (convert_plan.h).
#include "lsnif/apps/convert/convert_plan.h"

#include <re2/re2.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <set>

#include "lsnif/apps/convert/convert_cluster.h"
#include "lsnif/format/atomic_file.h"
#include "lsnif/import/gltf_scene.h"
#include "lsnif/import/json_text.h"
#include "lsnif/import/mesh_gltf.h"
#include "lsnif/core/model.h"
#include "lsnif/import/resolve_path.h"
#include "lsnif/scene/scene_gltf.h"
#include "lsnif/train/uv_materials.h"

namespace lsnif::convert {
namespace fs = std::filesystem;

// Occupied voxels per V^2 the plan assumes for a model's uv cells without its mesh
// (estimated_model_bytes).
constexpr uint64_t kPlannedOccupiedVoxels = 4;

namespace {

constexpr const char* kNodeExtension = "LSNIF_neural_object";

std::string url_decode(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out += static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

// Why an external buffer file cannot be used ("" when it can): outside the scene folder (the
// reference policy of resolve_path.h), missing, not a regular file or shorter than byteLength.
std::string check_buffer_file(const fs::path& dir, const std::string& uri, uint64_t byte_length, bool allow_outside) {
  std::string path;
  if (Status s = resolve_reference(dir.string(), url_decode(uri), allow_outside, "the URI", path); !s)
    return s.message();
  const fs::path file(path);
  std::error_code ec;
  if (!fs::exists(file, ec)) return "the file " + file.string() + " does not exist";
  if (!fs::is_regular_file(file, ec)) return file.string() + " is not a regular file";
  const uint64_t size = fs::file_size(file, ec);
  if (ec || size < byte_length)
    return format("%s has %llu bytes, the buffer needs %llu", file.string().c_str(),
                  (unsigned long long)size, (unsigned long long)byte_length);
  return "";
}

// For .gltf JSON: replaces every external buffer that cannot be used by an empty one (so that
// tinygltf loads the rest) and records why in `bad`. Returns the JSON to load (unchanged when it
// does not parse: gltf::load_model then reports the error).
std::string isolate_bad_buffers(const std::string& text, const std::string& name, const fs::path& dir,
                                bool allow_outside, std::vector<std::string>& bad) {
  nlohmann::json j;
  if (!json::parse(text, name, j) || !j.is_object() || !j.contains("buffers") || !j["buffers"].is_array())
    return text;
  nlohmann::json& buffers = j["buffers"];
  bad.assign(buffers.size(), "");
  bool changed = false;
  for (size_t i = 0; i < buffers.size(); ++i) {
    nlohmann::json& b = buffers[i];
    if (!b.is_object() || !b.contains("uri") || !b["uri"].is_string()) continue;
    const std::string uri = b["uri"].get<std::string>();
    if (uri.rfind("data:", 0) == 0) continue;
    const uint64_t length =
        b.contains("byteLength") && b["byteLength"].is_number_unsigned() ? b["byteLength"].get<uint64_t>() : 0;
    std::string why = check_buffer_file(dir, uri, length, allow_outside);
    if (why.empty()) continue;
    bad[i] = format("buffer %zu ('%s'): %s", i, uri.c_str(), why.c_str());
    b["uri"] = "data:application/octet-stream;base64,AA==";  // one zero byte: tinygltf rejects empty data
    b["byteLength"] = 1;
    changed = true;
  }
  return changed ? j.dump() : text;
}

std::string safe_name(const std::string& s) {
  std::string out;
  for (char c : s)
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  if (out.size() > 48) out.resize(48);
  return out.empty() ? std::string("object") : out;
}

// Why mesh `m` cannot become an LSNIF object ("" when it can, as far as the plan can tell: the
// training stage reads the data with every range check).
std::string mesh_problem(const Plan& plan, int m) {
  const tinygltf::Model& g = plan.gltf;
  const tinygltf::Mesh& mesh = g.meshes[size_t(m)];
  if (mesh.primitives.empty()) return "the mesh has no primitives";
  for (size_t p = 0; p < mesh.primitives.size(); ++p) {
    const tinygltf::Primitive& prim = mesh.primitives[p];
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (!gltf::is_triangle_mode(mode))
      return format("primitive %zu has mode %d (%s); only triangles can become an LSNIF object", p,
                    mode, gltf::mode_name(mode));
    if (prim.extensions.count("KHR_draco_mesh_compression"))
      return format("primitive %zu is Draco-compressed (not supported)", p);
    if (gltf::find_attribute(prim, "POSITION") < 0) return format("primitive %zu has no POSITION", p);
    std::vector<int> accessors{prim.indices};
    for (const auto& [key, acc] : prim.attributes) accessors.push_back(acc);
    for (int acc : accessors) {
      if (acc < 0) continue;
      if (size_t(acc) >= g.accessors.size()) return format("primitive %zu: accessor %d does not exist", p, acc);
      const tinygltf::Accessor& a = g.accessors[size_t(acc)];
      for (int view : {a.bufferView, a.sparse.isSparse ? a.sparse.indices.bufferView : -1,
                       a.sparse.isSparse ? a.sparse.values.bufferView : -1}) {
        if (view < 0 || size_t(view) >= g.bufferViews.size()) continue;
        const int buffer = g.bufferViews[size_t(view)].buffer;
        if (buffer >= 0 && size_t(buffer) < plan.bad_buffers.size() && !plan.bad_buffers[size_t(buffer)].empty())
          return format("primitive %zu: %s", p, plan.bad_buffers[size_t(buffer)].c_str());
      }
    }
  }
  return "";
}

using Pattern = std::unique_ptr<re2::RE2>;

// True when `re` matches somewhere in `s` (RE2: time linear in the name, no recursion).
bool search(const Pattern& re, const std::string& s) { return re2::RE2::PartialMatch(s, *re); }

Status compile(const std::string& pattern, const char* what, Pattern& out) {
  re2::RE2::Options options;
  options.set_log_errors(false);
  out = std::make_unique<re2::RE2>(pattern, options);
  if (!out->ok())
    return Status::error("%s '%s' is not a valid regular expression (RE2 syntax): %s", what, pattern.c_str(),
                         out->error().c_str());
  return Status::ok();
}

// Node extras: {"lsnif": true/false} (-1 when absent) and {"lsnif_group": "NAME"}.
int extras_tag(const tinygltf::Node& n) {
  if (!n.extras.IsObject() || !n.extras.Has("lsnif")) return -1;
  const tinygltf::Value& v = n.extras.Get("lsnif");
  return v.IsBool() ? (v.Get<bool>() ? 1 : 0) : -1;
}
std::string extras_group(const tinygltf::Node& n) {
  if (!n.extras.IsObject() || !n.extras.Has("lsnif_group")) return "";
  const tinygltf::Value& v = n.extras.Get("lsnif_group");
  return v.IsString() ? v.Get<std::string>() : "";
}

}  // namespace

std::vector<std::string> referenced_files(const Plan& plan, const std::string& input) {
  const tinygltf::Model& g = plan.gltf;
  std::vector<std::string> out{fs::path(input).lexically_normal().string()};
  auto add = [&](const std::string& ref) {
    if (ref.empty() || ref.rfind("data:", 0) == 0) return;
    std::string path;
    if (resolve_reference(plan.input_dir, url_decode(ref), true, "reference", path)) out.push_back(path);
  };
  for (const tinygltf::Buffer& b : g.buffers) add(b.uri);
  for (const tinygltf::Image& im : g.images) add(im.uri);
  auto string_field = [](const tinygltf::ExtensionMap& exts, const char* ext, const char* key) {
    auto it = exts.find(ext);
    if (it == exts.end() || !it->second.IsObject() || !it->second.Has(key) || !it->second.Get(key).IsString())
      return std::string();
    return it->second.Get(key).Get<std::string>();
  };
  for (const tinygltf::Node& n : g.nodes) add(string_field(n.extensions, kNodeExtension, "model"));
  add(string_field(g.extensions, "LSNIF_environment", "hdr"));
  return out;
}

const char* decision_text(Decision d) {
  switch (d) {
    case Decision::Convert: return "convert";
    case Decision::BelowThreshold: return "stays triangles (below --min-triangles)";
    case Decision::NoMemorySaved: return "stays triangles (frees less BLAS memory than --memory-margin x its model)";
    case Decision::NotSelected: return "stays triangles (not matched by --select)";
    case Decision::Excluded: return "stays triangles (matched by --exclude)";
    case Decision::TaggedOff: return "stays triangles (extras \"lsnif\": false)";
    case Decision::AlreadyLsnif: return "already an LSNIF object (kept as it is)";
    case Decision::Failed: return "FAILED";
  }
  return "?";
}

size_t Plan::instances_converted() const {
  size_t n = 0;
  for (const PlannedNode& p : nodes) n += p.decision == Decision::Convert;
  return n;
}

size_t Plan::failed_models() const {
  size_t n = 0;
  for (const PlannedModel& m : models) n += !m.error.empty();
  return n;
}

uint64_t estimated_model_bytes(const TrainSettings& train, uint32_t material_count, bool textured, const Mesh* mesh) {
  Model m;
  m.config = train.config;
  m.config.material_count = std::max(1u, material_count);
  // The surface channels' outputs, as the trainer decides them (without the mesh: when always on).
  m.config.surface_channels =
      (mesh ? learns_surface_channels(*mesh, train.surface_maps) : train.surface_maps == kSurfaceMapsOn) ? 1u : 0u;
  bool indexed = false;
  for (uint32_t l = 0; l < m.config.grid_levels && l < LSNIF_MAX_LEVELS; ++l) indexed |= train.indexed[l];
  const uint64_t uv_materials = mesh ? choose_uv_materials(*mesh, train.texture_coordinates).materials
                                     : textured && train.texture_coordinates == kTextureCoordinatesAuto ? 1u : 0u;
  if (uv_materials) {
    m.config.uv_materials = uv_materials;
    m.config.uv_cells = train.uv_cells;
  }
  if (mesh && (indexed || uv_materials) && !mesh->triangles.empty()) {
    // The indexed levels' tables and the uv cells as the trainer makes them: from the mesh's voxels.
    Model laid_out = m;
    if (model_layout(*mesh, train, laid_out.config, laid_out.voxels, laid_out.grid_index) &&
        build_uv_cells(*mesh, laid_out))
      m = std::move(laid_out);
  } else if (uv_materials) {
    // Per occupied voxel a record and about S^2 maps, for kPlannedOccupiedVoxels x V^2 occupied voxels
    // (the uv_cell_layout.h sizes; measured on four textured assets made elsewhere at V = 32, S = 2:
    // 2.6-5.6 V^2 occupied voxels, 3.8-4.3 maps per voxel).
    const uint64_t V = m.config.voxel_resolution, S = m.config.uv_cells;
    const uint64_t voxels = std::min(V * V * V, kPlannedOccupiedVoxels * V * V);
    m.config.uv_cell_voxels = uint32_t(voxels);
    m.config.uv_cell_maps = uint32_t(std::min<uint64_t>(voxels * S * S, LSNIF_MAX_UV_CELL_MAPS));
  }
  return memory_breakdown(m).total();
}

uint64_t planned_model_bytes(const TrainSettings& train, const Plan& plan, const PlannedModel& m) {
  return estimated_model_bytes(train, planned_material_count(plan, m), planned_textured(plan, m));
}

namespace {

// The glTF meshes of planned model `m`: its own and its nodes'.
std::set<int> planned_meshes(const Plan& plan, const PlannedModel& m) {
  std::set<int> meshes;
  if (m.mesh >= 0) meshes.insert(m.mesh);
  for (int n : m.nodes) meshes.insert(plan.nodes[size_t(n)].mesh);
  return meshes;
}

}  // namespace

bool planned_textured(const Plan& plan, const PlannedModel& m) {
  const tinygltf::Model& g = plan.gltf;
  for (int mesh : planned_meshes(plan, m)) {
    if (mesh < 0 || size_t(mesh) >= g.meshes.size()) continue;
    for (const tinygltf::Primitive& p : g.meshes[size_t(mesh)].primitives) {
      bool uvs = false;
      for (const auto& [name, accessor] : p.attributes) uvs |= name.rfind("TEXCOORD_", 0) == 0;
      if (p.material < 0 || size_t(p.material) >= g.materials.size() || !uvs) continue;
      const tinygltf::Material& mat = g.materials[size_t(p.material)];
      if (mat.pbrMetallicRoughness.baseColorTexture.index >= 0 ||
          mat.pbrMetallicRoughness.metallicRoughnessTexture.index >= 0 || mat.normalTexture.index >= 0 ||
          mat.occlusionTexture.index >= 0 || mat.emissiveTexture.index >= 0)
        return true;
    }
  }
  return false;
}

uint32_t planned_material_count(const Plan& plan, const PlannedModel& m) {
  std::set<int> materials;
  for (int mesh : planned_meshes(plan, m))
    for (const tinygltf::Primitive& p : plan.gltf.meshes[size_t(mesh)].primitives)
      materials.insert(p.material >= 0 && size_t(p.material) < plan.gltf.materials.size() ? p.material : -1);
  return std::max<uint32_t>(1, uint32_t(materials.size()));
}

Decision size_rule(const ConvertSettings& settings, uint64_t triangles, uint64_t freed_blas, uint64_t model_bytes) {
  if (triangles < settings.min_triangles) return Decision::BelowThreshold;
  if (settings.convert_when == ConvertWhen::Memory &&
      double(freed_blas) < settings.memory_margin * double(model_bytes))
    return Decision::NoMemorySaved;
  return Decision::Convert;
}

std::vector<BlasPrimitive> blas_primitives(const tinygltf::Model& g, int mesh) {
  std::vector<BlasPrimitive> out;
  if (mesh < 0 || size_t(mesh) >= g.meshes.size()) return out;
  for (const tinygltf::Primitive& p : g.meshes[size_t(mesh)].primitives) {
    const int position = gltf::find_attribute(p, "POSITION");
    if (position < 0 || size_t(position) >= g.accessors.size()) continue;
    const gltf::PrimitiveSize size = gltf::primitive_size(g, p);  // the triangles the readers make of it
    if (size.triangles) out.push_back({size.vertices, size.triangles});
  }
  return out;
}

uint64_t freed_blas_bytes(const Plan& plan, const std::vector<int>& object) {
  const std::set<int> in_object(object.begin(), object.end());
  std::set<int> meshes;
  for (int i : object) meshes.insert(plan.nodes[size_t(i)].mesh);
  for (size_t i = 0; i < plan.nodes.size(); ++i) {
    const PlannedNode& n = plan.nodes[i];
    if (meshes.count(n.mesh) && !in_object.count(int(i)) && n.decision != Decision::AlreadyLsnif) meshes.erase(n.mesh);
  }
  uint64_t bytes = 0;
  for (int m : meshes) bytes += plan.mesh_blas[size_t(m)];
  return bytes;
}

SceneMemory scene_memory(const Plan& plan, const std::vector<uint64_t>& model_bytes) {
  std::set<int> drawn, kept;
  for (const PlannedNode& n : plan.nodes) {
    if (n.decision == Decision::AlreadyLsnif) continue;
    drawn.insert(n.mesh);
    if (n.decision != Decision::Convert) kept.insert(n.mesh);
  }
  SceneMemory out;
  for (int m : drawn) out.blas_before += plan.mesh_blas[size_t(m)];
  for (int m : kept) out.blas_after += plan.mesh_blas[size_t(m)];
  for (size_t i = 0; i < plan.models.size(); ++i)
    if (plan.models[i].error.empty())
      out.models += i < model_bytes.size() && model_bytes[i] ? model_bytes[i] : plan.models[i].model_bytes;
  return out;
}

namespace {

// The settings' regular expressions, compiled.
struct Rules {
  Pattern select, exclude;
  std::vector<Pattern> groups;
};

Status compile_rules(const ConvertSettings& settings, Rules& rules) {
  if (!settings.select.empty())
    if (Status s = compile(settings.select, "--select", rules.select); !s) return s;
  if (!settings.exclude.empty())
    if (Status s = compile(settings.exclude, "--exclude", rules.exclude); !s) return s;
  rules.groups.resize(settings.groups.size());
  for (size_t i = 0; i < settings.groups.size(); ++i) {
    const GroupRule& g = settings.groups[i];
    if (g.name.empty() || g.pattern.empty())
      return Status::error("--group needs NAME=REGEX with both parts (got '%s=%s')", g.name.c_str(), g.pattern.c_str());
    if (Status s = compile(g.pattern, "--group", rules.groups[i]); !s) return s;
  }
  return Status::ok();
}

// Reads settings.input into plan.gltf (and its folder into plan.input_dir); plan.bad_buffers gets
// one entry per glTF buffer, for .gltf JSON why an external one cannot be used.
Status read_input(const ConvertSettings& settings, Plan& plan) {
  const std::string& in = settings.input;
  std::vector<unsigned char> bytes;
  std::string err;
  if (!gltf::read_whole_file(&bytes, &err, in, nullptr)) return Status::error("%s", err.c_str());
  std::string data(bytes.begin(), bytes.end());
  const bool binary = data.size() >= 4 && data.compare(0, 4, "glTF") == 0;
  plan.input_dir = fs::path(in).parent_path().string();
  const bool allow_outside = settings.import_options.allow_outside_refs;
  if (!binary) data = isolate_bad_buffers(data, in, fs::path(plan.input_dir), allow_outside, plan.bad_buffers);
  gltf::LoadOptions load_options;
  load_options.allow_outside_refs = allow_outside;
  load_options.keep_extension_json = true;
  if (Status s = gltf::load_model(data, binary, in, plan.input_dir, load_options, plan.gltf, plan.warnings); !s)
    return s;
  if (Status s = scene::check_extension_types(plan.gltf, in); !s) return s;
  plan.bad_buffers.resize(plan.gltf.buffers.size());
  return Status::ok();
}

// plan.nodes: the default scene's nodes that have a mesh, depth first, with their world transforms
// (plan.scene: that scene). The node graph's errors are read_gltf_scene's (gltf_scene.h: the rules
// every tool applies); a missing mesh is a warning (`in`: the input's name for the messages).
Status collect_nodes(const std::string& in, Plan& plan) {
  const tinygltf::Model& g = plan.gltf;
  GltfScene walk;
  if (Status s = read_gltf_scene(g, in, walk); !s) return s;
  plan.scene = walk.scene;
  for (const GltfSceneNode& item : walk.nodes) {
    const tinygltf::Node& n = g.nodes[size_t(item.node)];
    if (n.mesh < 0) continue;
    if (size_t(n.mesh) >= g.meshes.size()) {
      plan.warnings.push_back(format("%s: node %d references missing mesh %d; left as it is", in.c_str(),
                                     item.node, n.mesh));
      continue;
    }
    PlannedNode p;
    p.node = item.node;
    p.name = gltf_node_name(g, item.node);
    p.mesh = n.mesh;
    p.mesh_name = gltf_mesh_name(g, n.mesh);
    for (const tinygltf::Primitive& prim : g.meshes[size_t(n.mesh)].primitives) p.triangles += gltf::primitive_size(g, prim).triangles;
    p.world = item.world;
    plan.nodes.push_back(std::move(p));
  }
  return Status::ok();
}

// Adds the plan's models with unique, file-name safe names. A model's file must not be a file the
// input refers to (a model another node already uses, a buffer, an image): such names get a suffix
// like names used twice.
class ModelNamer {
 public:
  ModelNamer(const ConvertSettings& settings, const Plan& plan)
      : out_stem_(fs::path(settings.output).stem().string()),
        out_dir_(fs::path(settings.output).parent_path()),
        inputs_(referenced_files(plan, settings.input)) {}

  // Appends the model of `base` (a mesh or group name) to plan.models; returns its index.
  int add_model(Plan& plan, const std::string& base, int mesh, const std::string& group) {
    PlannedModel m;
    std::string name = safe_name(base);
    for (int k = 2; used_names_.count(name) || taken(name); ++k) name = safe_name(base) + "_" + std::to_string(k);
    used_names_.insert(name);
    m.name = name;
    m.file = (out_stem_.empty() ? std::string("scene") : out_stem_) + "." + name + ".lsnif";
    m.mesh = mesh;
    m.group = group;
    plan.models.push_back(std::move(m));
    return int(plan.models.size() - 1);
  }

 private:
  // True when the model file of `name` would be a file the input refers to.
  bool taken(const std::string& name) const {
    const std::string file = (out_stem_.empty() ? std::string("scene") : out_stem_) + "." + name + ".lsnif";
    const std::string path = (out_dir_ / file).lexically_normal().string();
    for (const std::string& input : inputs_)
      if (input == path || same_file(input, path)) return true;
    return false;
  }

  const std::string out_stem_;
  const fs::path out_dir_;
  const std::vector<std::string> inputs_;
  std::set<std::string> used_names_;
};

// What node `n` (planned as `p`, extras tag `tag`) is by the LSNIF extension, its tag, --exclude and
// --select alone: Convert when it goes on to grouping and --min-triangles.
Decision selection(const ConvertSettings& settings, const Rules& rules, const tinygltf::Node& n, int tag,
                   const PlannedNode& p) {
  if (n.extensions.count(kNodeExtension)) return Decision::AlreadyLsnif;
  if (tag == 0) return Decision::TaggedOff;
  if (tag != 1) {
    if (!settings.exclude.empty() && (search(rules.exclude, p.name) || search(rules.exclude, p.mesh_name)))
      return Decision::Excluded;
    if (!settings.select.empty() && !search(rules.select, p.name) && !search(rules.select, p.mesh_name))
      return Decision::NotSelected;
  }
  return Decision::Convert;
}

// Estimated bytes of a model of glTF mesh `mesh` (its materials), from the settings.
uint64_t mesh_model_bytes(const ConvertSettings& settings, const Plan& plan, int mesh) {
  PlannedModel one;
  one.mesh = mesh;
  return planned_model_bytes(settings.train, plan, one);
}

// Decides every node of plan.nodes and adds the models they use: one per group (its rule applied
// later, by settle_models) and one per glTF mesh, for its tagged nodes and, when the size rule
// (size_rule) says so, its other candidates.
void assign_models(const ConvertSettings& settings, const Rules& rules, Plan& plan) {
  const tinygltf::Model& g = plan.gltf;
  ModelNamer namer(settings, plan);
  // Selection and groups first: whether converting a mesh frees its BLAS depends on all its nodes.
  std::vector<int> tags(plan.nodes.size());
  std::map<int, std::vector<int>> mesh_candidates;  // per mesh: its candidate nodes outside groups
  for (size_t i = 0; i < plan.nodes.size(); ++i) {
    PlannedNode& p = plan.nodes[i];
    const tinygltf::Node& n = g.nodes[size_t(p.node)];
    tags[i] = extras_tag(n);
    p.decision = selection(settings, rules, n, tags[i], p);
    if (p.decision != Decision::Convert) continue;
    p.group = extras_group(n);
    for (size_t r = 0; p.group.empty() && r < settings.groups.size(); ++r)
      if (search(rules.groups[r], p.name)) p.group = settings.groups[r].name;
    if (p.group.empty()) mesh_candidates[p.mesh].push_back(int(i));
  }
  std::map<int, int> mesh_model;
  std::map<std::string, int> group_model;
  std::map<int, Decision> mesh_rule;  // per mesh: the size rule's decision for its untagged nodes
  for (size_t i = 0; i < plan.nodes.size(); ++i) {
    PlannedNode& p = plan.nodes[i];
    if (p.decision != Decision::Convert) continue;
    if (!p.group.empty()) {
      auto it = group_model.find(p.group);
      if (it == group_model.end()) it = group_model.emplace(p.group, namer.add_model(plan, p.group, -1, p.group)).first;
      p.model = it->second;  // the group's rule is applied by settle_models
      plan.models[size_t(p.model)].nodes.push_back(int(i));
      plan.models[size_t(p.model)].triangles += p.triangles;
      continue;
    }
    if (tags[i] != 1) {
      auto rule = mesh_rule.find(p.mesh);
      if (rule == mesh_rule.end()) {
        const uint64_t freed = freed_blas_bytes(plan, mesh_candidates[p.mesh]);
        rule = mesh_rule.emplace(p.mesh, size_rule(settings, p.triangles, freed, mesh_model_bytes(settings, plan, p.mesh)))
                   .first;
      }
      if (rule->second != Decision::Convert) {
        p.decision = rule->second;
        continue;
      }
    }
    auto it = mesh_model.find(p.mesh);
    if (it == mesh_model.end()) it = mesh_model.emplace(p.mesh, namer.add_model(plan, p.mesh_name, p.mesh, "")).first;
    p.model = it->second;
    plan.models[size_t(p.model)].nodes.push_back(int(i));
    plan.models[size_t(p.model)].triangles = p.triangles;
  }
}

// Groups the size rule keeps as triangles (unless a member is tagged) stay triangles; bad members
// fail the model. Drops the former from plan.models and renumbers the nodes' models; sets every
// model's estimated bytes.
void settle_models(const ConvertSettings& settings, Plan& plan) {
  const tinygltf::Model& g = plan.gltf;
  std::map<int, std::string> problems;  // per mesh, computed once
  auto problem_of = [&](int mesh) -> const std::string& {
    auto it = problems.find(mesh);
    if (it == problems.end()) it = problems.emplace(mesh, mesh_problem(plan, mesh)).first;
    return it->second;
  };
  std::vector<PlannedModel> kept;
  std::vector<int> remap(plan.models.size(), -1);
  for (size_t k = 0; k < plan.models.size(); ++k) {
    PlannedModel& m = plan.models[k];
    m.model_bytes = planned_model_bytes(settings.train, plan, m);
    bool tagged = false;
    for (int ni : m.nodes) tagged |= extras_tag(g.nodes[size_t(plan.nodes[size_t(ni)].node)]) == 1;
    const Decision rule = m.group.empty() || tagged ? Decision::Convert
                                                    : size_rule(settings, m.triangles, freed_blas_bytes(plan, m.nodes),
                                                                m.model_bytes);
    if (rule != Decision::Convert) {
      for (int ni : m.nodes) {
        plan.nodes[size_t(ni)].decision = rule;
        plan.nodes[size_t(ni)].model = -1;
      }
      continue;
    }
    for (int ni : m.nodes) {
      const PlannedNode& p = plan.nodes[size_t(ni)];
      const std::string& why = problem_of(p.mesh);
      if (!why.empty() && m.error.empty())
        m.error = format("node '%s' (mesh '%s'): %s", p.name.c_str(), p.mesh_name.c_str(), why.c_str());
    }
    remap[k] = int(kept.size());
    kept.push_back(std::move(m));
  }
  plan.models = std::move(kept);
  for (PlannedNode& p : plan.nodes) {
    if (p.model < 0) continue;
    p.model = remap[size_t(p.model)];
    if (p.model >= 0 && !plan.models[size_t(p.model)].error.empty()) p.decision = Decision::Failed;
  }
}

// plan.mesh_blas for the meshes of plan.nodes, with `sizer`; its error names the mesh.
Status size_blases(const BlasSizer& sizer, Plan& plan) {
  plan.blas_source = sizer.query ? sizer.source : estimated_blas_source();
  plan.mesh_blas.assign(plan.gltf.meshes.size(), 0);
  std::set<int> done;
  for (const PlannedNode& n : plan.nodes) {
    if (!done.insert(n.mesh).second) continue;
    if (Status s = blas_bytes(sizer, blas_primitives(plan.gltf, n.mesh), plan.mesh_blas[size_t(n.mesh)]); !s)
      return Status::error("mesh '%s': the size of its triangle BLAS: %s", printable(n.mesh_name).c_str(),
                           s.message().c_str());
  }
  return Status::ok();
}

// plan.memory: a row per mesh (its nodes outside groups) and per group, at its first node.
void fill_memory_table(const ConvertSettings& settings, Plan& plan) {
  std::map<std::pair<int, std::string>, size_t> row_of;  // (mesh, "") or (-1, group)
  for (size_t i = 0; i < plan.nodes.size(); ++i) {
    const PlannedNode& n = plan.nodes[i];
    if (n.decision == Decision::AlreadyLsnif) continue;
    const std::pair<int, std::string> key(n.group.empty() ? n.mesh : -1, n.group);
    auto it = row_of.find(key);
    if (it == row_of.end()) {
      it = row_of.emplace(key, plan.memory.size()).first;
      MemoryRow row;
      row.group = !n.group.empty();
      row.name = row.group ? n.group : n.mesh_name;
      row.mesh = row.group ? -1 : n.mesh;
      plan.memory.push_back(std::move(row));
    }
    MemoryRow& row = plan.memory[it->second];
    row.nodes.push_back(int(i));
    if (row.group || row.nodes.size() == 1) row.triangles += n.triangles;
    if (n.model >= 0) row.model = n.model;
  }
  for (MemoryRow& row : plan.memory) {
    // What the rule weighed: the candidates (nodes outside groups that --select, --exclude and the
    // tags leave to it); a row without any shows what converting all its nodes would free.
    std::vector<int> candidates;
    std::set<int> meshes;
    for (int i : row.nodes) {
      const PlannedNode& n = plan.nodes[size_t(i)];
      meshes.insert(n.mesh);
      if (n.decision == Decision::Convert || n.decision == Decision::BelowThreshold ||
          n.decision == Decision::NoMemorySaved || n.decision == Decision::Failed)
        candidates.push_back(i);
    }
    for (int m : meshes) row.blas_bytes += plan.mesh_blas[size_t(m)];
    row.freed_bytes = freed_blas_bytes(plan, candidates.empty() ? row.nodes : candidates);
    if (row.model >= 0) {
      row.model_bytes = plan.models[size_t(row.model)].model_bytes;
    } else if (row.group) {
      PlannedModel as_group;
      for (int i : row.nodes) as_group.nodes.push_back(i);
      row.model_bytes = planned_model_bytes(settings.train, plan, as_group);
    } else {
      row.model_bytes = mesh_model_bytes(settings, plan, row.mesh);
    }
  }
}

}  // namespace

Status check_settings(const ConvertSettings& settings) {
  if (!(settings.memory_margin >= kMinMemoryMargin && settings.memory_margin <= kMaxMemoryMargin))
    return Status::error("--memory-margin %g is outside [%.10g, %.10g] (the BLAS bytes a conversion must free per byte "
                         "of its model)", settings.memory_margin, kMinMemoryMargin, kMaxMemoryMargin);
  const bool plan = !settings.plan_dir.empty(), assemble = !settings.assemble_dir.empty();
  if (plan && assemble) return Status::error("--plan writes the jobs, --assemble adopts what they wrote: one at a time");
  if (plan && settings.dry_run) return Status::error("--plan writes the jobs, --dry-run writes nothing: one at a time");
  if (assemble && settings.force)
    return Status::error("--force retrains every model here, --assemble adopts the models of the plan's jobs: one at a "
                         "time");
  if (settings.retrain_missing && !assemble) return Status::error("--retrain-missing goes with --assemble DIR");
  if (!settings.job_command.empty() && !plan) return Status::error("--job-command goes with --plan DIR");
  if (plan)
    for (const auto& [what, text] : {std::pair<const char*, const std::string&>{"--job-command", settings.job_command},
                                     {"--plan", settings.plan_dir}, {"the input path", settings.input},
                                     {"-o", settings.output}})
      if (std::string why = command_line_problem(what, text); !why.empty()) return Status::error("%s", why.c_str());
  Rules unused;
  return compile_rules(settings, unused);
}

Status make_plan(const ConvertSettings& settings, Plan& plan) {
  plan = Plan();
  Rules rules;
  if (Status s = compile_rules(settings, rules); !s) return s;
  if (Status s = read_input(settings, plan); !s) return s;
  if (Status s = collect_nodes(settings.input, plan); !s) return s;
  if (Status s = size_blases(settings.blas, plan); !s) return s;
  // Decisions and models.
  assign_models(settings, rules, plan);
  settle_models(settings, plan);
  fill_memory_table(settings, plan);
  return Status::ok();
}

}  // namespace lsnif::convert
