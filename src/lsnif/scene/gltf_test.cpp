// gltf_test.cpp -- load_scene on the real test models under data/gltf (numbers checked against the
// files' own JSON, read here with nlohmann::json: accessor counts and min/max, node matrices), on
// synthetic files exercising every accessor and index type, TRS / matrix, instancing, materials,
// cameras and the error paths, and the LSNIF extensions and overrides (docs/scene-format.md).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <unistd.h>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include "lsnif/testing/fuzz_support.h"
#include "lsnif/core/model.h"
#include "lsnif/import/mesh.h"
#include "lsnif/format/model_format.h"
#include "lsnif/scene/scene_edit.h"
#include "lsnif/scene/scene_gltf.h"
#include "lsnif/testing/scene_test_support.h"

namespace lsnif::scene {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;
using fuzz::base64;
using fuzz::put_floats;
using fuzz::read_bytes;

const std::string kData = std::string(LSNIF_DATA_DIR) + "/gltf/";

// The JSON of a .gltf or of a .glb's JSON chunk.
json read_json(const std::string& path) {
  std::string b = read_bytes(path);
  if (b.size() >= 20 && b.compare(0, 4, "glTF") == 0) {
    uint32_t len;
    std::memcpy(&len, b.data() + 12, 4);
    return json::parse(b.substr(20, len));
  }
  return json::parse(b);
}

SceneLoadOptions quiet() {
  SceneLoadOptions o;
  o.quiet = true;
  return o;
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

bool any_warning(const Scene& s, const std::string& needle) {
  for (const std::string& w : s.warnings)
    if (contains(w, needle)) return true;
  return false;
}

// Node world matrices computed from the JSON, independently of the loader: column-major matrix or
// T * R * S.
glm::dmat4 json_local(const json& node) {
  if (node.contains("matrix")) {
    std::vector<double> m = node["matrix"].get<std::vector<double>>();
    return glm::make_mat4(m.data());
  }
  glm::dmat4 t(1.0), r(1.0), s(1.0);
  if (node.contains("translation")) {
    auto v = node["translation"].get<std::vector<double>>();
    t = glm::translate(glm::dmat4(1.0), glm::dvec3(v[0], v[1], v[2]));
  }
  if (node.contains("rotation")) {
    auto q = node["rotation"].get<std::vector<double>>();
    r = glm::mat4_cast(glm::normalize(glm::dquat(q[3], q[0], q[1], q[2])));
  }
  if (node.contains("scale")) {
    auto v = node["scale"].get<std::vector<double>>();
    s = glm::scale(glm::dmat4(1.0), glm::dvec3(v[0], v[1], v[2]));
  }
  return t * r * s;
}

struct JsonNode {
  int index;
  glm::dmat4 world;
};

// Depth-first over the default scene, in the file's order.
void json_walk(const json& doc, int index, const glm::dmat4& parent, std::vector<JsonNode>& out) {
  const json& node = doc["nodes"][size_t(index)];
  glm::dmat4 world = parent * json_local(node);
  out.push_back({index, world});
  if (node.contains("children"))
    for (int c : node["children"]) json_walk(doc, c, world, out);
}

std::vector<JsonNode> json_nodes(const json& doc) {
  std::vector<JsonNode> out;
  const int scene = doc.value("scene", 0);
  for (int r : doc["scenes"][size_t(scene)]["nodes"]) json_walk(doc, r, glm::dmat4(1.0), out);
  return out;
}

void expect_mat_near(const glm::mat4& a, const glm::dmat4& b, double tol, const std::string& what) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      EXPECT_NEAR(a[c][r], b[c][r], tol * std::max(1.0, std::abs(b[c][r]))) << what << " [" << c << "][" << r << "]";
}

void mesh_bounds(const Mesh& m, glm::vec3& lo, glm::vec3& hi) {
  lo = glm::vec3(INFINITY);
  hi = glm::vec3(-INFINITY);
  for (const Primitive& p : m.primitives)
    for (const glm::vec3& v : p.positions) {
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
}

// ---- real files -----------------------------------------------------------------------------

TEST(GltfLoad, BoxTexturedAllContainers) {
  const json doc = read_json(kData + "BoxTextured-glTF/BoxTextured.gltf");
  const json& pos = doc["accessors"][size_t(doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<int>())];
  const json& idx = doc["accessors"][size_t(doc["meshes"][0]["primitives"][0]["indices"].get<int>())];
  const std::string png = read_bytes(kData + "BoxTextured-glTF/CesiumLogoFlat.png");
  ASSERT_GE(png.size(), 24u);
  const uint32_t png_w = uint32_t(uint8_t(png[16])) << 24 | uint32_t(uint8_t(png[17])) << 16 |
                         uint32_t(uint8_t(png[18])) << 8 | uint8_t(png[19]);
  const std::vector<JsonNode> nodes = json_nodes(doc);
  ASSERT_EQ(nodes.size(), 2u);
  for (const char* file : {"BoxTextured-glTF/BoxTextured.gltf", "BoxTextured-glTF-Binary/BoxTextured.glb",
                           "BoxTextured-glTF-Embedded/BoxTextured.gltf"}) {
    SCOPED_TRACE(file);
    Scene s;
    Status st = load_scene(kData + file, quiet(), s);
    ASSERT_TRUE(st) << st.message();
    EXPECT_EQ(check_scene(s), "");
    ASSERT_EQ(s.meshes.size(), 1u);
    ASSERT_EQ(s.instances.size(), 1u);
    ASSERT_EQ(s.meshes[0].primitives.size(), 1u);
    const Primitive& p = s.meshes[0].primitives[0];
    EXPECT_EQ(p.indices.size(), idx["count"].get<size_t>());
    EXPECT_EQ(triangle_count(s.meshes[0]), 12u);
    EXPECT_EQ(p.positions.size(), pos["count"].get<size_t>());
    EXPECT_EQ(p.normals.size(), p.positions.size());
    EXPECT_EQ(p.uvs.size(), p.positions.size());
    glm::vec3 lo, hi;
    mesh_bounds(s.meshes[0], lo, hi);
    for (int k = 0; k < 3; ++k) {
      EXPECT_FLOAT_EQ(lo[k], pos["min"][size_t(k)].get<float>());
      EXPECT_FLOAT_EQ(hi[k], pos["max"][size_t(k)].get<float>());
    }
    expect_mat_near(s.instances[0].object_to_world, nodes[1].world, 1e-6, "instance");
    ASSERT_EQ(s.materials.size(), 1u);
    ASSERT_EQ(s.textures.size(), 1u);
    EXPECT_EQ(s.materials[0].base_color_texture, 0);
    EXPECT_EQ(s.textures[0].width, png_w);
    EXPECT_EQ(s.textures[0].rgba.size(), size_t(s.textures[0].width) * s.textures[0].height * 4);
    EXPECT_TRUE(s.cameras.empty());
    EXPECT_EQ(s.path, kData + file);
  }
}

TEST(GltfLoad, TwoCylinderEngineInstancingMatchesTheJson) {
  const std::string path = kData + "2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  const json doc = read_json(path);
  Scene s;
  Status st = load_scene(path, quiet(), s);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(check_scene(s), "");

  std::vector<JsonNode> mesh_nodes;
  const JsonNode* camera_node = nullptr;
  std::vector<JsonNode> all = json_nodes(doc);
  for (const JsonNode& n : all) {
    if (doc["nodes"][size_t(n.index)].contains("mesh")) mesh_nodes.push_back(n);
    if (doc["nodes"][size_t(n.index)].contains("camera")) camera_node = &n;
  }
  ASSERT_EQ(s.instances.size(), mesh_nodes.size());
  std::set<int> json_meshes;
  std::map<int, int32_t> gltf_to_scene;
  size_t triangles = 0;
  for (size_t i = 0; i < mesh_nodes.size(); ++i) {
    SCOPED_TRACE("instance " + std::to_string(i));
    const int m = doc["nodes"][size_t(mesh_nodes[i].index)]["mesh"];
    json_meshes.insert(m);
    const Instance& inst = s.instances[i];
    ASSERT_GE(inst.mesh, 0);
    EXPECT_EQ(inst.lsnif, -1);
    // Instancing: one glTF mesh <-> one scene mesh.
    auto [it, fresh] = gltf_to_scene.emplace(m, inst.mesh);
    EXPECT_EQ(it->second, inst.mesh);
    expect_mat_near(inst.object_to_world, mesh_nodes[i].world, 1e-5, "world");
    // Triangles and bounds from the accessors.
    size_t tris = 0;
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (const json& prim : doc["meshes"][size_t(m)]["primitives"]) {
      ASSERT_EQ(prim.value("mode", 4), 4);
      tris += doc["accessors"][size_t(prim["indices"].get<int>())]["count"].get<size_t>() / 3;
      const json& a = doc["accessors"][size_t(prim["attributes"]["POSITION"].get<int>())];
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], a["min"][size_t(k)].get<float>());
        hi[k] = std::max(hi[k], a["max"][size_t(k)].get<float>());
      }
    }
    const Mesh& mesh = s.meshes[size_t(inst.mesh)];
    EXPECT_EQ(triangle_count(mesh), tris);
    triangles += tris;
    glm::vec3 mlo, mhi;
    mesh_bounds(mesh, mlo, mhi);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(mlo[k], lo[k], 1e-4f * (hi[k] - lo[k]) + 1e-4f);
      EXPECT_NEAR(mhi[k], hi[k], 1e-4f * (hi[k] - lo[k]) + 1e-4f);
    }
  }
  EXPECT_EQ(s.meshes.size(), json_meshes.size());
  EXPECT_EQ(instanced_triangle_count(s), triangles);
  // The file instances some meshes many times.
  std::map<int32_t, int> uses;
  for (const Instance& inst : s.instances) uses[inst.mesh]++;
  int most = 0;
  for (auto& [m, n] : uses) most = std::max(most, n);
  EXPECT_GE(most, 4);
  // Camera: the node's world transform, yfov from the JSON.
  ASSERT_NE(camera_node, nullptr);
  ASSERT_EQ(s.cameras.size(), 1u);
  expect_mat_near(s.cameras[0].camera_to_world, camera_node->world, 1e-5, "camera");
  EXPECT_FLOAT_EQ(s.cameras[0].yfov, doc["cameras"][0]["perspective"]["yfov"].get<float>());
  EXPECT_FLOAT_EQ(s.cameras[0].aspect, 1.0f);
  EXPECT_EQ(s.materials.size(), doc["materials"].size());
}

