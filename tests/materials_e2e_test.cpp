// The albedo and material heads end to end: a scene of two objects with different materials (a red
// sphere and a blue box, one mesh) trains a tiny model whose material and albedo predictions on
// held-out rays must match the reference.
#include <gtest/gtest.h>

#include <cmath>

#include "lsnif/train/evaluate.h"
#include "lsnif/import/mesh.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/train/trainer.h"

namespace lsnif {
namespace {

void add_sphere(Mesh& m, glm::vec3 c, float r, uint32_t material) {
  const uint32_t base = uint32_t(m.positions.size()), rings = 16, segs = 32;
  for (uint32_t i = 0; i <= rings; ++i)
    for (uint32_t j = 0; j < segs; ++j) {
      const float th = 3.14159265f * float(i) / rings, ph = 6.2831853f * float(j) / segs;
      m.positions.push_back(c + r * glm::vec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)));
    }
  for (uint32_t i = 0; i < rings; ++i)
    for (uint32_t j = 0; j < segs; ++j) {
      const uint32_t a = base + i * segs + j, b = base + i * segs + (j + 1) % segs, c2 = a + segs, d = b + segs;
      m.triangles.push_back({a, c2, b});
      m.triangles.push_back({b, c2, d});
      m.triangle_material.push_back(material);
      m.triangle_material.push_back(material);
    }
}

void add_box(Mesh& m, glm::vec3 lo, glm::vec3 hi, uint32_t material) {
  const uint32_t base = uint32_t(m.positions.size());
  for (int i = 0; i < 8; ++i)
    m.positions.push_back({i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({base + q[0], base + q[1], base + q[2]});
    m.triangles.push_back({base + q[0], base + q[2], base + q[3]});
    m.triangle_material.push_back(material);
    m.triangle_material.push_back(material);
  }
}

TEST(Materials, TwoMaterialSceneLearnsMaterialAndAlbedo) {
  Mesh mesh;
  add_sphere(mesh, glm::vec3(-0.6f, 0.0f, 0.0f), 0.5f, 0);
  add_box(mesh, glm::vec3(0.2f, -0.4f, -0.4f), glm::vec3(1.0f, 0.4f, 0.4f), 1);
  mesh.materials = {{"red", glm::vec3(0.8f, 0.1f, 0.1f), -1}, {"blue", glm::vec3(0.1f, 0.2f, 0.9f), -1}};
  MeshImportReport report;
  ASSERT_TRUE(finalize_mesh(mesh, &report, "two-objects"));

  TrainSettings s = test::tiny_train_settings();
  s.steps = 300;
  Model model;
  Status st = train_model(mesh, s, model);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(model.config.material_count, 2u);
  ASSERT_EQ(model.materials.size(), 2u);
  EXPECT_EQ(model.materials[1].name, "blue");

  EvalSettings es;
  es.rays = 20000;
  EvalReport r;
  ASSERT_TRUE(evaluate_model(model, mesh, es, r));
  std::printf("%s", r.to_text().c_str());
  // The two objects are far apart compared with a voxel: the material is easy to tell.
  EXPECT_GT(r.model.material_accuracy, 0.97);
  // Measured 0.045 when written. Predicting the mean of the two colours would give ~0.27, so the
  // bound fails unless the albedo head tells the objects apart.
  EXPECT_LT(r.model.albedo_mae, 0.08);
  EXPECT_GT(r.model.accuracy, 0.95);
}

}  // namespace
}  // namespace lsnif
