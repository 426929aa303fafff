// mesh_subdivide_test.cpp -- midpoint subdivision against truths computed independently here by
// brute force (edge sets, areas in double, Euler characteristic, edge-use counts), on hand-made
// closed and open meshes and on the bunny; the input errors; the level choice for a target count.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <utility>

#include "lsnif/import/mesh_subdivide.h"

namespace lsnif {
namespace {

using Edge = std::pair<uint32_t, uint32_t>;

std::set<Edge> undirected_edges(const Mesh& m) {
  std::set<Edge> edges;
  for (const glm::uvec3& t : m.triangles)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  return edges;
}

long long euler_characteristic(const Mesh& m) {
  return static_cast<long long>(m.positions.size()) - static_cast<long long>(undirected_edges(m).size()) +
         static_cast<long long>(m.triangles.size());
}

glm::dvec3 face_cross(const Mesh& m, const glm::uvec3& t) {
  const glm::dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
  return glm::cross(b - a, c - a);
}

double total_area(const Mesh& m) {
  double area = 0;
  for (const glm::uvec3& t : m.triangles) area += 0.5 * glm::length(face_cross(m, t));
  return area;
}

// Closed: every directed edge appears once and its reverse once (consistently oriented, no
// boundary, no non-manifold edge).
bool watertight(const Mesh& m) {
  std::map<Edge, int> directed;
  for (const glm::uvec3& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  for (const auto& [e, count] : directed) {
    if (count != 1) return false;
    const auto reverse = directed.find({e.second, e.first});
    if (reverse == directed.end() || reverse->second != 1) return false;
  }
  return true;
}

// A regular-ish tetrahedron with outward winding.
Mesh tetrahedron() {
  Mesh m;
  m.positions = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  m.triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  return m;
}

// The unit cube, 8 corners, 12 outward triangles.
Mesh cube() {
  Mesh m;
  for (int i = 0; i < 8; ++i) m.positions.push_back(glm::vec3(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)));
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back(glm::uvec3(q[0], q[1], q[2]));
    m.triangles.push_back(glm::uvec3(q[0], q[2], q[3]));
  }
  return m;
}

// An open strip of two triangles with uvs, colors and two materials.
Mesh strip() {
  Mesh m;
  m.positions = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0.5f}};
  m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  m.colors = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  m.triangle_material = {0, 1};
  m.materials = {Material{"a", glm::vec3(1), -1}, Material{"b", glm::vec3(0.5f), -1}};
  return m;
}

// Every property the header promises, checked against brute-force truths on `in`.
void check_subdivision(const Mesh& in) {
  Mesh out;
  const Status s = subdivide_midpoint(in, out);
  ASSERT_TRUE(s) << s.message();
  const std::set<Edge> edges = undirected_edges(in);
  const size_t v = in.positions.size(), f = in.triangles.size(), e = edges.size();
  ASSERT_EQ(out.positions.size(), v + e);
  ASSERT_EQ(out.triangles.size(), 4 * f);
  // Originals first, unchanged.
  for (size_t i = 0; i < v; ++i) EXPECT_EQ(out.positions[i], in.positions[i]) << "vertex " << i;
  // Each new vertex is the midpoint of exactly one original edge, and every edge has one.
  std::set<Edge> matched;
  for (size_t i = v; i < out.positions.size(); ++i) {
    const glm::dvec3 p(out.positions[i]);
    int hits = 0;
    for (const Edge& ed : edges) {
      const glm::dvec3 mid = 0.5 * (glm::dvec3(in.positions[ed.first]) + glm::dvec3(in.positions[ed.second]));
      const double scale = 1.0 + glm::length(mid);
      if (glm::length(p - mid) <= 1e-6 * scale) {
        ++hits;
        matched.insert(ed);
      }
    }
    EXPECT_EQ(hits, 1) << "new vertex " << i << " is the midpoint of " << hits << " original edges";
  }
  EXPECT_EQ(matched.size(), e);
  // Area preserved; each child a quarter of its parent, with the parent's orientation.
  const double area_in = total_area(in), area_out = total_area(out);
  EXPECT_NEAR(area_out, area_in, 1e-6 * area_in);
  for (size_t i = 0; i < f; ++i) {
    const glm::dvec3 parent = face_cross(in, in.triangles[i]);
    for (size_t c = 0; c < 4; ++c) {
      const glm::dvec3 child = face_cross(out, out.triangles[4 * i + c]);
      EXPECT_NEAR(glm::length(child), 0.25 * glm::length(parent), 1e-5 * glm::length(parent));
      EXPECT_GT(glm::dot(child, parent), 0.0) << "child " << c << " of triangle " << i << " flipped";
    }
  }
  EXPECT_EQ(euler_characteristic(out), euler_characteristic(in));
  EXPECT_EQ(watertight(out), watertight(in));
}

