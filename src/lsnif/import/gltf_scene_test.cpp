// gltf_scene_test.cpp -- the node walk of gltf_scene.h: order and world transforms against
// transforms composed independently (glm::translate / rotate / scale), and every rule of the
// header as an error naming the problem.
#include "lsnif/import/gltf_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

namespace lsnif {
namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

int add_node(tinygltf::Model& g, const std::string& name, std::vector<int> children = {}, int mesh = -1) {
  tinygltf::Node n;
  n.name = name;
  n.children = std::move(children);
  n.mesh = mesh;
  g.nodes.push_back(n);
  return int(g.nodes.size()) - 1;
}

// One scene with roots `roots`; one mesh (never read by the walk) so nodes may reference mesh 0.
tinygltf::Model with_scene(tinygltf::Model g, std::vector<int> roots) {
  tinygltf::Scene sc;
  sc.nodes = std::move(roots);
  g.scenes = {sc};
  g.defaultScene = 0;
  g.meshes.resize(1);
  return g;
}

void expect_near(const glm::dmat4& a, const glm::dmat4& b) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_NEAR(a[c][r], b[c][r], 1e-12) << "column " << c << " row " << r;
}

TEST(GltfScene, LocalTransformIsMatrixOrTranslationRotationScale) {
  tinygltf::Model g;
  add_node(g, "n");
  g.nodes[0].translation = {1, 2, 3};
  g.nodes[0].rotation = {0, std::sin(0.25), 0, std::cos(0.25)};  // 0.5 rad about +y, not unit length below
  for (double& q : g.nodes[0].rotation) q *= 3.0;                   // normalized by the reader
  g.nodes[0].scale = {2, 3, 4};
  glm::dmat4 m;
  ASSERT_TRUE(gltf_local_transform(g, 0, "f.gltf", m));
  const glm::dmat4 want = glm::scale(glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(1, 2, 3)), 0.5,
                                                 glm::dvec3(0, 1, 0)),
                                     glm::dvec3(2, 3, 4));
  expect_near(m, want);
  g.nodes[0].matrix = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 7, 8, 9, 1};  // the matrix wins
  ASSERT_TRUE(gltf_local_transform(g, 0, "f.gltf", m));
  expect_near(m, glm::translate(glm::dmat4(1.0), glm::dvec3(7, 8, 9)));
}

TEST(GltfScene, DepthFirstInFileOrderWithWorldTransforms) {
  tinygltf::Model g;
  const int leaf = add_node(g, "leaf", {}, 0);
  const int mid = add_node(g, "mid", {leaf});
  const int other = add_node(g, "other", {}, 0);
  const int root = add_node(g, "root", {mid, other});
  const int second_root = add_node(g, "second");
  g.nodes[size_t(root)].translation = {0, 0, 5};
  g.nodes[size_t(mid)].rotation = {0, 0, std::sin(0.5), std::cos(0.5)};  // 1 rad about +z
  g.nodes[size_t(leaf)].scale = {2, 2, 2};
  const tinygltf::Model m = with_scene(g, {root, second_root});
  GltfScene walk;
  ASSERT_TRUE(read_gltf_scene(m, "f.gltf", walk));
  EXPECT_EQ(walk.scene, 0);
  ASSERT_EQ(walk.nodes.size(), 5u);
  const int order[] = {root, mid, leaf, other, second_root};
  for (size_t i = 0; i < 5; ++i) EXPECT_EQ(walk.nodes[i].node, order[i]) << i;
  const glm::dmat4 t_root = glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0, 5));
  const glm::dmat4 t_mid = t_root * glm::rotate(glm::dmat4(1.0), 1.0, glm::dvec3(0, 0, 1));
  expect_near(walk.nodes[1].world, t_mid);
  expect_near(walk.nodes[2].world, t_mid * glm::scale(glm::dmat4(1.0), glm::dvec3(2, 2, 2)));
  expect_near(walk.nodes[3].world, t_root);
  expect_near(walk.nodes[4].world, glm::dmat4(1.0));
}

