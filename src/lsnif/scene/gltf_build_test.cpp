// gltf_build_test.cpp -- gltf_build.h round trips through load_scene: a scene written with it
// (materials, a two-primitive mesh, instancing, node transforms, LSNIF objects with and without a
// reference mesh, a camera, the environment) loads back with the same meshes bit for bit, the same
// transforms, extension values, camera and environment; the written JSON is checked on its own
// (nlohmann::json: accessor min / max against the positions, the buffer file and its length, the
// extension lists); and bad input is refused with a message naming it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "lsnif/scene/gltf_build.h"
#include "lsnif/scene/scene_gltf.h"
#include "lsnif/testing/scene_test_support.h"

namespace lsnif::scene {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

Material material(const std::string& name, glm::vec4 color, float metallic, float roughness, glm::vec3 emission) {
  Material m;
  m.name = name;
  m.base_color = glm::vec3(color);
  m.alpha = color.a;
  m.metallic = metallic;
  m.roughness = roughness;
  m.emission = emission;
  return m;
}

// A tetrahedron (normals, uvs, material 0) and a quad (no normals, no uvs, material 1).
Mesh two_primitive_mesh() {
  Mesh m;
  m.name = "tetra_and_quad";
  Primitive a;
  a.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1.5f}};
  a.normals = {glm::normalize(glm::vec3(-1, -1, -1)), {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  a.uvs = {{0, 0}, {1, 0}, {0, 1}, {0.25f, 0.75f}};
  a.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  a.material = 0;
  Primitive b;
  b.positions = {{-2, -0.5f, -2}, {2, -0.5f, -2}, {2, -0.5f, 2}, {-2, -0.5f, 2}};
  b.indices = {0, 2, 1, 0, 3, 2};
  b.material = 1;
  m.primitives = {a, b};
  return m;
}

Mesh ground_mesh() {
  Mesh m;
  m.name = "ground";
  Primitive p;
  p.positions = {{-5, 0, -5}, {5, 0, -5}, {5, 0, 5}, {-5, 0, 5}};
  p.normals.assign(4, glm::vec3(0, 1, 0));
  p.indices = {0, 2, 1, 0, 3, 2};
  p.material = 1;
  m.primitives = {p};
  return m;
}

glm::mat4 placement(glm::vec3 t, float degrees, float scale) {
  return glm::scale(glm::rotate(glm::translate(glm::mat4(1.0f), t), glm::radians(degrees), glm::vec3(0, 1, 0)),
                    glm::vec3(scale));
}

void expect_mat_near(const glm::mat4& a, const glm::mat4& b, const std::string& what) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_NEAR(a[c][r], b[c][r], 1e-6f) << what << " [" << c << "][" << r << "]";
}

void expect_same_primitive(const Primitive& got, const Primitive& want, const std::string& what) {
  ASSERT_EQ(got.positions.size(), want.positions.size()) << what;
  for (size_t i = 0; i < want.positions.size(); ++i) EXPECT_EQ(got.positions[i], want.positions[i]) << what << " " << i;
  ASSERT_EQ(got.normals.size(), want.normals.size()) << what;
  for (size_t i = 0; i < want.normals.size(); ++i) EXPECT_EQ(got.normals[i], want.normals[i]) << what << " " << i;
  ASSERT_EQ(got.uvs.size(), want.uvs.size()) << what;
  for (size_t i = 0; i < want.uvs.size(); ++i) EXPECT_EQ(got.uvs[i], want.uvs[i]) << what << " " << i;
  EXPECT_EQ(got.indices, want.indices) << what;
  EXPECT_EQ(got.material, want.material) << what;
}

struct Written {
  std::vector<Material> materials;
  Mesh object, ground;
  glm::mat4 left, right;
  Camera camera;
  EnvironmentSpec env;
};