TEST(MeshSubdivide, Tetrahedron) {
  const Mesh m = tetrahedron();
  ASSERT_TRUE(watertight(m));
  ASSERT_EQ(euler_characteristic(m), 2);
  check_subdivision(m);
  Mesh out;
  ASSERT_TRUE(subdivide_midpoint(m, out));
  EXPECT_EQ(out.positions.size(), 10u);  // 4 + 6
  EXPECT_EQ(out.triangles.size(), 16u);
  EXPECT_TRUE(watertight(out));
}

TEST(MeshSubdivide, Cube) {
  const Mesh m = cube();
  ASSERT_TRUE(watertight(m));
  check_subdivision(m);
}

TEST(MeshSubdivide, OpenStripKeepsAttributesAndMaterials) {
  const Mesh m = strip();
  ASSERT_FALSE(watertight(m));
  ASSERT_EQ(euler_characteristic(m), 1);  // a disc
  check_subdivision(m);
  Mesh out;
  ASSERT_TRUE(subdivide_midpoint(m, out));
  ASSERT_EQ(out.uvs.size(), out.positions.size());
  ASSERT_EQ(out.colors.size(), out.positions.size());
  for (size_t i = m.positions.size(); i < out.positions.size(); ++i) {
    // Find the edge this vertex is the midpoint of, then compare the attribute averages.
    bool found = false;
    for (const Edge& ed : undirected_edges(m)) {
      if (glm::length(out.positions[i] - 0.5f * (m.positions[ed.first] + m.positions[ed.second])) > 1e-6f) continue;
      found = true;
      const glm::vec2 uv = 0.5f * (m.uvs[ed.first] + m.uvs[ed.second]);
      const glm::vec3 color = 0.5f * (m.colors[ed.first] + m.colors[ed.second]);
      EXPECT_NEAR(glm::length(out.uvs[i] - uv), 0.0f, 1e-6f);
      EXPECT_NEAR(glm::length(out.colors[i] - color), 0.0f, 1e-6f);
    }
    EXPECT_TRUE(found) << i;
  }
  ASSERT_EQ(out.triangle_material.size(), 8u);
  for (size_t i = 0; i < 8; ++i) EXPECT_EQ(out.triangle_material[i], m.triangle_material[i / 4]);
  EXPECT_EQ(out.materials.size(), 2u);
}

TEST(MeshSubdivide, NormalsStayUnitLength) {
  Mesh m = tetrahedron();
  for (const glm::vec3& p : m.positions) m.normals.push_back(glm::normalize(p));
  Mesh out;
  ASSERT_TRUE(subdivide_midpoint(m, out));
  ASSERT_EQ(out.normals.size(), out.positions.size());
  for (const glm::vec3& n : out.normals) EXPECT_NEAR(glm::length(n), 1.0f, 1e-5f);
}