TEST(GltfScene, WithoutScenesTheParentlessNodesAreTheRoots) {
  tinygltf::Model g;
  const int child = add_node(g, "child");
  add_node(g, "parent", {child});
  add_node(g, "alone");
  GltfScene walk;
  ASSERT_TRUE(read_gltf_scene(g, "f.gltf", walk));
  EXPECT_EQ(walk.scene, -1);
  ASSERT_EQ(walk.nodes.size(), 3u);
  EXPECT_EQ(walk.nodes[0].node, 1);
  EXPECT_EQ(walk.nodes[1].node, 0);
  EXPECT_EQ(walk.nodes[2].node, 2);
  g.nodes[0].children = {2};  // every node has a parent now (and the hierarchy a cycle)
  g.nodes[2].children = {1};
  Status s = read_gltf_scene(g, "f.gltf", walk);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "no root node")) << s.message();
  EXPECT_TRUE(walk.nodes.empty());
  ASSERT_TRUE(read_gltf_scene(tinygltf::Model(), "f.gltf", walk));  // nothing at all: an empty walk
  EXPECT_TRUE(walk.nodes.empty());
}

TEST(GltfScene, EveryRuleIsAnErrorNamingTheProblem) {
  struct Case {
    const char* what;
    void (*edit)(tinygltf::Model&);
    const char* expected;
  };
  // Base: root (node 0) -> a (node 1, mesh 0) and b (node 2, mesh 0).
  const Case cases[] = {
      {"missing node", [](tinygltf::Model& g) { g.nodes[0].children.push_back(9); }, "node 9 does not exist"},
      {"cycle", [](tinygltf::Model& g) { g.nodes[1].children = {0}; }, "node 0 is its own ancestor (cyclic"},
      {"two parents", [](tinygltf::Model& g) { g.nodes[2].children = {1}; },
       "node 1 ('a') is reached a second time"},
      {"root listed twice", [](tinygltf::Model& g) { g.scenes[0].nodes = {0, 0}; }, "reached a second time"},
      {"default scene", [](tinygltf::Model& g) { g.defaultScene = 4; }, "default scene 4 does not exist"},
      {"short matrix", [](tinygltf::Model& g) { g.nodes[1].matrix = {1, 0, 0}; }, "matrix has 3 numbers"},
      {"projective matrix",
       [](tinygltf::Model& g) { g.nodes[1].matrix = {1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}; },
       "node 1 ('a'): matrix is not affine"},
      {"NaN matrix",
       [](tinygltf::Model& g) {
         g.nodes[1].matrix = {1, 0, 0, 0, 0, std::numeric_limits<double>::quiet_NaN(), 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
       },
       "node 1 ('a'): NaN or infinite value in its matrix"},
      {"zero quaternion", [](tinygltf::Model& g) { g.nodes[0].rotation = {0, 0, 0, 0}; },
       "node 0 ('root'): rotation quaternion has zero length"},
      {"infinite scale", [](tinygltf::Model& g) { g.nodes[2].scale = {1, std::numeric_limits<double>::infinity(), 1}; },
       "NaN or infinite value in its scale"},
      {"two-number translation", [](tinygltf::Model& g) { g.nodes[2].translation = {1, 2}; }, "3 / 4 / 3 numbers"},
      {"overflowing world",
       [](tinygltf::Model& g) {
         g.nodes[0].scale = {1e300, 1e300, 1e300};
         g.nodes[1].scale = {1e300, 1e300, 1e300};
       },
       "node 1 ('a'): NaN or infinite value in its world transform"},
      {"flat mesh node", [](tinygltf::Model& g) { g.nodes[2].scale = {1, 0, 1}; },
       "node 2 ('b'): non-invertible world transform"},
  };
  for (const Case& c : cases) {
    tinygltf::Model g;
    add_node(g, "root", {1, 2});
    add_node(g, "a", {}, 0);
    add_node(g, "b", {}, 0);
    g = with_scene(g, {0});
    c.edit(g);
    GltfScene walk;
    const Status s = read_gltf_scene(g, "f.gltf", walk);
    EXPECT_FALSE(s) << c.what;
    EXPECT_TRUE(contains(s.message(), c.expected)) << c.what << ": " << s.message();
    EXPECT_TRUE(contains(s.message(), "f.gltf")) << c.what << ": " << s.message();
    EXPECT_TRUE(walk.nodes.empty()) << c.what;
  }
}

TEST(GltfScene, OnlyNodesThatPlaceSomethingNeedAnInvertibleTransform) {
  tinygltf::Model g;
  add_node(g, "group", {});
  g.nodes[0].scale = {0, 0, 0};  // places nothing: fine
  g = with_scene(g, {0});
  GltfScene walk;
  ASSERT_TRUE(read_gltf_scene(g, "f.gltf", walk));
  for (int what = 0; what < 3; ++what) {
    tinygltf::Model h = g;
    if (what == 0) h.nodes[0].mesh = 0;
    if (what == 1) h.nodes[0].camera = 0;
    if (what == 2) h.nodes[0].extensions["LSNIF_neural_object"] = tinygltf::Value(tinygltf::Value::Object());
    const Status s = read_gltf_scene(h, "f.gltf", walk);
    EXPECT_FALSE(s) << what;
    EXPECT_TRUE(contains(s.message(), "non-invertible world transform")) << s.message();
  }
}

TEST(GltfScene, SharedChildrenManyLevelsDeepStopAtTheFirstRepeat) {
  // Two nodes per level, both with the next level's two nodes as children: 2^40 paths.
  tinygltf::Model g;
  constexpr int kLevels = 40;
  for (int level = 0; level < kLevels; ++level)
    for (int k = 0; k < 2; ++k) {
      std::vector<int> children;
      if (level + 1 < kLevels) children = {2 * (level + 1), 2 * (level + 1) + 1};
      add_node(g, "n", children, 0);
    }
  g = with_scene(g, {0, 1});
  GltfScene walk;
  const Status s = read_gltf_scene(g, "f.gltf", walk);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "reached a second time")) << s.message();
  EXPECT_TRUE(contains(s.message(), "disjoint trees")) << s.message();
}

