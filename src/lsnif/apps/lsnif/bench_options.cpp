// bench_options.cpp -- see bench_options.h.
#include "lsnif/apps/lsnif/bench_options.h"

#include <cstdio>

#include "lsnif/format/atomic_file.h"
#include "lsnif/format/file_io.h"

namespace lsnif::cli {

std::string model_key_head(const std::string& fingerprint, const std::string& quality) {
  return "mesh " + fingerprint + "\n" + (quality.empty() ? "" : "quality " + quality + "\n");
}

bool file_holds(const std::string& path, const std::string& text) {
  std::string bytes;
  return read_file(path, bytes, text.size()) && bytes == text;
}

bool write_text_file(const char* command, const std::string& path, const std::string& text) {
  const Status s = write_file_atomic(path, text);
  if (!s) std::fprintf(stderr, "lsnif %s: %s\n", command, s.message().c_str());
  return bool(s);
}

namespace {

// The images of --quick.
constexpr uint32_t kQuickWidth = 64, kQuickHeight = 48, kQuickSpp = 2;
// --quick's training steps: the tiny preset's 30 leave its network predicting no hit at all
// (bunny: occlusion recall 0%, so every quality preset rendered the same image); at 200 (~0.8 s on
// bunny, 2 cores) it sees the object (recall 90%, occlusion accuracy 96%).
constexpr uint32_t kQuickSteps = 200;

// A number of the tiny preset (--quick's models).
uint32_t tiny_value(SettingId id) { return static_cast<uint32_t>(preset_value(kTinyPreset, id)); }

}  // namespace

void add_bench_run_options(Args& args, BenchRunOptions* o) {
  using render::kDefaultImageHeight, render::kDefaultImageWidth, render::kDefaultSpp;
  args.option("width", format("image width (0: %u, --quick %u)", kDefaultImageWidth, kQuickWidth), &o->width, 0,
              kMaxImageSide);
  args.option("height", format("image height (0: %u, --quick %u)", kDefaultImageHeight, kQuickHeight), &o->height, 0,
              kMaxImageSide);
  args.option("spp", format("samples per pixel (0: %u, --quick %u)", kDefaultSpp, kQuickSpp), &o->spp, 0, kMaxSpp);
  const uint32_t quick_steps = kQuickSteps, quick_batch = tiny_value(SettingId::Batch);
  args.option("steps", format("training steps (0: the default of lsnif train, --quick %u)", quick_steps), &o->steps, 0,
              uint32_t(setting_def(SettingId::Steps).max));
  args.option("batch", format("training rays per step (0: the default of lsnif train, --quick %u)", quick_batch),
              &o->batch, 0, uint32_t(setting_def(SettingId::Batch).max));
  args.option("seed", "training seed", &o->seed, 0, UINT64_MAX);
  args.option("threads", "training threads (0 = all cores)", &o->threads, 0, kMaxThreads);
  args.flag("quick",
            format("tiny models (V=%u, 2^%u-entry grid, %u-wide MLP, %u steps) and tiny images: seconds, for tests",
                   tiny_value(SettingId::Voxels), tiny_value(SettingId::TableLog2), tiny_value(SettingId::Width),
                   quick_steps),
            &o->quick);
  args.flag("retrain", "train every model even when a matching one exists", &o->retrain);
}

void apply_bench_run_options(const BenchRunOptions& o, TrainOptions& train, render::RenderSettings& rs) {
  rs.width = render::kDefaultImageWidth;
  rs.height = render::kDefaultImageHeight;
  rs.spp = render::kDefaultSpp;
  const auto set = [&train](SettingId id, uint64_t value) { train.given.set(id, {.u = value}); };
  if (o.quick) {
    // The tiny preset's values as given values, not the preset itself: --steps and --batch override
    // them, and cmd_bench's quality presets fill in only the settings they leave alone.
    for (uint32_t k = 0; k < kTinyPreset.count; ++k) {
      const SettingDef& d = setting_def(kTinyPreset.values[k].id);
      train.given.set(d.id, setting_value(d, kTinyPreset.values[k].value));
    }
    set(SettingId::Steps, kQuickSteps);
    rs.width = kQuickWidth;
    rs.height = kQuickHeight;
    rs.spp = kQuickSpp;
  }
  if (o.steps) set(SettingId::Steps, o.steps);
  if (o.batch) set(SettingId::Batch, o.batch);
  if (o.width) rs.width = o.width;
  if (o.height) rs.height = o.height;
  if (o.spp) rs.spp = o.spp;
  set(SettingId::Seed, o.seed);
  train.threads = o.threads;
}

}  // namespace lsnif::cli
