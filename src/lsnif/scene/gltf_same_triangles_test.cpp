// gltf_same_triangles_test.cpp -- one glTF file gives training, conversion and rendering the same
// triangles, since all three read its primitives through gltf::read_primitive
// (src/lsnif/import/gltf_primitive.h): the training mesh (load_mesh, every placement flattened),
// the converter's flattening (flatten_gltf_meshes, one placement at a time) and the renderer's scene
// (load_scene: each instance's mesh under its transform), compared as oriented world-space
// triangles. On a file written here that holds what the readers could disagree on (a triangle strip,
// a fan, a mesh shared by two nodes, one of them mirrored by a negative scale, a primitive without
// normals, a node under a parent) and on the glTF-Asset-Generator's primitive-mode files (made
// elsewhere); and what the reader refuses, every tool refuses.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>

#include <nlohmann/json.hpp>

#include "lsnif/format/file_io.h"
#include "lsnif/import/gltf_access.h"
#include "lsnif/import/gltf_scene.h"
#include "lsnif/import/mesh.h"
#include "lsnif/import/mesh_gltf.h"
#include "lsnif/scene/scene_gltf.h"
#include "lsnif/testing/scene_test_support.h"

namespace lsnif::scene {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// A world-space triangle, oriented (the side its normal faces is the front of the surface), its
// corners rotated so that the lexicographically smallest comes first.
using Triangle = std::array<glm::vec3, 3>;

bool less(const glm::vec3& a, const glm::vec3& b) {
  return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
}

Triangle canonical(glm::vec3 a, glm::vec3 b, glm::vec3 c) {
  if (less(b, a) && !less(c, b)) return {b, c, a};
  if (less(c, a) && less(c, b)) return {c, a, b};
  return {a, b, c};
}

// The training mesh's triangles (the flattener applies each node's world transform and flips the
// winding under a mirroring one, so that the front follows the transformed surface).
std::vector<Triangle> mesh_triangles(const lsnif::Mesh& mesh) {
  std::vector<Triangle> out;
  for (const glm::uvec3& t : mesh.triangles)
    out.push_back(canonical(mesh.positions[t.x], mesh.positions[t.y], mesh.positions[t.z]));
  return out;
}

// The renderer's triangles: each instance's mesh under object_to_world; under a mirroring transform
// the front is the other side of the object-space winding, so the corners are swapped to say so.
std::vector<Triangle> scene_triangles(const Scene& scene) {
  std::vector<Triangle> out;
  for (const Instance& inst : scene.instances) {
    if (inst.mesh < 0) continue;
    const bool mirror = glm::determinant(glm::mat3(inst.object_to_world)) < 0.0f;
    for (const Primitive& p : scene.meshes[size_t(inst.mesh)].primitives)
      for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
        glm::vec3 v[3];
        for (int k = 0; k < 3; ++k) v[k] = glm::vec3(inst.object_to_world * glm::vec4(p.positions[p.indices[i + k]], 1.0f));
        if (mirror) std::swap(v[1], v[2]);
        out.push_back(canonical(v[0], v[1], v[2]));
      }
  }
  return out;
}

// "" when `a` and `b` hold the same triangles (corners within `tol`, each matched once), else the
// first one without a match.
std::string same_triangles(const std::vector<Triangle>& a, const std::vector<Triangle>& b, float tol) {
  if (a.size() != b.size()) return std::to_string(a.size()) + " triangles against " + std::to_string(b.size());
  std::vector<bool> used(b.size(), false);
  auto close = [&](const Triangle& s, const Triangle& t) {
    for (int k = 0; k < 3; ++k)
      if (glm::length(s[size_t(k)] - t[size_t(k)]) > tol) return false;
    return true;
  };
  for (size_t i = 0; i < a.size(); ++i) {
    bool found = false;
    for (size_t j = 0; j < b.size() && !found; ++j)
      if (!used[j] && close(a[i], b[j])) used[j] = found = true;
    if (!found) {
      const glm::vec3& p = a[i][0];
      return "triangle " + std::to_string(i) + " at (" + std::to_string(p.x) + ", " + std::to_string(p.y) + ", " +
             std::to_string(p.z) + ") has no match";
    }
  }
  return "";
}

