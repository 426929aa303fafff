// uv_materials_test.cpp -- texture coordinates against the mesh's own: which materials report them
// (and the warning naming each textured material left on learned colours), the uv cells read at
// exact surface points against the interpolated uvs, and a trained model's hits on a sphere whose
// layout has seams and a mirrored half, measured by `lsnif eval`'s metrics against ground truth.
#include "lsnif/train/uv_materials.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "lsnif/core/rng.h"
#include "lsnif/core/uv_cells.h"
#include "lsnif/import/uv_layout.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/train/trainer.h"
#include "lsnif/train/voxelizer.h"

namespace lsnif {
namespace {

constexpr float kPi = 3.14159265f;

// The uv of a unit-sphere point: the band |latitude| <= 60 degrees maps to u = |longitude| / pi
// (the half z < 0 mirrors the half z > 0 onto the same texels), v = 0.05 + 0.5 (latitude / (2 pi / 3)
// + 0.5); each cap beyond 60 degrees is its own chart, projected from above into v in [0.6, 1]:
// three charts, seams at +-60 degrees.
glm::vec2 sphere_uv(glm::vec3 p, bool cap) {
  const float lat = std::asin(std::clamp(p.y, -1.0f, 1.0f));
  if (!cap) return {std::fabs(std::atan2(p.z, p.x)) / kPi, 0.05f + 0.5f * (lat / (2.0f * kPi / 3.0f) + 0.5f)};
  const float side = p.y > 0.0f ? 0.25f : 0.75f;
  return {side + 0.2f * p.x, 0.8f + 0.2f * p.z};
}

// A latitude-longitude sphere with the layout above: quads of `rows` x `columns`, each with its own
// four vertices (a soup, as importers write it), one material with a 256 x 256 texture.
Mesh layout_sphere(uint32_t rows, uint32_t columns) {
  Mesh m;
  for (uint32_t r = 0; r < rows; ++r)
    for (uint32_t c = 0; c < columns; ++c) {
      const float mid = (float(r) + 0.5f) / float(rows) * 180.0f - 90.0f;
      const bool cap = std::fabs(mid) > 60.0f;
      const uint32_t b = uint32_t(m.positions.size());
      for (const glm::uvec2 corner : {glm::uvec2(r, c), glm::uvec2(r + 1, c), glm::uvec2(r + 1, c + 1), glm::uvec2(r, c + 1)}) {
        const float lat = -kPi / 2 + kPi * float(corner.x) / float(rows);
        const float lon = -kPi + 2 * kPi * float(corner.y) / float(columns);
        // The poles exactly: their quads' two pole corners coincide, a triangle the importer drops.
        const float ring = corner.x == 0 || corner.x == rows ? 0.0f : std::cos(lat);
        const glm::vec3 p(ring * std::cos(lon), std::sin(lat), ring * std::sin(lon));
        m.positions.push_back(p);
        m.uvs.push_back(cap ? sphere_uv(p, true)
                            : glm::vec2(std::fabs(lon) / kPi, 0.05f + 0.5f * (lat / (2.0f * kPi / 3.0f) + 0.5f)));
      }
      m.triangles.push_back({b, b + 1, b + 2});  // counter-clockwise seen from outside
      m.triangles.push_back({b, b + 2, b + 3});
      m.triangle_material.insert(m.triangle_material.end(), {0u, 0u});
    }
  Texture t;
  t.width = t.height = 256;
  for (uint32_t y = 0; y < 256; ++y)
    for (uint32_t x = 0; x < 256; ++x) t.rgba.insert(t.rgba.end(), {uint8_t(x), uint8_t(y), 128, 255});
  m.textures.push_back(t);
  Material mat;
  mat.name = "painted";
  mat.base_color_texture = 0;
  m.materials = {mat};
  EXPECT_TRUE(finalize_mesh(m, nullptr, "layout sphere"));
  return m;
}

TEST(UvMaterials, TexturedMaterialsReportCoordinatesAndTheOthersSayWhyNot) {
  Mesh m = layout_sphere(12, 24);
  Material plain;
  plain.name = "plain";  // no texture: learned colours, no warning
  Material tinted = m.materials[0];
  tinted.name = "tinted";
  m.materials = {m.materials[0], plain, tinted};
  for (size_t t = 0; t < m.triangle_material.size(); ++t) m.triangle_material[t] = uint32_t(t % 3);
  UvMaterialChoice c = choose_uv_materials(m, kTextureCoordinatesAuto);
  EXPECT_EQ(c.materials, 0b101u);
  EXPECT_TRUE(c.warnings.empty());
  EXPECT_EQ(choose_uv_materials(m, kTextureCoordinatesOff).materials, 0u);

  // Vertex colours tinting material 2's triangles: its textures alone would lose them.
  m.colors.assign(m.positions.size(), glm::vec3(1.0f));
  m.colors[m.triangles[2].z] = glm::vec3(0.5f, 1.0f, 1.0f);  // a corner of triangle 2 alone
  c = choose_uv_materials(m, kTextureCoordinatesAuto);
  EXPECT_EQ(c.materials, 0b001u);
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("material 2 'tinted' keeps learned colours"), std::string::npos) << c.warnings[0];
  EXPECT_NE(c.warnings[0].find("vertex colours"), std::string::npos) << c.warnings[0];

  // Coordinates beyond what a hit can carry; a mesh without any.
  m.colors.clear();
  m.uvs[m.triangles[0].x] = glm::vec2(5000.0f, 0.0f);
  c = choose_uv_materials(m, kTextureCoordinatesAuto);
  EXPECT_EQ(c.materials, 0b100u);
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("beyond +-2047"), std::string::npos) << c.warnings[0];
  m.uvs.clear();
  c = choose_uv_materials(m, kTextureCoordinatesAuto);
  EXPECT_EQ(c.materials, 0u);
  ASSERT_EQ(c.warnings.size(), 2u);
  EXPECT_NE(c.warnings[1].find("no texture coordinates"), std::string::npos) << c.warnings[1];
}

