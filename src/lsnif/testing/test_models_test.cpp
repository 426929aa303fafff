// Tests of test_models.h, the seam between the GPU tests' trained models and the models the GPU check
// folder carries: with LSNIF_TEST_MODELS set, tiny_model (training build) saves NAME.lsnif and NAME.key;
// load_prepared_model (what the portable build calls) gives back the same bytes for the same mesh and
// settings, and refuses other settings, another mesh, a missing key and a corrupt model by name.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "lsnif/testing/test_models.h"
#include "lsnif/testing/test_support.h"

namespace lsnif::test {
namespace {

// A tetrahedron with corners at 0 and `size` on each axis: a mesh the trainer accepts in a few steps.
Mesh tetrahedron(float size) {
  Mesh m;
  m.positions = {{0, 0, 0}, {size, 0, 0}, {0, size, 0}, {0, 0, size}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  m.materials.resize(1);
  m.triangle_material.assign(4, 0);
  return m;
}

std::vector<uint8_t> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

TEST(TestModels, SavedWhenAskedAndLoadedBackOnlyForTheSameMeshAndSettings) {
  ScopedTestDir dir("lsnif_test_models_test");
  ASSERT_EQ(setenv("LSNIF_TEST_MODELS", dir.path("").c_str(), 1), 0);
  TrainSettings settings = tiny_train_settings();
  settings.steps = 5;
  const Mesh mesh = tetrahedron(1.0f);
  Model trained;
  const Status s = tiny_model("tetra", mesh, settings, trained);
  unsetenv("LSNIF_TEST_MODELS");
  ASSERT_TRUE(s) << s.message();
  std::vector<uint8_t> saved;
  ASSERT_TRUE(save_model_to_memory(trained, saved));
  EXPECT_EQ(file_bytes(dir.path("tetra.lsnif")), saved);

  Model loaded;
  Status l = load_prepared_model(dir.path(""), "tetra", mesh, settings, loaded);
  ASSERT_TRUE(l) << l.message();
  std::vector<uint8_t> again;
  ASSERT_TRUE(save_model_to_memory(loaded, again));
  EXPECT_EQ(again, saved);

  TrainSettings other = settings;
  other.steps = 6;
  l = load_prepared_model(dir.path(""), "tetra", mesh, other, loaded);
  ASSERT_FALSE(l);
  EXPECT_NE(l.message().find("other settings or another mesh"), std::string::npos) << l.message();
  EXPECT_NE(l.message().find("tetra"), std::string::npos) << l.message();
  other = settings;
  other.config.hidden_width = settings.config.hidden_width * 2;
  EXPECT_FALSE(load_prepared_model(dir.path(""), "tetra", mesh, other, loaded));
  EXPECT_FALSE(load_prepared_model(dir.path(""), "tetra", tetrahedron(1.5f), settings, loaded));

  l = load_prepared_model(dir.path(""), "missing", mesh, settings, loaded);
  ASSERT_FALSE(l);
  EXPECT_NE(l.message().find("missing.key not found"), std::string::npos) << l.message();

  std::vector<uint8_t> cut(saved.begin(), saved.begin() + long(saved.size() / 2));
  std::ofstream(dir.path("tetra.lsnif"), std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(cut.data()), std::streamsize(cut.size()));
  l = load_prepared_model(dir.path(""), "tetra", mesh, settings, loaded);
  ASSERT_FALSE(l);
  EXPECT_NE(l.message().find("test model tetra"), std::string::npos) << l.message();
}

}  // namespace
}  // namespace lsnif::test
