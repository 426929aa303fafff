// model_cache.h -- the models of the benchmarks `lsnif bench` and `lsnif bench-size`: train one, or
// reuse the one trained before from the same mesh with the same settings (their run options:
// bench_options.h). MODEL.lsnif is reused when it is a
// valid model and MODEL.lsnif.key beside it holds the mesh's fingerprint and the resolved training
// settings of this run.
#pragma once
#include <string>

#include "lsnif/apps/lsnif/bench_options.h"
#include "lsnif/import/mesh.h"
#include "lsnif/apps/lsnif/train_options.h"

namespace lsnif::cli {

struct CachedModel {
  bool reused = false;
  double train_seconds = 0;  // when trained
};

// Trains `mesh` (fingerprint: bench_scenes.h object_fingerprint or the like; label: how the summary
// names it) into opts.output unless `retrain` is false and a model of the same mesh and settings is
// there, and prints which happened. The key MODEL.lsnif.key holds the lines "mesh FINGERPRINT",
// "quality QUALITY" (when `quality` is not empty: the preset the model is for) and "settings JSON"
// (the resolved settings, settings_io.h's settings_to_json on one line), which a run of prepared
// models checks (bench_run.h). Returns the exit code (0 ok, 1 failure, 2 invalid options).
int train_or_reuse(const char* command, const Mesh& mesh, const std::string& fingerprint, const std::string& label,
                   const TrainOptions& opts, bool retrain, CachedModel& out, const std::string& quality = "");

}  // namespace lsnif::cli
