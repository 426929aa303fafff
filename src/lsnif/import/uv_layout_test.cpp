// uv_layout_test.cpp -- the uv layout measurements (uv_layout.h) on meshes whose charts, seams,
// mirrored pieces, overlap and tiling are known by construction.
#include "lsnif/import/uv_layout.h"

#include <gtest/gtest.h>

#include <vector>

namespace lsnif {
namespace {

// Appends the quad (x0..x1) x (0..1) at z = 0, counter-clockwise seen from +z, as two triangles of
// its own four vertices (a triangle soup, as the importers write), with the uvs of its corners
// (x0, 0), (x1, 0), (x1, 1), (x0, 1) in that order.
void add_quad(Mesh& m, float x0, float x1, glm::vec2 uv00, glm::vec2 uv10, glm::vec2 uv11, glm::vec2 uv01,
              uint32_t material = 0) {
  const uint32_t b = uint32_t(m.positions.size());
  m.positions.insert(m.positions.end(), {{x0, 0, 0}, {x1, 0, 0}, {x1, 1, 0}, {x0, 1, 0}});
  m.uvs.insert(m.uvs.end(), {uv00, uv10, uv11, uv01});
  m.triangles.push_back({b, b + 1, b + 2});
  m.triangles.push_back({b, b + 2, b + 3});
  m.triangle_material.insert(m.triangle_material.end(), {material, material});
}

Mesh two_materials() {
  Mesh m;
  m.materials.resize(2);
  return m;
}

TEST(UvLayout, OneQuadIsOneChartWithoutSeams) {
  Mesh m = two_materials();
  add_quad(m, 0, 1, {0, 0}, {1, 0}, {1, 1}, {0, 1});
  const UvLayout l = analyze_uv_layout(m, 0);
  EXPECT_EQ(l.triangles, 2u);
  EXPECT_EQ(l.charts, 1u);
  EXPECT_EQ(l.seam_edges, 0u);
  EXPECT_EQ(l.mirrored_triangles, 0u);
  EXPECT_EQ(l.overlap_fraction, 0.0) << l.describe();
  EXPECT_FALSE(l.tiling);
}

// Two quads sharing the edge x = 1 in space: continuous uvs join them into one chart; uvs that
// jump across the edge make it a seam and two charts.
TEST(UvLayout, AnEdgeWhoseSidesDisagreeIsASeam) {
  Mesh joined = two_materials();
  add_quad(joined, 0, 1, {0, 0}, {0.5f, 0}, {0.5f, 1}, {0, 1});
  add_quad(joined, 1, 2, {0.5f, 0}, {1, 0}, {1, 1}, {0.5f, 1});
  UvLayout l = analyze_uv_layout(joined, 0);
  EXPECT_EQ(l.charts, 1u) << l.describe();
  EXPECT_EQ(l.seam_edges, 0u);
  EXPECT_EQ(l.overlap_fraction, 0.0);

  Mesh cut = two_materials();
  add_quad(cut, 0, 1, {0, 0}, {0.4f, 0}, {0.4f, 1}, {0, 1});
  add_quad(cut, 1, 2, {0.6f, 0}, {1, 0}, {1, 1}, {0.6f, 1});
  l = analyze_uv_layout(cut, 0);
  EXPECT_EQ(l.charts, 2u) << l.describe();
  EXPECT_EQ(l.seam_edges, 1u);
  EXPECT_EQ(l.mirrored_triangles, 0u);
  EXPECT_EQ(l.overlap_fraction, 0.0);
}

// The second quad's uvs mirror the first's across their shared edge: the edge is no seam (both
// sides have u = 1 there), but the second quad's triangles wind the other way in uv space and both
// quads cover the same square.
TEST(UvLayout, AMirroredHalfIsMirroredAndOverlaps) {
  Mesh m = two_materials();
  add_quad(m, 0, 1, {0, 0}, {1, 0}, {1, 1}, {0, 1});
  add_quad(m, 1, 2, {1, 0}, {0, 0}, {0, 1}, {1, 1});
  const UvLayout l = analyze_uv_layout(m, 0);
  EXPECT_EQ(l.charts, 1u) << l.describe();
  EXPECT_EQ(l.seam_edges, 0u);
  EXPECT_EQ(l.mirrored_triangles, 2u);
  EXPECT_GT(l.overlap_fraction, 0.99) << l.describe();
}

// Half of the second quad over the first: the overlap is the shared area's share of the covered one.
TEST(UvLayout, OverlapIsTheShareCoveredTwice) {
  Mesh m = two_materials();
  add_quad(m, 0, 1, {0, 0}, {0.5f, 0}, {0.5f, 1}, {0, 1});
  add_quad(m, 2, 3, {0.25f, 0}, {0.75f, 0}, {0.75f, 1}, {0.25f, 1});  // not touching in space
  const UvLayout l = analyze_uv_layout(m, 0);
  EXPECT_EQ(l.charts, 2u);
  EXPECT_NEAR(l.overlap_fraction, 0.25 / 0.75, 0.01) << l.describe();
}

TEST(UvLayout, CoordinatesOutsideTheUnitSquareTile) {
  Mesh m = two_materials();
  add_quad(m, 0, 1, {0, 0}, {4, 0}, {4, 4}, {0, 4});
  const UvLayout l = analyze_uv_layout(m, 0);
  EXPECT_TRUE(l.tiling);
  EXPECT_EQ(l.uv_max, glm::vec2(4.0f));
  EXPECT_NE(l.describe().find("(tiling)"), std::string::npos) << l.describe();
}

TEST(UvLayout, OnlyTheMaterialsTrianglesWithUvsCount) {
  Mesh m = two_materials();
  add_quad(m, 0, 1, {0, 0}, {1, 0}, {1, 1}, {0, 1}, 0);
  add_quad(m, 1, 2, {0, 0}, {1, 0}, {1, 1}, {0, 1}, 1);  // material 1: not joined, not overlapping 0
  UvLayout l = analyze_uv_layout(m, 0);
  EXPECT_EQ(l.triangles, 2u);
  EXPECT_EQ(l.charts, 1u);
  EXPECT_EQ(l.seam_edges, 0u);
  EXPECT_EQ(l.overlap_fraction, 0.0);
  EXPECT_EQ(analyze_uv_layout(m, 1).triangles, 2u);
  EXPECT_EQ(analyze_uv_layout(m, 7).triangles, 0u);
  m.uvs.clear();
  EXPECT_EQ(analyze_uv_layout(m, 0).triangles, 0u);
}

}  // namespace
}  // namespace lsnif
