// lsnif bench-size [MESH...]: the size/quality curve of LSNIF models. For each mesh (bunny,
// armadillo, dragon: bench_scenes.h) and each setting of --settings (model settings on top of the
// defaults), train a model (or reuse the one trained from the same mesh with the same settings),
// and report its file bytes, `lsnif eval`'s metrics (src/lsnif/train/evaluate.h) and the LDR-FLIP of a
// render against the triangle reference (render_compare.h); then, per setting, the memory ratio of
// the `heavy` scene's triangle BLASes (~3M triangles) to that many LSNIF models of the setting.
// Writes OUT/results.md and OUT/MESH-SETTING.png (reference | LSNIF | FLIP).
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/bench_scenes.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/data_dir.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/apps/lsnif/model_cache.h"
#include "lsnif/core/model.h"
#include "lsnif/apps/lsnif/pipeline_option.h"
#include "lsnif/apps/lsnif/render_compare.h"
#include "lsnif/apps/lsnif/report_text.h"
#include "lsnif/apps/lsnif/train_options.h"
#include "lsnif/vulkan/raytracing.h"

namespace lsnif::cli {

namespace {

namespace fs = std::filesystem;

// Named points of the curve; any other entry of --settings is NAME=VALUE pairs joined by '+'. They
// pin the hidden width, so that they mean the same whatever the default is ("default" alone is
// `lsnif train`'s defaults: 8-bit, the coarse level indexed, W=128).
struct NamedSetting {
  const char* name;
  const char* values;
};
const NamedSetting kNamedSettings[] = {
    {"default", ""},
    // The paper's model: both levels hashed into 2^17 fp16 entries, 2x128 (the default before b8-i0).
    {"fp16-hashed", "grid-bits=16+width=128+indexed=0"},
    {"b8", "grid-bits=8+width=128+indexed=0"},
    {"b8-m16", "grid-bits=8+width=128+indexed=0+table-log2=16"},
    {"b8-m16-w64", "grid-bits=8+width=64+indexed=0+table-log2=16"},
    // Per-level table sizes: the coarse level (R=64) needs far fewer entries than the fine one.
    {"b8-m15-17", "grid-bits=8+width=128+indexed=0+table-log2=15,17"},
    {"b8-m16-17", "grid-bits=8+width=128+indexed=0+table-log2=16,17"},
    // The coarse level indexed: every vertex it can read has its own entry (no collisions), and the
    // table has as many entries as the mesh needs.
    {"b8-i0", "grid-bits=8+width=128+indexed=1,0"},
    {"b8-i0-m16", "grid-bits=8+width=128+table-log2=16+indexed=1,0"},
    {"b8-i0-m15", "grid-bits=8+width=128+table-log2=15+indexed=1,0"},
    // The network's cost with the indexed grid: hidden width W, boundary points H, hidden layers.
    {"b8-i0-w96", "grid-bits=8+width=96+indexed=1,0"},
    {"b8-i0-w96-h14", "grid-bits=8+width=96+points=14+indexed=1,0"},
    {"b8-i0-w64", "grid-bits=8+width=64+indexed=1,0"},
    {"b8-i0-w64-h14", "grid-bits=8+width=64+points=14+indexed=1,0"},
    {"b8-i0-w32", "grid-bits=8+width=32+indexed=1,0"},
    {"b8-i0-h10", "grid-bits=8+width=128+points=10+indexed=1,0"},
    {"b8-i0-l1", "grid-bits=8+width=128+layers=1+indexed=1,0"},
};
// The former default (the paper's model), the paper's network on the default grid, the default.
constexpr const char* kDefaultSettings = "fp16-hashed,b8-i0,default";
// mlp_flops_per_evaluation of the paper's network (H=18, L=2, F=3, W=128x2, one material).
constexpr uint64_t kPaperFlopsPerEvaluation = 62720;

struct SizeSetting {
  std::string name;    // as given (a named setting or the pairs themselves): file names, table rows
  std::string values;  // "NAME=VALUE+..." ("" = the defaults)
  SettingLayer layer;  // the values, parsed
};

// One entry of --settings; false (message printed) on an unknown name, a malformed pair, an
// unknown setting or a value that is not of its kind. Ranges are checked when resolved.
bool parse_setting(const std::string& entry, SizeSetting& out) {
  out = SizeSetting();
  out.name = entry;
  bool named = false;
  for (const NamedSetting& n : kNamedSettings)
    if (entry == n.name) named = true, out.values = n.values;
  if (!named) {
    if (entry.find('=') == std::string::npos) {
      std::string names;
      for (const NamedSetting& n : kNamedSettings) names += (names.empty() ? "" : ", ") + std::string(n.name);
      std::fprintf(stderr, "lsnif bench-size: unknown setting '%s' in --settings (named ones: %s; or NAME=VALUE "
                           "pairs joined by '+', e.g. grid-bits=8+table-log2=15)\n", printable(entry).c_str(),
                   names.c_str());
      return false;
    }
    out.values = entry;
  }
  size_t at = 0;
  while (at < out.values.size()) {
    size_t plus = out.values.find('+', at);
    if (plus == std::string::npos) plus = out.values.size();
    const std::string pair = out.values.substr(at, plus - at);
    const size_t eq = pair.find('=');
    const std::string key = eq == std::string::npos ? pair : pair.substr(0, eq);
    const SettingDef* d = eq == std::string::npos ? nullptr : find_setting(key);
    if (eq == std::string::npos || eq + 1 == pair.size() || plus + 1 == out.values.size()) {
      std::fprintf(stderr, "lsnif bench-size: malformed '%s' in --settings entry '%s' (NAME=VALUE expected)\n",
                   printable(pair).c_str(), printable(entry).c_str());
      return false;
    }
    if (!d) {
      std::fprintf(stderr, "lsnif bench-size: unknown setting '%s' in --settings entry '%s' (the names of "
                           "`lsnif train`'s options)\n", printable(key).c_str(), printable(entry).c_str());
      return false;
    }
    if (std::string why = set_setting_text(out.layer, *d, pair.substr(eq + 1)); !why.empty()) {
      std::fprintf(stderr, "lsnif bench-size: invalid value '%s' for %s in --settings entry '%s': %s\n",
                   printable(pair.substr(eq + 1)).c_str(), d->name, printable(entry).c_str(), why.c_str());
      return false;
    }
    at = plus + 1;
  }
  return true;
}

// Comma-separated entries, each once, in order. A piece of digits alone continues the list value
// that ends the entry before it (`table-log2=15,17`): no setting name or pair is only digits.
bool parse_settings(const std::string& text, std::vector<SizeSetting>& out) {
  out.clear();
  std::vector<std::string> entries;
  size_t at = 0;
  while (at <= text.size()) {
    size_t comma = text.find(',', at);
    if (comma == std::string::npos) comma = text.size();
    const std::string piece = text.substr(at, comma - at);
    const bool digits = !piece.empty() && piece.find_first_not_of("0123456789") == std::string::npos;
    if (digits && !entries.empty() && entries.back().find('=') != std::string::npos &&
        std::isdigit(static_cast<unsigned char>(entries.back().back())))
      entries.back() += "," + piece;
    else
      entries.push_back(piece);
    at = comma + 1;
  }
  for (const std::string& entry : entries) {
    if (entry.empty()) {
      std::fprintf(stderr, "lsnif bench-size: empty entry in --settings '%s'\n", printable(text).c_str());
      return false;
    }
    SizeSetting s;
    if (!parse_setting(entry, s)) return false;
    for (const SizeSetting& o : out)
      if (o.name == s.name) {
        std::fprintf(stderr, "lsnif bench-size: '%s' appears twice in --settings\n", printable(entry).c_str());
        return false;
      }
    out.push_back(std::move(s));
  }
  return true;
}

struct SizeRow {
  std::string mesh, setting, image;
  uint64_t model_bytes = 0;   // the .lsnif file
  uint64_t device_bytes = 0;  // on the device: model block + AABB BLAS (the renderer's statistics)
  uint64_t flops = 0;         // per network evaluation (mlp_flops_per_evaluation)
  EvalMetrics eval;
  double flip_mean = 0;
  CachedModel cached;
};

// Per setting: the heavy scene's triangle BLASes against as many LSNIF models of the setting.
struct HeavyRow {
  std::string setting;
  // One model of the setting: the largest measured (equal for every mesh unless a level is indexed,
  // whose table is sized to the mesh).
  uint64_t device_bytes = 0;
  uint64_t models = 0, triangles = 0, blas_bytes = 0;
  double ratio() const { return device_bytes ? double(blas_bytes) / double(models * device_bytes) : 0.0; }
};



// The row of the first setting (the baseline) for `mesh`.
const SizeRow& baseline_row(const std::vector<SizeRow>& rows, const std::string& mesh) {
  for (const SizeRow& r : rows)
    if (r.mesh == mesh) return r;
  return rows.front();
}

std::string size_table(const std::vector<SizeRow>& rows) {
  std::string t =
      "| mesh | setting | model bytes | smaller than the first setting | kFLOP per evaluation | of the paper's | "
      "occlusion acc | t err median | normal err median (deg) | FLIP mean | FLIP - first setting's |\n"
      "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const SizeRow& r : rows) {
    const SizeRow& b = baseline_row(rows, r.mesh);
    t += format("| %s | %s | %s | %.2fx | %.1f | %.0f%% | %.2f%% | %.3f%% | %.2f | %.4f | %+.4f |\n", r.mesh.c_str(),
                r.setting.c_str(), grouped(r.model_bytes).c_str(),
                r.model_bytes ? double(b.model_bytes) / double(r.model_bytes) : 0.0, 1e-3 * double(r.flops),
                100.0 * double(r.flops) / double(kPaperFlopsPerEvaluation), 100.0 * r.eval.accuracy,
                100.0 * r.eval.t_error_median, r.eval.normal_error_median, r.flip_mean, r.flip_mean - b.flip_mean);
  }
  return t;
}

std::string heavy_table(const std::vector<HeavyRow>& rows) {
  std::string t = "| setting | LSNIF per model (device bytes) | triangles | triangle BLAS (MiB) | BLAS / one model | "
                  "BLAS / the scene's models |\n|---|---:|---:|---:|---:|---:|\n";
  for (const HeavyRow& h : rows)
    if (!h.device_bytes)  // no model of the setting measured yet (an interrupted run)
      t += format("| %s | - | %s | %.2f | - | - |\n", h.setting.c_str(), grouped(h.triangles).c_str(), mib(h.blas_bytes));
    else
      t += format("| %s | %s | %s | %.2f | %.1f | %.1f (%llu models) |\n", h.setting.c_str(),
                grouped(h.device_bytes).c_str(), grouped(h.triangles).c_str(), mib(h.blas_bytes),
                h.device_bytes ? double(h.blas_bytes) / double(h.device_bytes) : 0.0, h.ratio(),
                static_cast<unsigned long long>(h.models));
  return t;
}

std::vector<HeavyRow> heavy_table_rows(const BenchScene& heavy, uint64_t heavy_blas,
                                       const std::vector<SizeSetting>& settings, const std::vector<SizeRow>& rows) {
  std::vector<HeavyRow> out;
  for (const SizeSetting& setting : settings) {
    HeavyRow h;
    h.setting = setting.name;
    h.triangles = object_triangles(heavy);
    h.blas_bytes = heavy_blas;
    for (const BenchObject& o : heavy.objects) h.models += o.placements.empty() ? 0 : 1;
    for (const SizeRow& r : rows)
      if (r.setting == setting.name) h.device_bytes = std::max(h.device_bytes, r.device_bytes);
    out.push_back(h);
  }
  return out;
}

std::string results_markdown(const std::vector<SizeRow>& rows, const std::vector<HeavyRow>& heavy,
                             const std::vector<SizeSetting>& settings, const render::RenderSettings& rs,
                             size_t eval_rays, const std::string& device, const std::string& training) {
  std::string md = "# lsnif bench-size: model size against quality\n\n";
  md += format("Device: %s. Training: %s. Eval: %zu held-out rays. Images %ux%u, %u samples per pixel, %u bounces.\n\n",
               device.c_str(), training.c_str(), eval_rays, rs.width, rs.height, rs.spp, rs.max_bounces);
  md += "Settings (on top of the training above):\n\n";
  for (const SizeSetting& s : settings)
    md += format("- %s: %s\n", s.name.c_str(), s.values.empty() ? "(none)" : s.values.c_str());
  md += "\n";
  md += size_table(rows);
  md += "\nModel bytes: the .lsnif file. Occlusion accuracy, t error (of the AABB diagonal) and normal error: "
        "`lsnif eval`'s. kFLOP per evaluation: 2 x the multiply-adds of the network's layers (the paper's "
        "network: 62.7). FLIP: mean LDR-FLIP of the LSNIF render against the triangle reference (same random "
        "numbers); the last column subtracts the first setting's on the same mesh.\n";
  md += "\n## Memory at ~3M triangles (the `heavy` scene)\n\n";
  md += heavy_table(heavy);
  md += "\nTriangle BLAS: the driver's accelerationStructureSize (PREFER_FAST_TRACE) of the heavy scene's "
        "subdivided meshes (one BLAS per mesh). LSNIF per model: the device memory (model block + AABB BLAS) "
        "that the renderer measured for this setting's models (equal for every mesh, except with an indexed "
        "level, whose table is sized to its mesh: then the largest of the meshes run). BLAS / one model: the "
        "~3M triangles against a single model (as `lsnif bench-memory` compares one mesh with one model); "
        "the scene's models: one per mesh, as `lsnif bench` counts them.\n";
  md += "\n## Models and images\n\n| mesh | setting | model | training | image |\n|---|---|---|---|---|\n";
  for (const SizeRow& r : rows) {
    const std::string how = r.cached.reused ? "reused (same mesh and settings)" : format("%.0f s", r.cached.train_seconds);
    md += format("| %s | %s | %s/%s.lsnif | %s | ![%s %s](%s) |\n", r.mesh.c_str(), r.setting.c_str(), r.mesh.c_str(),
                 r.setting.c_str(), how.c_str(), r.mesh.c_str(), r.setting.c_str(), r.image.c_str());
  }
  return md;
}

// The command line as given, then as checked (pipeline, settings, meshes).
struct SizeCommand {
  std::vector<std::string> names;
  std::string out_dir = "out/bench-size", data_dir = default_data_dir(), device, pipeline_name = "inline";
  std::string settings_text = kDefaultSettings;
  BenchRunOptions run;
  uint32_t rays = 0;
  std::string known;  // the meshes' names, for the help and messages
  render::PathPipeline pipeline{};
  std::vector<SizeSetting> settings;
  std::vector<std::string> meshes;
};

// Reads the options into `cmd`; the exit code when the command ends here (help, a bad option).
std::optional<int> parse_command_line(int argc, char** argv, SizeCommand& cmd) {
  std::string named;
  for (const NamedSetting& n : kNamedSettings)
    named += format("%s%s (%s)", named.empty() ? "" : ", ", n.name, *n.values ? n.values : "the defaults");
  Args args("bench-size",
            "The size/quality curve of LSNIF models: for each mesh and each setting of --settings, trains a\n"
            "model into OUT/MESH/SETTING.lsnif (reused when the mesh and settings are unchanged), evaluates it\n"
            "like `lsnif eval`, renders it against the triangle reference (FLIP), and writes OUT/results.md:\n"
            "model bytes, eval metrics and FLIP per mesh and setting, and per setting the triangle BLAS of the\n"
            "`heavy` scene (~3M triangles) over its LSNIF models' device memory.");
  for (const std::string& n : bench_mesh_names()) cmd.known += (cmd.known.empty() ? "" : ", ") + n;
  args.rest("MESH", "meshes to run: " + cmd.known + " (default: all)", &cmd.names);
  args.option("settings", "comma-separated settings, the first being the baseline of the ratios: named ones, " +
              named + ", or NAME=VALUE pairs of `lsnif train` options joined by '+' (a list value such as "
              "table-log2=15,17 keeps its commas)", &cmd.settings_text);
  args.option("out", "output folder", &cmd.out_dir);
  args.option("data", "folder with meshes/ and hdr/ from scripts/setup.sh", &cmd.data_dir);
  args.option("rays", "held-out eval rays (0: 100000, --quick 4000)", &cmd.rays, 0, kMaxEvalRays);
  add_bench_run_options(args, &cmd.run);
  args.option("pipeline", "inline or wavefront (docs/renderer.md): the pipeline of the renders (the same estimator)",
              &cmd.pipeline_name);
  add_device_option(args, &cmd.device);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  return std::nullopt;
}

// Checks --pipeline, --settings and the mesh names into cmd.pipeline, cmd.settings and cmd.meshes
// (each once, in order); false (message printed) on an invalid one.
bool check_choices(SizeCommand& cmd) {
  if (!parse_pipeline_option("bench-size", cmd.pipeline_name, cmd.pipeline)) return false;
  if (!parse_settings(cmd.settings_text, cmd.settings)) return false;
  if (cmd.names.empty()) cmd.names = bench_mesh_names();
  for (const std::string& n : cmd.names) {
    if (std::find(bench_mesh_names().begin(), bench_mesh_names().end(), n) == bench_mesh_names().end()) {
      std::fprintf(stderr, "lsnif bench-size: unknown mesh '%s' (meshes: %s)\n", printable(n).c_str(),
                   cmd.known.c_str());
      return false;
    }
    if (std::find(cmd.meshes.begin(), cmd.meshes.end(), n) == cmd.meshes.end()) cmd.meshes.push_back(n);
  }
  return true;
}

// True when the data folder holds every input file of the heavy scene and the meshes; else prints
// what is missing.
bool check_inputs(const SizeCommand& cmd) {
  if (!check_data_dir("bench-size", cmd.data_dir)) return false;
  std::vector<std::string> inputs = bench_scene_inputs("heavy", cmd.data_dir);
  for (const std::string& n : cmd.meshes) {
    const std::vector<std::string> more = bench_mesh_inputs(n, cmd.data_dir);
    inputs.insert(inputs.end(), more.begin(), more.end());
  }
  for (const std::string& f : inputs)
    if (!fs::is_regular_file(f)) {
      std::fprintf(stderr, "lsnif bench-size: %s not found: run scripts/setup.sh first (it fetches the meshes and HDR "
                           "environments)\n", f.c_str());
      return false;
    }
  return true;
}

// Every setting's options: `base` with the setting's values, checked (ranges, combinations) before
// any work; false (message printed) on an invalid one.
bool setting_options(const SizeCommand& cmd, const TrainOptions& base, std::vector<TrainOptions>& options) {
  for (const SizeSetting& s : cmd.settings) {
    TrainOptions o = base;
    for (size_t i = 0; i < kSettingCount; ++i)
      if (s.layer.given[i]) {
        const SettingId id = static_cast<SettingId>(i);
        o.given.set(id, s.layer.values[id], s.layer.choice[i]);
      }
    o.output = (fs::path(cmd.out_dir) / "model.lsnif").string();
    TrainSettings ts;
    if (!o.to_settings(ts)) {
      std::fprintf(stderr, "lsnif bench-size: (in --settings entry '%s')\n", printable(s.name).c_str());
      return false;
    }
    options.push_back(std::move(o));
  }
  return true;
}

// Creates the output folder; false (message printed) when it cannot.
bool create_output_folder(const SizeCommand& cmd) {
  std::error_code ec;
  fs::create_directories(cmd.out_dir, ec);
  if (ec || !fs::is_directory(cmd.out_dir)) {
    std::fprintf(stderr, "lsnif bench-size: cannot create the output folder %s: %s\n", cmd.out_dir.c_str(),
                 ec ? ec.message().c_str() : "not a folder");
    return false;
  }
  return true;
}

// Initializes `ctx` for the pipeline; false (message printed) when no device can run it.
bool init_device(const SizeCommand& cmd, vk::Context& ctx) {
  if (Status s = ctx.init(render::context_options(/*validation=*/false, cmd.device)); !s) {
    std::fprintf(stderr, "lsnif bench-size: no usable Vulkan ray-tracing device (`lsnif devices` tells what is "
                         "missing): %s\n", s.message().c_str());
    return false;
  }
  return true;
}

// Builds the heavy scene into `heavy` and sums its triangle BLAS sizes into `heavy_blas`; false
// (message printed) on failure.
bool measure_heavy_blas(vk::Context& ctx, const SizeCommand& cmd, BenchScene& heavy, uint64_t& heavy_blas) {
  // The heavy scene's meshes (subdivided as `lsnif bench` builds them): their triangle BLAS sizes.
  std::printf("\n== the heavy scene's triangle BLASes\n");
  std::fflush(stdout);
  vk::RayTracer rt(ctx);
  Status hs = make_bench_scene("heavy", cmd.data_dir, heavy);
  if (hs) hs = rt.init();
  heavy_blas = 0;
  for (size_t i = 0; hs && i < heavy.objects.size(); ++i) {
    const Mesh& m = heavy.objects[i].mesh;
    vk::BlasSizes sizes;
    hs = rt.triangle_blas_sizes(uint32_t(m.positions.size()), uint32_t(m.triangles.size()),
                               VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR, sizes);
    heavy_blas += sizes.acceleration_structure * heavy.objects[i].placements.size();
  }
  if (!hs) {
    std::fprintf(stderr, "lsnif bench-size: heavy scene: %s\n", hs.message().c_str());
    return false;
  }
  return true;
}

// What the measurements share.
struct SizeBench {
  vk::Context& ctx;
  const SizeCommand& cmd;
  const std::vector<TrainOptions>& options;  // per setting
  const render::RenderSettings& rs;
  const EvalSettings& es;
  const BenchScene& heavy;
  uint64_t heavy_blas;   // the heavy scene's triangle BLAS bytes
  std::string training;  // the base training, described
  fs::path results;      // OUT/results.md
};

// Writes results.md from the rows measured so far; false (message printed) when it cannot.
bool write_results(const SizeBench& b, const std::vector<SizeRow>& rows) {
  return write_text_file("bench-size", b.results.string(),
                         results_markdown(rows, heavy_table_rows(b.heavy, b.heavy_blas, b.cmd.settings, rows),
                                          b.cmd.settings, b.rs, b.es.rays, b.ctx.device_name(), b.training));
}

// Setting k on one mesh (its model in `dir`, trained or reused): the model bytes, its eval metrics
// and the FLIP of its render against the triangle reference, into `row`. Returns the exit code (0 ok).
int measure_setting(const SizeBench& b, const std::string& mesh_name, const Mesh& mesh, const std::string& hdr,
                    const std::string& fingerprint, const fs::path& dir, size_t k, SizeRow& row) {
  const SizeSetting& setting = b.cmd.settings[k];
  row.mesh = mesh_name;
  row.setting = setting.name;
  TrainOptions o = b.options[k];
  o.output = (dir / (setting.name + ".lsnif")).string();
  std::printf("\n-- %s, setting %s\n", mesh_name.c_str(), setting.name.c_str());
  if (int r = train_or_reuse("bench-size", mesh, fingerprint, mesh_name, o, b.cmd.run.retrain, row.cached)) return r;
  std::error_code ec;
  row.model_bytes = fs::file_size(o.output, ec);
  Model model;
  Status s = ec ? Status::error("%s: %s", o.output.c_str(), ec.message().c_str()) : load_model(o.output, model);
  EvalReport report;
  if (s) s = evaluate_model(model, mesh, b.es, report);
  if (!s) {
    std::fprintf(stderr, "lsnif bench-size: %s\n", s.message().c_str());
    return 1;
  }
  row.eval = report.model;
  row.flops = mlp_flops_per_evaluation(model.config);
  std::printf("eval      occlusion %.2f%%, t error median %.3f%%, normal error median %.2f deg (%zu rays)\n",
              100.0 * row.eval.accuracy, 100.0 * row.eval.t_error_median, row.eval.normal_error_median, b.es.rays);
  row.image = mesh_name + "-" + setting.name + ".png";
  CompareReport cmp;
  if (s = render_compare(b.ctx, object_on_ground(mesh, o.output, hdr), b.rs,
                         (fs::path(b.cmd.out_dir) / row.image).string(), cmp);
      !s) {
    std::fprintf(stderr, "lsnif bench-size: %s, setting %s: %s\n", mesh_name.c_str(), setting.name.c_str(),
                 s.message().c_str());
    return 1;
  }
  row.flip_mean = cmp.flip_mean;
  row.device_bytes = cmp.lsnif.lsnif_bytes;
  return 0;
}

// One mesh: loaded, then every setting measured, its row appended to `rows` and results.md
// rewritten. Returns the exit code (0 ok).
int run_mesh(const SizeBench& b, const std::string& mesh_name, std::vector<SizeRow>& rows) {
  std::printf("\n== mesh %s\n", mesh_name.c_str());
  std::fflush(stdout);
  Mesh mesh;
  std::string hdr;
  if (Status s = load_bench_mesh(mesh_name, b.cmd.data_dir, mesh, hdr); !s) {
    std::fprintf(stderr, "lsnif bench-size: %s\n", s.message().c_str());
    return 1;
  }
  const fs::path dir = fs::path(b.cmd.out_dir) / mesh_name;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    std::fprintf(stderr, "lsnif bench-size: cannot create %s: %s\n", dir.string().c_str(), ec.message().c_str());
    return 1;
  }
  const std::string fingerprint = mesh_fingerprint(mesh);
  for (size_t k = 0; k < b.cmd.settings.size(); ++k) {
    SizeRow row;
    if (int r = measure_setting(b, mesh_name, mesh, hdr, fingerprint, dir, k, row)) return r;
    rows.push_back(std::move(row));
    if (!write_results(b, rows)) return 1;
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

int cmd_bench_size(int argc, char** argv) {
  SizeCommand cmd;
  if (const std::optional<int> r = parse_command_line(argc, argv, cmd)) return *r;
  if (!check_choices(cmd)) return 2;
  if (!check_inputs(cmd)) return 1;

  TrainOptions base;
  render::RenderSettings rs;
  apply_bench_run_options(cmd.run, base, rs);
  rs.pipeline = cmd.pipeline;
  EvalSettings es;
  es.rays = cmd.rays ? cmd.rays : cmd.run.quick ? 4000 : es.rays;
  base.quiet = true;
  std::vector<TrainOptions> options;
  if (!setting_options(cmd, base, options)) return 2;
  TrainSettings base_settings;
  if (!options.front().to_settings(base_settings)) return 2;

  if (!create_output_folder(cmd)) return 1;
  vk::Context ctx;
  if (!init_device(cmd, ctx)) return 1;
  BenchScene heavy;
  uint64_t heavy_blas = 0;
  if (!measure_heavy_blas(ctx, cmd, heavy, heavy_blas)) return 1;

  const SizeBench bench{ctx, cmd, options, rs, es, heavy, heavy_blas,
                        format("%s%s", cmd.run.quick ? "--quick: " : "", base_settings.describe().c_str()),
                        fs::path(cmd.out_dir) / "results.md"};
  // results.md is written after every row, so that an interrupted run leaves the rows it measured.
  std::vector<SizeRow> rows;
  for (const std::string& mesh_name : cmd.meshes)
    if (int r = run_mesh(bench, mesh_name, rows)) return r;

  std::vector<HeavyRow> heavy_rows = heavy_table_rows(heavy, heavy_blas, cmd.settings, rows);
  std::printf("\n%s\n%s\nwrote %s and the images beside it\n", size_table(rows).c_str(), heavy_table(heavy_rows).c_str(),
              bench.results.string().c_str());
  return 0;
}

}  // namespace lsnif::cli