TEST(GltfLoad, CamerasKeepsThePerspectiveOneAndWarnsAboutTheOrthographicOne) {
  Scene s;
  Status st = load_scene(kData + "cameras/Cameras.gltf", quiet(), s);
  ASSERT_TRUE(st) << st.message();
  ASSERT_EQ(s.cameras.size(), 1u);
  EXPECT_NEAR(s.cameras[0].yfov, 0.7f, 1e-6f);
  EXPECT_EQ(glm::vec3(s.cameras[0].camera_to_world[3]), glm::vec3(0.5f, 0.5f, 3.0f));
  EXPECT_TRUE(any_warning(s, "orthographic"));
}

TEST(GltfLoad, BrokenFilesFailWithAMessage) {
  const std::pair<const char*, const char*> cases[] = {
      {"RecursiveNodes/RecursiveNodes.gltf", "cyclic"},
      {"IndexOutOfRange/IndexOutOfRange.gltf", "out of range"},
      {"IndexOutOfRange/AllIndicesOutOfRange.gltf", "out of range"},
      {"MissingBin/BoxTextured.gltf", "BoxTextured0.bin"},
      {"BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", "NaN or infinite"},
      {"draco/2CylinderEngine.gltf", "KHR_draco_mesh_compression"},
      {"BoxTextured-glTF-techniqueWebGL/BoxTextured.gltf", "KHR_technique_webgl"},
      {"TestNoRootNode/NoScene.gltf", "no scenes and no nodes"},
      {"TestNoRootNode/SceneWithoutNodes.gltf", "no instance"},
  };
  for (const auto& [file, why] : cases) {
    Scene s;
    Status st = load_scene(kData + file, quiet(), s);
    ASSERT_FALSE(st) << file;
    EXPECT_TRUE(contains(st.message(), file)) << st.message();
    EXPECT_TRUE(contains(st.message(), why)) << file << ": " << st.message();
    EXPECT_TRUE(s.instances.empty() && s.meshes.empty());
  }
  Scene s;
  EXPECT_FALSE(load_scene(kData + "does/not/exist.gltf", quiet(), s));
  Status st = load_scene(std::string(LSNIF_DATA_DIR) + "/../README.md", quiet(), s);
  EXPECT_TRUE(!st && contains(st.message(), "not a glTF")) << st.message();
}

