// test_models.h -- the GPU tests' trained models, by name (tiny_model: test_models_train.cpp or
// test_models_prepared.cpp, the rest inline). In the test executables of the normal build, tiny_model
// trains (Embree ground truth, lsnif_train); in the portable ones of the GPU check
// (executables with the CMake property LSNIF_PORTABLE: no Embree on the machine that runs them) it
// loads the model prepared for the same name, mesh and settings from the folder named by the
// environment variable LSNIF_TEST_MODELS. A training build with LSNIF_TEST_MODELS set also saves
// every model it trains there: that is how scripts/gpu-check.sh prepares them.
// Each model NAME is NAME.lsnif beside NAME.key (test_model_fingerprint): a prepared model of other
// settings or another mesh is refused, never used.
#pragma once
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "lsnif/core/model.h"
#include "lsnif/format/status.h"
#include "lsnif/import/mesh.h"
#include "lsnif/train/trainer.h"

namespace lsnif::test {

// The folder of LSNIF_TEST_MODELS ("" when unset or empty).
inline std::string test_models_dir() {
  const char* dir = std::getenv("LSNIF_TEST_MODELS");
  return dir && *dir ? dir : "";
}

// What a model of `mesh` trained with `settings` depends on, as one line of text: the model
// configuration, steps, batch, seed, indexed levels, texture coordinates and an FNV-1a hash of the
// mesh's positions and triangles. (From the settings' fields, not TrainSettings::describe, which lives with the trainer.)
inline std::string test_model_fingerprint(const Mesh& mesh, const TrainSettings& settings) {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* data, size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  };
  mix(mesh.positions.data(), mesh.positions.size() * sizeof(mesh.positions[0]));
  mix(mesh.triangles.data(), mesh.triangles.size() * sizeof(mesh.triangles[0]));
  std::string indexed;
  for (bool b : settings.indexed) indexed += b ? '1' : '0';
  char line[192];
  std::snprintf(line, sizeof line, " | steps=%u batch=%u seed=%llu indexed=%s uv=%u/%u | mesh %zu/%zu fnv1a=%016llx",
                settings.steps, settings.batch_size, (unsigned long long)settings.seed, indexed.c_str(),
                settings.texture_coordinates, settings.uv_cells, mesh.positions.size(), mesh.triangles.size(),
                (unsigned long long)h);
  return settings.config.describe() + line;
}

// Loads the model `name` prepared in `dir` (NAME.lsnif) after checking that NAME.key holds the
// fingerprint of `mesh` and `settings`; an error names the model and what is missing or different.
inline Status load_prepared_model(const std::string& dir, const std::string& name, const Mesh& mesh,
                                  const TrainSettings& settings, Model& model) {
  const std::string key_path = dir + "/" + name + ".key";
  std::ifstream f(key_path);
  if (!f) return Status::error("test model %s: %s not found (prepare the models with scripts/gpu-check.sh)",
                               name.c_str(), key_path.c_str());
  std::stringstream held;
  held << f.rdbuf();
  const std::string want = test_model_fingerprint(mesh, settings) + "\n";
  if (held.str() != want)
    return Status::error("test model %s: %s was prepared for other settings or another mesh (held '%s', this test "
                         "wants '%s'); prepare the models again with scripts/gpu-check.sh", name.c_str(),
                         key_path.c_str(), held.str().c_str(), want.c_str());
  if (Status s = load_model(dir + "/" + name + ".lsnif", model); !s) return s.context("test model " + name);
  return Status::ok();
}

// The model `name` (a file-name stem unique among the tests, e.g. "render_test.elephant") of `mesh`
// with `settings`: trained, or in a portable build loaded as the file comment says. An error names
// the model and what is missing.
Status tiny_model(const std::string& name, const Mesh& mesh, const TrainSettings& settings, Model& model);

}  // namespace lsnif::test