// The converter's triangles: flatten_gltf_meshes of each placement of a mesh in the file's scene.
std::vector<Triangle> converter_triangles(const std::string& path) {
  tinygltf::Model model;
  std::vector<std::string> warnings;
  std::string data;
  Status s = read_file(path, data, uint64_t(1) << 30);
  EXPECT_TRUE(s) << s.message();
  const bool binary = data.size() >= 4 && std::memcmp(data.data(), "glTF", 4) == 0;
  s = gltf::load_model(data, binary, path, fs::path(path).parent_path().string(), gltf::LoadOptions(), model,
                              warnings);
  EXPECT_TRUE(s) << s.message();
  GltfScene walk;
  s = read_gltf_scene(model, path, walk);
  EXPECT_TRUE(s) << s.message();
  std::vector<Triangle> out;
  for (const GltfSceneNode& n : walk.nodes) {
    const int mesh = model.nodes[size_t(n.node)].mesh;
    if (mesh < 0) continue;
    lsnif::Mesh flat;
    std::vector<int> sources;
    MeshImportReport report;
    s = flatten_gltf_meshes(model, {GltfMeshPart{mesh, n.world}}, path, flat, sources, &report, true);
    if (!s) continue;  // a mesh without triangles (the renderer skips it as well)
    const std::vector<Triangle> t = mesh_triangles(flat);
    out.insert(out.end(), t.begin(), t.end());
  }
  return out;
}

SceneLoadOptions quiet() {
  SceneLoadOptions o;
  o.quiet = true;
  return o;
}

// Appends `values` to the buffer as a bufferView + accessor; returns the accessor index.
template <class T>
int add_accessor(json& j, std::string& bin, const std::vector<T>& values, int component_type, const char* type,
                 int components) {
  while (bin.size() % 4) bin.push_back('\0');
  const size_t offset = bin.size();
  bin.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", values.size() * sizeof(T)}});
  json a = {{"bufferView", int(j["bufferViews"].size()) - 1},
            {"componentType", component_type},
            {"count", values.size() / size_t(components)},
            {"type", type}};
  if (std::string(type) == "VEC3") {
    std::vector<float> lo(3, 1e30f), hi(3, -1e30f);
    for (size_t i = 0; i < values.size(); ++i) {
      lo[i % 3] = std::min(lo[i % 3], float(values[i]));
      hi[i % 3] = std::max(hi[i % 3], float(values[i]));
    }
    a["min"] = lo;
    a["max"] = hi;
  }
  j["accessors"].push_back(a);
  return int(j["accessors"].size()) - 1;
}

// The file: mesh 0 a triangle strip with normals and a fan without normals (uint16 indices), mesh
// 1 a triangle list without normals (uint32 indices); mesh 0 placed by node "a" and, mirrored by a
// negative scale and rotated, by node "b"; mesh 1 by node "c" under a translated parent.
std::string write_held_out(const TempDir& dir) {
  json j;
  j["asset"] = {{"version", "2.0"}};
  std::string bin;
  const std::vector<float> strip = {0, 0, 0, 0, 1, 0, 1, 0, 0.2f, 1, 1, 0.1f, 2, 0, 0, 2, 1.2f, 0.3f};
  std::vector<float> strip_normals;
  for (int i = 0; i < 6; ++i) strip_normals.insert(strip_normals.end(), {0.0f, 0.0f, 1.0f});
  const std::vector<float> fan = {0, 0, 1, 1, 0, 1.1f, 0.7f, 0.7f, 1, 0, 1, 1.2f, -0.7f, 0.7f, 1};
  const std::vector<uint16_t> fan_indices = {0, 1, 2, 3, 4};
  const std::vector<float> tris = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
  const std::vector<uint32_t> tri_indices = {0, 1, 2, 0, 3, 1, 1, 3, 4, 2, 4, 3};
  const int a_strip = add_accessor(j, bin, strip, 5126, "VEC3", 3);
  const int a_strip_n = add_accessor(j, bin, strip_normals, 5126, "VEC3", 3);
  const int a_fan = add_accessor(j, bin, fan, 5126, "VEC3", 3);
  const int a_fan_i = add_accessor(j, bin, fan_indices, 5123, "SCALAR", 1);
  const int a_tris = add_accessor(j, bin, tris, 5126, "VEC3", 3);
  const int a_tris_i = add_accessor(j, bin, tri_indices, 5125, "SCALAR", 1);
  j["buffers"] = json::array({{{"uri", "held_out.bin"}, {"byteLength", bin.size()}}});
  j["meshes"] = json::array(
      {{{"name", "strip_and_fan"},
        {"primitives", json::array({{{"attributes", {{"POSITION", a_strip}, {"NORMAL", a_strip_n}}}, {"mode", 5}},
                                    {{"attributes", {{"POSITION", a_fan}}}, {"indices", a_fan_i}, {"mode", 6}}})}},
       {{"name", "list"}, {"primitives", json::array({{{"attributes", {{"POSITION", a_tris}}}, {"indices", a_tris_i}}})}}});
  j["nodes"] = json::array({{{"name", "a"}, {"mesh", 0}, {"translation", {0.5, 0.0, -1.0}}},
                            {{"name", "b"}, {"mesh", 0}, {"scale", {-1.0, 1.0, 1.0}}, {"rotation", {0.0, 0.3826834, 0.0, 0.9238795}}},
                            {{"name", "parent"}, {"translation", {0.0, 2.0, 0.0}}, {"children", {3}}},
                            {{"name", "c"}, {"mesh", 1}, {"scale", {1.0, 2.0, 0.5}}}});
  j["scenes"] = json::array({{{"nodes", {0, 1, 2}}}});
  j["scene"] = 0;
  write_file(dir / "held_out.bin", bin);
  write_file(dir / "held_out.gltf", j.dump(1));
  return dir / "held_out.gltf";
}

