// cmd_bench.cpp -- `lsnif bench`: bench_run.h with the trainer, which trains each scene's models (or
// reuses the ones trained before from the same mesh with the same settings, model_cache.h).
#include <string>
#include <vector>

#include "lsnif/apps/lsnif/bench_run.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/model_cache.h"
#include "lsnif/format/numbers.h"

namespace lsnif::cli {

namespace {

bool describe_training(const TrainOptions& train, const std::string& out_dir, bool quick, std::string& text) {
  // to_settings wants an output name for the loss-curve path it derives; nothing is written under it.
  TrainOptions checked = train;
  checked.output = out_dir + "/model.lsnif";
  TrainSettings settings;
  if (!checked.to_settings(settings)) return false;
  text = (quick ? "--quick: " : "") + settings.describe();
  return true;
}

// BenchTrainer::train: per object of `bench`, its model of quality `preset` in `dir`.
int train_preset_models(const TrainOptions& topt, bool retrain, const BenchScene& bench, const std::string& preset,
                        const std::string& dir, std::vector<BenchModelRow>& rows) {
  for (const BenchObject& o : bench.objects) {
    BenchModelRow m;
    m.name = o.name;
    m.origin = o.origin;
    m.triangles = o.mesh.triangles.size();
    // The preset's values where the run does not set them itself (--quick keeps its tiny width).
    TrainOptions mo = topt;
    const Preset* quality = find_preset("quality", preset.c_str());
    for (uint32_t v = 0; quality && v < quality->count; ++v) {
      const PresetValue& pv = quality->values[v];
      if (!mo.given.given[size_t(pv.id)]) mo.given.set(pv.id, {.u = uint64_t(pv.value)});
    }
    mo.output = dir + "/" + bench_model_file(o.name, preset);
    CachedModel cached;
    if (int r = train_or_reuse("bench", o.mesh, object_fingerprint(o),
                               o.name + " (" + o.origin + ", " + preset + " quality)", mo, retrain, cached, preset))
      return r;
    m.reused = cached.reused;
    m.train_seconds = cached.train_seconds;
    rows.push_back(m);
  }
  return 0;
}

}  // namespace

int cmd_bench(int argc, char** argv) {
  static const BenchTrainer trainer = {describe_training, train_preset_models};
  return run_bench(argc, argv, &trainer);
}

}  // namespace lsnif::cli
