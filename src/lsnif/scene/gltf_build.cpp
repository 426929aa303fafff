// gltf_build.cpp -- see gltf_build.h.
#include "lsnif/scene/gltf_build.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <sstream>

#include "lsnif/format/atomic_file.h"
#include "lsnif/import/json_text.h"

namespace lsnif::scene {
namespace {

constexpr const char* kNodeExtension = "LSNIF_neural_object";
constexpr const char* kEnvironmentExtension = "LSNIF_environment";
constexpr const char* kEmissiveStrength = "KHR_materials_emissive_strength";

void use_extension(tinygltf::Model& model, const std::string& name) {
  if (std::find(model.extensionsUsed.begin(), model.extensionsUsed.end(), name) == model.extensionsUsed.end())
    model.extensionsUsed.push_back(name);
}

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Appends `bytes` bytes at `data` to buffer 0 (4-byte aligned) as a new bufferView; its index.
int append_view(tinygltf::Model& model, const void* data, size_t bytes, int target) {
  std::vector<unsigned char>& buf = model.buffers[0].data;
  buf.resize((buf.size() + 3) & ~size_t(3), 0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buf.size();
  view.byteLength = bytes;
  view.target = target;
  const auto* p = static_cast<const unsigned char*>(data);
  buf.insert(buf.end(), p, p + bytes);
  model.bufferViews.push_back(std::move(view));
  return int(model.bufferViews.size() - 1);
}

// Appends an accessor over a new bufferView holding `count` elements of `type` / `component`.
int append_accessor(tinygltf::Model& model, const void* data, size_t count, int type, int component,
                    size_t element_bytes, int target) {
  tinygltf::Accessor acc;
  acc.bufferView = append_view(model, data, count * element_bytes, target);
  acc.byteOffset = 0;
  acc.componentType = component;
  acc.count = count;
  acc.type = type;
  model.accessors.push_back(std::move(acc));
  return int(model.accessors.size() - 1);
}

Status check_primitive(const tinygltf::Model& model, const Primitive& p, const std::string& where) {
  const size_t n = p.positions.size();
  if (p.indices.empty()) return Status::error("%s: no triangles", where.c_str());
  if (p.indices.size() % 3)
    return Status::error("%s: %zu indices is not a multiple of 3", where.c_str(), p.indices.size());
  for (size_t i = 0; i < p.indices.size(); ++i)
    if (p.indices[i] >= n)
      return Status::error("%s: index %zu is %u, but there are %zu vertices", where.c_str(), i, p.indices[i], n);
  for (size_t i = 0; i < n; ++i)
    if (!finite(p.positions[i])) return Status::error("%s: position %zu is not finite", where.c_str(), i);
  if (!p.normals.empty() && p.normals.size() != n)
    return Status::error("%s: %zu normals for %zu vertices", where.c_str(), p.normals.size(), n);
  for (size_t i = 0; i < p.normals.size(); ++i)
    if (!finite(p.normals[i])) return Status::error("%s: normal %zu is not finite", where.c_str(), i);
  if (!p.uvs.empty() && p.uvs.size() != n)
    return Status::error("%s: %zu uvs for %zu vertices", where.c_str(), p.uvs.size(), n);
  for (size_t i = 0; i < p.uvs.size(); ++i)
    if (!std::isfinite(p.uvs[i].x) || !std::isfinite(p.uvs[i].y))
      return Status::error("%s: uv %zu is not finite", where.c_str(), i);
  if (p.material >= model.materials.size())
    return Status::error("%s: material %u does not exist (%zu materials)", where.c_str(), p.material,
                         model.materials.size());
  return Status::ok();
}

std::vector<double> matrix_of(const glm::mat4& m) {
  std::vector<double> out(16);
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) out[size_t(4 * c + r)] = double(m[c][r]);
  return out;
}

}  // namespace

tinygltf::Model new_gltf_model(const std::string& generator) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = generator;
  model.scenes.resize(1);
  model.defaultScene = 0;
  model.buffers.resize(1);
  return model;
}

int add_material(tinygltf::Model& model, const Material& material) {
  tinygltf::Material m;
  m.name = material.name;
  m.pbrMetallicRoughness.baseColorFactor = {material.base_color.r, material.base_color.g, material.base_color.b,
                                            material.alpha};
  m.pbrMetallicRoughness.metallicFactor = material.metallic;
  m.pbrMetallicRoughness.roughnessFactor = material.roughness;
  const double peak = std::max({double(material.emission.r), double(material.emission.g), double(material.emission.b)});
  if (peak > 1.0) {
    m.emissiveFactor = {material.emission.r / peak, material.emission.g / peak, material.emission.b / peak};
    tinygltf::Value::Object strength;
    strength["emissiveStrength"] = tinygltf::Value(peak);
    m.extensions[kEmissiveStrength] = tinygltf::Value(std::move(strength));
    use_extension(model, kEmissiveStrength);
  } else {
    m.emissiveFactor = {material.emission.r, material.emission.g, material.emission.b};
  }
  if (material.base_color_texture >= 0) m.pbrMetallicRoughness.baseColorTexture.index = material.base_color_texture;
  if (material.cutoff() > 0.0f) {  // BLEND is read as a cut-out (AlphaMode): written as one
    m.alphaMode = "MASK";
    m.alphaCutoff = material.cutoff();
  }
  model.materials.push_back(std::move(m));
  return int(model.materials.size() - 1);
}

