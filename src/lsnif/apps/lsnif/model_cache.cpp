// model_cache.cpp -- see model_cache.h.
#include "lsnif/apps/lsnif/model_cache.h"

#include <cstdio>
#include <fstream>
#include <sstream>

#include "lsnif/format/atomic_file.h"
#include "lsnif/renderer/scene_gltf.h"

namespace lsnif::cli {

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool write_text_file(const char* command, const std::string& path, const std::string& text) {
  const Status s = write_file_atomic(path, text);
  if (!s) std::fprintf(stderr, "lsnif %s: %s\n", command, s.message().c_str());
  return bool(s);
}

void add_bench_run_options(Args& args, BenchRunOptions* o) {
  args.option("width", "image width (0: 320, --quick 64)", &o->width);
  args.option("height", "image height (0: 240, --quick 48)", &o->height);
  args.option("spp", "samples per pixel (0: 16, --quick 2)", &o->spp);
  args.option("steps", "training steps (0: the default of lsnif train, --quick 30)", &o->steps);
  args.option("batch", "training rays per step (0: the default of lsnif train, --quick 1024)", &o->batch);
  args.option("seed", "training seed", &o->seed);
  args.option("threads", "training threads (0 = all cores)", &o->threads);
  args.flag("quick", "tiny models (V=16, 2^12-entry grid, 32-wide MLP, 30 steps) and tiny images: seconds, for tests",
            &o->quick);
  args.flag("retrain", "train every model even when a matching one exists", &o->retrain);
}

void apply_bench_run_options(const BenchRunOptions& o, TrainOptions& train, render::RenderSettings& rs) {
  rs.width = 320;
  rs.height = 240;
  rs.spp = 16;
  const auto set = [&train](SettingId id, uint64_t value) { train.given.set(id, {.u = value}); };
  if (o.quick) {
    set(SettingId::Voxels, 16);
    set(SettingId::ResMin, 32);
    set(SettingId::ResMax, 64);
    set(SettingId::TableLog2, 12);
    set(SettingId::Width, 32);
    set(SettingId::Steps, 30);
    set(SettingId::Batch, 1024);
    rs.width = 64;
    rs.height = 48;
    rs.spp = 2;
  }
  if (o.steps) set(SettingId::Steps, o.steps);
  if (o.batch) set(SettingId::Batch, o.batch);
  if (o.width) rs.width = o.width;
  if (o.height) rs.height = o.height;
  if (o.spp) rs.spp = o.spp;
  set(SettingId::Seed, o.seed);
  train.threads = o.threads;
}

int train_or_reuse(const char* command, const Mesh& mesh, const std::string& fingerprint, const std::string& label,
                   const TrainOptions& opts, bool retrain, CachedModel& out) {
  out = CachedModel();
  const std::string key_path = opts.output + ".key";
  TrainSettings ts;
  if (!opts.to_settings(ts)) return 2;
  const std::string key = "mesh " + fingerprint + "\nsettings " + ts.describe() + "\n";
  if (!retrain && scene::check_lsnif_file(opts.output) && read_text_file(key_path) == key) {
    out.reused = true;
    std::printf("model     reusing %s (same mesh and settings; --retrain trains it again)\n", opts.output.c_str());
    return 0;
  }
  std::printf("model     training %s for %s (%zu triangles)\n", opts.output.c_str(), label.c_str(),
              mesh.triangles.size());
  std::fflush(stdout);
  TrainReport rep;
  if (int r = train_mesh(mesh, label, opts, nullptr, &rep)) return r;
  if (!write_text_file(command, key_path, key)) {
    std::fprintf(stderr, "lsnif %s: cannot write %s\n", command, key_path.c_str());
    return 1;
  }
  out.train_seconds = rep.seconds;
  return 0;
}

}  // namespace lsnif::cli