// The Asset Generator's primitive-mode files: the renderer draws what glTF's triangle modes draw
// (TRIANGLES: count / 3, TRIANGLE_STRIP and TRIANGLE_FAN: count - 2, counted here from the files'
// accessors) and skips points and lines with counted warnings; the converter's reading of the same
// file (load_mesh, what convert and train flatten) has the same triangles, corner for corner.
TEST(GltfLoad, PrimitiveModesReadAlikeByTheRendererAndTheConverter) {
  const std::string dir = kData + "glTF-Asset-Generator/Mesh_PrimitiveMode/";
  int loaded = 0, skipped = 0, strips_or_fans = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".gltf") continue;
    const std::string path = entry.path().string();
    SCOPED_TRACE(path);
    const json doc = read_json(path);
    size_t tris = 0, others = 0;
    for (const json& prim : doc["meshes"][0]["primitives"]) {
      const int mode = prim.value("mode", 4);
      const json& a = prim.contains("indices") ? doc["accessors"][size_t(prim["indices"].get<int>())]
                                               : doc["accessors"][size_t(prim["attributes"]["POSITION"].get<int>())];
      const size_t count = a["count"].get<size_t>();
      if (mode == 4) {
        tris += count / 3;
      } else if (mode == 5 || mode == 6) {
        tris += count >= 3 ? count - 2 : 0;
        ++strips_or_fans;
      } else {
        ++others;
      }
    }
    Scene s;
    Status st = load_scene(path, quiet(), s);
    if (others) {
      ++skipped;
      EXPECT_TRUE(any_warning(s, "draws no triangles; skipped"));
      EXPECT_TRUE(any_warning(s, format("skipped %zu primitives that draw no triangles", others)));
    }
    if (!tris) {
      EXPECT_FALSE(st);
      EXPECT_TRUE(contains(st.message(), "no instance")) << st.message();
      continue;
    }
    ++loaded;
    ASSERT_TRUE(st) << st.message();
    ASSERT_EQ(instanced_triangle_count(s), tris);
    // The renderer's triangles in world space, in file order.
    std::vector<glm::vec3> corners;
    for (const Instance& in : s.instances)
      for (const Primitive& p : s.meshes[size_t(in.mesh)].primitives)
        for (uint32_t i : p.indices) corners.push_back(glm::vec3(in.object_to_world * glm::vec4(p.positions[i], 1.0f)));
    ::lsnif::Mesh flat;
    const Status ms = ::lsnif::load_mesh(path, flat);
    ASSERT_TRUE(ms) << ms.message();
    ASSERT_EQ(flat.triangles.size(), tris);
    for (size_t t = 0; t < tris; ++t)
      for (int k = 0; k < 3; ++k)
        EXPECT_LT(glm::length(flat.positions[flat.triangles[t][k]] - corners[3 * t + size_t(k)]), 1e-5f)
            << "triangle " << t << " corner " << k;
  }
  EXPECT_GE(loaded, 4);
  EXPECT_GE(strips_or_fans, 2);
  EXPECT_GE(skipped, 4);
}

TEST(GltfLoad, WarningsForWhatIsIgnored) {
  Scene s;
  ASSERT_TRUE(load_scene(kData + "glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf", quiet(), s));
  EXPECT_TRUE(any_warning(s, "morph targets ignored"));
  ASSERT_TRUE(load_scene(kData + "simple_skin/simple_skin.gltf", quiet(), s));
  EXPECT_TRUE(any_warning(s, "skinning ignored"));
  ASSERT_TRUE(load_scene(kData + "textureTransform/TextureTransformTest.gltf", quiet(), s));
  EXPECT_FALSE(any_warning(s, "KHR_texture_transform"));  // honoured (gltf_material_test.cpp)
  ASSERT_TRUE(load_scene(kData + "BoxBadNormals-glTF-Binary/BoxBadNormals.glb", quiet(), s));
  EXPECT_TRUE(any_warning(s, "face normals"));
  EXPECT_EQ(check_scene(s), "");
  EXPECT_TRUE(s.meshes[0].primitives[0].normals.empty());
}

// ---- synthetic files --------------------------------------------------------------------------

std::string synthetic_bin() {
  std::string b;
  b += put_floats({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});  // 0: positions
  b += put_floats({0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1});  // 48: normals
  b += put_floats({0, 0, 1, 0, 1, 1, 0, 1});              // 96: uvs
  b += std::string("\x00\x01\x02\x00\x02\x03\x00\x00", 8);  // 128: ubyte indices (+2 pad)
  for (uint16_t i : std::initializer_list<uint16_t>{0, 1, 2, 0, 2, 3}) b.append(reinterpret_cast<const char*>(&i), 2);  // 136
  for (uint32_t i : {0, 1, 2, 0, 2, 3}) b.append(reinterpret_cast<const char*>(&i), 4);  // 148
  for (int16_t v : std::initializer_list<int16_t>{0, 0, 0, 0, 2, 0, 0, 0, 2, 2, 0, 0, 0, 2, 0, 0})  // 172: short xyz + pad, stride 8
    b.append(reinterpret_cast<const char*>(&v), 2);
  b += std::string("\x02\x00\x00\x00", 4);  // 204: sparse index (ubyte) + pad
  b += put_floats({5, 5, 5});               // 208: sparse value
  return b;                                  // 220 bytes
}

json synthetic_doc() {
  const std::string bin = synthetic_bin();
  json d = json::parse(R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0, 3, 4, 5, 6, 7, 8]}],
  "nodes": [
    {"name": "root", "translation": [10, 0, 0], "children": [1, 2]},
    {"name": "a", "mesh": 0, "rotation": [0, 0, 0.70710678, 0.70710678], "scale": [2, 2, 2]},
    {"name": "b", "mesh": 0, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,5,0,1]},
    {"name": "c", "mesh": 1},
    {"name": "d", "mesh": 2},
    {"name": "e", "mesh": 3},
    {"name": "f", "mesh": 4},
    {"name": "g", "mesh": 5},
    {"name": "cam", "camera": 0, "translation": [0, 0, 5]},
    {"name": "orphan", "mesh": 0}
  ],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "aspectRatio": 1.5, "znear": 0.1}}],
  "meshes": [
    {"name": "quad", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]},
    {"name": "quad_ushort", "primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 2}, "indices": 4, "material": 1}]},
    {"name": "quad_uint", "primitives": [{"attributes": {"POSITION": 0}, "indices": 5}]},
    {"name": "quantized", "primitives": [{"attributes": {"POSITION": 6}, "indices": 4, "material": 0}]},
    {"name": "sparse", "primitives": [{"attributes": {"POSITION": 7}, "indices": 4, "material": 0}]},
    {"name": "two_prims", "primitives": [
      {"attributes": {"POSITION": 0}, "indices": 3, "material": 1},
      {"attributes": {"POSITION": 0}, "indices": 4, "material": 0},
      {"attributes": {"POSITION": 0}, "mode": 0}]}
  ],
  "materials": [
    {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 0.25},
     "emissiveFactor": [1, 0.5, 0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}},
    {"name": "tex", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}
  ],
  "textures": [{"source": 0}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
    {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
    {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
    {"bufferView": 3, "componentType": 5121, "count": 6, "type": "SCALAR"},
    {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"},
    {"bufferView": 5, "componentType": 5125, "count": 6, "type": "SCALAR"},
    {"bufferView": 6, "componentType": 5122, "count": 4, "type": "VEC3"},
    {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
     "sparse": {"count": 1, "indices": {"bufferView": 7, "componentType": 5121}, "values": {"bufferView": 8}}}
  ],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 48},
    {"buffer": 0, "byteOffset": 48, "byteLength": 48},
    {"buffer": 0, "byteOffset": 96, "byteLength": 32},
    {"buffer": 0, "byteOffset": 128, "byteLength": 6},
    {"buffer": 0, "byteOffset": 136, "byteLength": 12},
    {"buffer": 0, "byteOffset": 148, "byteLength": 24},
    {"buffer": 0, "byteOffset": 172, "byteLength": 32, "byteStride": 8},
    {"buffer": 0, "byteOffset": 204, "byteLength": 1},
    {"buffer": 0, "byteOffset": 208, "byteLength": 12}
  ]})");
  d["buffers"] = json::array({{{"byteLength", bin.size()},
                               {"uri", "data:application/octet-stream;base64," + base64(bin)}}});
  d["images"] = json::array({{{"uri", std::string("data:image/png;base64,") + fuzz::kPngBase64}}});
  return d;
}

