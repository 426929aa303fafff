// bench_options.h -- what the benchmarks `lsnif bench` and `lsnif bench-size` share besides their
// models (model_cache.h): their run options (image size, training length, --quick) and small text
// files (the reuse keys beside models and scenes). No training code: `lsnif-gpu bench` links it.
#pragma once
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/train_options.h"
#include "lsnif/renderer/renderer.h"

namespace lsnif::cli {

// True when the file at `path` holds exactly `text` (a file that cannot be read holds nothing;
// nothing longer than `text` is read).
bool file_holds(const std::string& path, const std::string& text);
// Writes `text` atomically; on failure prints "lsnif COMMAND: why" and returns false.
bool write_text_file(const char* command, const std::string& path, const std::string& text);

// The head of a benchmark model's key (MODEL.lsnif.key, model_cache.h): "mesh FINGERPRINT", then
// "quality QUALITY" when `quality` is not empty, a line each; the key's "settings JSON" line follows.
std::string model_key_head(const std::string& fingerprint, const std::string& quality);

// The options of a benchmark run (0: the default, or --quick's).
struct BenchRunOptions {
  uint32_t width = 0, height = 0, spp = 0, steps = 0, batch = 0, threads = 0;
  uint64_t seed = 1;
  bool quick = false, retrain = false;
};

// Registers --width --height --spp --steps --batch --seed --threads --quick --retrain.
void add_bench_run_options(Args& args, BenchRunOptions* options);

// Applies them (to the fields of `train`, none of its functions): the default image (render_defaults.h) and the default training, or with --quick the
// models of the tiny preset (settings_table.h kTinyPreset, as given values) trained 200 steps, and 64x48 images at
// 2 spp; then the values given. Sets the seed and threads of `train`.
void apply_bench_run_options(const BenchRunOptions& options, TrainOptions& train, render::RenderSettings& rs);

}  // namespace lsnif::cli
