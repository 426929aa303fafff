// Alpha cut-outs learned as geometry: a quad whose base colour texture cuts a checkerboard of holes
// into it (glTF alphaMode MASK). Trained against the alpha-tested ground truth, the model learns the
// holes as empty space; the same quad trained as OPAQUE does not. Both are measured by evaluate_model
// against the alpha-tested ground truth (ground_truth.h), the independent truth here.
#include <gtest/gtest.h>

#include <cstdio>

#include "lsnif/testing/test_support.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/train/trainer.h"

namespace lsnif {
namespace {

// A unit quad in z = 0, uv = xy, cut by an N x N checkerboard: alpha 0 in the odd cells.
Mesh checkerboard_quad(AlphaMode mode) {
  constexpr uint32_t N = 4;
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.normals.assign(4, glm::vec3(0, 0, 1));
  m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  m.triangle_material = {0, 0};
  Material leaf;
  leaf.name = "leaf";
  leaf.base_color_texture = 0;
  leaf.alpha_mode = mode;
  m.materials = {leaf};
  Texture t;
  t.width = t.height = N;
  for (uint32_t y = 0; y < N; ++y)
    for (uint32_t x = 0; x < N; ++x) t.rgba.insert(t.rgba.end(), {60, 160, 40, (x + y) % 2 ? uint8_t(0) : uint8_t(255)});
  m.textures = {t};
  return m;
}

EvalMetrics train_and_evaluate(const Mesh& trained_on, const Mesh& truth) {
  TrainSettings s = test::tiny_train_settings();
  s.steps = 600;
  s.seed = 11;
  Model model;
  EXPECT_TRUE(train_model(trained_on, s, model));
  EvalSettings es;
  es.rays = 20000;
  EvalReport report;
  EXPECT_TRUE(evaluate_model(model, truth, es, report));
  return report.model;
}

TEST(Cutouts, AModelTrainedWithTheAlphaTestLearnsTheHoles) {
  const Mesh masked = checkerboard_quad(AlphaMode::Mask), opaque = checkerboard_quad(AlphaMode::Opaque);
  const EvalMetrics cut = train_and_evaluate(masked, masked);
  const EvalMetrics solid = train_and_evaluate(opaque, masked);
  std::printf("alpha-tested training: accuracy %.4f, precision %.4f, recall %.4f, albedo MAE %.4f; opaque training: "
              "accuracy %.4f, precision %.4f, recall %.4f\n",
              cut.accuracy, cut.precision, cut.recall, cut.albedo_mae, solid.accuracy, solid.precision, solid.recall);
  // Measured (seed 11): 0.998 accuracy, 0.992 precision; the opaque model 0.872 and 0.501. Half the
  // quad is holes, so a model that learned the quad as solid hits them all: its precision is about
  // the opaque fraction of the quad's hits, 0.5, and its accuracy is what the rays that meet the
  // quad's holes cost it.
  EXPECT_GT(cut.accuracy, 0.98);
  EXPECT_GT(cut.precision, 0.95);
  EXPECT_GT(cut.recall, 0.95);
  EXPECT_LT(solid.precision, 0.6);
  EXPECT_GT(cut.accuracy, solid.accuracy + 0.08);
  // The albedo is the opaque texels' colour (60, 160, 40): learned on the surface that exists.
  EXPECT_LT(cut.albedo_mae, 0.05);
}

}  // namespace
}  // namespace lsnif
