// bench_run.h -- `lsnif bench` without the training: scenes, renders and the report (bench_run.cpp),
// with the models of each scene from a BenchTrainer (cmd_bench.cpp: trains them, lsnif_train and
// Embree) or, with --models DIR, copied from a folder of models prepared before (a previous
// `lsnif bench --out DIR`, e.g. with --no-render). The GPU check's `lsnif-gpu bench` has no trainer:
// it needs --models, and links no training code.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/apps/lsnif/bench_options.h"
#include "lsnif/apps/lsnif/bench_scenes.h"

namespace lsnif::cli {

// A scene's model of one quality preset, as the report lists it.
struct BenchModelRow {
  std::string name, origin;
  uint64_t triangles = 0;
  bool reused = false;        // reused from an earlier run (or copied from --models)
  double train_seconds = 0;   // when trained
};

// The model file of `object` for quality `preset` (default: `lsnif train`'s defaults; high, low:
// Table 1's H and L networks, `lsnif train --quality high|low`): OBJECT.lsnif for default,
// OBJECT.PRESET.lsnif otherwise.
std::string bench_model_file(const std::string& object, const std::string& preset);

// How `lsnif bench` trains.
struct BenchTrainer {
  // Checks the training options (`train`, as apply_bench_run_options set them; models are written
  // under `out_dir`) and describes them for results.md; false (message printed) when invalid.
  bool (*describe)(const TrainOptions& train, const std::string& out_dir, bool quick, std::string& text);
  // Trains (or, unless `retrain`, reuses) the models of `scene` for quality `preset` into `dir`
  // (bench_model_file names) and appends their rows. Returns the exit code (0 ok).
  int (*train)(const TrainOptions& train, bool retrain, const BenchScene& scene, const std::string& preset,
               const std::string& dir, std::vector<BenchModelRow>& rows);
};

// `lsnif bench` on `argc`/`argv` (the arguments after the command name). Without a trainer, --models
// is required. Returns the exit code (0 ok, 1 failure, 2 usage error).
int run_bench(int argc, char** argv, const BenchTrainer* trainer);

}  // namespace lsnif::cli
