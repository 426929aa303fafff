// convert_test_support.h -- scenes and settings shared by the converter's tests (not part of
// lsnif_convert): glTF scenes written with gltf_build.h from the elephant mesh and a quad, and
// training settings that make a model in about a second.
#pragma once
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "lsnif/apps/convert/convert.h"
#include "lsnif/scene/gltf_build.h"
#include "lsnif/testing/test_support.h"  // tests/: ScopedTestDir, tiny_preset_settings

namespace lsnif::convert::test {

inline const std::string kElephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";

// The elephant (5558 triangles) as a scene mesh: with `split`, two primitives (even triangles
// with material `a`, odd ones with `b`), else one with material `a`.
inline scene::Mesh elephant_mesh(const std::string& name, uint32_t a, uint32_t b, bool split) {
  Mesh m;
  EXPECT_TRUE(load_mesh(kElephant, m)) << kElephant;
  scene::Mesh out;
  out.name = name;
  out.primitives.resize(split ? 2 : 1);
  out.primitives[0].material = a;
  if (split) out.primitives[1].material = b;
  for (scene::Primitive& p : out.primitives) p.positions = m.positions;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    scene::Primitive& p = out.primitives[split ? t % 2 : 0];
    for (int c = 0; c < 3; ++c) p.indices.push_back(m.triangles[t][c]);
  }
  return out;
}

inline scene::Mesh quad_mesh(const std::string& name, uint32_t material) {
  scene::Mesh out;
  out.name = name;
  scene::Primitive p;
  p.positions = {{-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}};
  p.indices = {0, 2, 1, 0, 3, 2};
  p.material = material;
  out.primitives.push_back(p);
  return out;
}

inline glm::mat4 placed(glm::vec3 t, float degrees, float scale) {
  glm::mat4 m = glm::translate(glm::mat4(1.0f), t);
  m = glm::rotate(m, glm::radians(degrees), glm::vec3(0, 1, 0));
  return glm::scale(m, glm::vec3(scale));
}

inline int add_mesh_or_fail(tinygltf::Model& g, const scene::Mesh& mesh) {
  int index = -1;
  Status s = scene::add_mesh(g, mesh, index);
  EXPECT_TRUE(s) << s.message();
  return index;
}

// Sets node extras {"KEY": value}.
template <class T>
void set_extra(tinygltf::Model& g, int node, const std::string& key, T value) {
  tinygltf::Value::Object o;
  if (g.nodes[size_t(node)].extras.IsObject()) o = g.nodes[size_t(node)].extras.Get<tinygltf::Value::Object>();
  o[key] = tinygltf::Value(value);
  g.nodes[size_t(node)].extras = tinygltf::Value(o);
}

// A scene under construction in a fresh folder: materials 0 grey and 1 red, mesh `elephant`
// (primitive 0 red, primitive 1 grey) and mesh `floor` (grey); the tests add the nodes.
struct TestScene {
  lsnif::test::ScopedTestDir dir;
  std::string path;
  tinygltf::Model g = scene::new_gltf_model("lsnif convert tests");
  int elephant = -1, floor = -1;
  explicit TestScene(const std::string& prefix) : dir(prefix), path(dir.path("scene.gltf")) {
    scene::add_material(g, scene::Material{"grey"});
    scene::add_material(g, scene::Material{"red"});
    elephant = add_mesh_or_fail(g, elephant_mesh("elephant", 1, 0, true));
    floor = add_mesh_or_fail(g, quad_mesh("floor", 0));
  }
};

inline void save_or_fail(const tinygltf::Model& g, const std::string& path) {
  Status s = scene::save_gltf(g, path);
  ASSERT_TRUE(s) << s.message();
}

// Settings that train a tiny model in about a second: the tiny preset (`lsnif convert --tiny`; 30
// steps of 1024 rays, V=16, 2x32 MLP). The tests of these settings decide by the triangle rule
// (ConvertWhen::Triangles, --min-triangles 1000: the elephant converts, the quad stays); the
// memory rule's tests set ConvertWhen::Memory themselves.
inline ConvertSettings tiny_settings(const std::string& in, const std::string& out) {
  ConvertSettings s;
  s.input = in;
  s.output = out;
  s.convert_when = ConvertWhen::Triangles;
  s.train = lsnif::test::tiny_preset_settings();
  s.eval_rays = 2000;
  s.progress = false;
  return s;
}

// Runs the converter with its report swallowed (kept in a temporary file, returned in `log`).
inline int run_quiet(const ConvertSettings& s, ConvertResult& r, std::string* log = nullptr) {
  FILE* f = std::tmpfile();
  const int code = run_convert(s, r, f, f);
  if (log) {
    std::rewind(f);
    char buf[4096];
    size_t n;
    log->clear();
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) log->append(buf, n);
  }
  std::fclose(f);
  return code;
}

inline nlohmann::json read_json(const std::string& path) {
  std::ifstream f(path);
  return nlohmann::json::parse(f, nullptr, false);
}

inline void write_json(const std::string& path, const nlohmann::json& j) {
  std::ofstream(path, std::ios::trunc) << j.dump(1);
}

}  // namespace lsnif::convert::test