int add_image_texture(tinygltf::Model& model, const std::string& uri) {
  tinygltf::Image image;
  image.uri = uri;
  model.images.push_back(std::move(image));
  tinygltf::Texture texture;
  texture.source = int(model.images.size() - 1);
  model.textures.push_back(std::move(texture));
  return int(model.textures.size() - 1);
}

Status add_mesh(tinygltf::Model& model, const Mesh& mesh, int& index) {
  if (model.buffers.empty()) return Status::error("mesh '%s': the model has no buffer (use new_gltf_model)", mesh.name.c_str());
  if (mesh.primitives.empty()) return Status::error("mesh '%s' has no primitive", mesh.name.c_str());
  uint64_t bytes = model.buffers[0].data.size();
  for (size_t i = 0; i < mesh.primitives.size(); ++i) {
    const Primitive& p = mesh.primitives[i];
    if (Status s = check_primitive(model, p, format("mesh '%s' primitive %zu", mesh.name.c_str(), i)); !s) return s;
    bytes += 16 + sizeof(glm::vec3) * (p.positions.size() + p.normals.size()) + sizeof(glm::vec2) * p.uvs.size() +
             sizeof(uint32_t) * p.indices.size();
  }
  if (bytes > std::numeric_limits<uint32_t>::max())
    return Status::error("mesh '%s': the glTF buffer would exceed 4 GiB (%llu bytes)", mesh.name.c_str(),
                         static_cast<unsigned long long>(bytes));
  tinygltf::Mesh gm;
  gm.name = mesh.name;
  for (const Primitive& p : mesh.primitives) {
    tinygltf::Primitive gp;
    gp.mode = TINYGLTF_MODE_TRIANGLES;
    gp.material = int(p.material);
    glm::vec3 lo(std::numeric_limits<float>::infinity()), hi = -lo;
    for (const glm::vec3& v : p.positions) {
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
    const int pos = append_accessor(model, p.positions.data(), p.positions.size(), TINYGLTF_TYPE_VEC3,
                                    TINYGLTF_COMPONENT_TYPE_FLOAT, sizeof(glm::vec3), TINYGLTF_TARGET_ARRAY_BUFFER);
    model.accessors[size_t(pos)].minValues = {lo.x, lo.y, lo.z};
    model.accessors[size_t(pos)].maxValues = {hi.x, hi.y, hi.z};
    gp.attributes["POSITION"] = pos;
    if (!p.normals.empty())
      gp.attributes["NORMAL"] = append_accessor(model, p.normals.data(), p.normals.size(), TINYGLTF_TYPE_VEC3,
                                                TINYGLTF_COMPONENT_TYPE_FLOAT, sizeof(glm::vec3),
                                                TINYGLTF_TARGET_ARRAY_BUFFER);
    if (!p.uvs.empty())
      gp.attributes["TEXCOORD_0"] = append_accessor(model, p.uvs.data(), p.uvs.size(), TINYGLTF_TYPE_VEC2,
                                                    TINYGLTF_COMPONENT_TYPE_FLOAT, sizeof(glm::vec2),
                                                    TINYGLTF_TARGET_ARRAY_BUFFER);
    gp.indices = append_accessor(model, p.indices.data(), p.indices.size(), TINYGLTF_TYPE_SCALAR,
                                 TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, sizeof(uint32_t),
                                 TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    gm.primitives.push_back(std::move(gp));
  }
  model.meshes.push_back(std::move(gm));
  index = int(model.meshes.size() - 1);
  return Status::ok();
}

int add_node(tinygltf::Model& model, const std::string& name, int mesh, const glm::mat4& transform) {
  tinygltf::Node node;
  node.name = name;
  node.mesh = mesh;
  if (transform != glm::mat4(1.0f)) node.matrix = matrix_of(transform);
  model.nodes.push_back(std::move(node));
  const int index = int(model.nodes.size() - 1);
  if (model.scenes.empty()) {
    model.scenes.resize(1);
    model.defaultScene = 0;
  }
  model.scenes[size_t(std::max(model.defaultScene, 0))].nodes.push_back(index);
  return index;
}

void set_neural_object(tinygltf::Model& model, int node, const std::string& model_uri,
                       const std::vector<uint32_t>& materials) {
  tinygltf::Value::Object ext;
  ext["model"] = tinygltf::Value(model_uri);
  if (!materials.empty()) {
    tinygltf::Value::Array list;
    for (uint32_t m : materials) list.push_back(tinygltf::Value(int(m)));
    ext["materials"] = tinygltf::Value(std::move(list));
  }
  model.nodes[size_t(node)].extensions[kNodeExtension] = tinygltf::Value(std::move(ext));
  use_extension(model, kNodeExtension);
}

int add_camera(tinygltf::Model& model, const Camera& camera, float znear, float zfar) {
  tinygltf::Camera c;
  c.name = camera.name;
  c.type = "perspective";
  c.perspective.yfov = camera.yfov;
  c.perspective.aspectRatio = camera.aspect;
  c.perspective.znear = znear;
  c.perspective.zfar = zfar;
  model.cameras.push_back(std::move(c));
  const int node = add_node(model, camera.name, -1, camera.camera_to_world);
  model.nodes[size_t(node)].camera = int(model.cameras.size() - 1);
  return node;
}

void set_environment(tinygltf::Model& model, const EnvironmentSpec& env) {
  tinygltf::Value::Object ext;
  if (!env.hdr.empty()) ext["hdr"] = tinygltf::Value(env.hdr);
  ext["color"] = tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(double(env.color.r)),
                                                         tinygltf::Value(double(env.color.g)),
                                                         tinygltf::Value(double(env.color.b))});
  ext["intensity"] = tinygltf::Value(double(env.intensity));
  ext["rotation_degrees"] = tinygltf::Value(double(env.rotation_degrees));
  model.extensions[kEnvironmentExtension] = tinygltf::Value(std::move(ext));
  use_extension(model, kEnvironmentExtension);
}

