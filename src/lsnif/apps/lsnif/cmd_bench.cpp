// lsnif bench [SCENE...]: the paper's Table 1 on the bundled scenes (bench_scenes.h,
// docs/bench-scenes.md). Per scene: build it into OUT/SCENE/ (glTF with the LSNIF extensions) when
// missing or changed; per quality preset (--quality high,low: Table 1's H and L columns) train every
// unique model it needs (or reuse one trained from the same mesh with the same settings); per
// pipeline (--pipeline inline|wavefront|both) render it in reference and LSNIF mode with the same
// random sequences (render_compare.h), the wavefront renders with stage times; report LSNIF count,
// LSNIF memory against the triangle BLAS it replaces, time per sample of both modes, the LDR-FLIP
// of the LSNIF image and the wavefront stages. Writes OUT/results.md and per row OUT/SCENE[.low].
// PIPELINE.png (reference | LSNIF | FLIP heatmap).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/bench_scenes.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/data_dir.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/apps/lsnif/model_cache.h"
#include "lsnif/apps/lsnif/pipeline_option.h"
#include "lsnif/apps/lsnif/render_compare.h"
#include "lsnif/apps/lsnif/report_text.h"
#include "lsnif/renderer/scene_gltf.h"
#include "lsnif/apps/lsnif/train_options.h"
#include "lsnif/harness/vk_compute.h"

