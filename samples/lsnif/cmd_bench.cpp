// lsnif bench [SCENE...]: the paper's Table 1 on the bundled scenes (bench_scenes.h,
// docs/bench-scenes.md). Per scene: build it into OUT/SCENE/ (glTF with the LSNIF extensions) when
// missing or changed, train every unique model it needs (or reuse one trained from the same mesh
// with the same settings), render it in reference and LSNIF mode with the same random sequences
// (render_compare.h), and report LSNIF count, LSNIF memory against the triangle BLAS it replaces,
// time per sample of both modes and the LDR-FLIP of the LSNIF image. Writes OUT/results.md and
// OUT/SCENE.png (reference | LSNIF | FLIP heatmap).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "args.h"
#include "atomic_file.h"
#include "bench_scenes.h"
#include "commands.h"
#include "data_dir.h"
#include "device_option.h"
#include "pipeline_option.h"
#include "render_compare.h"
#include "scene_gltf.h"
#include "train_options.h"
#include "vk_compute.h"

namespace lsnif::cli {

namespace {

namespace fs = std::filesystem;

struct ModelRow {
  std::string name, origin;
  uint64_t triangles = 0;
  bool reused = false;
  double train_seconds = 0;
};

struct SceneRow {
  std::string name, summary, image;
  uint64_t triangles = 0;  // instanced triangles of the LSNIF objects
  CompareReport cmp;
  std::vector<ModelRow> models;
};

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool write_text(const fs::path& path, const std::string& text) {
  const Status s = write_file_atomic(path.string(), text);
  if (!s) std::fprintf(stderr, "lsnif bench: %s\n", s.message().c_str());
  return bool(s);
}

std::string count_text(uint64_t n) {
  if (n >= 1000000) return format("%.2fM", double(n) / 1e6);
  if (n >= 1000) return format("%.1fk", double(n) / 1e3);
  return std::to_string(n);
}

double mib(uint64_t bytes) { return double(bytes) / 1048576.0; }

// Triangle BLAS memory of the LSNIF objects' meshes: what reference mode builds beyond LSNIF mode
// (both build the same ground).
uint64_t object_blas_bytes(const CompareReport& c) {
  return c.reference.triangle_blas_bytes > c.lsnif.triangle_blas_bytes
             ? c.reference.triangle_blas_bytes - c.lsnif.triangle_blas_bytes
             : 0;
}

std::string table(const std::vector<SceneRow>& rows) {
  std::string t =
      "| Scene | Tris (LSNIF objects) | LSNIF count | LSNIF (MiB) | triangle BLAS (MiB) | BLAS / LSNIF | "
      "T LSNIF (ms/spp) | T reference (ms/spp) | T LSNIF / T reference | FLIP mean |\n"
      "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const SceneRow& r : rows) {
    const render::RenderStats& l = r.cmp.lsnif;
    const render::RenderStats& ref = r.cmp.reference;
    const uint64_t blas = object_blas_bytes(r.cmp);
    t += format("| %s | %s | %u (%u) | %.3f | %.3f | %.2f | %.1f | %.1f | %.2f | %.4f |\n", r.name.c_str(),
                count_text(r.triangles).c_str(), l.lsnif_instances, l.lsnif_models, mib(l.lsnif_bytes), mib(blas),
                l.lsnif_bytes ? double(blas) / double(l.lsnif_bytes) : 0.0, l.ms_per_sample, ref.ms_per_sample,
                ref.ms_per_sample > 0 ? l.ms_per_sample / ref.ms_per_sample : 0.0, r.cmp.flip_mean);
  }
  return t;
}

std::string results_markdown(const std::vector<SceneRow>& rows, const render::RenderSettings& rs,
                             const std::string& device, const std::string& training) {
  std::string md = "# lsnif bench: LSNIF vs triangles on the bundled scenes (like Table 1 of the paper)\n\n";
  md += format("Device: %s. Images %ux%u, %u samples per pixel, %u bounces, %s pipeline. Training: %s.\n\n",
               device.c_str(), rs.width, rs.height, rs.spp, rs.max_bounces, render::pipeline_name(rs.pipeline),
               training.c_str());
  md += table(rows);
  md += "\nLSNIF count: LSNIF instances (unique models). LSNIF: device memory of the models (model block + AABB "
        "BLAS). Triangle BLAS: the BLASes of the same objects' meshes in reference mode (one per unique mesh, "
        "instances share it). T: wall time per sample per pixel (one path per pixel), the first pass excluded. "
        "FLIP: mean LDR-FLIP of the LSNIF image against the reference (same random numbers).\n";
  md += "\n## Models\n\n| Scene | model | mesh | triangles | training |\n|---|---|---|---:|---|\n";
  for (const SceneRow& r : rows)
    for (const ModelRow& m : r.models) {
      const std::string how = m.reused ? "reused (same mesh and settings)" : format("%.0f s", m.train_seconds);
      md += format("| %s | %s.lsnif | %s | %s | %s |\n", r.name.c_str(), m.name.c_str(), m.origin.c_str(),
                   count_text(m.triangles).c_str(), how.c_str());
    }
  md += "\n## Images (reference | LSNIF | FLIP)\n";
  for (const SceneRow& r : rows)
    md += format("\n%s: %s\n\n![%s](%s)\n", r.name.c_str(), r.summary.c_str(), r.name.c_str(), r.image.c_str());
  return md;
}

}  // namespace

