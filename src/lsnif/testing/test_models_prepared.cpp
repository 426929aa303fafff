// test_models_prepared.cpp -- tiny_model of the portable build (the GPU check's test executables):
// loads the model prepared in LSNIF_TEST_MODELS (load_prepared_model). Never trains (no Embree here).
#include "lsnif/testing/test_models.h"

namespace lsnif::test {

Status tiny_model(const std::string& name, const Mesh& mesh, const TrainSettings& settings, Model& model) {
  const std::string dir = test_models_dir();
  if (dir.empty())
    return Status::error("test model %s: this portable test build trains no models; set LSNIF_TEST_MODELS to the "
                         "folder scripts/gpu-check.sh prepared", name.c_str());
  return load_prepared_model(dir, name, mesh, settings, model);
}

}  // namespace lsnif::test