// Writes the test scene into `dir` as scene.gltf (+ scene.bin) with fake models and an HDR file.
Written write_test_scene(const TempDir& dir) {
  Written w;
  w.materials = {material("red", {0.8f, 0.1f, 0.1f, 1}, 0.0f, 0.5f, glm::vec3(0)),
                 material("grey", {0.45f, 0.45f, 0.45f, 1}, 0.25f, 0.8f, glm::vec3(0)),
                 material("lamp", {1, 1, 1, 1}, 0.0f, 1.0f, {4.0f, 2.0f, 0.5f})};
  w.object = two_primitive_mesh();
  w.ground = ground_mesh();
  w.left = placement({-1.5f, 0.2f, 0.3f}, 30.0f, 0.75f);
  w.right = placement({1.5f, 0, -0.4f}, -120.0f, 1.25f);
  w.camera.name = "front";
  w.camera.yfov = 0.65f;
  w.camera.aspect = 1.5f;
  w.camera.camera_to_world = glm::inverse(glm::lookAt(glm::vec3(0.5f, 2, 6), glm::vec3(0), glm::vec3(0, 1, 0)));
  w.env.hdr = "sky/studio.exr";
  w.env.color = {0.9f, 0.8f, 0.7f};
  w.env.intensity = 1.5f;
  w.env.rotation_degrees = 90.0f;
  write_fake_lsnif(dir / "models/object.lsnif");
  write_fake_lsnif(dir / "models/other.lsnif");
  write_file(dir / "sky/studio.exr", "not decoded by load_scene");

  tinygltf::Model model = new_gltf_model("gltf_build_test");
  for (const Material& m : w.materials) add_material(model, m);
  int object = -1, ground = -1;
  EXPECT_TRUE(add_mesh(model, w.object, object));
  EXPECT_TRUE(add_mesh(model, w.ground, ground));
  add_node(model, "ground", ground, glm::mat4(1.0f));
  const int left = add_node(model, "left", object, w.left);
  const int right = add_node(model, "right", object, w.right);
  const int neural_only = add_node(model, "neural_only", -1, placement({0, 1, 0}, 0.0f, 2.0f));
  add_node(model, "triangles_only", object, placement({0, 0, 3}, 45.0f, 1.0f));
  set_neural_object(model, left, "models/object.lsnif", {2, 0});
  set_neural_object(model, right, "models/object.lsnif", {2, 0});
  set_neural_object(model, neural_only, "models/other.lsnif", {});
  add_camera(model, w.camera, 0.01f, 100.0f);
  set_environment(model, w.env);
  EXPECT_TRUE(save_gltf(model, dir / "scene.gltf"));
  return w;
}

