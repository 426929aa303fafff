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
                r.preset.c_str(), render::pipeline_name(r.pipeline), count_text(r.triangles).c_str(),
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

}  // namespace

int cmd_bench(int argc, char** argv) {
  std::vector<std::string> names;
  std::string out_dir = "out/bench", data_dir = default_data_dir(), device, pipeline_name = "both",
              preset_names = "high,low", primary_name = "traced";
  BenchRunOptions run;
  Args args("bench",
            "The paper's Table 1 on the bundled scenes (docs/bench-scenes.md): builds each scene from the\n"
            "meshes and HDR images of scripts/setup.sh into OUT/SCENE/ (OUT = --out), trains its LSNIF models\n"
            "(reused when the mesh and settings are unchanged), renders it in reference and LSNIF mode, and\n"
            "writes OUT/results.md (memory, time per sample, FLIP) and OUT/SCENE.png (reference | LSNIF | FLIP).");
  std::string known;
  for (const std::string& n : bench_scene_names()) known += (known.empty() ? "" : ", ") + n;
  args.rest("SCENE", "scenes to run: " + known + " (default: all)", &names);
  args.option("out", "output folder", &out_dir);
  args.option("data", "folder with meshes/ and hdr/ from scripts/setup.sh", &data_dir);
  add_bench_run_options(args, &run);
  args.option("pipeline", "inline, wavefront or both (docs/renderer.md): the pipelines each scene is rendered with",
              &pipeline_name);
  args.option("quality", "the paper's configurations to train and compare, a list: high, low (Table 1's H and L)",
              &preset_names);
  add_primary_option(args, &primary_name);
  add_device_option(args, &device);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;

  std::vector<render::PathPipeline> pipelines;
  if (pipeline_name == "both") {
    pipelines = {render::PathPipeline::inline_rt, render::PathPipeline::wavefront};
  } else {
    render::PathPipeline one;
    if (!render::parse_pipeline(pipeline_name, one)) {
      std::fprintf(stderr, "lsnif bench: --pipeline must be inline, wavefront or both, not '%s'\n",
                   printable(pipeline_name).c_str());
      return 2;
    }
    pipelines = {one};
  }
  render::PrimaryVisibility primary;
  if (!parse_primary_option("bench", primary_name, primary)) return 2;
  std::vector<std::string> presets;
  for (size_t at = 0; at <= preset_names.size();) {
    const size_t comma = std::min(preset_names.find(',', at), preset_names.size());
    const std::string p = preset_names.substr(at, comma - at);
    if (p != "high" && p != "low") {
      std::fprintf(stderr, "lsnif bench: --quality takes a list of high and low, not '%s'\n", printable(p).c_str());
      return 2;
    }
    if (std::find(presets.begin(), presets.end(), p) == presets.end()) presets.push_back(p);
    at = comma + 1;
  }
  if (names.empty()) names = bench_scene_names();
  std::vector<std::string> scenes;
  for (const std::string& n : names) {
    bool ok = false;
    for (const std::string& k : bench_scene_names()) ok |= n == k;
    if (!ok) {
      std::fprintf(stderr, "lsnif bench: unknown scene '%s' (scenes: %s)\n", n.c_str(), known.c_str());
      return 2;
    }
    bool seen = false;
    for (const std::string& s : scenes) seen |= s == n;
    if (!seen) scenes.push_back(n);
  }
  if (!check_data_dir("bench", data_dir)) return 1;
  for (const std::string& n : scenes)
    for (const std::string& f : bench_scene_inputs(n, data_dir))
      if (!fs::is_regular_file(f)) {
        std::fprintf(stderr,
                     "lsnif bench: %s (needed by scene '%s') not found: run scripts/setup.sh first (it fetches "
                     "the meshes and HDR environments)\n", f.c_str(), n.c_str());
        return 1;
      }

  TrainOptions topt;
  render::RenderSettings rs;
  apply_bench_run_options(run, topt, rs);
  rs.primary = primary;
  // Checked (and described for results.md) before any work; to_settings wants an output name for
  // the loss-curve path it derives, nothing is written under it.
  TrainSettings train_settings;
  topt.output = (fs::path(out_dir) / "model.lsnif").string();
  if (!topt.to_settings(train_settings)) return 2;

  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec || !fs::is_directory(out_dir)) {
    std::fprintf(stderr, "lsnif bench: cannot create the output folder %s: %s\n", out_dir.c_str(),
                 ec ? ec.message().c_str() : "not a folder");
    return 1;
  }
  vk::ComputeContext ctx;
  // The wavefront pipeline's options include the inline one's (ray queries besides ray tracing).
  const bool wavefront = std::find(pipelines.begin(), pipelines.end(), render::PathPipeline::wavefront) != pipelines.end();
  if (Status s = ctx.init(render::context_options(wavefront ? render::PathPipeline::wavefront
                                                            : render::PathPipeline::inline_rt,
                                                  /*validation=*/false, device));
      !s) {
    std::fprintf(stderr, "lsnif bench: no usable Vulkan ray-tracing device (`lsnif devices` tells what is missing): %s\n",
                 s.message().c_str());
    return 1;
  }

  std::vector<SceneRow> rows;
  for (const std::string& name : scenes) {
    std::printf("\n== scene %s\n", name.c_str());
    std::fflush(stdout);
    BenchScene bench;
    if (Status s = make_bench_scene(name, data_dir, bench); !s) {
      std::fprintf(stderr, "lsnif bench: %s\n", s.message().c_str());
      return 1;
    }
    SceneRow base;
    base.name = name;
    base.summary = bench.summary;
    base.triangles = object_triangles(bench);
    const fs::path dir = fs::path(out_dir) / name;
    fs::create_directories(dir, ec);
    const fs::path gltf = dir / (name + ".gltf"), scene_key = dir / "scene.key";
    const std::string fingerprint = scene_fingerprint(bench) + "\n";
    if (fs::is_regular_file(gltf) && read_text_file(scene_key.string()) == fingerprint) {
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

    // The reference render of each pipeline, shared by the quality rows (it traces only meshes).
    std::map<render::PathPipeline, ReferenceRender> references;
    for (const std::string& preset : presets) {
      SceneRow models = base;
      models.preset = preset;
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
                                   o.name + " (" + o.origin + ", " + preset + " quality)", mo, run.retrain, cached))
          return r;
        m.reused = cached.reused;
        m.train_seconds = cached.train_seconds;
        models.models.push_back(m);
      }

      // The scene file names the high models; the low rows trace the low ones in their place.
      scene::SceneLoadOptions lo;
      scene::Scene sc;
      if (Status s = scene::load_scene(gltf.string(), lo, sc); !s) {
        std::fprintf(stderr, "lsnif bench: %s\n", s.message().c_str());
        return 1;
      }
      for (scene::LsnifObject& obj : sc.lsnif_objects) {
        const fs::path high(obj.resolved_path);
        obj.resolved_path = (high.parent_path() / model_file(high.stem().string(), preset)).string();
      }
      for (const render::PathPipeline pipeline : pipelines) {
        SceneRow row = models;
        if (pipeline != pipelines.front()) row.models.clear();  // listed once per preset
        row.pipeline = pipeline;
        row.image = name + (preset == "high" ? "" : "." + preset) + "." + render::pipeline_name(pipeline) + ".png";
        render::RenderSettings prs = rs;
        prs.pipeline = pipeline;
        prs.stage_times = pipeline == render::PathPipeline::wavefront;
        std::printf("\n-- %s, %s quality, %s pipeline\n", name.c_str(), preset.c_str(), render::pipeline_name(pipeline));
        std::fflush(stdout);
        if (Status s = render_compare(ctx, sc, prs, (fs::path(out_dir) / row.image).string(), row.cmp,
                                  &references[pipeline]);
            !s) {
          std::fprintf(stderr, "lsnif bench: scene %s: %s\n", name.c_str(), s.message().c_str());
          return 1;
        }
        rows.push_back(std::move(row));
      }
    }
  }

  const std::string training =
      format("%s%s", run.quick ? "--quick: " : "", train_settings.describe().c_str());
  const fs::path results = fs::path(out_dir) / "results.md";
  if (!write_text_file("bench", results.string(), results_markdown(rows, rs, ctx.device_name(), training))) {
    std::fprintf(stderr, "lsnif bench: cannot write %s\n", results.string().c_str());
    return 1;
  }
  std::printf("\n%s\n%s\nwrote %s and the images beside it\n", table(rows).c_str(), stage_table(rows).c_str(),
              results.string().c_str());
  return 0;
}

}  // namespace lsnif::cli
