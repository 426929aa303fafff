// convert_plan.cpp -- reading the input glTF and deciding what to convert (convert_plan.h).
#include "lsnif/apps/convert/convert_plan.h"

#include <re2/re2.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <set>

#include "lsnif/format/atomic_file.h"
#include "lsnif/import/gltf_scene.h"
#include "lsnif/import/json_text.h"
#include "lsnif/import/mesh_gltf.h"
#include "lsnif/core/model.h"
#include "lsnif/import/resolve_path.h"
#include "lsnif/renderer/scene_gltf.h"

namespace lsnif::convert {
namespace fs = std::filesystem;

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

uint64_t primitive_triangles(const tinygltf::Model& g, const tinygltf::Primitive& p) {
  const int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
  if (!is_triangle_mode(mode)) return 0;
  int acc = p.indices >= 0 ? p.indices : gltf::find_attribute(p, "POSITION");
  if (acc < 0 || size_t(acc) >= g.accessors.size()) return 0;
  const uint64_t n = g.accessors[size_t(acc)].count;
  return mode == TINYGLTF_MODE_TRIANGLES ? n / 3 : (n >= 3 ? n - 2 : 0);
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
    if (!is_triangle_mode(mode))
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

bool is_triangle_mode(int mode) {
  if (mode < 0) mode = TINYGLTF_MODE_TRIANGLES;  // glTF's default
  return mode == TINYGLTF_MODE_TRIANGLES || mode == TINYGLTF_MODE_TRIANGLE_STRIP ||
         mode == TINYGLTF_MODE_TRIANGLE_FAN;
}

const char* decision_text(Decision d) {
  switch (d) {
    case Decision::Convert: return "convert";
    case Decision::BelowThreshold: return "stays triangles (below --min-triangles)";
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

uint64_t estimated_model_bytes(const TrainSettings& train, uint32_t material_count, const Mesh* mesh) {
  Model m;
  m.config = train.config;
  m.config.material_count = std::max(1u, material_count);
  bool indexed = false;
  for (uint32_t l = 0; l < m.config.grid_levels && l < LSNIF_MAX_LEVELS; ++l) indexed |= train.indexed[l];
  if (mesh && indexed && !mesh->triangles.empty()) {
    // The indexed levels' tables as the trainer sizes them: from the mesh's voxels.
    Config indexed_config = m.config;
    if (model_layout(*mesh, train, indexed_config, m.voxels, m.grid_index)) m.config = indexed_config;
  }
  return memory_breakdown(m).total();
}

uint32_t planned_material_count(const Plan& plan, const PlannedModel& m) {
  std::set<int> materials, meshes;
  if (m.mesh >= 0) meshes.insert(m.mesh);
  for (int n : m.nodes) meshes.insert(plan.nodes[size_t(n)].mesh);
  for (int mesh : meshes)
    for (const tinygltf::Primitive& p : plan.gltf.meshes[size_t(mesh)].primitives)
      materials.insert(p.material >= 0 && size_t(p.material) < plan.gltf.materials.size() ? p.material : -1);
  return std::max<uint32_t>(1, uint32_t(materials.size()));
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
    for (const tinygltf::Primitive& prim : g.meshes[size_t(n.mesh)].primitives) p.triangles += primitive_triangles(g, prim);
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

// Decides every node of plan.nodes and adds the models they use: one per group (its threshold
// applied later, by settle_models) and one per glTF mesh.
void assign_models(const ConvertSettings& settings, const Rules& rules, Plan& plan) {
  const tinygltf::Model& g = plan.gltf;
  ModelNamer namer(settings, plan);
  std::map<int, int> mesh_model;
  std::map<std::string, int> group_model;
  for (size_t i = 0; i < plan.nodes.size(); ++i) {
    PlannedNode& p = plan.nodes[i];
    const tinygltf::Node& n = g.nodes[size_t(p.node)];
    const int tag = extras_tag(n);
    p.decision = selection(settings, rules, n, tag, p);
    if (p.decision != Decision::Convert) continue;
    std::string group = extras_group(n);
    for (size_t r = 0; group.empty() && r < settings.groups.size(); ++r)
      if (search(rules.groups[r], p.name)) group = settings.groups[r].name;
    if (!group.empty()) {
      auto it = group_model.find(group);
      if (it == group_model.end()) it = group_model.emplace(group, namer.add_model(plan, group, -1, group)).first;
      p.model = it->second;
      p.decision = Decision::Convert;  // the group's threshold is applied by settle_models
      plan.models[size_t(p.model)].nodes.push_back(int(i));
      plan.models[size_t(p.model)].triangles += p.triangles;
      continue;
    }
    if (tag != 1 && p.triangles < settings.min_triangles) {
      p.decision = Decision::BelowThreshold;
      continue;
    }
    auto it = mesh_model.find(p.mesh);
    if (it == mesh_model.end()) it = mesh_model.emplace(p.mesh, namer.add_model(plan, p.mesh_name, p.mesh, "")).first;
    p.model = it->second;
    p.decision = Decision::Convert;
    plan.models[size_t(p.model)].nodes.push_back(int(i));
    plan.models[size_t(p.model)].triangles = p.triangles;
  }
}

// Groups below the threshold (unless a member is tagged) stay triangles; bad members fail the model.
// Drops the former from plan.models and renumbers the nodes' models.
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
    bool tagged = false;
    for (int ni : m.nodes) tagged |= extras_tag(g.nodes[size_t(plan.nodes[size_t(ni)].node)]) == 1;
    if (!m.group.empty() && !tagged && m.triangles < settings.min_triangles) {
      for (int ni : m.nodes) {
        plan.nodes[size_t(ni)].decision = Decision::BelowThreshold;
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

}  // namespace

Status check_settings(const ConvertSettings& settings) {
  Rules unused;
  return compile_rules(settings, unused);
}

Status make_plan(const ConvertSettings& settings, Plan& plan) {
  plan = Plan();
  Rules rules;
  if (Status s = compile_rules(settings, rules); !s) return s;
  if (Status s = read_input(settings, plan); !s) return s;
  if (Status s = collect_nodes(settings.input, plan); !s) return s;
  // Decisions and models.
  assign_models(settings, rules, plan);
  settle_models(settings, plan);
  return Status::ok();
}

}  // namespace lsnif::convert
