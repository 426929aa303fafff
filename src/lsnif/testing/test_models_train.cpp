// test_models_train.cpp -- tiny_model of the normal build: trains; with LSNIF_TEST_MODELS set, also
// saves NAME.lsnif and NAME.key there (scripts/gpu-check.sh prepares the portable tests' models so).
#include "lsnif/format/atomic_file.h"
#include "lsnif/testing/test_models.h"

namespace lsnif::test {

Status tiny_model(const std::string& name, const Mesh& mesh, const TrainSettings& settings, Model& model) {
  if (Status s = train_model(mesh, settings, model); !s) return s.context("test model " + name);
  const std::string dir = test_models_dir();
  if (dir.empty()) return Status::ok();
  if (Status s = save_model(model, dir + "/" + name + ".lsnif"); !s) return s.context("test model " + name);
  const std::string key = test_model_fingerprint(mesh, settings) + "\n";
  return write_file_atomic(dir + "/" + name + ".key", key.data(), key.size());
}

}  // namespace lsnif::test
