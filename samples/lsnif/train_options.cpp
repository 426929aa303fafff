#include "train_options.h"

#include <omp.h>

#include <cmath>
#include <cstdio>
#include <utility>

#include "atomic_file.h"
#include "mesh.h"

namespace lsnif::cli {

void TrainOptions::add_to(Args& args, const char* output_help) {
  args.alias("-o", "output");
  args.option("output", output_help, &output);
  args.option("voxels", "voxel resolution V", &voxels);
  args.option("points", "max boundary points H", &points);
  args.option("levels", "hash-grid levels L", &levels);
  args.option("res-min", "coarsest grid resolution", &res_min);
  args.option("res-max", "finest grid resolution", &res_max);
  args.option("table-log2", "log2 hash-table entries per level M", &table_log2);
  args.option("features", "features per entry F", &features);
  args.option("width", "hidden layer width W", &width);
  args.option("layers", "hidden layers", &layers);
  args.option("steps", "training steps", &steps);
  args.option("batch", "rays per step", &batch);
  args.option("seed", "random seed", &seed);
  args.option("lr", "Adam learning rate", &lr);
  args.option("hit", "hit distance parametrization: segments (ours) or aabb (paper)", &hit);
  args.option("ray-reuse", "steps each training ray is used in (1 = fresh rays every step)", &ray_reuse);
  args.option("normal-loss", "normal loss: angle (ours) or cosine (paper)", &normal_loss);
  args.option("threads", "worker threads (0 = all cores)", &threads);
  args.option("csv", "loss curve CSV (default: MODEL.csv)", &csv);
  args.option("w-occlusion", "loss weight of occlusion", &loss.occlusion);
  args.option("w-distance", "loss weight of hit distance", &loss.distance);
  args.option("w-normal", "loss weight of the normal", &loss.normal);
  args.option("w-albedo", "loss weight of albedo", &loss.albedo);
  args.option("w-material", "loss weight of the material", &loss.material);
  args.option("quality", "the paper's configuration: high (default widths) or low (--width 64 --points 10)", &quality);
  args.flag("paper", "paper settings: batch 2^18, hit=aabb, normal-loss=cosine, ray-reuse=1 (slow on a CPU)",
            &paper);
  args.flag("quiet", "no progress bar", &quiet);
  add_import_flags(args, &import_options);
}

void add_import_flags(Args& args, MeshImportOptions* options, bool meshes) {
  args.flag("allow-outside-refs",
            "let files the input refers to (buffers, images, mtllib, models, HDR) lie outside its folder",
            &options->allow_outside_refs);
  if (meshes)
    args.flag("allow-dropped-triangles", "import a mesh even when most of its triangles are degenerate or invalid",
              &options->allow_dropping_most);
}

bool TrainOptions::to_settings(TrainSettings& s) const {
  // The options' own ranges first, named as the user typed them (the checks below divide by the
  // voxel resolution and compare with the batch).
  if (voxels < 1 || voxels > 256) {
    std::fprintf(stderr, "lsnif: --voxels %u out of range [1, 256]\n", voxels);
    return false;
  }
  if (steps < 1 || batch < 1) {
    std::fprintf(stderr, "lsnif: --steps (%u) and --batch (%u) must be at least 1\n", steps, batch);
    return false;
  }
  if (!(lr > 0.0f) || !std::isfinite(lr)) {
    std::fprintf(stderr, "lsnif: --lr %g must be a positive, finite learning rate\n", double(lr));
    return false;
  }
  const std::pair<const char*, float> weights[] = {{"--w-occlusion", loss.occlusion}, {"--w-distance", loss.distance},
                                                   {"--w-normal", loss.normal}, {"--w-albedo", loss.albedo},
                                                   {"--w-material", loss.material}};
  float weight_sum = 0.0f;
  for (const auto& [name, w] : weights) {
    if (!(w >= 0.0f) || !std::isfinite(w)) {
      std::fprintf(stderr, "lsnif: %s %g must be a finite weight >= 0\n", name, double(w));
      return false;
    }
    weight_sum += w;
  }
  if (!(weight_sum > 0.0f)) {
    std::fprintf(stderr, "lsnif: every loss weight (--w-*) is 0: nothing would be trained\n");
    return false;
  }
  Config& c = s.config;
  c.voxel_resolution = voxels;
  c.max_points = points;
  c.grid_levels = levels;
  if (levels < 1 || levels > LSNIF_MAX_LEVELS) {
    std::fprintf(stderr, "lsnif: --levels %u out of range [1, %u]\n", levels, LSNIF_MAX_LEVELS);
    return false;
  }
  if (res_min < 1 || res_max < res_min) {
    std::fprintf(stderr, "lsnif: need 1 <= --res-min <= --res-max (got %u, %u)\n", res_min, res_max);
    return false;
  }
  if (res_min % voxels || res_max % voxels) {
    std::fprintf(stderr,
                 "lsnif: --res-min %u and --res-max %u must each be a multiple of the voxel resolution %u "
                 "(voxel faces must lie on grid planes)\n", res_min, res_max, voxels);
    return false;
  }
  uint32_t hidden_width = width, max_points = points;
  if (quality == "low") {
    const TrainOptions defaults;
    if (width != defaults.width || points != defaults.points) {
      std::fprintf(stderr, "lsnif: --quality low sets --width %u and --points %u; give either --quality or those\n",
                   kLowQualityWidth, kLowQualityPoints);
      return false;
    }
    hidden_width = kLowQualityWidth;
    max_points = kLowQualityPoints;
  } else if (quality != "high") {
    std::fprintf(stderr, "lsnif: --quality must be 'high' or 'low' (got '%s')\n", quality.c_str());
    return false;
  }
  c.max_points = max_points;
  set_grid_resolutions(c, res_min, res_max);
  c.log2_table_size = table_log2;
  c.features = features;
  c.hidden_width = hidden_width;
  c.hidden_layers = layers;
  if (hit == "segments") {
    c.hit_param = HitParam::VoxelSegments;
  } else if (hit == "aabb") {
    c.hit_param = HitParam::AabbInterval;
  } else {
    std::fprintf(stderr, "lsnif: --hit must be 'segments' or 'aabb' (got '%s')\n", hit.c_str());
    return false;
  }
  s.steps = steps;
  s.batch_size = batch;
  s.ray_reuse = ray_reuse;
  s.seed = seed;
  s.loss_settings = loss;
  if (normal_loss == "angle") {
    s.loss_settings.normal_loss = NormalLoss::Angle;
  } else if (normal_loss == "cosine") {
    s.loss_settings.normal_loss = NormalLoss::Cosine;
  } else {
    std::fprintf(stderr, "lsnif: --normal-loss must be 'angle' or 'cosine' (got '%s')\n", normal_loss.c_str());
    return false;
  }
  if (paper) {
    s.batch_size = 1u << 18;
    c.hit_param = HitParam::AabbInterval;
    s.loss_settings.normal_loss = NormalLoss::Cosine;
    s.ray_reuse = 1;
  }
  if (s.ray_reuse < 1 || s.ray_reuse > s.batch_size) {
    std::fprintf(stderr, "lsnif: --ray-reuse %u must be in [1, --batch %u]\n", s.ray_reuse, s.batch_size);
    return false;
  }
  s.adam.learning_rate = lr;
  s.progress = !quiet;
  s.loss_curve = true;
  if (Status st = c.validate(); !st) {
    std::fprintf(stderr, "lsnif: invalid model settings: %s\n", st.message().c_str());
    return false;
  }
  return true;
}

namespace {

// The model and the CSV can be written, and neither is the mesh or the other: checked before the
// work, so that a bad -o fails in a second, not after the training.
int check_outputs(const TrainOptions& opts, const std::string& mesh_path) {
  const std::string csv = opts.csv_path();
  Status s = check_not_an_input(opts.output, "-o", {mesh_path});
  if (s) s = check_not_an_input(csv, "--csv", {mesh_path, opts.output});
  if (s && csv == opts.output) s = Status::error("--csv and -o name the same file '%s'", csv.c_str());
  if (s) s = check_output_path(opts.output).context("-o");
  if (s) s = check_output_path(csv).context("--csv");
  if (!s) {
    std::fprintf(stderr, "lsnif: %s\n", s.message().c_str());
    return 1;
  }
  return 0;
}

}  // namespace

int run_training(const std::string& mesh_path, const TrainOptions& opts, Model* trained) {
  TrainSettings settings;
  if (!opts.to_settings(settings)) return 2;
  if (int r = check_outputs(opts, mesh_path)) return r;
  Mesh mesh;
  MeshImportReport import;
  if (Status s = load_mesh(mesh_path, mesh, &import, opts.import_options); !s) {
    std::fprintf(stderr, "lsnif: %s\n", s.message().c_str());
    return 1;
  }
  for (const std::string& w : import.warnings) std::fprintf(stderr, "lsnif: warning: %s\n", w.c_str());
  return train_mesh(mesh, mesh_path, opts, trained);
}

int train_mesh(const Mesh& mesh, const std::string& label, const TrainOptions& opts, Model* trained,
               TrainReport* report) {
  TrainSettings settings;
  if (!opts.to_settings(settings)) return 2;
  if (int r = check_outputs(opts, "")) return r;
  if (opts.threads) omp_set_num_threads(int(opts.threads));
  std::printf("mesh      %s: %zu triangles, %zu materials\n", label.c_str(), mesh.triangles.size(),
              mesh.materials.size());
  std::printf("settings  %s (%d threads)\n", settings.describe().c_str(), omp_get_max_threads());
  std::fflush(stdout);
  Model model;
  TrainReport rep;
  if (Status s = train_model(mesh, settings, model, &rep); !s) {
    std::fprintf(stderr, "lsnif: training failed: %s\n", s.message().c_str());
    return 1;
  }
  if (Status s = save_model(model, opts.output); !s) {
    std::fprintf(stderr, "lsnif: %s\n", s.message().c_str());
    return 1;
  }
  if (Status s = write_file_atomic(opts.csv_path(), rep.loss_curve); !s) {
    std::fprintf(stderr, "lsnif: loss curve: %s\n", s.message().c_str());
    return 1;
  }
  const MemoryBreakdown mem = memory_breakdown(model);
  std::printf("trained   %u steps x %u rays in %.1f s (%.0f rays/s): sampling %.1f s, encoding %.1f s, "
              "MLP %.1f s, loss %.1f s, Adam %.1f s\n",
              settings.steps, settings.batch_size, rep.seconds, rep.rays_per_second(), rep.seconds_sampling,
              rep.seconds_encoding, rep.seconds_mlp, rep.seconds_loss, rep.seconds_optimizer);
  std::printf("loss      final %.4f (occlusion %.4f distance %.4f normal %.4f albedo %.4f material %.4f)\n",
              rep.final_loss.total(), rep.final_loss.occlusion, rep.final_loss.distance, rep.final_loss.normal,
              rep.final_loss.albedo, rep.final_loss.material);
  std::printf("wrote     %s (%.3f MiB, %u occupied voxels) and %s\n", opts.output.c_str(), double(mem.total()) / 1048576.0,
              rep.occupied_voxels, opts.csv_path().c_str());
  std::fflush(stdout);
  if (trained) *trained = std::move(model);
  if (report) *report = rep;
  return 0;
}

}  // namespace lsnif::cli
