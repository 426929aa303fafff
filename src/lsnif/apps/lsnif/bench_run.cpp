// bench_run.cpp -- lsnif bench [SCENE...]: the paper's Table 1 on the bundled scenes (bench_scenes.h,
// docs/bench-scenes.md), without the training (bench_run.h). Per scene: build it into OUT/SCENE/
// (glTF with the LSNIF extensions) when missing or changed; per quality preset (--quality high,low:
// Table 1's H and L columns) get every unique model it needs (trained by the BenchTrainer, or with
// --models copied from a folder of models prepared before); per
// pipeline (--pipeline auto|inline|wavefront|both; auto: the LSNIF mode's choice for the scene and
// device against the fastest triangle path, pipeline_option.h) render it in reference and LSNIF mode
// with the same random sequences (render_compare.h), the wavefront renders with stage times; report LSNIF count,
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

#include <nlohmann/json.hpp>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/bench_run.h"
#include "lsnif/apps/lsnif/bench_scenes.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/data_dir.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/apps/lsnif/bench_options.h"
#include "lsnif/format/file_io.h"
#include "lsnif/format/model_format.h"
#include "lsnif/apps/lsnif/pipeline_option.h"
#include "lsnif/apps/lsnif/render_compare.h"
#include "lsnif/apps/lsnif/report_text.h"
#include "lsnif/scene/scene_gltf.h"
#include "lsnif/vulkan/context.h"
#include "lsnif/train/settings_io.h"