// Model frame (voxels, config) of `mesh` with its texture-coordinate materials and uv cells: what
// train_model builds after training, without training.
Model cells_only(const Mesh& mesh, uint32_t cells_per_voxel) {
  Model model;
  model.config.voxel_resolution = 16;
  model.config.uv_materials = choose_uv_materials(mesh, kTextureCoordinatesAuto).materials;
  model.config.uv_cells = cells_per_voxel;
  model.voxels = voxelize(mesh, 16, pad_aabb(mesh.bounds()), true);
  const Status s = build_uv_cells(mesh, model);
  EXPECT_TRUE(s) << s.message();
  return model;
}

// Read at exact surface points with the exact normal, the cells give the mesh's own uvs: inside a
// chart to well below a texel of a 256 texture, on the seams' cells the nearer side's (a small share).
TEST(UvMaterials, CellsGiveTheMeshsCoordinatesAtSurfacePoints) {
  const Mesh mesh = layout_sphere(24, 48);
  for (uint32_t cells : {1u, 2u}) {
    const Model model = cells_only(mesh, cells);
    ASSERT_GT(model.config.uv_cell_maps, 0u);
    const UvCells reader(model);
    std::vector<double> errors;
    for (uint32_t i = 0; i < 4000; ++i) {
      Rng rng(5, 1, i);
      const uint32_t t = uint32_t(rng.next_float() * float(mesh.triangles.size())) % uint32_t(mesh.triangles.size());
      float u = rng.next_float(), v = rng.next_float();
      if (u + v > 1.0f) {
        u = 1.0f - u;
        v = 1.0f - v;
      }
      const glm::uvec3 tri = mesh.triangles[t];
      const glm::vec3 p0 = mesh.positions[tri.x], p1 = mesh.positions[tri.y], p2 = mesh.positions[tri.z];
      const glm::vec3 x = (1 - u - v) * p0 + u * p1 + v * p2, n = glm::normalize(glm::cross(p1 - p0, p2 - p0));
      glm::vec2 expected, got;
      ASSERT_TRUE(mesh.uv_at(t, u, v, expected));
      ASSERT_TRUE(reader.lookup(x, n, -n, got)) << "no piece at surface point " << i;
      errors.push_back(double(glm::length(got - expected)) * 256.0);
    }
    std::sort(errors.begin(), errors.end());
    EXPECT_LT(errors[errors.size() / 2], 0.25) << cells << " cells per voxel edge";
    const double far = double(std::count_if(errors.begin(), errors.end(), [](double e) { return e > 2.0; }));
    EXPECT_LT(far / double(errors.size()), 0.08) << cells << " cells per voxel edge";
  }
}

// A point off the surface along the ray (the network's distance error) reads the texel the ray
// sees: where the ray meets the piece's plane, not the point's own cell's value.
TEST(UvMaterials, APointOffAlongTheRayReadsWhereTheRayMeetsTheSurface) {
  const Mesh mesh = layout_sphere(24, 48);
  const Model model = cells_only(mesh, 2);
  const UvCells reader(model);
  // A slanted ray: along the surface as much as into it.
  const glm::vec3 hit = glm::normalize(glm::vec3(0.3f, 0.2f, 0.9f));
  const glm::vec3 direction = glm::normalize(glm::normalize(glm::cross(hit, glm::vec3(0.0f, 1.0f, 0.0f))) - hit);
  glm::vec2 at, off;
  ASSERT_TRUE(reader.lookup(hit, hit, direction, at));
  ASSERT_TRUE(reader.lookup(hit + 0.02f * direction, hit, direction, off));  // a quarter voxel past the surface
  EXPECT_LT(glm::length(off - at) * 256.0f, 0.5f);
  EXPECT_LT(glm::length(at - sphere_uv(hit, false)) * 256.0f, 1.0f);
}

// Trained on the sphere, the model's hits report the texture coordinate of the sphere's layout on
// both mirrored halves and both caps, within a texel or two of a 256 texture at the median, and land
// on the right chart nearly always.
TEST(UvMaterials, TrainedHitsReportTheLayoutsCoordinatesOnSeamsAndMirroredHalves) {
  const Mesh mesh = layout_sphere(24, 48);
  const UvLayout layout = analyze_uv_layout(mesh, 0);
  EXPECT_EQ(layout.charts, 3u) << layout.describe();
  EXPECT_GT(layout.seam_edges, 0u);
  EXPECT_GT(layout.mirrored_triangles, 0u);
  TrainSettings s = test::tiny_train_settings();
  s.steps = 300;
  s.texture_coordinates = kTextureCoordinatesAuto;
  Model model;
  const Status trained = train_model(mesh, s, model);
  ASSERT_TRUE(trained) << trained.message();
  EXPECT_EQ(model.config.uv_materials, 1u);
  EvalSettings es;
  es.rays = 20000;
  EvalReport report;
  ASSERT_TRUE(evaluate_model(model, mesh, es, report));
  ASSERT_EQ(report.uv_materials.size(), 1u);
  const UvMaterialEval& u = report.uv_materials[0];
  EXPECT_EQ(u.charts, 3u);
  EXPECT_EQ(u.texture_size, 256u);
  EXPECT_GT(u.hits, 1000u);
  EXPECT_LT(u.texel_error_median, 2.0) << report.to_text();
  EXPECT_LT(u.wrong_chart, 0.05) << report.to_text();
}

}  // namespace
}  // namespace lsnif