TEST(GltfBuild, RoundTripThroughLoadScene) {
  TempDir dir;
  const Written w = write_test_scene(dir);
  SceneLoadOptions opts;
  opts.quiet = true;
  Scene s;
  const Status st = load_scene(dir / "scene.gltf", opts, s);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(check_scene(s), "");
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();

  // Materials: glTF material i is scene material i; emission above 1 survives through
  // KHR_materials_emissive_strength. The loader appends its default material for the node that
  // has neither a mesh nor a "materials" map.
  ASSERT_EQ(s.materials.size(), w.materials.size() + 1);
  EXPECT_EQ(s.materials.back().name, "default");
  for (size_t i = 0; i < w.materials.size(); ++i) {
    EXPECT_EQ(s.materials[i].name, w.materials[i].name);
    const glm::vec4 got(s.materials[i].base_color, s.materials[i].alpha), want(w.materials[i].base_color, w.materials[i].alpha);
    for (int k = 0; k < 4; ++k) EXPECT_FLOAT_EQ(got[k], want[k]) << i;
    EXPECT_FLOAT_EQ(s.materials[i].metallic, w.materials[i].metallic) << i;
    EXPECT_FLOAT_EQ(s.materials[i].roughness, w.materials[i].roughness) << i;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.materials[i].emission[k], w.materials[i].emission[k], 1e-5f) << i;
  }

  // Meshes in first-use order: ground, then the object (shared by three nodes).
  ASSERT_EQ(s.meshes.size(), 2u);
  EXPECT_EQ(s.meshes[0].name, "ground");
  ASSERT_EQ(s.meshes[0].primitives.size(), 1u);
  expect_same_primitive(s.meshes[0].primitives[0], w.ground.primitives[0], "ground");
  EXPECT_EQ(s.meshes[1].name, "tetra_and_quad");
  ASSERT_EQ(s.meshes[1].primitives.size(), 2u);
  expect_same_primitive(s.meshes[1].primitives[0], w.object.primitives[0], "tetra");
  expect_same_primitive(s.meshes[1].primitives[1], w.object.primitives[1], "quad");

  // Instances with their transforms and LSNIF objects.
  ASSERT_EQ(s.instances.size(), 5u);
  const Instance& ground = s.instances[0];
  EXPECT_EQ(ground.node_name, "ground");
  EXPECT_EQ(ground.mesh, 0);
  EXPECT_EQ(ground.lsnif, -1);
  expect_mat_near(ground.object_to_world, glm::mat4(1.0f), "ground");
  const Instance& left = s.instances[1];
  const Instance& right = s.instances[2];
  EXPECT_EQ(left.node_name, "left");
  EXPECT_EQ(right.node_name, "right");
  EXPECT_EQ(left.mesh, 1);
  EXPECT_EQ(right.mesh, 1);
  expect_mat_near(left.object_to_world, w.left, "left");
  expect_mat_near(right.object_to_world, w.right, "right");
  ASSERT_GE(left.lsnif, 0);
  EXPECT_EQ(left.lsnif, right.lsnif) << "same model and material map: one LSNIF object";
  const Instance& neural = s.instances[3];
  EXPECT_EQ(neural.node_name, "neural_only");
  EXPECT_EQ(neural.mesh, -1);
  ASSERT_GE(neural.lsnif, 0);
  EXPECT_NE(neural.lsnif, left.lsnif);
  expect_mat_near(neural.object_to_world, placement({0, 1, 0}, 0.0f, 2.0f), "neural_only");
  EXPECT_EQ(s.instances[4].node_name, "triangles_only");
  EXPECT_EQ(s.instances[4].lsnif, -1);
  expect_mat_near(s.instances[4].object_to_world, placement({0, 0, 3}, 45.0f, 1.0f), "triangles_only");

  ASSERT_EQ(s.lsnif_objects.size(), 2u);
  const LsnifObject& obj = s.lsnif_objects[size_t(left.lsnif)];
  EXPECT_EQ(obj.model_path, "models/object.lsnif");
  EXPECT_TRUE(fs::equivalent(obj.resolved_path, dir / "models/object.lsnif"));
  EXPECT_EQ(obj.material_map, (std::vector<uint32_t>{2, 0}));
  const LsnifObject& other = s.lsnif_objects[size_t(neural.lsnif)];
  EXPECT_EQ(other.model_path, "models/other.lsnif");
  ASSERT_EQ(other.material_map.size(), 1u);  // no "materials" and no mesh: the default material
  EXPECT_EQ(s.materials[other.material_map[0]].name, "default");

  // Camera and environment.
  ASSERT_EQ(s.cameras.size(), 1u);
  EXPECT_EQ(s.cameras[0].name, "front");
  EXPECT_FLOAT_EQ(s.cameras[0].yfov, w.camera.yfov);
  EXPECT_FLOAT_EQ(s.cameras[0].aspect, w.camera.aspect);
  expect_mat_near(s.cameras[0].camera_to_world, w.camera.camera_to_world, "camera");
  EXPECT_TRUE(fs::equivalent(s.environment.path, dir / "sky/studio.exr"));
  for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(s.environment.color[k], w.env.color[k] * w.env.intensity);
  EXPECT_NEAR(s.environment.rotation, std::numbers::pi_v<float> / 2, 1e-6f);
}