// Writes `doc` as scene.gltf into `dir` and loads it.
Status load_doc(const json& doc, const TempDir& dir, Scene& s, const SceneLoadOptions& o = quiet()) {
  write_file(dir / "scene.gltf", doc.dump(1));
  return load_scene(dir / "scene.gltf", o, s);
}

int instance_of(const Scene& s, const std::string& node) {
  for (size_t i = 0; i < s.instances.size(); ++i)
    if (s.instances[i].node_name == node) return int(i);
  return -1;
}

TEST(GltfSynthetic, AccessorsIndicesTransformsMaterialsCamera) {
  TempDir dir;
  Scene s;
  Status st = load_doc(synthetic_doc(), dir, s);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(check_scene(s), "");
  ASSERT_EQ(s.instances.size(), 7u);  // a, b, c, d, e, f, g (orphan is not in the scene)
  EXPECT_EQ(instance_of(s, "orphan"), -1);
  ASSERT_EQ(s.meshes.size(), 6u);
  const Instance& a = s.instances[size_t(instance_of(s, "a"))];
  const Instance& b = s.instances[size_t(instance_of(s, "b"))];
  EXPECT_EQ(a.mesh, b.mesh);  // instancing
  // a = T(10,0,0) R_z(90) S(2): (1,0,0) -> (10,2,0); b = T(10,0,0) T(0,5,0).
  const glm::vec3 pa = glm::vec3(a.object_to_world * glm::vec4(1, 0, 0, 1));
  EXPECT_NEAR(glm::distance(pa, glm::vec3(10, 2, 0)), 0.0f, 1e-5f);
  EXPECT_EQ(glm::vec3(b.object_to_world * glm::vec4(0, 0, 0, 1)), glm::vec3(10, 5, 0));
  // Index component types.
  const std::vector<uint32_t> quad = {0, 1, 2, 0, 2, 3};
  for (const char* n : {"a", "c", "d"})
    EXPECT_EQ(s.meshes[size_t(s.instances[size_t(instance_of(s, n))].mesh)].primitives[0].indices, quad) << n;
  const Primitive& pq = s.meshes[size_t(s.instances[size_t(instance_of(s, "e"))].mesh)].primitives[0];
  EXPECT_EQ(pq.positions[2], glm::vec3(2, 2, 0));  // SHORT positions (KHR_mesh_quantization)
  const Primitive& ps = s.meshes[size_t(s.instances[size_t(instance_of(s, "f"))].mesh)].primitives[0];
  EXPECT_EQ(ps.positions[1], glm::vec3(1, 0, 0));
  EXPECT_EQ(ps.positions[2], glm::vec3(5, 5, 5));  // sparse substitution
  // Primitives: POINTS skipped and counted; two triangle primitives kept with their materials.
  const Mesh& two = s.meshes[size_t(s.instances[size_t(instance_of(s, "g"))].mesh)];
  ASSERT_EQ(two.primitives.size(), 2u);
  EXPECT_EQ(two.primitives[0].material, 1u);
  EXPECT_EQ(two.primitives[1].material, 0u);
  EXPECT_TRUE(any_warning(s, "mode 0 (POINTS) draws no triangles"));
  EXPECT_TRUE(any_warning(s, "skipped 1 primitives that draw no triangles (POINTS: 1)"));
  // Materials: the file's two plus the default one for quad_uint.
  ASSERT_EQ(s.materials.size(), 3u);
  const Primitive& pd = s.meshes[size_t(s.instances[size_t(instance_of(s, "d"))].mesh)].primitives[0];
  EXPECT_EQ(pd.material, 2u);
  EXPECT_EQ(s.materials[2].name, "default");
  EXPECT_EQ(glm::vec4(s.materials[0].base_color, s.materials[0].alpha), glm::vec4(1, 0, 0, 1));
  EXPECT_EQ(s.materials[0].metallic, 0.0f);
  EXPECT_EQ(s.materials[0].roughness, 0.25f);
  EXPECT_EQ(s.materials[0].emission, glm::vec3(4, 2, 0));  // emissive strength folded in
  EXPECT_EQ(s.materials[1].base_color_texture, 0);
  ASSERT_EQ(s.textures.size(), 1u);
  EXPECT_EQ(s.textures[0].width, 2u);
  EXPECT_EQ(s.textures[0].height, 2u);
  EXPECT_EQ(std::vector<uint8_t>(s.textures[0].rgba.begin(), s.textures[0].rgba.begin() + 4),
            (std::vector<uint8_t>{255, 0, 0, 255}));
  const Primitive& pa0 = s.meshes[size_t(a.mesh)].primitives[0];
  EXPECT_EQ(pa0.normals.size(), 4u);
  EXPECT_EQ(pa0.uvs[2], glm::vec2(1, 1));
  // Camera.
  ASSERT_EQ(s.cameras.size(), 1u);
  EXPECT_EQ(glm::vec3(s.cameras[0].camera_to_world[3]), glm::vec3(0, 0, 5));
  EXPECT_FLOAT_EQ(s.cameras[0].yfov, 0.5f);
  EXPECT_FLOAT_EQ(s.cameras[0].aspect, 1.5f);
  // Default environment.
  EXPECT_TRUE(s.environment.path.empty());
  EXPECT_EQ(s.environment.color, glm::vec3(1.0f));
  EXPECT_FALSE(describe_scene(s).empty());
}

TEST(GltfSynthetic, GlbContainerWithEmbeddedImage) {
  json d = synthetic_doc();
  std::string bin = synthetic_bin();
  const std::string png = fuzz::png_bytes();
  const size_t png_offset = bin.size();
  bin += png;
  while (bin.size() % 4) bin += '\0';
  d["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", png_offset}, {"byteLength", png.size()}});
  d["images"] = json::array({{{"bufferView", d["bufferViews"].size() - 1}, {"mimeType", "image/png"}}});
  d["buffers"] = json::array({{{"byteLength", bin.size()}}});
  TempDir dir;
  write_file(dir / "scene.glb", fuzz::glb(d.dump(), bin));
  Scene s;
  Status st = load_scene(dir / "scene.glb", quiet(), s);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(check_scene(s), "");
  ASSERT_EQ(s.textures.size(), 1u);
  EXPECT_EQ(s.textures[0].rgba[4], 0);  // green pixel
  EXPECT_EQ(s.textures[0].rgba[5], 255);
  EXPECT_EQ(s.instances.size(), 7u);
}

