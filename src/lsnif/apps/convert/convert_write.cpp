// convert_write.cpp -- OUT.gltf from the plan and the models (convert_write.h).
#include "lsnif/apps/convert/convert_write.h"

#include <cstring>
#include <filesystem>

#include "lsnif/format/file_io.h"
#include "lsnif/scene/gltf_build.h"
#include "lsnif/import/mesh_gltf.h"

namespace lsnif::convert {
namespace fs = std::filesystem;

namespace {

// Accessor indices a primitive refers to (attributes, indices, morph targets), -1 included.
std::vector<int*> primitive_accessors(tinygltf::Primitive& p) {
  std::vector<int*> out{&p.indices};
  for (auto& [key, acc] : p.attributes) out.push_back(&acc);
  for (auto& target : p.targets)
    for (auto& [key, acc] : target) out.push_back(&acc);
  return out;
}

// BufferViews an accessor refers to (its data and its sparse indices / values).
std::vector<int*> accessor_views(tinygltf::Accessor& a) {
  std::vector<int*> out{&a.bufferView};
  if (a.sparse.isSparse) {
    out.push_back(&a.sparse.indices.bufferView);
    out.push_back(&a.sparse.values.bufferView);
  }
  return out;
}

// Why bufferView `v` cannot be copied ("" when it can).
std::string view_problem(const tinygltf::Model& g, const Plan& plan, int v) {
  if (v < 0 || size_t(v) >= g.bufferViews.size()) return format("bufferView %d does not exist", v);
  const tinygltf::BufferView& view = g.bufferViews[size_t(v)];
  if (view.buffer >= 0 && size_t(view.buffer) < plan.bad_buffers.size() && !plan.bad_buffers[size_t(view.buffer)].empty())
    return plan.bad_buffers[size_t(view.buffer)];
  const unsigned char* data = nullptr;
  Status s = gltf::view_range(g, v, 0, view.byteLength, data);
  return s ? std::string() : s.message();
}

// Why mesh `m` of `g` cannot be written ("" when every byte it uses can be copied).
std::string mesh_write_problem(tinygltf::Model& g, const Plan& plan, int m) {
  for (tinygltf::Primitive& p : g.meshes[size_t(m)].primitives)
    for (int* acc : primitive_accessors(p)) {
      if (*acc < 0) continue;
      if (size_t(*acc) >= g.accessors.size()) return format("accessor %d does not exist", *acc);
      for (int* v : accessor_views(g.accessors[size_t(*acc)]))
        if (*v >= 0)
          if (std::string why = view_problem(g, plan, *v); !why.empty()) return why;
    }
  return "";
}

// Keeps only the meshes nodes use, the accessors those meshes use and the bufferViews those
// accessors and the images use; copies the views into one buffer (4-byte aligned).
void compact(tinygltf::Model& g, const Plan& plan, WriteReport& report) {
  for (const tinygltf::Buffer& b : g.buffers) report.buffer_bytes_in += b.data.size();
  if (!g.skins.empty() || !g.animations.empty()) {
    report.notes.push_back(format("dropped %zu skins and %zu animations (not carried over by the converter)",
                                  g.skins.size(), g.animations.size()));
    g.skins.clear();
    g.animations.clear();
    for (tinygltf::Node& n : g.nodes) n.skin = -1;
  }
  // Meshes in use whose data can be copied.
  std::vector<int> mesh_map(g.meshes.size(), -1);
  std::vector<std::string> problem(g.meshes.size());
  std::vector<uint8_t> checked(g.meshes.size(), 0);
  for (size_t ni = 0; ni < g.nodes.size(); ++ni) {
    tinygltf::Node& n = g.nodes[ni];
    if (n.mesh < 0) continue;
    if (size_t(n.mesh) >= g.meshes.size()) {
      n.mesh = -1;
      continue;
    }
    if (!checked[size_t(n.mesh)]) {
      problem[size_t(n.mesh)] = mesh_write_problem(g, plan, n.mesh);
      checked[size_t(n.mesh)] = 1;
    }
    if (!problem[size_t(n.mesh)].empty()) {
      report.notes.push_back(format("node '%s': mesh %d ('%s') left out of the output: %s", n.name.c_str(), n.mesh,
                                    g.meshes[size_t(n.mesh)].name.c_str(), problem[size_t(n.mesh)].c_str()));
      n.mesh = -1;
      continue;
    }
    mesh_map[size_t(n.mesh)] = 0;
  }
  std::vector<tinygltf::Mesh> meshes;
  for (size_t m = 0; m < g.meshes.size(); ++m) {
    if (mesh_map[m] < 0) continue;
    mesh_map[m] = int(meshes.size());
    meshes.push_back(std::move(g.meshes[m]));
  }
  report.meshes_removed = g.meshes.size() - meshes.size();
  g.meshes = std::move(meshes);
  for (tinygltf::Node& n : g.nodes)
    if (n.mesh >= 0) n.mesh = mesh_map[size_t(n.mesh)];

  // Accessors.
  std::vector<int> acc_map(g.accessors.size(), -1);
  std::vector<tinygltf::Accessor> accessors;
  for (tinygltf::Mesh& m : g.meshes)
    for (tinygltf::Primitive& p : m.primitives)
      for (int* acc : primitive_accessors(p)) {
        if (*acc < 0) continue;
        int& mapped = acc_map[size_t(*acc)];
        if (mapped < 0) {
          mapped = int(accessors.size());
          accessors.push_back(g.accessors[size_t(*acc)]);
        }
        *acc = mapped;
      }
  g.accessors = std::move(accessors);

  // BufferViews, copied into one buffer.
  std::vector<int> view_map(g.bufferViews.size(), -1);
  std::vector<tinygltf::BufferView> views;
  tinygltf::Buffer buffer;
  auto keep_view = [&](int& v) {
    if (v < 0) return;
    if (size_t(v) >= view_map.size() || !view_problem(g, plan, v).empty()) {
      v = -1;
      return;
    }
    int& mapped = view_map[size_t(v)];
    if (mapped < 0) {
      tinygltf::BufferView view = g.bufferViews[size_t(v)];
      const unsigned char* data = nullptr;
      (void)gltf::view_range(g, v, 0, view.byteLength, data);  // checked by view_problem
      buffer.data.resize((buffer.data.size() + 3) & ~size_t(3), 0);
      view.byteOffset = buffer.data.size();
      view.buffer = 0;
      buffer.data.insert(buffer.data.end(), data, data + view.byteLength);
      mapped = int(views.size());
      views.push_back(std::move(view));
    }
    v = mapped;
  };
  for (tinygltf::Accessor& a : g.accessors)
    for (int* v : accessor_views(a)) keep_view(*v);
  for (tinygltf::Image& im : g.images) {
    if (im.bufferView < 0) continue;
    const int before = im.bufferView;
    keep_view(im.bufferView);
    if (im.bufferView < 0)
      report.notes.push_back(format("image %s: its bufferView %d is unreadable; the image has no data", im.name.c_str(), before));
  }
  g.bufferViews = std::move(views);
  g.buffers.assign(1, std::move(buffer));
  report.buffer_bytes_out = g.buffers[0].data.size();
}

// `uri`, relative to the input's folder (or absolute), made relative to the output's folder.
std::string relocate(const std::string& uri, const std::string& input_dir, const std::string& output_dir) {
  fs::path p(uri);
  if (p.is_relative()) p = fs::path(input_dir) / p;
  std::error_code ec;
  const fs::path rel = fs::relative(fs::weakly_canonical(p, ec), fs::weakly_canonical(output_dir.empty() ? "." : output_dir, ec), ec);
  return ec || rel.empty() ? fs::absolute(p).generic_string() : rel.generic_string();
}

// True when `relocated` (a path relocate made) leads out of the output folder.
bool leaves_folder(const std::string& relocated) {
  const fs::path p(relocated);
  return p.is_absolute() || (!p.empty() && *p.begin() == "..");
}

// An external PNG or JPEG image the output would reach outside its folder (the input's images,
// converted into another folder) is embedded into the output's binary buffer instead, so that the
// output folder is self-contained and loads without --allow-outside-refs; with that option the
// image is referenced where it lies. A file that is missing, too large or neither PNG nor JPEG
// (the formats glTF embeds) is an error naming it and the way out.
Status embed_outside_images(tinygltf::Model& g, const std::string& input_dir, const std::string& output_dir,
                            bool allow_outside_refs, WriteReport& report) {
  constexpr uint64_t kMaxEmbeddedImageBytes = uint64_t(1) << 28;
  for (size_t i = 0; i < g.images.size(); ++i) {
    tinygltf::Image& im = g.images[i];
    if (im.uri.empty() || im.uri.rfind("data:", 0) == 0 || allow_outside_refs) continue;
    if (!leaves_folder(relocate(im.uri, input_dir, output_dir))) continue;
    const fs::path source = fs::path(im.uri).is_relative() ? fs::path(input_dir) / im.uri : fs::path(im.uri);
    std::vector<uint8_t> bytes;
    if (Status s = read_file(source.string(), bytes, kMaxEmbeddedImageBytes); !s)
      return s.context(format("image %zu ('%s') lies outside the output folder and cannot be embedded", i,
                              excerpt(im.uri).c_str()));
    const bool png = bytes.size() >= 8 && std::memcmp(bytes.data(), "\x89PNG\r\n\x1a\n", 8) == 0;
    const bool jpeg = bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF;
    if (!png && !jpeg)
      return Status::error("image %zu ('%s') lies outside the output folder and is neither PNG nor JPEG, so it "
                           "cannot be embedded: write the output beside it or pass --allow-outside-refs",
                           i, excerpt(im.uri).c_str());
    tinygltf::Buffer buffer;
    buffer.data.assign(bytes.begin(), bytes.end());
    g.buffers.push_back(std::move(buffer));
    tinygltf::BufferView view;
    view.buffer = int(g.buffers.size() - 1);
    view.byteLength = bytes.size();
    g.bufferViews.push_back(view);
    report.notes.push_back(format("image %zu ('%s'): embedded into the binary buffer (it lies outside the output "
                                  "folder; --allow-outside-refs references it there instead)",
                                  i, excerpt(im.uri).c_str()));
    im.bufferView = int(g.bufferViews.size() - 1);
    im.mimeType = png ? "image/png" : "image/jpeg";
    im.uri.clear();
  }
  return Status::ok();
}

// Files the input refers to stay where they are: external images (those not embedded), the models
// of nodes that were LSNIF objects already and the environment image get paths relative to the
// output folder.
void relocate_files(tinygltf::Model& g, const std::string& input_dir, const std::string& output_dir) {
  for (tinygltf::Image& im : g.images)
    if (!im.uri.empty() && im.uri.rfind("data:", 0) != 0) im.uri = relocate(im.uri, input_dir, output_dir);
  auto fix = [&](tinygltf::ExtensionMap& exts, const char* ext, const char* key) {
    auto it = exts.find(ext);
    if (it == exts.end() || !it->second.IsObject() || !it->second.Has(key) || !it->second.Get(key).IsString()) return;
    const std::string path = it->second.Get(key).Get<std::string>();
    if (path.empty()) return;
    tinygltf::Value::Object o = it->second.Get<tinygltf::Value::Object>();
    o[key] = tinygltf::Value(relocate(path, input_dir, output_dir));
    it->second = tinygltf::Value(std::move(o));
  };
  for (tinygltf::Node& n : g.nodes) fix(n.extensions, "LSNIF_neural_object", "model");
  fix(g.extensions, "LSNIF_environment", "hdr");
}

bool has_triangle_primitive(const tinygltf::Model& g, int mesh) {
  for (const tinygltf::Primitive& p : g.meshes[size_t(mesh)].primitives)
    if (gltf::is_triangle_mode(p.mode)) return true;
  return false;
}

}  // namespace

Status build_output(const ConvertSettings& settings, const Plan& plan, const std::vector<ModelResult>& results,
                    bool planned_as_trained, tinygltf::Model& out, WriteReport& report) {
  report = WriteReport();
  out = plan.gltf;
  const std::string output_dir = fs::path(settings.output).parent_path().string();
  if (Status s = embed_outside_images(out, plan.input_dir, output_dir, settings.import_options.allow_outside_refs, report);
      !s)
    return s;
  relocate_files(out, plan.input_dir, output_dir);
  if (out.scenes.empty()) {  // make the implicit scene (every root node) explicit before adding nodes
    out.scenes.resize(1);
    out.scenes[0].nodes = gltf::parentless_nodes(out);
    out.defaultScene = 0;
  }
  int default_material = -1;
  auto material_list = [&](const ModelResult& r) {
    std::vector<uint32_t> list;
    for (int src : r.material_sources) {
      if (src < 0 && default_material < 0) {
        default_material = scene::add_material(out, scene::Material{"lsnif_default"});
      }
      list.push_back(uint32_t(src < 0 ? default_material : src));
    }
    return list;
  };
  struct GroupNode {
    size_t model;
    std::vector<uint32_t> materials;
  };
  std::vector<GroupNode> groups;
  for (size_t i = 0; i < plan.models.size(); ++i) {
    const PlannedModel& m = plan.models[i];
    const ModelResult& r = results[i];
    const bool made = r.state == ModelState::Trained || r.state == ModelState::Adopted ||
                      r.state == ModelState::UpToDate || (planned_as_trained && r.state == ModelState::Planned);
    if (!made) continue;
    const std::vector<uint32_t> materials = material_list(r);
    for (int ni : m.nodes) {
      tinygltf::Node& n = out.nodes[size_t(plan.nodes[size_t(ni)].node)];
      if (m.group.empty()) {
        scene::set_neural_object(out, plan.nodes[size_t(ni)].node, m.file, materials);
        ++report.converted_nodes;
        if (!settings.keep_meshes) n.mesh = -1;
      } else {
        n.mesh = -1;  // the group node (below) carries the model and, with --keep-meshes, the reference
      }
    }
    if (!m.group.empty()) groups.push_back({i, materials});
  }
  // Failed objects stay as they were, but a mesh whose triangle data does not read (indices past
  // the vertices, bad accessors, ...) would make OUT.gltf unreadable: its nodes lose it. Meshes
  // without a triangle primitive (points, lines) are kept.
  for (size_t i = 0; i < plan.models.size(); ++i) {
    if (results[i].state != ModelState::Failed) continue;
    for (int ni : plan.models[i].nodes) {
      const PlannedNode& p = plan.nodes[size_t(ni)];
      if (!has_triangle_primitive(plan.gltf, p.mesh)) continue;
      Mesh alone;
      std::vector<int> sources;
      if (Status st = flatten_gltf_meshes(plan.gltf, {{p.mesh, glm::dmat4(1.0)}}, p.mesh_name, alone, sources); !st) {
        out.nodes[size_t(p.node)].mesh = -1;
        report.notes.push_back(format("node '%s': mesh '%s' left out of the output: %s", p.name.c_str(),
                                      p.mesh_name.c_str(), st.message().c_str()));
      }
    }
  }
  compact(out, plan, report);
  for (const GroupNode& gn : groups) {
    const PlannedModel& m = plan.models[gn.model];
    int mesh = -1;
    if (settings.keep_meshes)
      if (Status s = scene::add_mesh(out, scene::mesh_from(m.name + "_reference", results[gn.model].mesh, gn.materials), mesh); !s)
        return s.context(format("group '%s'", m.group.c_str()));
    const int node = scene::add_node(out, m.group, mesh, glm::mat4(1.0f));
    scene::set_neural_object(out, node, m.file, gn.materials);
    ++report.converted_nodes;
    ++report.group_nodes;
  }
  out.asset.generator = "lsnif convert (from " + (out.asset.generator.empty() ? std::string("unknown") : out.asset.generator) + ")";
  return Status::ok();
}

Status write_output(const ConvertSettings& settings, const Plan& plan,
                    const std::vector<ModelResult>& results, WriteReport& report) {
  if (fs::path(settings.output).extension() != ".gltf")
    return Status::error("%s: the output must be a .gltf file", settings.output.c_str());
  tinygltf::Model out;
  if (Status s = build_output(settings, plan, results, false, out, report); !s) return s;
  return scene::save_gltf(out, settings.output);
}

}  // namespace lsnif::convert