// The three readings of `path`; "" when they agree.
std::string compare_tools(const std::string& path) {
  lsnif::Mesh training;
  MeshImportReport report;
  MeshImportOptions options;
  options.allow_dropping_most = true;
  if (Status s = load_mesh(path, training, &report, options); !s) return "load_mesh: " + s.message();
  Scene scene;
  if (Status s = load_scene(path, quiet(), scene); !s) return "load_scene: " + s.message();
  const std::vector<Triangle> train = mesh_triangles(training), render = scene_triangles(scene),
                              convert = converter_triangles(path);
  if (train.empty()) return "no triangles";
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const Triangle& t : train)
    for (const glm::vec3& p : t) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  const float tol = 1e-5f * std::max(1.0f, glm::length(hi - lo));
  if (std::string d = same_triangles(train, render, tol); !d.empty()) return "training vs rendering: " + d;
  if (std::string d = same_triangles(convert, render, tol); !d.empty()) return "conversion vs rendering: " + d;
  return "";
}

TEST(GltfSameTriangles, StripsFansMirrorsSharedMeshesAndFlatNormals) {
  TempDir dir;
  const std::string path = write_held_out(dir);
  EXPECT_EQ(compare_tools(path), "");
  // The count the file was written for: a strip of 6 vertices (4), a fan of 5 (3), a list of 4,
  // mesh 0 placed twice.
  lsnif::Mesh training;
  ASSERT_TRUE(load_mesh(path, training));
  EXPECT_EQ(training.triangles.size(), 2u * (4u + 3u) + 4u);
}

// A primitive the reader refuses is refused by every tool, with the same words: normalized index
// accessors (glTF forbids them; the training importer used to read them) and a material that does
// not exist.
TEST(GltfSameTriangles, WhatTheReaderRefusesEveryToolRefuses) {
  const std::vector<std::pair<std::string, std::function<void(json&)>>> cases = {
      {"indices must not be normalized", [](json& j) { j["accessors"][3]["normalized"] = true; }},
      {"material 5 does not exist", [](json& j) { j["meshes"][1]["primitives"][0]["material"] = 5; }},
  };
  for (const auto& [why, spoil] : cases) {
    TempDir dir;
    const std::string path = write_held_out(dir);
    std::string text;
    ASSERT_TRUE(read_file(path, text, uint64_t(1) << 30));
    json j = json::parse(text);
    spoil(j);
    write_file(path, j.dump(1));
    lsnif::Mesh training;
    const Status trained = load_mesh(path, training);
    EXPECT_FALSE(trained) << why;
    EXPECT_NE(trained.message().find(why), std::string::npos) << trained.message();
    Scene scene;
    const Status rendered = load_scene(path, quiet(), scene);
    EXPECT_FALSE(rendered) << why;
    EXPECT_NE(rendered.message().find(why), std::string::npos) << rendered.message();
  }
}

TEST(GltfSameTriangles, TheAssetGeneratorsPrimitiveModes) {
  const std::string dir = std::string(LSNIF_DATA_DIR) + "/gltf/glTF-Asset-Generator/Mesh_PrimitiveMode";
  if (!fs::exists(dir)) GTEST_SKIP() << "Mesh_PrimitiveMode not found in " << dir;
  int compared = 0;
  for (int i = 0; i <= 15; ++i) {
    char name[64];
    std::snprintf(name, sizeof name, "/Mesh_PrimitiveMode_%02d.gltf", i);
    const std::string path = dir + name;
    lsnif::Mesh training;
    if (!load_mesh(path, training)) continue;  // points and lines only: neither tool draws them
    EXPECT_EQ(compare_tools(path), "") << name;
    ++compared;
  }
  EXPECT_GE(compared, 8);  // the files with strips, fans and lists
}

}  // namespace
}  // namespace lsnif::scene