TEST(GltfSynthetic, ErrorsNameTheProblem) {
  TempDir dir;
  struct Case {
    const char* what;
    std::function<void(json&)> edit;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {"missing mesh", [](json& d) { d["nodes"][3]["mesh"] = 42; }, "missing mesh 42"},
      {"missing accessor", [](json& d) { d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 77; },
       "accessor 77 does not exist"},
      {"vertex index out of range", [](json& d) {
         d["accessors"].push_back({{"bufferView", 0}, {"componentType", 5126}, {"count", 2}, {"type", "VEC3"}});
         d["meshes"][2]["primitives"][0]["attributes"]["POSITION"] = 8;
       }, "index 2 at position 2 out of range (2 vertices)"},
      {"missing buffer", [](json& d) { d["buffers"][0]["uri"] = "nope.bin"; }, "nope.bin"},
      {"missing bufferView", [](json& d) { d["accessors"][1]["bufferView"] = 99; }, "bufferView"},
      {"view past the buffer", [](json& d) { d["bufferViews"][5]["byteLength"] = 4000; }, "exceeds buffer"},
      {"material out of range", [](json& d) { d["meshes"][0]["primitives"][0]["material"] = 9; },
       "material 9 does not exist"},
      {"texture out of range", [](json& d) { d["materials"][1]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = 3; },
       "missing texture 3"},
      {"non-invertible", [](json& d) { d["nodes"][3]["scale"] = {1, 0, 1}; }, "non-invertible"},
      {"overflowing transform", [](json& d) {
         d["nodes"][0]["scale"] = {1e300, 1e300, 1e300};
         d["nodes"][1]["scale"] = {1e300, 1e300, 1e300};
       }, "NaN or infinite value in its world transform"},
      {"projective matrix", [](json& d) { d["nodes"][2]["matrix"][3] = 0.5; }, "not affine"},
      {"short matrix", [](json& d) { d["nodes"][2]["matrix"].erase(0); }, "matrix has 15 numbers"},
      {"zero quaternion", [](json& d) { d["nodes"][1]["rotation"] = {0, 0, 0, 0}; }, "zero length"},
      {"cycle", [](json& d) { d["nodes"][1]["children"] = {0}; }, "cyclic"},
      {"missing node", [](json& d) { d["scenes"][0]["nodes"].push_back(50); }, "node 50 does not exist"},
      {"missing camera", [](json& d) { d["nodes"][8]["camera"] = 4; }, "missing camera 4"},
      {"bad yfov", [](json& d) { d["cameras"][0]["perspective"]["yfov"] = 4.0; }, "yfov"},
      {"unsupported required extension", [](json& d) { d["extensionsRequired"] = {"EXT_meshopt_compression"}; },
       "EXT_meshopt_compression"},
      {"signed indices", [](json& d) { d["accessors"][3]["componentType"] = 5120; }, "unsigned"},
      {"normal count", [](json& d) { d["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 2; }, "NORMAL"},
      {"default scene", [](json& d) { d["scene"] = 3; }, "scene"},
      {"sparse index", [](json& d) { d["accessors"][7]["sparse"]["count"] = 9; }, "sparse"},
  };
  for (const Case& c : cases) {
    json d = synthetic_doc();
    c.edit(d);
    Scene s;
    Status st = load_doc(d, dir, s);
    EXPECT_FALSE(st) << c.what;
    EXPECT_TRUE(contains(st.message(), c.expected)) << c.what << ": " << st.message();
    EXPECT_TRUE(contains(st.message(), "scene.gltf")) << c.what << ": " << st.message();
    EXPECT_TRUE(s.instances.empty());
  }
  // NaN in a position (bytes in the buffer).
  {
    json d = synthetic_doc();
    std::string bin = synthetic_bin();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::memcpy(&bin[16], &nan, 4);
    d["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(bin);
    Scene s;
    Status st = load_doc(d, dir, s);
    EXPECT_FALSE(st);
    EXPECT_TRUE(contains(st.message(), "POSITION (accessor 0) vertex 1 is NaN or infinite")) << st.message();
  }
  // Broken JSON.
  {
    std::string js = synthetic_doc().dump();
    write_file(dir / "broken.gltf", js.substr(0, js.size() / 2));
    Scene s;
    Status st = load_scene(dir / "broken.gltf", quiet(), s);
    EXPECT_FALSE(st);
    EXPECT_TRUE(contains(st.message(), "broken.gltf: invalid glTF")) << st.message();
  }
  // A number too large for a double in a transform: rejected, never propagated.
  {
    std::string js = synthetic_doc().dump();
    const std::string from = "\"translation\":[10,0,0]";
    ASSERT_NE(js.find(from), std::string::npos);
    js.replace(js.find(from), from.size(), "\"translation\":[1e400,0,0]");
    write_file(dir / "huge.gltf", js);
    Scene s;
    Status st = load_scene(dir / "huge.gltf", quiet(), s);
    EXPECT_FALSE(st);
    EXPECT_TRUE(contains(st.message(), "huge.gltf")) << st.message();
  }
}

TEST(GltfSynthetic, ClampsAndWarnings) {
  TempDir dir;
  json d = synthetic_doc();
  d["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = 1.5;
  d["images"][0]["uri"] = "data:image/png;base64,AAAA";  // undecodable: untextured, not fatal
  d["meshes"][1]["primitives"][0]["indices"] = 3;
  d["accessors"][3]["count"] = 5;  // 5 indices: the last 2 ignored
  Scene s;
  Status st = load_doc(d, dir, s);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(check_scene(s), "");
  EXPECT_EQ(s.materials[0].roughness, 1.0f);
  EXPECT_TRUE(any_warning(s, "clamped"));
  EXPECT_EQ(s.materials[1].base_color_texture, -1);
  EXPECT_TRUE(any_warning(s, "could not be used"));
  EXPECT_TRUE(any_warning(s, "not a multiple of 3"));
  EXPECT_EQ(s.meshes[size_t(s.instances[size_t(instance_of(s, "c"))].mesh)].primitives[0].indices.size(), 3u);
}

// ---- LSNIF_neural_object ------------------------------------------------------------------------

TEST(GltfLsnif, NodeExtensionResolvesValidatesAndShares) {
  TempDir dir;
  write_fake_lsnif(dir / "models/g.lsnif");
  json d = synthetic_doc();
  d["nodes"][7]["extensions"]["LSNIF_neural_object"] = {{"model", "models/g.lsnif"}};  // g: mesh + model
  d["nodes"].push_back({{"name", "only"}, {"translation", {0, 1, 0}},
                        {"extensions", {{"LSNIF_neural_object", {{"model", "models/g.lsnif"}, {"materials", {1}}}}}}});
  d["nodes"].push_back({{"name", "only2"},
                        {"extensions", {{"LSNIF_neural_object", {{"model", dir / "models/g.lsnif"}, {"materials", {1}}}}}}});
  d["scenes"][0]["nodes"].push_back(10);
  d["scenes"][0]["nodes"].push_back(11);
  d["extensionsUsed"] = {"LSNIF_neural_object"};
  Scene s;
  // The absolute model path of "only2" is outside the scene's folder by policy: refused unless allowed.
  Status st = load_doc(d, dir, s);
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("it is an absolute path"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("--allow-outside-refs"), std::string::npos) << st.message();
  SceneLoadOptions allow = quiet();
  allow.allow_outside_refs = true;
  st = load_doc(d, dir, s, allow);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(check_scene(s), "");
  ASSERT_EQ(s.instances.size(), 9u);
  const Instance& g = s.instances[size_t(instance_of(s, "g"))];
  ASSERT_GE(g.lsnif, 0);
  EXPECT_GE(g.mesh, 0);  // the reference mesh stays
  const LsnifObject& og = s.lsnif_objects[size_t(g.lsnif)];
  EXPECT_EQ(og.model_path, "models/g.lsnif");
  EXPECT_EQ(fs::path(og.resolved_path), fs::path(dir / "models/g.lsnif"));
  EXPECT_EQ(og.material_map, (std::vector<uint32_t>{1, 0}));  // the primitives' materials
  const Instance& only = s.instances[size_t(instance_of(s, "only"))];
  const Instance& only2 = s.instances[size_t(instance_of(s, "only2"))];
  EXPECT_EQ(only.mesh, -1);
  EXPECT_EQ(only.lsnif, only2.lsnif);  // same file (relative vs absolute), same map: one object
  EXPECT_NE(only.lsnif, g.lsnif);      // different material map
  EXPECT_EQ(s.lsnif_objects[size_t(only.lsnif)].material_map, std::vector<uint32_t>{1});
  EXPECT_EQ(glm::vec3(only.object_to_world[3]), glm::vec3(0, 1, 0));
  EXPECT_EQ(s.lsnif_objects.size(), 2u);
}

TEST(GltfLsnif, NodeExtensionErrors) {
  TempDir dir;
  write_fake_lsnif(dir / "ok.lsnif");
  write_file(dir / "bad.lsnif", "LSNIX-not-a-model-at-all");
  struct Case {
    json ext;
    bool with_mesh;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {{{"model", "missing.lsnif"}}, true, "does not exist"},
      {{{"model", "bad.lsnif"}}, true, "bad magic"},
      {{{"model", "ok.lsnif"}, {"materials", {0, 7}}}, true, "\"materials\"[1]"},
      {{{"model", "ok.lsnif"}, {"materials", {-1}}}, false, "\"materials\"[0]"},
      {{{"model", "ok.lsnif"}, {"materials", "x"}}, false, "must be an array"},
      {{{"model", 3}}, true, "non-empty string"},
      {{{"materials", {0}}}, false, "nothing to render"},
  };
  for (const Case& c : cases) {
    json d = synthetic_doc();
    json& node = d["nodes"][c.with_mesh ? 7 : 8];  // g (mesh) or cam (no mesh)
    node["extensions"]["LSNIF_neural_object"] = c.ext;
    Scene s;
    Status st = load_doc(d, dir, s);
    EXPECT_FALSE(st) << c.ext.dump();
    EXPECT_TRUE(contains(st.message(), c.expected)) << c.ext.dump() << ": " << st.message();
  }
  // Without a model but with a mesh: drawn as triangles, with a warning.
  json d = synthetic_doc();
  d["nodes"][7]["extensions"]["LSNIF_neural_object"] = json::object();
  Scene s;
  ASSERT_TRUE(load_doc(d, dir, s));
  EXPECT_EQ(s.instances[size_t(instance_of(s, "g"))].lsnif, -1);
  EXPECT_TRUE(any_warning(s, "drawn as triangles"));
}

TEST(GltfLsnif, OverridesReplaceMeshNodes) {
  TempDir dir;
  write_fake_lsnif(dir / "o.lsnif");
  SceneLoadOptions o = quiet();
  LsnifOverride ov;
  ASSERT_TRUE(parse_lsnif_override("c=" + (dir / "o.lsnif"), ov));
  EXPECT_EQ(ov.node, "c");
  o.lsnif_overrides.push_back(ov);
  ASSERT_TRUE(parse_lsnif_override("g=" + (dir / "o.lsnif"), ov));
  o.lsnif_overrides.push_back(ov);
  Scene s;
  Status st = load_doc(synthetic_doc(), dir, s, o);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(check_scene(s), "");
  const Instance& c = s.instances[size_t(instance_of(s, "c"))];
  const Instance& g = s.instances[size_t(instance_of(s, "g"))];
  ASSERT_GE(c.lsnif, 0);
  ASSERT_GE(c.mesh, 0);
  EXPECT_EQ(s.lsnif_objects[size_t(c.lsnif)].resolved_path, dir / "o.lsnif");
  EXPECT_EQ(s.lsnif_objects[size_t(c.lsnif)].material_map, std::vector<uint32_t>{1});
  EXPECT_EQ(s.lsnif_objects[size_t(g.lsnif)].material_map, (std::vector<uint32_t>{1, 0}));
  EXPECT_EQ(s.instances[size_t(instance_of(s, "a"))].lsnif, -1);
  // Explicit map.
  o.lsnif_overrides.resize(1);
  o.lsnif_overrides[0].materials = {0, 0, 1};
  ASSERT_TRUE(load_doc(synthetic_doc(), dir, s, o));
  EXPECT_EQ(s.lsnif_objects[0].material_map, (std::vector<uint32_t>{0, 0, 1}));

  // Errors.
  auto fails = [&](const std::string& arg, const char* expected) {
    SceneLoadOptions oo = quiet();
    LsnifOverride x;
    ASSERT_TRUE(parse_lsnif_override(arg, x)) << arg;
    oo.lsnif_overrides.push_back(x);
    Scene t;
    Status e = load_doc(synthetic_doc(), dir, t, oo);
    EXPECT_FALSE(e) << arg;
    EXPECT_TRUE(contains(e.message(), expected)) << arg << ": " << e.message();
  };
  fails("zzz=" + (dir / "o.lsnif"), "no node named 'zzz'");
  fails("orphan=" + (dir / "o.lsnif"), "not part of the rendered scene");
  fails("cam=" + (dir / "o.lsnif"), "neither a mesh nor");
  fails("c=" + (dir / "nothing.lsnif"), "does not exist");
  LsnifOverride x;
  for (const char* bad : {"c", "=x.lsnif", "c=", ""}) EXPECT_FALSE(parse_lsnif_override(bad, x)) << bad;
  ASSERT_TRUE(parse_lsnif_override("a=b=c.lsnif", x));
  EXPECT_EQ(x.node, "a=b");
  EXPECT_EQ(x.model_path, "c.lsnif");
}

// ---- LSNIF_environment ---------------------------------------------------------------------------

TEST(GltfEnvironment, ExtensionAndOverrides) {
  TempDir dir;
  write_file(dir / "sky/studio.hdr", "#?RADIANCE\n");  // existence is checked, not the contents
  json d = synthetic_doc();
  d["extensions"]["LSNIF_environment"] = {
      {"hdr", "sky/studio.hdr"}, {"color", {1, 0.5, 0.25}}, {"intensity", 2}, {"rotation_degrees", 90}};
  Scene s;
  Status st = load_doc(d, dir, s);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(fs::path(s.environment.path), fs::path(dir / "sky/studio.hdr"));
  EXPECT_EQ(s.environment.color, glm::vec3(2, 1, 0.5));
  EXPECT_NEAR(s.environment.rotation, std::numbers::pi / 2, 1e-6);

  SceneLoadOptions o = quiet();
  o.environment.hdr = "";
  o.environment.intensity = 3.0f;
  o.environment.rotation_degrees = 180.0f;
  ASSERT_TRUE(load_doc(d, dir, s, o));
  EXPECT_TRUE(s.environment.path.empty());
  EXPECT_EQ(s.environment.color, glm::vec3(3, 1.5, 0.75));
  EXPECT_NEAR(s.environment.rotation, std::numbers::pi, 1e-6);
  o.environment = EnvironmentOverride();
  o.environment.hdr = dir / "sky/studio.hdr";  // an override path is used as given
  o.environment.color = glm::vec3(0.5f);
  ASSERT_TRUE(load_doc(synthetic_doc(), dir, s, o));
  EXPECT_EQ(s.environment.path, dir / "sky/studio.hdr");
  EXPECT_EQ(s.environment.color, glm::vec3(0.5f));

  const std::vector<std::pair<json, const char*>> bad = {
      {{{"hdr", "missing.hdr"}}, "missing.hdr"},
      {{{"intensity", -1}}, "intensity"},
      {{{"color", {1, 2}}}, "color"},
      {{{"rotation_degrees", "x"}}, "rotation_degrees"},
      {{{"hdr", 5}}, "hdr"},
  };
  for (const auto& [ext, expected] : bad) {
    json e = synthetic_doc();
    e["extensions"]["LSNIF_environment"] = ext;
    Status es = load_doc(e, dir, s);
    EXPECT_FALSE(es) << ext.dump();
    EXPECT_TRUE(contains(es.message(), expected)) << ext.dump() << ": " << es.message();
  }
  SceneLoadOptions neg = quiet();
  neg.environment.intensity = -2.0f;
  EXPECT_FALSE(load_doc(synthetic_doc(), dir, s, neg));
}

TEST(GltfEnvironment, Sun) {
  TempDir dir;
  json d = synthetic_doc();
  Scene s;
  ASSERT_TRUE(load_doc(d, dir, s));
  EXPECT_FALSE(s.sun.enabled);  // no sun unless asked for
  d["extensions"]["LSNIF_environment"] = {
      {"sun", {{"direction", {0, 3, 4}}, {"color", {1, 0.5, 0.25}}, {"intensity", 4}, {"angular_diameter_degrees", 1}}}};
  Status st = load_doc(d, dir, s);
  ASSERT_TRUE(st) << st.message();
  EXPECT_TRUE(s.sun.enabled);
  EXPECT_NEAR(s.sun.direction.y, 0.6f, 1e-6f);
  EXPECT_NEAR(s.sun.direction.z, 0.8f, 1e-6f);
  EXPECT_EQ(s.sun.irradiance, glm::vec3(4, 2, 1));
  EXPECT_NEAR(s.sun.angular_diameter, std::numbers::pi / 180.0, 1e-7);
  const std::vector<std::pair<json, const char*>> bad = {
      {{{"color", {1, 1, 1}}}, "direction"},
      {{{"direction", {0, 0, 0}}}, "non-zero"},
      {{{"direction", {0, 1}}}, "direction"},
      {{{"direction", {0, 1, 0}}, {"intensity", -1}}, "irradiance"},
      {{{"direction", {0, 1, 0}}, {"angular_diameter_degrees", 0}}, "angular diameter"},
      {{{"direction", {0, 1, 0}}, {"angular_diameter_degrees", 120}}, "angular diameter"},
      {json::array({1, 2}), "sun"},
  };
  for (const auto& [sun, expected] : bad) {
    json e = synthetic_doc();
    e["extensions"]["LSNIF_environment"] = {{"sun", sun}};
    Status es = load_doc(e, dir, s);
    EXPECT_FALSE(es) << sun.dump();
    EXPECT_TRUE(contains(es.message(), expected)) << sun.dump() << ": " << es.message();
  }
}

// ---- the example scene for the renderer ---------------------------------------------------------

TEST(GltfExample, BunnyOnPlane) {
  const std::string path = std::string(LSNIF_SCENE_EXAMPLES_DIR) + "/bunny_on_plane.gltf";
  TempDir dir;
  write_fake_lsnif(dir / "bunny.lsnif");
  SceneLoadOptions o = quiet();
  LsnifOverride ov;
  ASSERT_TRUE(parse_lsnif_override("bunny=" + (dir / "bunny.lsnif"), ov));
  o.lsnif_overrides.push_back(ov);
  Scene s;
  Status st = load_scene(path, o, s);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(check_scene(s), "");
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  ASSERT_EQ(s.instances.size(), 2u);
  const Instance& ground = s.instances[size_t(instance_of(s, "ground"))];
  const Instance& bunny = s.instances[size_t(instance_of(s, "bunny"))];
  ASSERT_GE(ground.mesh, 0);
  EXPECT_EQ(ground.lsnif, -1);
  EXPECT_EQ(triangle_count(s.meshes[size_t(ground.mesh)]), 2u);
  EXPECT_EQ(bunny.mesh, -1);
  ASSERT_EQ(bunny.lsnif, 0);
  EXPECT_EQ(s.lsnif_objects[0].material_map, std::vector<uint32_t>{1});
  EXPECT_EQ(s.materials[1].name, "bunny");
  glm::vec3 lo, hi;
  ASSERT_TRUE(scene_bounds(s, lo, hi));
  EXPECT_EQ(lo, glm::vec3(-2, 0, -2));
  EXPECT_EQ(hi, glm::vec3(2, 0, 2));
  // The ground faces up (counter-clockwise seen from +y).
  const Primitive& p = s.meshes[size_t(ground.mesh)].primitives[0];
  for (size_t t = 0; t < p.indices.size(); t += 3) {
    const glm::vec3 n = glm::cross(p.positions[p.indices[t + 1]] - p.positions[p.indices[t]],
                                   p.positions[p.indices[t + 2]] - p.positions[p.indices[t]]);
    EXPECT_GT(n.y, 0.0f);
  }
  ASSERT_EQ(s.cameras.size(), 1u);
  const glm::mat4& cam = s.cameras[0].camera_to_world;
  EXPECT_EQ(glm::vec3(cam[3]), glm::vec3(0, 1, 3));
  const glm::vec3 forward = -glm::normalize(glm::vec3(cam[2]));
  EXPECT_LT(forward.y, 0.0f);  // looks slightly down, towards the bunny
  EXPECT_LT(forward.z, -0.9f);
  EXPECT_TRUE(s.environment.path.empty());
  EXPECT_NEAR(s.environment.color.x, 0.8f, 1e-6f);
  EXPECT_NEAR(s.environment.color.z, 1.0f, 1e-6f);

  // Without the override the node's own "bunny.lsnif" (beside the scene) is used: an error until a
  // model is copied there.
  Scene t;
  st = load_scene(path, quiet(), t);
  if (fs::exists(std::string(LSNIF_SCENE_EXAMPLES_DIR) + "/bunny.lsnif")) {
    EXPECT_TRUE(st) << st.message();
  } else {
    EXPECT_FALSE(st);
    EXPECT_TRUE(contains(st.message(), "bunny.lsnif")) << st.message();
  }
}

}  // namespace
}  // namespace lsnif::scene

// ---- hostile inputs --------------------------------------------------------------------------

namespace lsnif::scene {
namespace {

// tinygltf drops extension values that are not objects; the loader must not (docs/scene-format.md).
TEST(GltfHostile, ExtensionsOfAnotherTypeAreErrorsNamingTheNode) {
  TempDir dir;
  write_fake_lsnif(dir / "bunny.lsnif");
  for (const json& value : {json("bunny.lsnif"), json(5), json::array({1}), json(nullptr)}) {
    json d = synthetic_doc();
    d["nodes"].push_back({{"name", "objectless"}, {"extensions", {{"LSNIF_neural_object", value}}}});
    d["scenes"][0]["nodes"].push_back(d["nodes"].size() - 1);
    Scene s;
    Status st = load_doc(d, dir, s);
    ASSERT_FALSE(st) << value.dump();
    EXPECT_NE(st.message().find("node 10 ('objectless'): LSNIF_neural_object must be a JSON object, not a " +
                                std::string(value.type_name())),
              std::string::npos)
        << st.message();
    json e = synthetic_doc();
    e["extensions"]["LSNIF_environment"] = value;
    st = load_doc(e, dir, s);
    ASSERT_FALSE(st) << value.dump();
    EXPECT_NE(st.message().find("LSNIF_environment must be a JSON object"), std::string::npos) << st.message();
  }
  // The text "LSNIF_neural_object" elsewhere (a string value) is no extension.
  json d = synthetic_doc();
  d["nodes"][1]["extensions"]["OTHER_ext"] = {{"note", "LSNIF_neural_object"}};
  Scene s;
  Status st = load_doc(d, dir, s);
  EXPECT_TRUE(st) << st.message();
}

TEST(GltfHostile, DeepJsonAndOutsideReferencesAreRefused) {
  TempDir dir;
  json d = synthetic_doc();
  std::string text = d.dump();
  text.insert(text.size() - 1, ",\"extras\":" + std::string(20000, '[') + std::string(20000, ']'));
  for (const bool binary : {false, true}) {
    Scene s;
    const std::string bytes = binary ? fuzz::glb(text, "") : text;
    Status st = load_scene_from_memory(bytes, binary, "deep", dir.str(), quiet(), s);
    ASSERT_FALSE(st);
    EXPECT_NE(st.message().find("deep: JSON nested deeper than 128 levels"), std::string::npos) << st.message();
  }
  // Model and environment image outside the scene's folder.
  write_fake_lsnif(dir / "m.lsnif");
  write_file(dir / "sky.hdr", "not read");
  std::filesystem::create_directories(dir / "scene");
  json m = synthetic_doc();
  m["nodes"][1]["extensions"]["LSNIF_neural_object"] = {{"model", "../m.lsnif"}};
  json h = synthetic_doc();
  h["extensions"]["LSNIF_environment"] = {{"hdr", "../sky.hdr"}};
  for (const json& doc : {m, h}) {
    Scene s;
    write_file(dir / "scene/s.gltf", doc.dump());
    Status st = load_scene(dir / "scene/s.gltf", quiet(), s);
    ASSERT_FALSE(st);
    EXPECT_NE(st.message().find("refers to a file outside the folder"), std::string::npos) << st.message();
    SceneLoadOptions allow = quiet();
    allow.allow_outside_refs = true;
    st = load_scene(dir / "scene/s.gltf", allow, s);
    EXPECT_TRUE(st) << st.message();
  }
}

// A valid model file of an untrained network whose stored box is `lo`..`hi`.
void write_model_with_bounds(const std::string& path, glm::vec3 lo, glm::vec3 hi) {
  Status s = save_model(tiny_model(lo, hi), path);
  ASSERT_TRUE(s) << s.message();
}

TEST(GltfHostile, OverrideModelsMustMatchTheNodeMeshSpace) {
  TempDir dir;
  json d = synthetic_doc();
  Scene s;
  ASSERT_TRUE(load_doc(d, dir, s));
  // Node "c" uses mesh 1 (the quad's positions): its box by hand, padded by 1% of the diagonal.
  const Instance& c = s.instances[size_t(instance_of(s, "c"))];
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const Primitive& p : s.meshes[size_t(c.mesh)].primitives)
    for (const glm::vec3& q : p.positions) lo = glm::min(lo, q), hi = glm::max(hi, q);
  const float pad = 0.01f * glm::length(hi - lo);
  write_model_with_bounds(dir / "same.lsnif", lo - pad, hi + pad);
  write_model_with_bounds(dir / "raw.lsnif", 10.0f * (lo - pad), 10.0f * (hi + pad));  // another object space
  for (const char* model : {"same.lsnif", "raw.lsnif"}) {
    SceneLoadOptions o = quiet();
    LsnifOverride ov;
    ASSERT_TRUE(parse_lsnif_override("c=" + (dir / model), ov));
    o.lsnif_overrides.push_back(ov);
    ASSERT_TRUE(load_doc(d, dir, s, o));
    Status st = check_models_fit_meshes(s);
    if (std::string(model) == "same.lsnif") {
      EXPECT_TRUE(st) << st.message();
    } else {
      ASSERT_FALSE(st);
      EXPECT_NE(st.message().find("node 'c': model " + (dir / model) + " was trained in another object space"),
                std::string::npos)
          << st.message();
      EXPECT_NE(st.message().find(format("(%g %g %g)", double(10.0f * (lo.x - pad)), double(10.0f * (lo.y - pad)),
                                         double(10.0f * (lo.z - pad)))),
                std::string::npos)
          << st.message();
    }
  }
}

}  // namespace
}  // namespace lsnif::scene