TEST(GltfScene, DepthLimit) {
  for (const int depth : {kGltfMaxNodeDepth, kGltfMaxNodeDepth + 1}) {
    tinygltf::Model g;
    for (int i = 0; i <= depth; ++i) add_node(g, "", i < depth ? std::vector<int>{i + 1} : std::vector<int>{}, 0);
    g = with_scene(g, {0});
    GltfScene walk;
    const Status s = read_gltf_scene(g, "f.gltf", walk);
    if (depth == kGltfMaxNodeDepth) {
      EXPECT_TRUE(s) << s.message();
      EXPECT_EQ(walk.nodes.size(), size_t(depth) + 1);
    } else {
      EXPECT_FALSE(s);
      EXPECT_TRUE(contains(s.message(), "deeper than 256 levels")) << s.message();
    }
  }
}

// gltf::primitive_size against the triangles gltf::triangle_list actually makes of k indices, for
// every triangle mode and small k (with and without an index accessor), and 0 for other modes.
TEST(GltfScene, PrimitiveSizeCountsWhatTheTriangleListMakes) {
  tinygltf::Model g;
  g.accessors.resize(2);
  tinygltf::Primitive prim;
  prim.attributes["POSITION"] = 0;
  for (const int mode : {-1, TINYGLTF_MODE_TRIANGLES, TINYGLTF_MODE_TRIANGLE_STRIP, TINYGLTF_MODE_TRIANGLE_FAN,
                         TINYGLTF_MODE_POINTS, TINYGLTF_MODE_LINE})
    for (size_t k = 0; k < 12; ++k)
      for (const bool indexed : {false, true}) {
        SCOPED_TRACE(testing::Message() << "mode " << mode << " k " << k << " indexed " << indexed);
        prim.mode = mode;
        prim.indices = indexed ? 1 : -1;
        g.accessors[0].count = indexed ? 40 : k;
        g.accessors[1].count = k;
        std::vector<uint32_t> indices(k);
        for (size_t i = 0; i < k; ++i) indices[i] = uint32_t(i);
        const uint64_t truth = gltf::is_triangle_mode(mode) ? gltf::triangle_list(mode, indices).size() / 3 : 0;
        const gltf::PrimitiveSize size = gltf::primitive_size(g, prim);
        EXPECT_EQ(size.triangles, truth);
        EXPECT_EQ(size.vertices, gltf::is_triangle_mode(mode) ? g.accessors[0].count : 0u);
      }
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.indices = 7;  // past the list: counts nothing (reading it is the error)
  EXPECT_EQ(gltf::primitive_size(g, prim).triangles, 0u);
}

