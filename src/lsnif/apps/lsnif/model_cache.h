// model_cache.h -- what the benchmarks `lsnif bench` and `lsnif bench-size` share: their run
// options (image size, training length, --quick), and their models: train one, or reuse the one
// trained before from the same mesh with the same settings. MODEL.lsnif is reused when it is a
// valid model and MODEL.lsnif.key beside it holds the mesh's fingerprint and the resolved training
// settings of this run.
#pragma once
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/import/mesh.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/apps/lsnif/train_options.h"

namespace lsnif::cli {

// True when the file at `path` holds exactly `text` (a file that cannot be read holds nothing;
// nothing longer than `text` is read).
bool file_holds(const std::string& path, const std::string& text);
// Writes `text` atomically; on failure prints "lsnif COMMAND: why" and returns false.
bool write_text_file(const char* command, const std::string& path, const std::string& text);

// The options of a benchmark run (0: the default, or --quick's).
struct BenchRunOptions {
  uint32_t width = 0, height = 0, spp = 0, steps = 0, batch = 0, threads = 0;
  uint64_t seed = 1;
  bool quick = false, retrain = false;
};

// Registers --width --height --spp --steps --batch --seed --threads --quick --retrain.
void add_bench_run_options(Args& args, BenchRunOptions* options);

// Applies them: the default image (render_defaults.h) and the default training, or with --quick the
// models of the tiny preset (settings_table.h kTinyPreset, as given values) and 64x48 images at
// 2 spp; then the values given. Sets the seed and threads of `train`.
void apply_bench_run_options(const BenchRunOptions& options, TrainOptions& train, render::RenderSettings& rs);

struct CachedModel {
  bool reused = false;
  double train_seconds = 0;  // when trained
};

// Trains `mesh` (fingerprint: bench_scenes.h object_fingerprint or the like; label: how the summary
// names it) into opts.output unless `retrain` is false and a model of the same mesh and settings is
// there, and prints which happened. Returns the exit code (0 ok, 1 failure, 2 invalid options).
int train_or_reuse(const char* command, const Mesh& mesh, const std::string& fingerprint, const std::string& label,
                   const TrainOptions& opts, bool retrain, CachedModel& out);

}  // namespace lsnif::cli