namespace {

// Repairs what tinygltf writes against the specification (gltf_text, gltf_text_embedded).
void repair_tinygltf_json(nlohmann::json& j) {
  // tinygltf writes an object without properties (a node `{}`) as null, which no
  // glTF reader takes (its own loader included): each becomes the empty object it was.
  for (auto& [key, value] : j.items())
    if (value.is_array())
      for (nlohmann::json& element : value)
        if (element.is_null()) element = nlohmann::json::object();
  // tinygltf keeps an absent perspective zfar (an infinite projection) as 0 and writes it back as
  // 0, which the specification forbids (zfar > 0 when present): such a camera is written without it.
  if (j.contains("cameras") && j["cameras"].is_array())
    for (nlohmann::json& camera : j["cameras"])
      if (camera.contains("perspective") && camera["perspective"].contains("zfar") &&
          camera["perspective"]["zfar"].is_number() && camera["perspective"]["zfar"].get<double>() == 0.0)
        camera["perspective"].erase("zfar");
}

// tinygltf's JSON of `model` (which the writer may change: pass a copy), repaired.
Status serialize(tinygltf::Model& model, nlohmann::json& j) {
  std::ostringstream stream;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, stream, /*prettyPrint=*/false, /*writeBinary=*/false))
    return Status::error("tinygltf could not serialize the scene");
  if (Status s = json::parse(stream.str(), "the serialized scene", j); !s) return s;
  repair_tinygltf_json(j);
  return Status::ok();
}

}  // namespace

Status gltf_text(const tinygltf::Model& model, const std::string& bin_uri, std::string& text) {
  if (model.buffers.size() > 1)
    return Status::error("the model has %zu buffers; only buffer 0 is written", model.buffers.size());
  // tinygltf writes buffers into the JSON (as data URIs) or into files of its own (unchecked);
  // the JSON is made without them and buffer 0 is added as a reference to `bin_uri`.
  tinygltf::Model out = model;
  const size_t bin_bytes = out.buffers.empty() ? 0 : out.buffers[0].data.size();
  const std::string buffer_name = out.buffers.empty() ? std::string() : out.buffers[0].name;
  out.buffers.clear();
  nlohmann::json j;
  if (Status s = serialize(out, j); !s) return s;
  if (bin_bytes > 0) {
    nlohmann::json buffer = {{"byteLength", bin_bytes}};
    if (bin_uri.empty()) return Status::error("the scene has binary data but no buffer file name");
    buffer["uri"] = bin_uri;
    if (!buffer_name.empty()) buffer["name"] = buffer_name;
    j["buffers"] = nlohmann::json::array({buffer});
  }
  text = json::dump(j) + "\n";
  return Status::ok();
}

Status gltf_text_embedded(const tinygltf::Model& model, std::string& text) {
  tinygltf::Model out = model;
  nlohmann::json j;
  if (Status s = serialize(out, j); !s) return s;
  text = json::dump(j);
  return Status::ok();
}

Status save_gltf(const tinygltf::Model& model, const std::string& path) {
  const std::filesystem::path p(path);
  if (p.extension() != ".gltf") return Status::error("%s: expected a .gltf file name", path.c_str());
  const std::string bin = p.stem().string() + ".bin";
  const bool has_bin = !model.buffers.empty() && !model.buffers[0].data.empty();
  std::string text;
  if (Status s = gltf_text(model, bin, text); !s) return s.context(path);
  // The buffer first: the scene file never refers to a buffer file that is not complete.
  if (has_bin) {
    const std::string bin_path = (p.parent_path() / bin).string();
    const std::vector<unsigned char>& data = model.buffers[0].data;
    if (Status s = write_file_atomic(bin_path, data.data(), data.size()); !s) return s;
  }
  return write_file_atomic(path, text);
}

}  // namespace lsnif::scene