TEST(GltfBuild, WrittenJsonFollowsGltf) {
  TempDir dir;
  const Written w = write_test_scene(dir);
  std::ifstream in(dir / "scene.gltf");
  const json j = json::parse(in);
  EXPECT_EQ(j["asset"]["version"], "2.0");
  EXPECT_EQ(j["asset"]["generator"], "gltf_build_test");
  EXPECT_EQ(j["scene"], 0);
  ASSERT_EQ(j["buffers"].size(), 1u);
  EXPECT_EQ(j["buffers"][0]["uri"], "scene.bin");
  EXPECT_EQ(j["buffers"][0]["byteLength"].get<uint64_t>(), fs::file_size(dir / "scene.bin"));
  const auto used = j["extensionsUsed"].get<std::vector<std::string>>();
  for (const char* ext : {"LSNIF_neural_object", "LSNIF_environment", "KHR_materials_emissive_strength"})
    EXPECT_NE(std::find(used.begin(), used.end(), ext), used.end()) << ext;
  EXPECT_FALSE(j.contains("extensionsRequired"));
  // Every bufferView is 4-byte aligned and inside the buffer.
  for (const json& v : j["bufferViews"]) {
    const uint64_t off = v.value("byteOffset", uint64_t(0)), len = v["byteLength"];
    EXPECT_EQ(off % 4, 0u);
    EXPECT_LE(off + len, j["buffers"][0]["byteLength"].get<uint64_t>());
  }
  // POSITION min / max are the bounds of the positions written.
  const json& prim = j["meshes"][0]["primitives"][0];
  const json& acc = j["accessors"][prim["attributes"]["POSITION"].get<size_t>()];
  EXPECT_EQ(acc["min"], json::array({0.0, 0.0, 0.0}));
  EXPECT_EQ(acc["max"], json::array({1.0, 1.0, 1.5}));
  EXPECT_EQ(acc["count"], 4);
  EXPECT_EQ(j["accessors"][prim["indices"].get<size_t>()]["componentType"], 5125);  // UNSIGNED_INT
  // The identity transform is left out; the others are matrices.
  EXPECT_FALSE(j["nodes"][0].contains("matrix"));
  EXPECT_EQ(j["nodes"][1]["matrix"].size(), 16u);
  // Emission 4 = factor 1 x strength 4.
  const json& lamp = j["materials"][2];
  EXPECT_DOUBLE_EQ(lamp["emissiveFactor"][0].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(lamp["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"].get<double>(), 4.0);
  EXPECT_EQ(j["nodes"][1]["extensions"]["LSNIF_neural_object"]["materials"], json::array({2, 0}));
  EXPECT_FALSE(j["nodes"][3]["extensions"]["LSNIF_neural_object"].contains("materials"));
  EXPECT_EQ(j["extensions"]["LSNIF_environment"]["hdr"], "sky/studio.exr");
  EXPECT_DOUBLE_EQ(j["extensions"]["LSNIF_environment"]["rotation_degrees"].get<double>(), 90.0);
  EXPECT_EQ(w.materials.size(), j["materials"].size());
}

// What tinygltf writes against the specification is repaired in both texts: objects without
// properties (a node) stay {} instead of null (a default sampler is an object too), an infinite perspective camera (zfar 0 in
// tinygltf) has no zfar; a finite one and an orthographic one keep theirs.
TEST(GltfBuild, TextsRepairWhatTinygltfWritesWrong) {
  tinygltf::Model m;
  m.asset.version = "2.0";
  m.nodes.resize(2);
  m.nodes[1].camera = 0;
  m.samplers.resize(1);
  tinygltf::Camera infinite, finite, ortho;
  infinite.type = finite.type = "perspective";
  infinite.perspective.yfov = finite.perspective.yfov = 0.8;
  infinite.perspective.znear = finite.perspective.znear = 0.1;
  finite.perspective.zfar = 100.0;
  ortho.type = "orthographic";
  ortho.orthographic.xmag = ortho.orthographic.ymag = 1.0;
  ortho.orthographic.znear = 0.1;
  ortho.orthographic.zfar = 10.0;
  m.cameras = {infinite, finite, ortho};
  m.scenes.resize(1);
  m.scenes[0].nodes = {0, 1};
  std::string a, b;
  ASSERT_TRUE(gltf_text(m, "scene.bin", a));
  ASSERT_TRUE(gltf_text_embedded(m, b));
  for (const std::string& text : {a, b}) {
    const json j = json::parse(text);
    EXPECT_EQ(j["nodes"][0], json::object()) << text;
    EXPECT_TRUE(j["samplers"][0].is_object()) << text;
    EXPECT_FALSE(j["cameras"][0]["perspective"].contains("zfar")) << text;
    EXPECT_EQ(j["cameras"][1]["perspective"]["zfar"], 100.0) << text;
    EXPECT_EQ(j["cameras"][2]["orthographic"]["zfar"], 10.0) << text;
  }
}

TEST(GltfBuild, RefusesBadInputNamingIt) {
  tinygltf::Model model = new_gltf_model("test");
  add_material(model, material("only", glm::vec4(1), 0, 1, glm::vec3(0)));
  int index = -1;
  Mesh m = ground_mesh();  // material 1: missing
  Status s = add_mesh(model, m, index);
  EXPECT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "ground")) << s.message();
  EXPECT_TRUE(contains(s.message(), "material 1")) << s.message();
  EXPECT_TRUE(model.meshes.empty() && model.accessors.empty() && model.buffers[0].data.empty());

  m.primitives[0].material = 0;
  m.primitives[0].indices[4] = 7;
  s = add_mesh(model, m, index);
  EXPECT_TRUE(contains(s.message(), "index 4 is 7")) << s.message();
  m.primitives[0].indices = {0, 1, 2, 0};
  s = add_mesh(model, m, index);
  EXPECT_TRUE(contains(s.message(), "multiple of 3")) << s.message();
  m = ground_mesh();
  m.primitives[0].material = 0;
  m.primitives[0].normals.pop_back();
  s = add_mesh(model, m, index);
  EXPECT_TRUE(contains(s.message(), "3 normals for 4 vertices")) << s.message();
  m = ground_mesh();
  m.primitives[0].material = 0;
  m.primitives[0].positions[2].y = std::nanf("");
  s = add_mesh(model, m, index);
  EXPECT_TRUE(contains(s.message(), "position 2 is not finite")) << s.message();
  m.primitives.clear();
  s = add_mesh(model, m, index);
  EXPECT_TRUE(contains(s.message(), "no primitive")) << s.message();
  EXPECT_TRUE(model.meshes.empty());

  TempDir dir;
  s = save_gltf(model, dir / "no_such_folder/scene.gltf");
  EXPECT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "no_such_folder/scene.gltf")) << s.message();
  s = save_gltf(model, dir / "scene.glb");
  EXPECT_TRUE(contains(s.message(), "expected a .gltf")) << s.message();
}

// A model without binary data writes no .bin; load_scene reads a camera-and-LSNIF-only scene.
TEST(GltfBuild, SceneWithoutBuffers) {
  TempDir dir;
  write_fake_lsnif(dir / "m.lsnif");
  tinygltf::Model model = new_gltf_model("test");
  const int node = add_node(model, "object", -1, glm::translate(glm::mat4(1.0f), glm::vec3(0, 0.5f, 0)));
  set_neural_object(model, node, "m.lsnif", {});
  ASSERT_TRUE(save_gltf(model, dir / "empty.gltf"));
  EXPECT_FALSE(fs::exists(dir / "empty.bin"));
  SceneLoadOptions opts;
  opts.quiet = true;
  Scene s;
  const Status st = load_scene(dir / "empty.gltf", opts, s);
  ASSERT_TRUE(st) << st.message();
  ASSERT_EQ(s.instances.size(), 1u);
  EXPECT_FLOAT_EQ(s.instances[0].object_to_world[3].y, 0.5f);
  EXPECT_EQ(s.environment.path, "");
  EXPECT_EQ(s.environment.color, glm::vec3(1.0f));
}

}  // namespace
}  // namespace lsnif::scene