int cmd_bench(int argc, char** argv) {
  std::vector<std::string> names;
  std::string out_dir = "out/bench", data_dir = default_data_dir(), device, pipeline_name = "inline";
  uint32_t width = 0, height = 0, spp = 0, steps = 0, batch = 0, threads = 0;
  uint64_t seed = 1;
  bool quick = false, retrain = false;
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
  args.option("width", "image width (0: 320, --quick 64)", &width);
  args.option("height", "image height (0: 240, --quick 48)", &height);
  args.option("spp", "samples per pixel (0: 16, --quick 2)", &spp);
  args.option("steps", "training steps (0: 2000, --quick 30)", &steps);
  args.option("batch", "training rays per step (0: the default of lsnif train, --quick 1024)", &batch);
  args.option("seed", "training seed", &seed);
  args.option("threads", "training threads (0 = all cores)", &threads);
  args.flag("quick", "tiny models (V=16, 2^12-entry grid, 32-wide MLP, 30 steps) and tiny images: seconds, for tests",
            &quick);
  args.flag("retrain", "train every model even when a matching one exists", &retrain);
  add_pipeline_option(args, &pipeline_name);
  add_device_option(args, &device);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;

  render::PathPipeline pipeline;
  if (!parse_pipeline_option("bench", pipeline_name, pipeline)) return 2;
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
  rs.width = 320;
  rs.height = 240;
  rs.spp = 16;
  rs.pipeline = pipeline;
  const auto set = [&topt](SettingId id, uint64_t value) { topt.given.set(id, {.u = value}); };
  if (quick) {
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
  if (steps) set(SettingId::Steps, steps);
  if (batch) set(SettingId::Batch, batch);
  if (width) rs.width = width;
  if (height) rs.height = height;
  if (spp) rs.spp = spp;
  set(SettingId::Seed, seed);
  topt.threads = threads;
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
  if (Status s = ctx.init(render::context_options(pipeline, /*validation=*/false, device)); !s) {
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
    SceneRow row;
    row.name = name;
    row.summary = bench.summary;
    row.triangles = object_triangles(bench);
    const fs::path dir = fs::path(out_dir) / name;
    fs::create_directories(dir, ec);
    const fs::path gltf = dir / (name + ".gltf"), scene_key = dir / "scene.key";
    const std::string fingerprint = scene_fingerprint(bench) + "\n";
    if (fs::is_regular_file(gltf) && read_text(scene_key) == fingerprint) {
      std::printf("scene     reusing %s (unchanged)\n", gltf.string().c_str());
    } else {
      if (Status s = write_bench_scene(bench, dir.string()); !s) {
        std::fprintf(stderr, "lsnif bench: scene %s: %s\n", name.c_str(), s.message().c_str());
        return 1;
      }
      if (!write_text(scene_key, fingerprint)) {
        std::fprintf(stderr, "lsnif bench: cannot write %s\n", scene_key.string().c_str());
        return 1;
      }
      std::printf("scene     wrote %s: %s\n", gltf.string().c_str(), bench.summary.c_str());
    }
    std::fflush(stdout);

    for (const BenchObject& o : bench.objects) {
      ModelRow m;
      m.name = o.name;
      m.origin = o.origin;
      m.triangles = o.mesh.triangles.size();
      TrainOptions mo = topt;
      mo.output = (dir / (o.name + ".lsnif")).string();
      const fs::path key_path = mo.output + ".key";
      TrainSettings ts;
      if (!mo.to_settings(ts)) return 2;
      const std::string key = "mesh " + object_fingerprint(o) + "\nsettings " + ts.describe() + "\n";
      if (!retrain && scene::check_lsnif_file(mo.output) && read_text(key_path) == key) {
        m.reused = true;
        std::printf("model     reusing %s (same mesh and settings; --retrain trains it again)\n", mo.output.c_str());
      } else {
        std::printf("model     training %s for %s (%zu triangles)\n", mo.output.c_str(), o.name.c_str(),
                    o.mesh.triangles.size());
        std::fflush(stdout);
        TrainReport rep;
        if (int r = train_mesh(o.mesh, o.name + " (" + o.origin + ")", mo, nullptr, &rep)) return r;
        if (!write_text(key_path, key)) {
          std::fprintf(stderr, "lsnif bench: cannot write %s\n", key_path.string().c_str());
          return 1;
        }
        m.train_seconds = rep.seconds;
      }
      row.models.push_back(m);
    }

    scene::SceneLoadOptions lo;
    scene::Scene sc;
    if (Status s = scene::load_scene(gltf.string(), lo, sc); !s) {
      std::fprintf(stderr, "lsnif bench: %s\n", s.message().c_str());
      return 1;
    }
    row.image = name + ".png";
    std::fflush(stdout);
    if (Status s = render_compare(ctx, sc, rs, (fs::path(out_dir) / row.image).string(), row.cmp); !s) {
      std::fprintf(stderr, "lsnif bench: scene %s: %s\n", name.c_str(), s.message().c_str());
      return 1;
    }
    rows.push_back(std::move(row));
  }

  const std::string training =
      format("%s%s", quick ? "--quick: " : "", train_settings.describe().c_str());
  const fs::path results = fs::path(out_dir) / "results.md";
  if (!write_text(results, results_markdown(rows, rs, ctx.device_name(), training))) {
    std::fprintf(stderr, "lsnif bench: cannot write %s\n", results.string().c_str());
    return 1;
  }
  std::printf("\n%s\nwrote %s and the images beside it\n", table(rows).c_str(), results.string().c_str());
  return 0;
}

}  // namespace lsnif::cli