namespace lsnif::cli {

namespace {

namespace fs = std::filesystem;


// One measurement: a scene with the models of one quality preset, rendered by one pipeline.
struct SceneRow {
  std::string name, summary, image, preset;
  std::string pipeline_entry;  // of --pipeline: auto, inline or wavefront
  render::RenderChoice path, reference_path;  // of the LSNIF and the reference render
  uint64_t triangles = 0;  // instanced triangles of the LSNIF objects
  CompareReport cmp;
  std::vector<BenchModelRow> models;  // those trained or reused for this preset (listed once per preset)
};

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

// The row's pipeline, with the broad phase its LSNIF render's queries ran with ("wavefront (trace-rays)"),
// and for --pipeline auto the primary visibility and the reference's path ("wavefront (ray-query),
// raster; reference inline, traced").
std::string pipeline_label(const SceneRow& r) {
  std::string label = render::pipeline_name(r.path.pipeline);
  if (r.path.pipeline == render::PathPipeline::wavefront)
    label += format(" (%s)", render::broad_phase_name(r.cmp.lsnif.broad_phase));
  if (r.pipeline_entry == "auto")
    label += format(", %s; reference %s, %s", render::primary_name(r.path.primary),
                    render::pipeline_name(r.reference_path.pipeline), render::primary_name(r.reference_path.primary));
  return label;
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
  md += format("Device: %s. Images %ux%u, %u samples per pixel, %u bounces. Training: %s.\n\n",
               device.c_str(), rs.width, rs.height, rs.spp, rs.max_bounces, training.c_str());
  md += "Pipelines and primary visibility:\n\n";
  for (const SceneRow& r : rows)
    md += format("- %s, %s quality: LSNIF %s, %s (%s); reference %s, %s (%s)\n", r.name.c_str(), r.preset.c_str(),
                 render::pipeline_name(r.path.pipeline), render::primary_name(r.path.primary), r.path.why.c_str(),
                 render::pipeline_name(r.reference_path.pipeline), render::primary_name(r.reference_path.primary),
                 r.reference_path.why.c_str());
  md += "\n";
  md += table(rows);
  md += "\nLSNIF count: LSNIF instances (unique models). LSNIF: device memory of the models (model block + AABB "
        "BLAS). Triangle BLAS: the BLASes of the same objects' meshes in reference mode (one per unique mesh, "
        "instances share it). T: wall time per sample per pixel (one path per pixel), the first pass excluded. "
        "FLIP: mean LDR-FLIP of the LSNIF image against the reference (same random numbers). Quality: the "
        "model: default (`lsnif train`'s: the paper's network, W=128 and H=18, on the default grid; high: "
        "`--quality high`, the same network in its own file), low (`--quality low`: the paper's W=64, H=10 on "
        "the default grid). The reference is rendered "
        "by the row's pipeline (with `--pipeline auto`: the fastest triangle path), once per scene and path: both "
        "quality rows compare against the same render.\n";
  if (const std::string st = stage_table(rows); !st.empty()) {
    md += "\n## Wavefront stages (device time per sample, timestamps)\n\n" + st;
    md += "\nBroad phase, sort, encode (walk and sparse-grid encoding), MLP and resolve are lsnifCmdQuery's stages, "
          "summed over the path and shadow rays of all bounces; shade includes light connections and accumulation.\n";
  }
  md += "\n## Models\n\n| Scene | model | mesh | triangles | training |\n|---|---|---|---:|---|\n";
  for (const SceneRow& r : rows)
    for (const BenchModelRow& m : r.models) {
      const std::string how = m.reused ? "reused (same mesh and settings)" : format("%.0f s", m.train_seconds);
      md += format("| %s | %s | %s | %s | %s |\n", r.name.c_str(), bench_model_file(m.name, r.preset).c_str(),
                   m.origin.c_str(), count_text(m.triangles).c_str(), how.c_str());
    }
  md += "\n## Images (reference | LSNIF | FLIP)\n";
  for (const SceneRow& r : rows)
    md += format("\n%s: %s\n\n![%s](%s)\n", r.name.c_str(), r.summary.c_str(), r.name.c_str(), r.image.c_str());
  return md;
}

nlohmann::ordered_json stages_json(const render::StageTimes& s) {
  return {{"raster", s.raster}, {"camera", s.camera}, {"broad_phase", s.broad}, {"sort", s.sort},
          {"encode", s.encode}, {"mlp", s.mlp},       {"resolve", s.resolve},   {"shade", s.shade},
          {"total", s.total()}};
}

// results.json: what results.md tables, as numbers (times in ms per sample, memory in bytes).
nlohmann::ordered_json results_json(const std::vector<SceneRow>& rows, const render::RenderSettings& rs,
                                    const vk::Context& ctx, const std::string& training) {
  nlohmann::ordered_json j = {{"device", ctx.device_name()},
                              {"width", rs.width},
                              {"height", rs.height},
                              {"spp", rs.spp},
                              {"bounces", rs.max_bounces},
                              {"training", training}};
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const SceneRow& r : rows) {
    const render::RenderStats& l = r.cmp.lsnif;
    const render::RenderStats& ref = r.cmp.reference;
    const uint64_t blas = object_blas_bytes(r.cmp);
    nlohmann::ordered_json row = {
        {"scene", r.name},
        {"quality", r.preset},
        {"pipeline", render::pipeline_name(r.path.pipeline)},
        {"primary", render::primary_name(r.path.primary)},
        {"pipeline_choice", r.path.why},
        {"reference_pipeline", render::pipeline_name(r.reference_path.pipeline)},
        {"reference_primary", render::primary_name(r.reference_path.primary)},
        {"reference_choice", r.reference_path.why},
        {"broad_phase", r.path.pipeline == render::PathPipeline::wavefront ? render::broad_phase_name(l.broad_phase) : ""},
        {"object_triangles", r.triangles},
        {"lsnif_instances", l.lsnif_instances},
        {"lsnif_models", l.lsnif_models},
        {"lsnif_bytes", l.lsnif_bytes},
        {"triangle_blas_bytes", blas},
        {"blas_over_lsnif", l.lsnif_bytes ? double(blas) / double(l.lsnif_bytes) : 0.0},
        {"ms_per_sample_lsnif", l.ms_per_sample},
        {"ms_per_sample_reference", ref.ms_per_sample},
        {"lsnif_over_reference", ref.ms_per_sample > 0 ? l.ms_per_sample / ref.ms_per_sample : 0.0},
        {"flip_mean", r.cmp.flip_mean},
        {"flip_median", r.cmp.flip_median},
        {"image", r.image}};
    if (l.has_stages) row["stages_lsnif"] = stages_json(l.stages);
    if (ref.has_stages) row["stages_reference"] = stages_json(ref.stages);
    list.push_back(std::move(row));
  }
  j["rows"] = std::move(list);
  return j;
}

// The command line as given, then as checked (pipelines, primary visibility, presets, scenes).
struct BenchCommand {
  std::vector<std::string> names;
  std::string out_dir = "out/bench", data_dir = default_data_dir(), device, pipeline_name = "auto",
              preset_names = "default,low", primary_name = "auto", broad_phase_name = "auto";
  std::string models_dir;  // --models: take the models from here instead of training
  bool no_render = false;  // --no-render: build the scenes and train their models only
  BenchRunOptions run;
  std::string known;  // the bundled scenes' names, for the help and messages
  std::vector<std::string> pipelines;  // auto, inline, wavefront
  render::BroadPhase broad_phase{};
  std::vector<std::string> presets, scenes;
};

// Reads the options into `cmd`; the exit code when the command ends here (help, a bad option).
// (`trains`: whether this program can train; without, --models is required and --no-render absent.)
std::optional<int> parse_command_line(int argc, char** argv, bool trains, BenchCommand& cmd) {
  Args args("bench",
            std::string("The paper's Table 1 on the bundled scenes (docs/bench-scenes.md): builds each scene from the\n"
                        "meshes and HDR images of scripts/setup.sh into OUT/SCENE/ (OUT = --out), ") +
                (trains ? "trains its LSNIF models\n(reused when the mesh and settings are unchanged) or copies "
                          "them from --models, "
                        : "copies its LSNIF models\nfrom --models (this program trains none), ") +
                "renders it in reference and LSNIF mode, and\nwrites OUT/results.md and OUT/results.json (memory, "
                "time per sample, FLIP) and OUT/SCENE.png\n(reference | LSNIF | FLIP).");
  for (const std::string& n : bench_scene_names()) cmd.known += (cmd.known.empty() ? "" : ", ") + n;
  args.rest("SCENE", "scenes to run: " + cmd.known + " (default: all)", &cmd.names);
  args.option("out", "output folder", &cmd.out_dir);
  args.option("data", "folder with meshes/ and hdr/ from scripts/setup.sh", &cmd.data_dir);
  args.option("models",
              "take the models from this folder (MODELS/SCENE/OBJECT[.high|.low].lsnif and .key, as `lsnif bench --out "
              "MODELS` left them) instead of training",
              &cmd.models_dir);
  if (trains) args.flag("no-render", "build the scenes and train their models, render nothing", &cmd.no_render);
  add_bench_run_options(args, &cmd.run);
  args.option("pipeline",
              "auto (the fastest correct pipeline for the scene and device against the fastest triangle path), "
              "inline, wavefront or both (docs/renderer.md): the pipelines each scene is rendered with; a forced "
              "one renders the reference too",
              &cmd.pipeline_name);
  args.option("quality",
              "the models to train and compare, a list: default (lsnif train's), high, low (the paper's Table 1 "
              "H and L networks; high is the default network, in its own files)",
              &cmd.preset_names);
  add_primary_option(args, &cmd.primary_name);
  add_broad_phase_option(args, &cmd.broad_phase_name);
  add_device_option(args, &cmd.device);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  return std::nullopt;
}

// Checks --pipeline, --primary, --quality and the scene names into cmd.pipelines,
// cmd.presets and cmd.scenes (each once, in order); false (message printed) on an invalid one.
bool check_choices(BenchCommand& cmd) {
  if (cmd.pipeline_name == "both") {
    cmd.pipelines = {"inline", "wavefront"};
  } else {
    render::PathPipeline one;
    if (cmd.pipeline_name != "auto" && !render::parse_pipeline(cmd.pipeline_name, one)) {
      std::fprintf(stderr, "lsnif bench: --pipeline must be auto, inline, wavefront or both, not '%s'\n",
                   printable(cmd.pipeline_name).c_str());
      return false;
    }
    cmd.pipelines = {cmd.pipeline_name};
  }
  PathOptions primary;
  primary.primary = cmd.primary_name;
  if (!check_path_options("bench", primary)) return false;
  if (!parse_broad_phase_option("bench", cmd.broad_phase_name, cmd.broad_phase)) return false;
  const std::string& preset_names = cmd.preset_names;
  for (size_t at = 0; at <= preset_names.size();) {
    const size_t comma = std::min(preset_names.find(',', at), preset_names.size());
    const std::string p = preset_names.substr(at, comma - at);
    if (p != "default" && p != "high" && p != "low") {
      std::fprintf(stderr, "lsnif bench: --quality takes a list of default, high and low, not '%s'\n",
                   printable(p).c_str());
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
                     "the meshes, textures and HDR environments)\n", f.c_str(), n.c_str());
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
bool init_device(const BenchCommand& cmd, vk::Context& ctx) {
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

// Why the prepared model `from` (with its key FROM.key) is not the model of object `o` at quality
// `preset` ("" when it is): the key must name the object's mesh and the preset (model_cache.h), and
// the model's own training record must hold the key's settings and the mesh's hash, so that neither
// a model copied over another nor a key copied with it passes.
std::string prepared_model_problem(const BenchObject& o, const std::string& preset, const fs::path& from) {
  const std::string key_path = from.string() + ".key";
  std::string key;
  if (Status s = read_file(key_path, key, 1 << 16); !s) return s.message();
  if (key.rfind(model_key_head(object_fingerprint(o), ""), 0) != 0)
    return "its key names another mesh than the scene's " + o.name + " (" + o.origin + ")";
  const std::string head = model_key_head(object_fingerprint(o), preset);
  if (key.rfind(head, 0) != 0)
    return "its key names another quality than " + preset + " (or none: prepared before keys named it)";
  const size_t at = head.size();
  const std::string settings_tag = "settings ";
  if (key.compare(at, settings_tag.size(), settings_tag) != 0 || key.empty() || key.back() != '\n')
    return "its key holds no settings line";
  SettingLayer layer;
  TrainSettings claimed;
  const std::string settings = key.substr(at + settings_tag.size(), key.size() - 1 - at - settings_tag.size());
  if (Status s = parse_settings_json(settings, key_path, layer); !s) return s.message();
  if (Status s = resolve_settings({&layer}, claimed); !s) return s.message();
  std::vector<uint8_t> bytes;
  ModelFileView view;
  if (Status s = read_model_file(from.string(), bytes); !s) return s.message();
  if (Status s = parse_model_file(bytes.data(), bytes.size(), view); !s) return s.message();
  if (std::string why = training_record_difference(view.training, claimed, mesh_hash(o.mesh)); !why.empty())
    return "the model is not the one its key describes: " + why;
  return "";
}

// Copies the scene's models of quality `preset` from the folder of --models (MODELS/SCENE/, as a
// `lsnif bench --out MODELS` run left them) into `dir`, after checking that each is the object's
// model of that quality (prepared_model_problem); lists them in `rows`. Returns the exit code (0 ok).
int copy_prepared_models(const BenchCommand& cmd, const BenchScene& bench, const std::string& preset,
                         const fs::path& dir, std::vector<BenchModelRow>& rows) {
  for (const BenchObject& o : bench.objects) {
    const std::string file = bench_model_file(o.name, preset);
    const fs::path from = fs::path(cmd.models_dir) / bench.name / file;
    const std::string prepare = format("prepare the models with `lsnif bench %s --quality %s --no-render --out %s`",
                                       bench.name.c_str(), preset.c_str(), cmd.models_dir.c_str());
    if (!fs::is_regular_file(from) || !fs::is_regular_file(from.string() + ".key")) {
      std::fprintf(stderr, "lsnif bench: --models: %s (or its .key) not found: %s\n", from.string().c_str(),
                   prepare.c_str());
      return 1;
    }
    if (std::string why = prepared_model_problem(o, preset, from); !why.empty()) {
      std::fprintf(stderr, "lsnif bench: --models: %s is not the %s-quality model of %s: %s; %s\n",
                   from.string().c_str(), preset.c_str(), o.name.c_str(), why.c_str(), prepare.c_str());
      return 1;
    }
    std::error_code ec;
    for (const char* ext : {"", ".key"})
      if (!ec)
        fs::copy_file(from.string() + ext, (dir / file).string() + ext, fs::copy_options::overwrite_existing, ec);
    if (ec) {
      std::fprintf(stderr, "lsnif bench: copying %s into %s: %s\n", from.string().c_str(), dir.string().c_str(),
                   ec.message().c_str());
      return 1;
    }
    std::printf("model     %s from %s\n", file.c_str(), from.string().c_str());
    rows.push_back({o.name, o.origin, o.mesh.triangles.size(), /*reused=*/true, 0.0});
  }
  return 0;
}

// Loads the scene file `gltf` of `bench` into `sc`, its LSNIF objects tracing the models of
// `preset`; false (message printed) when it cannot be loaded.
bool load_preset_scene(const fs::path& gltf, const BenchScene& bench, const std::string& preset, scene::Scene& sc) {
  // The scene file names the default models; the other rows trace theirs in their place (and the
  // default ones need not exist: a run of other presets prepares none).
  scene::SceneLoadOptions lo;
  if (preset != "default")
    for (const BenchObject& o : bench.objects)
      lo.pending_models.push_back((gltf.parent_path() / bench_model_file(o.name, "default")).lexically_normal().string());
  if (Status s = scene::load_scene(gltf.string(), lo, sc); !s) {
    std::fprintf(stderr, "lsnif bench: %s\n", s.message().c_str());
    return false;
  }
  for (scene::LsnifObject& obj : sc.lsnif_objects) {
    const fs::path named(obj.resolved_path);
    obj.resolved_path = (named.parent_path() / bench_model_file(named.stem().string(), preset)).string();
  }
  return true;
}

// Renders `sc` with each pipeline in reference and LSNIF mode (the reference render of a pipeline
// taken from or kept in `references`) and appends a row per pipeline to `rows`, from `models` (the
// scene's and preset's fields); false (message printed) on failure.
bool render_preset(vk::Context& ctx, const BenchCommand& cmd, const scene::Scene& sc, const SceneRow& models,
                   const render::RenderSettings& rs, std::map<std::string, ReferenceRender>& references,
                   std::vector<SceneRow>& rows) {
  const std::string& name = models.name;
  const std::string& preset = models.preset;
  for (const std::string& entry : cmd.pipelines) {
    SceneRow row = models;
    if (entry != cmd.pipelines.front()) row.models.clear();  // listed once per preset
    row.pipeline_entry = entry;
    PathOptions given;
    given.pipeline = entry;
    given.primary = cmd.primary_name;
    const uint64_t pixels = uint64_t(rs.width) * rs.height;
    if (!resolve_path_options("bench", given, ctx, sc, /*reference=*/false, pixels, row.path)) return false;
    // auto: the reference takes the fastest triangle path; a forced pipeline renders it too, unless
    // that is the wavefront pipeline and the reference's triangles have cut-outs (which it does not
    // alpha-test): then the reference is inline, and the report says why.
    row.reference_path = row.path;
    if (entry == "auto" &&
        !resolve_path_options("bench", PathOptions(), ctx, sc, /*reference=*/true, pixels, row.reference_path))
      return false;
    if (const std::string cutout = render::cutout_material(sc, /*reference=*/true);
        row.reference_path.pipeline == render::PathPipeline::wavefront && !cutout.empty()) {
      row.reference_path.pipeline = render::PathPipeline::inline_rt;
      row.reference_path.why = "inline: material '" + printable(cutout) +
                               "' is an alpha cut-out, which lsnifCmdQuery does not alpha-test";
    }
    row.image = name + (preset == "default" ? "" : "." + preset) + "." + entry + ".png";
    render::RenderSettings prs = rs;
    prs.pipeline = row.path.pipeline;
    prs.primary = row.path.primary;
    prs.broad_phase = cmd.broad_phase;
    prs.stage_times = true;  // the wavefront renders' stages (the inline pipeline has none)
    std::printf("\n-- %s, %s quality, %s pipeline, %s primary (%s)\n", name.c_str(), preset.c_str(),
                render::pipeline_name(row.path.pipeline), render::primary_name(row.path.primary), row.path.why.c_str());
    std::fflush(stdout);
    const std::string ref_key = std::string(render::pipeline_name(row.reference_path.pipeline)) + "," +
                                render::primary_name(row.reference_path.primary);
    if (Status s = render_compare(ctx, sc, prs, (fs::path(cmd.out_dir) / row.image).string(), row.cmp,
                                  &references[ref_key], &row.reference_path);
        !s) {
      std::fprintf(stderr, "lsnif bench: scene %s: %s\n", name.c_str(), s.message().c_str());
      return false;
    }
    rows.push_back(std::move(row));
  }
  return true;
}

// One scene: built (or reused), then per preset its models trained, reused or copied (--models) and,
// unless --no-render, its renders appended to `rows`. Returns the exit code (0 ok).
int run_scene(vk::Context& ctx, const BenchCommand& cmd, const BenchTrainer* trainer, const std::string& name,
              const TrainOptions& topt, const render::RenderSettings& rs, std::vector<SceneRow>& rows) {
  std::printf("\n== scene %s\n", name.c_str());
  std::fflush(stdout);
  BenchScene bench;
  SceneRow base;
  fs::path dir, gltf;
  if (int r = prepare_scene(name, cmd, bench, base, dir, gltf)) return r;

  // The reference render of each pipeline, shared by the quality rows (it traces only meshes).
  std::map<std::string, ReferenceRender> references;  // by the reference's pipeline and primary visibility
  for (const std::string& preset : cmd.presets) {
    SceneRow models = base;
    models.preset = preset;
    const int r = cmd.models_dir.empty()
                      ? trainer->train(topt, cmd.run.retrain, bench, preset, dir.string(), models.models)
                      : copy_prepared_models(cmd, bench, preset, dir, models.models);
    if (r) return r;
    if (cmd.no_render) continue;
    scene::Scene sc;
    if (!load_preset_scene(gltf, bench, preset, sc)) return 1;
    if (!render_preset(ctx, cmd, sc, models, rs, references, rows)) return 1;
  }
  return 0;
}

// Writes OUT/results.md and prints the tables; false (message printed) when it cannot be written.
bool write_report(const BenchCommand& cmd, const std::vector<SceneRow>& rows, const render::RenderSettings& rs,
                  const vk::Context& ctx, const std::string& training) {
  const fs::path results = fs::path(cmd.out_dir) / "results.md";
  const fs::path json = fs::path(cmd.out_dir) / "results.json";
  if (!write_text_file("bench", results.string(), results_markdown(rows, rs, ctx.device_name(), training)) ||
      !write_text_file("bench", json.string(), results_json(rows, rs, ctx, training).dump(2) + "\n"))
    return false;
  std::printf("\n%s\n%s\nwrote %s, %s and the images beside them\n", table(rows).c_str(), stage_table(rows).c_str(),
              results.string().c_str(), json.string().c_str());
  return true;
}

}  // namespace

std::string bench_model_file(const std::string& object, const std::string& preset) {
  return preset == "default" ? object + ".lsnif" : object + "." + preset + ".lsnif";
}

int run_bench(int argc, char** argv, const BenchTrainer* trainer) {
  BenchCommand cmd;
  if (const std::optional<int> r = parse_command_line(argc, argv, trainer != nullptr, cmd)) return *r;
  if (!check_choices(cmd)) return 2;
  if (!trainer && cmd.models_dir.empty()) {
    std::fprintf(stderr, "lsnif bench: this program trains no models: --models DIR is required (a folder that "
                 "`lsnif bench --no-render --out DIR` prepared)\n");
    return 2;
  }
  if (cmd.no_render && !cmd.models_dir.empty()) {
    std::fprintf(stderr, "lsnif bench: --no-render with --models would do nothing: --no-render prepares models\n");
    return 2;
  }
  if (!check_inputs(cmd)) return 1;

  TrainOptions topt;
  render::RenderSettings rs;
  apply_bench_run_options(cmd.run, topt, rs);
  // Checked (and described for results.md) before any work.
  std::string training = "models prepared in " + cmd.models_dir;
  if (cmd.models_dir.empty() && !trainer->describe(topt, cmd.out_dir, cmd.run.quick, training)) return 2;

  if (!create_output_folder(cmd)) return 1;
  vk::Context ctx;
  if (!cmd.no_render && !init_device(cmd, ctx)) return 1;

  std::vector<SceneRow> rows;
  for (const std::string& name : cmd.scenes)
    if (int r = run_scene(ctx, cmd, trainer, name, topt, rs, rows)) return r;
  if (cmd.no_render) {
    std::printf("\nprepared the models of %zu scene(s) in %s (--no-render: nothing rendered)\n", cmd.scenes.size(),
                cmd.out_dir.c_str());
    return 0;
  }
  return write_report(cmd, rows, rs, ctx, training) ? 0 : 1;
}

int cmd_bench_prepared(int argc, char** argv) { return run_bench(argc, argv, nullptr); }

}  // namespace lsnif::cli
