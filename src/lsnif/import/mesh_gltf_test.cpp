// flatten_gltf_meshes (mesh_gltf.h): chosen meshes of a parsed glTF model under chosen transforms
// become one training mesh; materials in first-use order with their glTF sources; a mirroring
// transform keeps the triangles facing outwards; primitives without usable normals are flat; bad
// parts are errors naming the mesh.
#include <gtest/gtest.h>

#include <cstring>

#include <glm/gtc/matrix_transform.hpp>

#include "lsnif/import/mesh_gltf.h"

namespace lsnif {
namespace {

// Appends `values` to buffer 0 as a new bufferView + accessor; returns the accessor index.
template <class T>
int append(tinygltf::Model& g, const std::vector<T>& values, int component, int type, size_t count) {
  if (g.buffers.empty()) g.buffers.resize(1);
  std::vector<unsigned char>& data = g.buffers[0].data;
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = values.size() * sizeof(T);
  data.resize(data.size() + view.byteLength);
  std::memcpy(data.data() + view.byteOffset, values.data(), view.byteLength);
  g.bufferViews.push_back(view);
  tinygltf::Accessor a;
  a.bufferView = int(g.bufferViews.size() - 1);
  a.componentType = component;
  a.type = type;
  a.count = count;
  g.accessors.push_back(a);
  return int(g.accessors.size() - 1);
}

// One triangle (0,0,0) (1,0,0) (0,1,0) per primitive, with the given materials.
int add_triangle_mesh(tinygltf::Model& g, const std::vector<int>& materials) {
  const int pos = append(g, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}, TINYGLTF_COMPONENT_TYPE_FLOAT,
                         TINYGLTF_TYPE_VEC3, 3);
  const int idx = append(g, std::vector<uint32_t>{0, 1, 2}, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                         TINYGLTF_TYPE_SCALAR, 3);
  tinygltf::Mesh m;
  for (int mat : materials) {
    tinygltf::Primitive p;
    p.attributes["POSITION"] = pos;
    p.indices = idx;
    p.material = mat;
    p.mode = TINYGLTF_MODE_TRIANGLES;
    m.primitives.push_back(p);
  }
  g.meshes.push_back(m);
  return int(g.meshes.size() - 1);
}

tinygltf::Model three_materials() {
  tinygltf::Model g;
  for (const char* name : {"a", "b", "c"}) {
    tinygltf::Material m;
    m.name = name;
    g.materials.push_back(m);
  }
  return g;
}

TEST(FlattenGltfMeshes, PartsUnderTransformsWithMaterialSources) {
  tinygltf::Model g = three_materials();
  const int m0 = add_triangle_mesh(g, {2, -1});
  const int m1 = add_triangle_mesh(g, {0, 2});
  const glm::dmat4 move = glm::translate(glm::dmat4(1.0), glm::dvec3(5, 0, 0));
  Mesh mesh;
  std::vector<int> sources;
  ASSERT_TRUE(flatten_gltf_meshes(g, {{m0, glm::dmat4(1.0)}, {m1, move}}, "test", mesh, sources));
  ASSERT_EQ(mesh.triangles.size(), 4u);
  // First use: glTF 2 (mesh 0 primitive 0), the default (primitive 1), then glTF 0.
  EXPECT_EQ(sources, (std::vector<int>{2, -1, 0}));
  EXPECT_EQ(mesh.materials[0].name, "c");
  EXPECT_EQ(mesh.triangle_material, (std::vector<uint32_t>{0, 1, 2, 0}));
  // The second part's vertices are moved by (5, 0, 0).
  const glm::uvec3 t = mesh.triangles[2];
  EXPECT_EQ(mesh.positions[t.x], glm::vec3(5, 0, 0));
  EXPECT_EQ(mesh.positions[t.y], glm::vec3(6, 0, 0));
  EXPECT_EQ(mesh.positions[t.z], glm::vec3(5, 1, 0));
}

TEST(FlattenGltfMeshes, MirroringKeepsTheFacing) {
  tinygltf::Model g = three_materials();
  const int m = add_triangle_mesh(g, {0});
  Mesh mesh;
  std::vector<int> sources;
  const glm::dmat4 mirror = glm::scale(glm::dmat4(1.0), glm::dvec3(-1, 1, 1));
  ASSERT_TRUE(flatten_gltf_meshes(g, {{m, mirror}}, "test", mesh, sources));
  ASSERT_EQ(mesh.triangles.size(), 1u);
  const glm::vec3 a = mesh.positions[mesh.triangles[0].x], b = mesh.positions[mesh.triangles[0].y],
                  c = mesh.positions[mesh.triangles[0].z];
  // The input triangle faces +z; mirroring x keeps it facing +z once the winding is swapped.
  EXPECT_GT(glm::cross(b - a, c - a).z, 0.0f);
}

// A tetrahedron of 4 shared vertices without NORMAL: glTF shades it flat (the renderer's face
// normals), so the flattened mesh carries each face's normal on vertices of its own, never the
// smooth normals of the shared corners; with a zero NORMAL the same (the renderer's rule).
TEST(FlattenGltfMeshes, PrimitivesWithoutUsableNormalsAreFlat) {
  for (const bool zero_normal : {false, true}) {
    SCOPED_TRACE(zero_normal ? "a zero NORMAL" : "no NORMAL");
    tinygltf::Model g = three_materials();
    const std::vector<float> corners = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const int pos = append(g, corners, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 4);
    const int idx = append(g, std::vector<uint32_t>{0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3},
                           TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, 12);
    tinygltf::Primitive p;
    p.attributes["POSITION"] = pos;
    if (zero_normal)
      p.attributes["NORMAL"] = append(g, std::vector<float>{0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0},
                                      TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 4);
    p.indices = idx;
    p.material = 0;
    p.mode = TINYGLTF_MODE_TRIANGLES;
    tinygltf::Mesh m;
    m.primitives.push_back(p);
    g.meshes.push_back(m);
    Mesh mesh;
    std::vector<int> sources;
    const glm::dmat4 mirror = glm::scale(glm::dmat4(1.0), glm::dvec3(1, -1, 1));
    for (const glm::dmat4& world : {glm::dmat4(1.0), mirror}) {
      ASSERT_TRUE(flatten_gltf_meshes(g, {{0, world}}, "test", mesh, sources));
      ASSERT_EQ(mesh.triangles.size(), 4u);
      ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
      glm::vec3 centre(0.0f);
      for (const glm::vec3& v : mesh.positions) centre += v / float(mesh.positions.size());
      for (const glm::uvec3& t : mesh.triangles) {
        const glm::vec3 a = mesh.positions[t.x], b = mesh.positions[t.y], c = mesh.positions[t.z];
        const glm::vec3 face = glm::normalize(glm::cross(b - a, c - a));
        EXPECT_GT(glm::dot(face, a - centre), 0.0f) << "faces outwards";
        for (int k = 0; k < 3; ++k) EXPECT_LT(glm::length(mesh.normals[t[k]] - face), 1e-6f) << k;
      }
    }
  }
}

TEST(FlattenGltfMeshes, BadPartsAreErrorsNamingTheMesh) {
  tinygltf::Model g = three_materials();
  const int m = add_triangle_mesh(g, {0});
  Mesh mesh;
  std::vector<int> sources;
  Status s = flatten_gltf_meshes(g, {{7, glm::dmat4(1.0)}}, "test", mesh, sources);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("mesh 7 does not exist"), std::string::npos) << s.message();
  g.meshes[size_t(m)].primitives[0].mode = TINYGLTF_MODE_LINE;
  s = flatten_gltf_meshes(g, {{m, glm::dmat4(1.0)}}, "test", mesh, sources);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("no triangle primitives"), std::string::npos) << s.message();
  EXPECT_TRUE(mesh.triangles.empty());
}

}  // namespace
}  // namespace lsnif