TEST(MeshSubdivide, SeveralLevelsAndInPlace) {
  const Mesh m = cube();
  Mesh two;
  ASSERT_TRUE(subdivide_midpoint(m, 2, two));
  EXPECT_EQ(two.triangles.size(), 12u * 16u);
  EXPECT_EQ(euler_characteristic(two), 2);
  EXPECT_TRUE(watertight(two));
  EXPECT_NEAR(total_area(two), 6.0, 1e-6);
  // Twice by hand, the second time in place, gives the same mesh.
  Mesh step;
  ASSERT_TRUE(subdivide_midpoint(m, step));
  ASSERT_TRUE(subdivide_midpoint(step, step));
  EXPECT_EQ(step.triangles, two.triangles);
  EXPECT_EQ(step.positions, two.positions);
  Mesh zero;
  ASSERT_TRUE(subdivide_midpoint(m, 0, zero));
  EXPECT_EQ(zero.triangles, m.triangles);
}

TEST(MeshSubdivide, Bunny) {
  const std::string path = std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " missing: run scripts/setup.sh";
  Mesh bunny;
  ASSERT_TRUE(load_mesh(path, bunny));
  ASSERT_EQ(bunny.triangles.size(), 75408u);
  const size_t edges = undirected_edges(bunny).size();
  Mesh out;
  ASSERT_TRUE(subdivide_midpoint(bunny, out));
  EXPECT_EQ(out.positions.size(), bunny.positions.size() + edges);
  EXPECT_EQ(out.triangles.size(), 4u * 75408u);
  EXPECT_EQ(euler_characteristic(out), euler_characteristic(bunny));
  EXPECT_EQ(watertight(out), watertight(bunny));
  const double area = total_area(bunny);
  EXPECT_NEAR(total_area(out), area, 1e-6 * area);
}

TEST(MeshSubdivide, RejectsBadInput) {
  Mesh out;
  Status s = subdivide_midpoint(Mesh(), out);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("empty"), std::string::npos) << s.message();

  Mesh no_triangles = tetrahedron();
  no_triangles.triangles.clear();
  EXPECT_FALSE(subdivide_midpoint(no_triangles, out));

  Mesh out_of_range = tetrahedron();
  out_of_range.triangles[2] = glm::uvec3(0, 1, 4);
  s = subdivide_midpoint(out_of_range, out);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("triangle 2"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("out of range"), std::string::npos) << s.message();

  Mesh repeated = tetrahedron();
  repeated.triangles[1] = glm::uvec3(3, 3, 1);
  s = subdivide_midpoint(repeated, out);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("triangle 1"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("degenerate"), std::string::npos) << s.message();

  Mesh collinear;
  collinear.positions = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
  collinear.triangles = {{0, 1, 2}};
  s = subdivide_midpoint(collinear, out);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("zero area"), std::string::npos) << s.message();

  Mesh nan = tetrahedron();
  nan.positions[3].y = std::nanf("");
  s = subdivide_midpoint(nan, 2, out);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("vertex 3"), std::string::npos) << s.message();
}

TEST(MeshSubdivide, LevelForTarget) {
  // bunny00: 75,408 triangles -> 301,632 / 1,206,528 / 4,826,112 / 19,304,448.
  EXPECT_EQ(subdivision_level_for(75408, 1000000), 2u);
  EXPECT_EQ(subdivision_level_for(75408, 5000000), 3u);
  EXPECT_EQ(subdivision_level_for(75408, 300000), 1u);
  EXPECT_EQ(subdivision_level_for(75408, 0), 0u);
  EXPECT_EQ(subdivision_level_for(75408, 75408), 0u);
  EXPECT_EQ(subdivision_level_for(75408, 19304448), 4u);
  EXPECT_EQ(subdivision_level_for(2, 5), 0u);  // |2 - 5| = |8 - 5|: the lower level
  EXPECT_EQ(subdivision_level_for(2, 6), 1u);
  EXPECT_EQ(subdivision_level_for(1, UINT64_MAX, 3), 3u);  // capped
  EXPECT_EQ(subdivision_level_for(1, UINT64_MAX), 16u);
  EXPECT_EQ(subdivision_level_for(0, 1000), 0u);
}

}  // namespace
}  // namespace lsnif
