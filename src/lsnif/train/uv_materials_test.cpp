// uv_materials_test.cpp -- texture coordinates against the mesh's own: which materials report them
// (and the warning naming each textured material left on learned colours), the uv cells read at
// exact surface points against the interpolated uvs, and a trained model's hits on a sphere whose
// layout has seams and a mirrored half, measured by `lsnif eval`'s metrics against ground truth.
#include "lsnif/train/uv_materials.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <vector>

#include "lsnif/core/rng.h"
#include "lsnif/core/uv_cells.h"
#include "lsnif/format/uv_cell_layout.h"
#include "lsnif/import/uv_layout.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/train/trainer.h"
#include "lsnif/train/voxelizer.h"

namespace lsnif {
namespace {

using test::layout_sphere;
using test::sphere_uv;

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

// Trains the tests' small model of `mesh` with texture coordinates (train_model: the measured
// choice included) and evaluates it on 20,000 held-out rays.
void train_and_evaluate(const Mesh& mesh, Model& model, TrainReport& rep, EvalReport& report) {
  TrainSettings s = test::tiny_train_settings();
  s.steps = 300;
  s.texture_coordinates = kTextureCoordinatesAuto;
  const Status trained = train_model(mesh, s, model, &rep);
  ASSERT_TRUE(trained) << trained.message();
  EvalSettings es;
  es.rays = 20000;
  const Status evaluated = evaluate_model(model, mesh, es, report);
  ASSERT_TRUE(evaluated) << evaluated.message();
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
  Model model;
  TrainReport rep;
  EvalReport report;
  ASSERT_NO_FATAL_FAILURE(train_and_evaluate(mesh, model, rep, report));
  EXPECT_EQ(model.config.uv_materials, 1u);
  ASSERT_EQ(report.uv_materials.size(), 1u);
  const UvMaterialEval& u = report.uv_materials[0];
  EXPECT_EQ(u.charts, 3u);
  EXPECT_EQ(u.texture_size, 256u);
  EXPECT_GT(u.hits, 1000u);
  EXPECT_LT(u.texel_error_median, 2.0) << report.to_text();
  EXPECT_LT(u.wrong_chart, 0.05) << report.to_text();
}

// The measured half of the choice (measure_uv_materials, run by train_model): on the sphere painted
// with a checkerboard of 8 x 8 cells, which a small network's colours blur, the coordinates shade
// closer to the reference (eval's channel errors: the truth is the mesh's own channels) and are
// kept without a warning. The same model with every map's coordinate moved by one checker cell
// samples the opposite colour: measured again, the material falls back to learned colours, with a
// warning naming it, and the cells are gone (a valid model without texture coordinates).
TEST(UvMaterials, TheMeasuredChoiceKeepsCoordinatesOnlyWhereTheyShadeCloser) {
  Mesh mesh = layout_sphere(24, 48);
  Texture& t = mesh.textures[0];
  for (uint32_t y = 0; y < t.height; ++y)
    for (uint32_t x = 0; x < t.width; ++x) {
      const bool dark = ((x * 8 / t.width) + (y * 8 / t.height)) % 2 == 1;
      uint8_t* texel = &t.rgba[4 * (size_t(y) * t.width + x)];
      texel[0] = dark ? 30 : 230;
      texel[1] = dark ? 60 : 200;
      texel[2] = dark ? 180 : 40;
    }
  Model model;
  TrainReport rep;
  EvalReport report;
  ASSERT_NO_FATAL_FAILURE(train_and_evaluate(mesh, model, rep, report));
  EXPECT_EQ(model.config.uv_materials, 1u);
  EXPECT_TRUE(rep.uv_warnings.empty()) << rep.uv_warnings[0];
  ASSERT_EQ(report.uv_materials.size(), 1u);
  const UvMaterialEval& u = report.uv_materials[0];
  std::printf("%s", report.uv_text().c_str());
  EXPECT_LT(u.channel_error_textures, 0.5 * u.channel_error_colours) << report.uv_text();

  // One checker cell (1/8 in u) off everywhere.
  Model moved = model;
  const size_t maps = size_t(kUvVoxelWords) * moved.config.uv_cell_voxels;
  ASSERT_GT(moved.config.uv_cell_maps, 0u);
  for (uint32_t i = 0; i < moved.config.uv_cell_maps; ++i) {
    uint32_t& word = moved.uv_cells[maps + size_t(kUvMapWords) * i];
    word = std::bit_cast<uint32_t>(std::bit_cast<float>(word) + 0.125f);
  }
  ASSERT_TRUE(moved.validate());
  std::vector<std::string> warnings;
  ASSERT_TRUE(measure_uv_materials(mesh, moved, warnings));
  EXPECT_EQ(moved.config.uv_materials, 0u);
  EXPECT_EQ(moved.config.uv_cells, 0u);
  EXPECT_TRUE(moved.uv_cells.empty());
  EXPECT_TRUE(moved.validate());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("material 0 'painted' keeps learned colours"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("learned colours 0."), std::string::npos) << warnings[0];
  // Measured again, the kept model is left as it is.
  Model again = model;
  warnings.clear();
  ASSERT_TRUE(measure_uv_materials(mesh, again, warnings));
  EXPECT_TRUE(warnings.empty());
  EXPECT_EQ(again.uv_cells, model.uv_cells);
}

}  // namespace
}  // namespace lsnif
