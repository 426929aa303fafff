// scene_gltf.cpp -- glTF 2.0 scene loader for the renderer (scene_gltf.h; the LSNIF extensions are
// specified in docs/scene-format.md). Unlike src/lsnif/import/mesh_gltf.cpp, which flattens a file into one
// object-space triangle soup for training, this keeps the node hierarchy's instancing: meshes stay
// in object space and every node becomes an Instance with its world transform.
//
// tinygltf 2.7 leaves most validation to the user, so every index, accessor and buffer range is
// checked before a byte is read: loading, accessor reads and image decoding go through
// src/lsnif/import/gltf_access.h (library lsnif_import, shared with src/lsnif/import/mesh_gltf.cpp); the rest is checked
// here.
#include "lsnif/renderer/scene_gltf.h"

#include "lsnif/renderer/scene_edit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <set>

#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "lsnif/import/gltf_access.h"
#include "lsnif/import/gltf_scene.h"
#include "lsnif/import/json_text.h"
#include "lsnif/import/resolve_path.h"

namespace lsnif::scene {
namespace {

constexpr uint64_t kMaxPixels = uint64_t(1) << 26;       // per texture (8192 x 8192)
constexpr size_t kMaxVertices = size_t(1) << 30;         // per accessor
constexpr size_t kMaxMessageChars = 600;  // of tinygltf's error and warning text
constexpr size_t kMaxListedWarnings = 8;  // per kind; the rest are counted in a summary line
constexpr const char* kNodeExtension = "LSNIF_neural_object";
constexpr const char* kEnvironmentExtension = "LSNIF_environment";
constexpr uint8_t kLsnifMagic[8] = {'L', 'S', 'N', 'I', 'F', 0x00, '\r', '\n'};

// double -> float without undefined behaviour (out-of-range magnitudes become +-infinity).
float to_float(double d) {
  constexpr double kMax = static_cast<double>(std::numeric_limits<float>::max());
  if (d > kMax) return std::numeric_limits<float>::infinity();
  if (d < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(d);
}

// Short printable excerpt of a name for messages.
std::string excerpt(std::string_view s) {
  std::string out(s.substr(0, 40));
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = '?';
  if (s.size() > 40) out += "...";
  return out;
}

bool all_finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double d) { return std::isfinite(d); });
}

// A finite number from a JSON value.
bool number_of(const tinygltf::Value& v, double& out) {
  if (!v.IsNumber()) return false;
  out = v.GetNumberAsDouble();
  return std::isfinite(out);
}

class SceneBuilder {
 public:
  SceneBuilder(const tinygltf::Model& model, const std::string& name, const std::string& base_dir,
               const SceneLoadOptions& options, Scene& scene)
      : model_(model), name_(name), base_dir_(base_dir), options_(options), scene_(scene),
        mesh_map_(model.meshes.size(), -2), image_map_(model.images.size(), -2),
        node_overrides_(model.nodes.size()) {}