// check_gltf_geometry: the sum over a list of placements (a mesh listed twice counts twice) against
// a sum made by hand, exactly at the budget and one past it, for triangles and for vertices.
TEST(GltfScene, GeometryBudgetSumsEveryPlacement) {
  tinygltf::Model g;
  g.accessors.resize(2);
  g.accessors[0].count = 3 * 1000;  // positions: 1000 triangles without indices
  g.accessors[1].count = 6;         // 2 indexed triangles over the same 3000 positions
  tinygltf::Primitive flat, indexed;
  flat.attributes["POSITION"] = indexed.attributes["POSITION"] = 0;
  indexed.indices = 1;
  g.meshes.resize(2);
  g.meshes[0].primitives = {flat, indexed};  // 1002 triangles, 6000 vertices
  g.meshes[1].primitives = {indexed};        // 2 triangles, 3000 vertices
  EXPECT_TRUE(check_gltf_geometry(g, {0, 0, 1, 9, -1}, true, "f.gltf"));  // 9, -1: nothing
  g.accessors[0].count = 3 * kGltfMaxGeometry + 3;  // one placement past the budget: a singular message
  const Status one = check_gltf_geometry(g, {1}, true, "f.gltf");
  ASSERT_FALSE(one);
  EXPECT_TRUE(contains(one.message(), "the scene's 1 mesh placement holds " + std::to_string(3 * kGltfMaxGeometry + 3) +
                                          " vertices")) << one.message();
  g.accessors[0].count = 3 * 1000;
  // Vertices past the budget first: placements of mesh 1 alone, 3000 vertices each.
  const size_t fit = size_t(kGltfMaxGeometry / 3000);
  std::vector<int> many(fit, 1);
  EXPECT_TRUE(check_gltf_geometry(g, many, true, "f.gltf"));
  many.push_back(1);
  Status s = check_gltf_geometry(g, many, true, "f.gltf");
  ASSERT_FALSE(s);
  EXPECT_EQ(s.message(), "f.gltf: the scene's " + std::to_string(fit + 1) + " mesh placements hold " +
                             std::to_string(3000 * (fit + 1)) + " vertices, more than the 134217728 (2^27) a tool "
                             "builds from one glTF file");
  // Triangles past the budget (vertices too: triangles are named first).
  g.accessors[0].count = 3 * kGltfMaxGeometry;
  s = check_gltf_geometry(g, {0, 0}, false, "f.gltf");
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "the scene's 2 meshes hold " + std::to_string(2 * (kGltfMaxGeometry + 2)) +
                                        " triangles")) << s.message();
  // Counts the file chose near 2^64 saturate instead of wrapping to a small sum.
  g.accessors[0].count = std::numeric_limits<size_t>::max() / 2;
  s = check_gltf_geometry(g, std::vector<int>(8, 0), false, "f.gltf");
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), std::to_string(std::numeric_limits<uint64_t>::max()) + " triangles"))
      << s.message();
}

}  // namespace
}  // namespace lsnif