namespace lsnif::cli {

namespace {

namespace fs = std::filesystem;

struct ModelRow {
  std::string name, origin;
  uint64_t triangles = 0;
  bool reused = false;
  double train_seconds = 0;
};

// One measurement: a scene with the models of one quality preset, rendered by one pipeline.
struct SceneRow {
  std::string name, summary, image, preset;
  render::PathPipeline pipeline = render::PathPipeline::inline_rt;
  uint64_t triangles = 0;  // instanced triangles of the LSNIF objects
  CompareReport cmp;
  std::vector<ModelRow> models;  // those trained or reused for this preset (listed once per preset)
};

// The paper's two configurations (Table 1's H and L columns): `lsnif train --quality high|low`.
// The high models keep the plain names (OBJECT.lsnif), the low ones are OBJECT.low.lsnif.
std::string model_file(const std::string& object, const std::string& preset) {
  return preset == "high" ? object + ".lsnif" : object + "." + preset + ".lsnif";
}

std::string count_text(uint64_t n) {
  if (n >= 1000000) return format("%.2fM", double(n) / 1e6);
  if (n >= 1000) return format("%.1fk", double(n) / 1e3);
  return std::to_string(n);
}


// Triangle BLAS memory of the LSNIF objects' meshes: what reference mode builds beyond LSNIF mode
// (both build the same ground).
uint64_t object_blas_bytes(const CompareReport& c) {
  return c.reference.triangle_blas_bytes > c.lsnif.triangle_blas_bytes
             ? c.reference.triangle_blas_bytes - c.lsnif.triangle_blas_bytes
             : 0;
}

// The row's pipeline, with the broad phase its LSNIF render's queries ran with ("wavefront (trace-rays)").
std::string pipeline_label(const SceneRow& r) {
  if (r.pipeline != render::PathPipeline::wavefront) return render::pipeline_name(r.pipeline);
  return format("%s (%s)", render::pipeline_name(r.pipeline), render::broad_phase_name(r.cmp.lsnif.broad_phase));
}

std::string table(const std::vector<SceneRow>& rows) {
  std::string t =
      "| Scene | quality | pipeline | Tris (LSNIF objects) | LSNIF count | LSNIF (MiB) | triangle BLAS (MiB) | "
      "BLAS / LSNIF | T LSNIF (ms/spp) | T reference (ms/spp) | T LSNIF / T reference | FLIP mean |\n"
      "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const SceneRow& r : rows) {
    const render::RenderStats& l = r.cmp.lsnif;
    const render::RenderStats& ref = r.cmp.reference;
    const uint64_t blas = object_blas_bytes(r.cmp);
    t += format("| %s | %s | %s | %s | %u (%u) | %.3f | %.3f | %.2f | %.1f | %.1f | %.2f | %.4f |\n", r.name.c_str(),
                r.preset.c_str(), pipeline_label(r).c_str(), count_text(r.triangles).c_str(),
                l.lsnif_instances, l.lsnif_models, mib(l.lsnif_bytes), mib(blas),
                l.lsnif_bytes ? double(blas) / double(l.lsnif_bytes) : 0.0, l.ms_per_sample, ref.ms_per_sample,
                ref.ms_per_sample > 0 ? l.ms_per_sample / ref.ms_per_sample : 0.0, r.cmp.flip_mean);
  }
  return t;
}

// The wavefront rows' stage times (RenderSettings::stage_times) of the LSNIF and the reference render.
std::string stage_table(const std::vector<SceneRow>& rows) {
  std::string t =
      "| Scene | quality | mode | raster | camera | broad phase | sort | encode | MLP | resolve | shade | total (ms/spp) |\n"
      "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  bool any = false;
  for (const SceneRow& r : rows)
    for (const render::RenderStats* st : {&r.cmp.lsnif, &r.cmp.reference}) {
      if (!st->has_stages) continue;
      any = true;
      const render::StageTimes& s = st->stages;
      t += format("| %s | %s | %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.1f |\n", r.name.c_str(),
                  r.preset.c_str(), st == &r.cmp.lsnif ? "LSNIF" : "reference", s.raster, s.camera, s.broad, s.sort, s.encode,
                  s.mlp, s.resolve, s.shade, s.total());
    }
  return any ? t : std::string();
}

std::string results_markdown(const std::vector<SceneRow>& rows, const render::RenderSettings& rs,
                             const std::string& device, const std::string& training) {
  std::string md = "# lsnif bench: LSNIF vs triangles on the bundled scenes (like Table 1 of the paper)\n\n";
  md += format("Device: %s. Images %ux%u, %u samples per pixel, %u bounces, %s primary visibility. Training: %s.\n\n",
               device.c_str(), rs.width, rs.height, rs.spp, rs.max_bounces, render::primary_name(rs.primary),
               training.c_str());
  md += table(rows);
  md += "\nLSNIF count: LSNIF instances (unique models). LSNIF: device memory of the models (model block + AABB "
        "BLAS). Triangle BLAS: the BLASes of the same objects' meshes in reference mode (one per unique mesh, "
        "instances share it). T: wall time per sample per pixel (one path per pixel), the first pass excluded. "
        "FLIP: mean LDR-FLIP of the LSNIF image against the reference (same random numbers). Quality: the "
        "paper's configurations (high: the defaults; low: `--quality low`, W=64, H=10). The reference is rendered "
        "by the row's pipeline, once per scene and pipeline: both quality rows compare against the same render.\n";
  if (const std::string st = stage_table(rows); !st.empty()) {
    md += "\n## Wavefront stages (device time per sample, timestamps)\n\n" + st;
    md += "\nBroad phase, sort, encode (walk and sparse-grid encoding), MLP and resolve are lsnifCmdQuery's stages, "
          "summed over the path and shadow rays of all bounces; shade includes light connections and accumulation.\n";
  }
  md += "\n## Models\n\n| Scene | model | mesh | triangles | training |\n|---|---|---|---:|---|\n";
  for (const SceneRow& r : rows)
    for (const ModelRow& m : r.models) {
      const std::string how = m.reused ? "reused (same mesh and settings)" : format("%.0f s", m.train_seconds);
      md += format("| %s | %s | %s | %s | %s |\n", r.name.c_str(), model_file(m.name, r.preset).c_str(),
                   m.origin.c_str(), count_text(m.triangles).c_str(), how.c_str());
    }
  md += "\n## Images (reference | LSNIF | FLIP)\n";
  for (const SceneRow& r : rows)
    md += format("\n%s: %s\n\n![%s](%s)\n", r.name.c_str(), r.summary.c_str(), r.name.c_str(), r.image.c_str());
  return md;
}

// The command line as given, then as checked (pipelines, primary visibility, presets, scenes).
struct BenchCommand {
  std::vector<std::string> names;
  std::string out_dir = "out/bench", data_dir = default_data_dir(), device, pipeline_name = "both",
              preset_names = "high,low", primary_name = "traced", broad_phase_name = "auto";
  BenchRunOptions run;
  std::string known;  // the bundled scenes' names, for the help and messages
  std::vector<render::PathPipeline> pipelines;
  render::PrimaryVisibility primary{};
  render::BroadPhase broad_phase{};
  std::vector<std::string> presets, scenes;
};

// Reads the options into `cmd`; the exit code when the command ends here (help, a bad option).
std::optional<int> parse_command_line(int argc, char** argv, BenchCommand& cmd) {
  Args args("bench",
            "The paper's Table 1 on the bundled scenes (docs/bench-scenes.md): builds each scene from the\n"
            "meshes and HDR images of scripts/setup.sh into OUT/SCENE/ (OUT = --out), trains its LSNIF models\n"
            "(reused when the mesh and settings are unchanged), renders it in reference and LSNIF mode, and\n"
            "writes OUT/results.md (memory, time per sample, FLIP) and OUT/SCENE.png (reference | LSNIF | FLIP).");
  for (const std::string& n : bench_scene_names()) cmd.known += (cmd.known.empty() ? "" : ", ") + n;
  args.rest("SCENE", "scenes to run: " + cmd.known + " (default: all)", &cmd.names);
  args.option("out", "output folder", &cmd.out_dir);
  args.option("data", "folder with meshes/ and hdr/ from scripts/setup.sh", &cmd.data_dir);
  add_bench_run_options(args, &cmd.run);
  args.option("pipeline", "inline, wavefront or both (docs/renderer.md): the pipelines each scene is rendered with",
              &cmd.pipeline_name);
  args.option("quality", "the paper's configurations to train and compare, a list: high, low (Table 1's H and L)",
              &cmd.preset_names);
  add_primary_option(args, &cmd.primary_name);
  add_broad_phase_option(args, &cmd.broad_phase_name);
  add_device_option(args, &cmd.device);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  return std::nullopt;
}

// Checks --pipeline, --primary, --quality and the scene names into cmd.pipelines, cmd.primary,
// cmd.presets and cmd.scenes (each once, in order); false (message printed) on an invalid one.
bool check_choices(BenchCommand& cmd) {
  if (cmd.pipeline_name == "both") {
    cmd.pipelines = {render::PathPipeline::inline_rt, render::PathPipeline::wavefront};
  } else {
    render::PathPipeline one;
    if (!render::parse_pipeline(cmd.pipeline_name, one)) {
      std::fprintf(stderr, "lsnif bench: --pipeline must be inline, wavefront or both, not '%s'\n",
                   printable(cmd.pipeline_name).c_str());
      return false;
    }
    cmd.pipelines = {one};
  }
  if (!parse_primary_option("bench", cmd.primary_name, cmd.primary)) return false;
  if (!parse_broad_phase_option("bench", cmd.broad_phase_name, cmd.broad_phase)) return false;
  const std::string& preset_names = cmd.preset_names;
  for (size_t at = 0; at <= preset_names.size();) {
    const size_t comma = std::min(preset_names.find(',', at), preset_names.size());
    const std::string p = preset_names.substr(at, comma - at);
    if (p != "high" && p != "low") {
      std::fprintf(stderr, "lsnif bench: --quality takes a list of high and low, not '%s'\n", printable(p).c_str());
      return false;
    }
    if (std::find(cmd.presets.begin(), cmd.presets.end(), p) == cmd.presets.end()) cmd.presets.push_back(p);
    at = comma + 1;
  }
  if (cmd.names.empty()) cmd.names = bench_scene_names();
  for (const std::string& n : cmd.names) {
    bool ok = false;
    for (const std::string& k : bench_scene_names()) ok |= n == k;
    if (!ok) {
      std::fprintf(stderr, "lsnif bench: unknown scene '%s' (scenes: %s)\n", n.c_str(), cmd.known.c_str());
      return false;
    }
    bool seen = false;
    for (const std::string& s : cmd.scenes) seen |= s == n;
    if (!seen) cmd.scenes.push_back(n);
  }
  return true;
}

// True when the data folder holds every input file of the scenes; else prints what is missing.
bool check_inputs(const BenchCommand& cmd) {
  if (!check_data_dir("bench", cmd.data_dir)) return false;
  for (const std::string& n : cmd.scenes)
    for (const std::string& f : bench_scene_inputs(n, cmd.data_dir))
      if (!fs::is_regular_file(f)) {
        std::fprintf(stderr,
                     "lsnif bench: %s (needed by scene '%s') not found: run scripts/setup.sh first (it fetches "
                     "the meshes and HDR environments)\n", f.c_str(), n.c_str());
        return false;
      }
  return true;
}

// Creates the output folder; false (message printed) when it cannot.
bool create_output_folder(const BenchCommand& cmd) {
  std::error_code ec;
  fs::create_directories(cmd.out_dir, ec);
  if (ec || !fs::is_directory(cmd.out_dir)) {
    std::fprintf(stderr, "lsnif bench: cannot create the output folder %s: %s\n", cmd.out_dir.c_str(),
                 ec ? ec.message().c_str() : "not a folder");
    return false;
  }
  return true;
}

// Initializes `ctx` for the pipelines; false (message printed) when no device can run them.
bool init_device(const BenchCommand& cmd, vk::ComputeContext& ctx) {
  if (Status s = ctx.init(render::context_options(/*validation=*/false, cmd.device));
      !s) {
    std::fprintf(stderr, "lsnif bench: no usable Vulkan ray-tracing device (`lsnif devices` tells what is missing): %s\n",
                 s.message().c_str());
    return false;
  }
  return true;
}

// Builds scene `name` into `bench` and writes it to `dir`/NAME.gltf (`gltf`) unless the file there
// is of the same scene; `base` receives the rows' scene fields. Returns the exit code (0 ok).
int prepare_scene(const std::string& name, const BenchCommand& cmd, BenchScene& bench, SceneRow& base,
                  fs::path& dir, fs::path& gltf) {
  if (Status s = make_bench_scene(name, cmd.data_dir, bench); !s) {
    std::fprintf(stderr, "lsnif bench: %s\n", s.message().c_str());
    return 1;
  }
  base.name = name;
  base.summary = bench.summary;
  base.triangles = object_triangles(bench);
  dir = fs::path(cmd.out_dir) / name;
  std::error_code ec;
  fs::create_directories(dir, ec);
  gltf = dir / (name + ".gltf");
  const fs::path scene_key = dir / "scene.key";
  const std::string fingerprint = scene_fingerprint(bench) + "\n";
  if (fs::is_regular_file(gltf) && file_holds(scene_key.string(), fingerprint)) {
    std::printf("scene     reusing %s (unchanged)\n", gltf.string().c_str());
  } else {
    if (Status s = write_bench_scene(bench, dir.string()); !s) {
      std::fprintf(stderr, "lsnif bench: scene %s: %s\n", name.c_str(), s.message().c_str());
      return 1;
    }
    if (!write_text_file("bench", scene_key.string(), fingerprint)) {
      std::fprintf(stderr, "lsnif bench: cannot write %s\n", scene_key.string().c_str());
      return 1;
    }
    std::printf("scene     wrote %s: %s\n", gltf.string().c_str(), bench.summary.c_str());
  }
  std::fflush(stdout);
  return 0;
}

// Trains (or reuses) the scene's models of quality `preset` into `dir`, listed in models.models.
// Returns the exit code (0 ok).
int train_preset_models(const BenchCommand& cmd, const BenchScene& bench, const std::string& preset,
                        const TrainOptions& topt, const fs::path& dir, SceneRow& models) {
  for (const BenchObject& o : bench.objects) {
    ModelRow m;
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
    mo.output = (dir / model_file(o.name, preset)).string();
    CachedModel cached;
    if (int r = train_or_reuse("bench", o.mesh, object_fingerprint(o),
                               o.name + " (" + o.origin + ", " + preset + " quality)", mo, cmd.run.retrain, cached))
      return r;
    m.reused = cached.reused;
    m.train_seconds = cached.train_seconds;
    models.models.push_back(m);
  }
  return 0;
}

// Loads the scene file `gltf` into `sc`, its LSNIF objects tracing the models of `preset`; false
// (message printed) when it cannot be loaded.
bool load_preset_scene(const fs::path& gltf, const std::string& preset, scene::Scene& sc) {
  // The scene file names the high models; the low rows trace the low ones in their place.
  scene::SceneLoadOptions lo;
  if (Status s = scene::load_scene(gltf.string(), lo, sc); !s) {
    std::fprintf(stderr, "lsnif bench: %s\n", s.message().c_str());
    return false;
  }
  for (scene::LsnifObject& obj : sc.lsnif_objects) {
    const fs::path high(obj.resolved_path);
    obj.resolved_path = (high.parent_path() / model_file(high.stem().string(), preset)).string();
  }
  return true;
}

// Renders `sc` with each pipeline in reference and LSNIF mode (the reference render of a pipeline
// taken from or kept in `references`) and appends a row per pipeline to `rows`, from `models` (the
// scene's and preset's fields); false (message printed) on failure.
bool render_preset(vk::ComputeContext& ctx, const BenchCommand& cmd, const scene::Scene& sc, const SceneRow& models,
                   const render::RenderSettings& rs, std::map<render::PathPipeline, ReferenceRender>& references,
                   std::vector<SceneRow>& rows) {
  const std::string& name = models.name;
  const std::string& preset = models.preset;
  for (const render::PathPipeline pipeline : cmd.pipelines) {
    SceneRow row = models;
    if (pipeline != cmd.pipelines.front()) row.models.clear();  // listed once per preset
    row.pipeline = pipeline;
    row.image = name + (preset == "high" ? "" : "." + preset) + "." + render::pipeline_name(pipeline) + ".png";
    render::RenderSettings prs = rs;
    prs.pipeline = pipeline;
    prs.broad_phase = cmd.broad_phase;
    prs.stage_times = pipeline == render::PathPipeline::wavefront;
    std::printf("\n-- %s, %s quality, %s pipeline\n", name.c_str(), preset.c_str(), render::pipeline_name(pipeline));
    std::fflush(stdout);
    if (Status s = render_compare(ctx, sc, prs, (fs::path(cmd.out_dir) / row.image).string(), row.cmp,
                                  &references[pipeline]);
        !s) {
      std::fprintf(stderr, "lsnif bench: scene %s: %s\n", name.c_str(), s.message().c_str());
      return false;
    }
    rows.push_back(std::move(row));
  }
  return true;
}

// One scene: built (or reused), then per preset its models trained (or reused) and its renders,
// appended to `rows`. Returns the exit code (0 ok).
int run_scene(vk::ComputeContext& ctx, const BenchCommand& cmd, const std::string& name, const TrainOptions& topt,
              const render::RenderSettings& rs, std::vector<SceneRow>& rows) {
  std::printf("\n== scene %s\n", name.c_str());
  std::fflush(stdout);
  BenchScene bench;
  SceneRow base;
  fs::path dir, gltf;
  if (int r = prepare_scene(name, cmd, bench, base, dir, gltf)) return r;

  // The reference render of each pipeline, shared by the quality rows (it traces only meshes).
  std::map<render::PathPipeline, ReferenceRender> references;
  for (const std::string& preset : cmd.presets) {
    SceneRow models = base;
    models.preset = preset;
    if (int r = train_preset_models(cmd, bench, preset, topt, dir, models)) return r;
    scene::Scene sc;
    if (!load_preset_scene(gltf, preset, sc)) return 1;
    if (!render_preset(ctx, cmd, sc, models, rs, references, rows)) return 1;
  }
  return 0;
}

// Writes OUT/results.md and prints the tables; false (message printed) when it cannot be written.
bool write_report(const BenchCommand& cmd, const std::vector<SceneRow>& rows, const render::RenderSettings& rs,
                  const vk::ComputeContext& ctx, const TrainSettings& train_settings) {
  const std::string training =
      format("%s%s", cmd.run.quick ? "--quick: " : "", train_settings.describe().c_str());
  const fs::path results = fs::path(cmd.out_dir) / "results.md";
  if (!write_text_file("bench", results.string(), results_markdown(rows, rs, ctx.device_name(), training))) {
    std::fprintf(stderr, "lsnif bench: cannot write %s\n", results.string().c_str());
    return false;
  }
  std::printf("\n%s\n%s\nwrote %s and the images beside it\n", table(rows).c_str(), stage_table(rows).c_str(),
              results.string().c_str());
  return true;
}

}  // namespace

int cmd_bench(int argc, char** argv) {
  BenchCommand cmd;
  if (const std::optional<int> r = parse_command_line(argc, argv, cmd)) return *r;
  if (!check_choices(cmd)) return 2;
  if (!check_inputs(cmd)) return 1;

  TrainOptions topt;
  render::RenderSettings rs;
  apply_bench_run_options(cmd.run, topt, rs);
  rs.primary = cmd.primary;
  // Checked (and described for results.md) before any work; to_settings wants an output name for
  // the loss-curve path it derives, nothing is written under it.
  TrainSettings train_settings;
  topt.output = (fs::path(cmd.out_dir) / "model.lsnif").string();
  if (!topt.to_settings(train_settings)) return 2;

  if (!create_output_folder(cmd)) return 1;
  vk::ComputeContext ctx;
  if (!init_device(cmd, ctx)) return 1;

  std::vector<SceneRow> rows;
  for (const std::string& name : cmd.scenes)
    if (int r = run_scene(ctx, cmd, name, topt, rs, rows)) return r;
  return write_report(cmd, rows, rs, ctx, train_settings) ? 0 : 1;
}

}  // namespace lsnif::cli