  Status run() {
    Status s = check_extensions();
    if (s) s = load_materials();
    if (s) s = resolve_overrides();
    if (s) s = load_environment();
    if (!s) return s;
    if (model_.scenes.empty() && model_.nodes.empty())
      return Status::error("%s: the file has no scenes and no nodes", file());
    GltfScene walk;  // the node graph's rules: lsnif/import/gltf_scene.h
    s = read_gltf_scene(model_, name_, walk);
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
                           skipped_primitives_ ? " (primitives that are not TRIANGLES were skipped)" : "");
    return Status::ok();
  }

 private:
  const char* file() const { return name_.c_str(); }

  void warn(const std::string& msg) { scene_.warnings.push_back(name_ + ": " + msg); }

  // Warnings of one kind: the first few are listed, the rest counted at the end.
  void warn_counted(const std::string& kind, const std::string& msg) {
    if (++warn_counts_[kind] <= kMaxListedWarnings) warn(msg);
  }

  void summarize_warnings() {
    for (const auto& [kind, n] : warn_counts_)
      if (n > kMaxListedWarnings)
        warn(format("... %zu more warnings like the above (%s)", n - kMaxListedWarnings, kind.c_str()));
    if (skipped_primitives_) {
      std::string by_mode;
      for (const auto& [mode, n] : skipped_by_mode_)
        by_mode += format("%s%s: %zu", by_mode.empty() ? "" : ", ", gltf::mode_name(mode), n);
      warn(format("skipped %zu primitives that are not TRIANGLES (%s)", skipped_primitives_,
                  by_mode.c_str()));
    }
  }

  std::string node_label(int index) const { return gltf_node_label(model_, index); }

  // ---- extensions ----------------------------------------------------------------------------

  Status check_extensions() {
    if (Status s = check_extension_types(model_, name_); !s) return s;
    static const std::set<std::string> supported = {
        kNodeExtension, kEnvironmentExtension, "KHR_materials_emissive_strength",
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

  // ---- materials and textures ----------------------------------------------------------------

  Status load_materials() {
    scene_.materials.reserve(model_.materials.size() + 1);
    for (size_t i = 0; i < model_.materials.size(); ++i) {
      Status s = load_material(i);
      if (!s) return s;
    }
    return Status::ok();
  }

  Status load_material(size_t index) {
    const tinygltf::Material& gm = model_.materials[index];
    Material m;
    m.name = gm.name.empty() ? format("material_%zu", index) : gm.name;
    const std::string where = format("%s: material %zu ('%s')", file(), index, excerpt(m.name).c_str());
    const tinygltf::PbrMetallicRoughness& pbr = gm.pbrMetallicRoughness;
    const std::vector<double>& bc = pbr.baseColorFactor;
    if (bc.size() != 4 || !all_finite(bc))
      return Status::error("%s: baseColorFactor must be 4 finite numbers", where.c_str());
    const std::vector<double>& ef = gm.emissiveFactor;
    if (ef.size() != 3 || !all_finite(ef))
      return Status::error("%s: emissiveFactor must be 3 finite numbers", where.c_str());
    if (!std::isfinite(pbr.metallicFactor) || !std::isfinite(pbr.roughnessFactor))
      return Status::error("%s: metallicFactor / roughnessFactor must be finite", where.c_str());
    bool clamped = false;
    auto unit = [&](double v) {
      const double c = std::clamp(v, 0.0, 1.0);
      clamped |= c != v;
      return static_cast<float>(c);
    };
    m.base_color = glm::vec4(unit(bc[0]), unit(bc[1]), unit(bc[2]), unit(bc[3]));
    m.metallic = unit(pbr.metallicFactor);
    m.roughness = unit(pbr.roughnessFactor);
    glm::dvec3 emission(std::max(ef[0], 0.0), std::max(ef[1], 0.0), std::max(ef[2], 0.0));
    clamped |= emission != glm::dvec3(ef[0], ef[1], ef[2]);
    if (auto it = gm.extensions.find("KHR_materials_emissive_strength"); it != gm.extensions.end()) {
      double strength = 1.0;
      if (!it->second.IsObject())
        return Status::error("%s: KHR_materials_emissive_strength must be an object", where.c_str());
      const tinygltf::Value& v = it->second.Get("emissiveStrength");
      if (it->second.Has("emissiveStrength") && (!number_of(v, strength) || strength < 0.0))
        return Status::error("%s: emissiveStrength must be a finite number >= 0", where.c_str());
      emission *= strength;
    }
    m.emission = glm::vec3(to_float(emission.x), to_float(emission.y), to_float(emission.z));
    if (!std::isfinite(m.emission.x + m.emission.y + m.emission.z))
      return Status::error("%s: emission overflows a float", where.c_str());
    if (clamped) warn(where.substr(name_.size() + 2) + ": factors outside their range were clamped");

    Status s = texture_slot(pbr.baseColorTexture, "baseColorTexture", where, m.base_color_texture);
    if (s) s = texture_slot(pbr.metallicRoughnessTexture, "metallicRoughnessTexture", where,
                            m.metallic_roughness_texture);
    if (s) s = texture_slot(gm.emissiveTexture, "emissiveTexture", where, m.emission_texture);
    if (!s) return s;
    if (gm.normalTexture.index >= 0 || gm.occlusionTexture.index >= 0)
      warn_counted("normal/occlusion maps", where.substr(name_.size() + 2) +
                                                ": normal / occlusion textures ignored");
    // The uv set the renderer's single uv channel should carry: the base color's, else the first
    // textured slot's.
    int set = -1;
    for (const tinygltf::TextureInfo* info :
         {&pbr.baseColorTexture, &pbr.metallicRoughnessTexture, &gm.emissiveTexture}) {
      if (info->index < 0) continue;
      if (set < 0) set = info->texCoord;
      else if (info->texCoord != set)
        warn(where.substr(name_.size() + 2) + format(": textures use different TEXCOORD sets; "
                                                     "TEXCOORD_%d used for all", set));
    }
    if (set < 0 || set > 15) {
      if (set > 15) warn(where.substr(name_.size() + 2) + format(": texCoord %d unsupported; TEXCOORD_0 used", set));
      set = 0;
    }
    material_uv_set_.push_back(set);
    scene_.materials.push_back(std::move(m));
    return Status::ok();
  }

  Status texture_slot(const tinygltf::TextureInfo& info, const char* slot, const std::string& where,
                      int32_t& out) {
    out = -1;
    if (info.index < 0) return Status::ok();
    if (size_t(info.index) >= model_.textures.size())
      return Status::error("%s: %s references missing texture %d (%zu textures)", where.c_str(), slot,
                           info.index, model_.textures.size());
    if (info.extensions.count("KHR_texture_transform"))
      warn_counted("KHR_texture_transform", where.substr(name_.size() + 2) + ": " + slot +
                                                  ": KHR_texture_transform ignored");
    const int source = model_.textures[size_t(info.index)].source;
    if (source < 0) {
      warn(where.substr(name_.size() + 2) +
           format(": %s: texture %d has no PNG/JPEG source (extension-only images are not "
                  "supported); untextured", slot, info.index));
      return Status::ok();
    }
    if (size_t(source) >= model_.images.size())
      return Status::error("%s: %s: texture %d references missing image %d (%zu images)",
                           where.c_str(), slot, info.index, source, model_.images.size());
    out = image_texture(source, where);
    return Status::ok();
  }

  // Scene texture for glTF image `source` (decoded once), or -1 with a warning.
  int32_t image_texture(int source, const std::string& where) {
    int32_t& mapped = image_map_[size_t(source)];
    if (mapped != -2) return mapped;
    mapped = -1;
    tinygltf::Image image = model_.images[size_t(source)];
    std::string why = image.uri.empty() ? "no image data" : "image data missing or undecodable";
    if (!gltf::resolve_image(model_, image, kMaxPixels, why)) {
      warn(where.substr(name_.size() + 2) +
           format(": image %d could not be used (%s); untextured", source, why.c_str()));
      return -1;
    }
    Texture t;
    t.name = !image.name.empty() ? image.name
             : (!image.uri.empty() && image.uri.rfind("data:", 0) != 0) ? image.uri
                                                                         : format("image_%d", source);
    t.width = static_cast<uint32_t>(image.width);
    t.height = static_cast<uint32_t>(image.height);
    t.rgba = std::move(image.image);
    mapped = int32_t(scene_.textures.size());
    scene_.textures.push_back(std::move(t));
    return mapped;
  }

  uint32_t default_material() {
    if (default_material_ < 0) {
      default_material_ = int32_t(scene_.materials.size());
      Material m;
      m.name = "default";
      scene_.materials.push_back(std::move(m));
      material_uv_set_.push_back(0);
    }
    return uint32_t(default_material_);
  }

  // ---- meshes ----------------------------------------------------------------------------------

  // Scene mesh for glTF mesh `gltf_mesh` (loaded on first use); -1 when it has no triangles.
  Status mesh_index(int gltf_mesh, int32_t& out) {
    int32_t& mapped = mesh_map_[size_t(gltf_mesh)];
    if (mapped != -2) {
      out = mapped;
      return Status::ok();
    }
    const tinygltf::Mesh& gm = model_.meshes[size_t(gltf_mesh)];
    Mesh mesh;
    mesh.name = gm.name.empty() ? format("mesh_%d", gltf_mesh) : gm.name;
    for (size_t p = 0; p < gm.primitives.size(); ++p) {
      const std::string where = format("%s: mesh %d ('%s') primitive %zu", file(), gltf_mesh,
                                       excerpt(mesh.name).c_str(), p);
      Primitive prim;
      bool keep = false;
      Status s = load_primitive(gm.primitives[p], where, prim, keep);
      if (!s) return s;
      if (keep) mesh.primitives.push_back(std::move(prim));
    }
    if (mesh.primitives.empty()) {
      warn(format("mesh %d ('%s') has no TRIANGLES primitive with triangles; nodes using it draw "
                  "no triangles", gltf_mesh, excerpt(mesh.name).c_str()));
      mapped = -1;
    } else {
      mapped = int32_t(scene_.meshes.size());
      scene_.meshes.push_back(std::move(mesh));
    }
    out = mapped;
    return Status::ok();
  }

  Status load_primitive(const tinygltf::Primitive& gp, const std::string& where, Primitive& prim,
                        bool& keep) {
    keep = false;
    const std::string short_where = where.substr(name_.size() + 2);
    const int mode = gp.mode < 0 ? TINYGLTF_MODE_TRIANGLES : gp.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES) {
      ++skipped_primitives_;
      ++skipped_by_mode_[mode];
      warn_counted("non-TRIANGLES primitives",
                   format("%s: mode %d (%s) is not TRIANGLES; skipped", short_where.c_str(), mode,
                          gltf::mode_name(mode)));
      return Status::ok();
    }
    if (gp.extensions.count("KHR_draco_mesh_compression"))
      return Status::error("%s: Draco-compressed primitives are not supported", where.c_str());
    if (!gp.targets.empty())
      warn_counted("morph targets", short_where + ": morph targets ignored (base shape used)");

    // Material.
    if (gp.material >= int(model_.materials.size()))
      return Status::error("%s: material %d does not exist (%zu materials)", where.c_str(),
                           gp.material, model_.materials.size());
    prim.material = gp.material >= 0 ? uint32_t(gp.material) : default_material();

    // Positions.
    std::vector<double> pos, nrm, uv;
    int nc = 0;
    const gltf::AccessorReader reader{model_, kMaxVertices};
    Status s = reader.read_positions(gp, where, pos);
    if (!s) return s;
    const size_t n = pos.size() / 3;
    for (size_t i = 0; i < pos.size(); ++i)
      if (!std::isfinite(to_float(pos[i])))
        return Status::error("%s: POSITION (accessor %d) vertex %zu is NaN or infinite", where.c_str(),
                             gltf::find_attribute(gp, "POSITION"), i / 3);
    prim.positions.resize(n);
    for (size_t i = 0; i < n; ++i)
      prim.positions[i] = glm::vec3(to_float(pos[3 * i]), to_float(pos[3 * i + 1]), to_float(pos[3 * i + 2]));

    // Normals: unit length; a NaN or zero normal drops the primitive's normals (face normals used).
    if (int acc = gltf::find_attribute(gp, "NORMAL"); acc >= 0) {
      s = reader.read_attribute(acc, "NORMAL", {TINYGLTF_TYPE_VEC3}, false, n, where, nrm, nc);
      if (!s) return s;
      prim.normals.resize(n);
      for (size_t i = 0; i < n && !prim.normals.empty(); ++i) {
        glm::dvec3 q(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]);
        const double len = glm::length(q);
        if (!std::isfinite(len) || !(len > 1e-20)) {
          warn_counted("bad normals", short_where + format(": NORMAL %zu is NaN, infinite or zero; "
                                                           "the primitive uses face normals", i));
          prim.normals.clear();
          break;
        }
        q /= len;
        prim.normals[i] = glm::vec3(float(q.x), float(q.y), float(q.z));
      }
    }

    // Texture coordinates of the material's uv set.
    const int set = material_uv_set_[prim.material];
    const std::string uv_key = "TEXCOORD_" + std::to_string(set);
    if (int acc = gltf::find_attribute(gp, uv_key); acc >= 0) {
      s = reader.read_attribute(acc, uv_key, {TINYGLTF_TYPE_VEC2}, false, n, where, uv, nc);
      if (!s) return s;
      if (!std::all_of(uv.begin(), uv.end(), [](double d) { return std::isfinite(to_float(d)); })) {
        warn_counted("bad uvs", short_where + ": " + uv_key + " has NaN or infinite values; untextured");
      } else {
        prim.uvs.resize(n);
        for (size_t i = 0; i < n; ++i) prim.uvs[i] = glm::vec2(to_float(uv[2 * i]), to_float(uv[2 * i + 1]));
      }
    } else {
      const Material& m = scene_.materials[prim.material];
      if (m.base_color_texture >= 0 || m.metallic_roughness_texture >= 0 || m.emission_texture >= 0)
        warn_counted("missing uvs", short_where + ": textured material but no " + uv_key +
                                        "; textures read at uv (0, 0)");
    }

    // Indices.
    if (gp.indices >= 0) {
      s = reader.read_indices(gp.indices, n, true, where, prim.indices);
      if (!s) return s;
    } else {
      prim.indices.resize(n);
      for (size_t i = 0; i < n; ++i) prim.indices[i] = static_cast<uint32_t>(i);
    }
    if (prim.indices.size() % 3 != 0) {
      warn_counted("index counts", short_where + format(": %zu indices is not a multiple of 3; the "
                                                        "last %zu ignored", prim.indices.size(),
                                                        prim.indices.size() % 3));
      prim.indices.resize(prim.indices.size() - prim.indices.size() % 3);
    }
    if (prim.indices.empty()) {
      warn_counted("empty primitives", short_where + ": no triangles; skipped");
      return Status::ok();
    }
    keep = true;
    return Status::ok();
  }

  // ---- nodes -----------------------------------------------------------------------------------

  // One node of the walk (read_gltf_scene: indices, hierarchy and transforms already checked).
  Status visit(int index, const glm::dmat4& world) {
    visited_[size_t(index)] = 1;
    const tinygltf::Node& node = model_.nodes[size_t(index)];
    Status s = add_instance(index, world);
    if (s) s = add_camera(index, world);
    if (!s) return s;
    if (node.skin >= 0) warn_counted("skins", node_label(index) + ": skinning ignored (static mesh)");
    return Status::ok();
  }

  Status add_camera(int index, const glm::dmat4& world) {
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
  Status parse_material_list(const tinygltf::Value& v, const std::string& where,
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

  Status add_instance(int index, const glm::dmat4& world) {
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
    inst.node_name = node.name.empty() ? format("node_%d", index) : node.name;
    Status s = check_world_transform(world, inst.object_to_world);
    if (!s) return s.context(who);
    inst.mesh = mesh;
    inst.lsnif = lsnif;
    scene_.instances.push_back(std::move(inst));
    return Status::ok();
  }

  // ---- overrides and environment ------------------------------------------------------------

  Status resolve_overrides() {
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

  Status check_overrides_used() const {
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

  // LSNIF_environment "sun": {"direction": [x, y, z], "color": [r, g, b], "intensity": E,
  // "angular_diameter_degrees": D}; irradiance = color * intensity.
  Status load_sun(const tinygltf::Value& v, const std::string& where) {
    if (!v.IsObject()) return Status::error("%s must be a JSON object", where.c_str());
    glm::dvec3 direction(0.0), color(1.0);
    double intensity = 1.0, diameter = 0.53;
    bool has_direction = false;
    auto vec3_of = [](const tinygltf::Value& f, glm::dvec3& out) {
      return f.IsArray() && f.ArrayLen() == 3 && number_of(f.Get(0), out.x) && number_of(f.Get(1), out.y) &&
             number_of(f.Get(2), out.z);
    };
    for (const std::string& key : v.Keys()) {
      const tinygltf::Value& f = v.Get(key);
      if (key == "direction") {
        if (!vec3_of(f, direction)) return Status::error("%s: \"direction\" must be 3 finite numbers", where.c_str());
        has_direction = true;
      } else if (key == "color") {
        if (!vec3_of(f, color)) return Status::error("%s: \"color\" must be 3 finite numbers", where.c_str());
      } else if (key == "intensity") {
        if (!number_of(f, intensity)) return Status::error("%s: \"intensity\" must be a finite number", where.c_str());
      } else if (key == "angular_diameter_degrees") {
        if (!number_of(f, diameter))
          return Status::error("%s: \"angular_diameter_degrees\" must be a finite number", where.c_str());
      } else {
        warn(format("%s: unknown property \"%s\" ignored", where.c_str(), excerpt(key).c_str()));
      }
    }
    if (!has_direction) return Status::error("%s needs a \"direction\" (towards the sun)", where.c_str());
    return make_sun(direction, color * intensity, diameter, where, scene_.sun);
  }

  Status load_environment() {
    Environment& env = scene_.environment;
    env = Environment();
    std::string hdr;
    bool hdr_relative_to_scene = true;
    glm::dvec3 color(1.0);
    double intensity = 1.0, degrees = 0.0;
    const std::string where = std::string(file()) + ": " + kEnvironmentExtension;
    if (auto it = model_.extensions.find(kEnvironmentExtension); it != model_.extensions.end()) {
      const tinygltf::Value& v = it->second;
      if (!v.IsObject()) return Status::error("%s must be a JSON object", where.c_str());
      for (const std::string& key : v.Keys()) {
        const tinygltf::Value& f = v.Get(key);
        if (key == "hdr") {
          if (!f.IsString()) return Status::error("%s: \"hdr\" must be a string", where.c_str());
          hdr = f.Get<std::string>();
        } else if (key == "color") {
          if (!f.IsArray() || f.ArrayLen() != 3 || !number_of(f.Get(0), color.x) ||
              !number_of(f.Get(1), color.y) || !number_of(f.Get(2), color.z))
            return Status::error("%s: \"color\" must be 3 finite numbers", where.c_str());
        } else if (key == "intensity") {
          if (!number_of(f, intensity))
            return Status::error("%s: \"intensity\" must be a finite number", where.c_str());
        } else if (key == "rotation_degrees") {
          if (!number_of(f, degrees))
            return Status::error("%s: \"rotation_degrees\" must be a finite number", where.c_str());
        } else if (key == "sun") {
          if (Status s = load_sun(f, where + ": sun"); !s) return s;
        } else {
          warn(format("%s: unknown property \"%s\" ignored", kEnvironmentExtension, excerpt(key).c_str()));
        }
      }
    }
    const EnvironmentOverride& o = options_.environment;
    if (o.hdr) {
      hdr = *o.hdr;
      hdr_relative_to_scene = false;
    }
    if (o.color) color = glm::dvec3(*o.color);
    if (o.intensity) intensity = double(*o.intensity);
    if (o.rotation_degrees) degrees = double(*o.rotation_degrees);
    if (!std::isfinite(color.x + color.y + color.z) || color.x < 0.0 || color.y < 0.0 || color.z < 0.0)
      return Status::error("%s: color must be finite and >= 0", where.c_str());
    if (!std::isfinite(intensity) || intensity < 0.0)
      return Status::error("%s: intensity %g must be finite and >= 0", where.c_str(), intensity);
    if (!std::isfinite(degrees))
      return Status::error("%s: rotation_degrees must be finite", where.c_str());
    const glm::dvec3 radiance = color * intensity;
    env.color = glm::vec3(to_float(radiance.x), to_float(radiance.y), to_float(radiance.z));
    if (!std::isfinite(env.color.x + env.color.y + env.color.z))
      return Status::error("%s: color x intensity overflows a float", where.c_str());
    env.rotation = float(std::fmod(degrees, 360.0) * std::numbers::pi / 180.0);
    if (!hdr.empty()) {
      // The scene's own image follows the reference policy; a --env path is the user's and is used as given.
      Status s = hdr_relative_to_scene ? resolve_reference(base_dir_, hdr, options_.allow_outside_refs, "hdr", env.path)
                                       : resolve_reference("", hdr, true, "--env", env.path);
      std::error_code ec;
      if (s && !std::filesystem::is_regular_file(env.path, ec))
        s = Status::error("'%s' does not exist or is not a regular file", env.path.c_str());
      if (!s) return s.context(where + ": hdr '" + excerpt(hdr) + "'");
    }
    return Status::ok();
  }

  const tinygltf::Model& model_;
  const std::string& name_;
  const std::string& base_dir_;
  const SceneLoadOptions& options_;
  Scene& scene_;
  std::vector<int32_t> mesh_map_;   // glTF mesh -> scene mesh (-2: not yet, -1: no triangles)
  std::vector<int32_t> image_map_;  // glTF image -> scene texture (-2: not yet, -1: unusable)
  std::vector<const LsnifOverride*> node_overrides_;
  std::vector<int> material_uv_set_;  // per scene material
  std::vector<uint8_t> visited_;
  std::map<std::string, size_t> warn_counts_;
  std::map<int, size_t> skipped_by_mode_;
  int32_t default_material_ = -1;
  size_t skipped_primitives_ = 0;
};

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
    load_options.max_pixels = kMaxPixels;
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
