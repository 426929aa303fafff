// trainer.h -- offline training of one LSNIF object (paper 5.2): fresh rays every step from the ray
// sampler, ground truth from Embree, sparse hash grid and MLP optimized jointly with Adam.
// Deterministic for a given seed and thread count.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "lsnif/format/config.h"
#include "lsnif/train/loss.h"
#include "lsnif/train/lr_schedule.h"
#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/train/optimizer.h"
#include "lsnif/train/ray_sampler.h"

namespace lsnif {

// The Config of `lsnif train`'s default model: Config{} (the paper's grid) with settings_table.h's
// grid bits (its indexed levels are TrainSettings::indexed).
inline Config default_model_config() {
  Config c;
  c.grid_bits = default_u32(SettingId::GridBits);
  return c;
}

// The defaults and ranges are those of settings_table.h; settings_io.h reads and writes them.
struct TrainSettings {
  Config config = default_model_config();
  // Levels whose table is indexed (Config::index_slots; the trainer builds the index from the voxels).
  bool indexed[LSNIF_MAX_LEVELS] = {default_indexed(0) != 0, default_indexed(1) != 0, default_indexed(2) != 0,
                                    default_indexed(3) != 0};
  // kSurfaceMapsAuto / On / Off (settings_table.h): whether config.surface_channels is set and
  // normal maps are baked, decided from the mesh's materials by surface_channels_for.
  uint32_t surface_maps = default_u32(SettingId::SurfaceMaps);
  // kTextureCoordinatesAuto / Off: which materials' hits report their texture coordinate, read from
  // uv cells built after training (config.uv_materials, decided from the mesh by choose_uv_materials,
  // uv_materials.h).
  uint32_t texture_coordinates = default_u32(SettingId::TextureCoordinates);
  uint32_t uv_cells = default_u32(SettingId::UvCells);  // Config::uv_cells when a material reports uvs
  uint32_t steps = default_u32(SettingId::Steps);
  uint32_t batch_size = default_u32(SettingId::Batch);  // paper: 2^18 on a GPU; see settings_table.h
  uint64_t seed = default_u64(SettingId::Seed);
  // Ground-truth reuse: each training ray serves this many steps on average, drawn at random from
  // a pool of ray_pool_size rays of which every step replaces batch / ray_reuse (1 = fresh rays
  // every step; trainer.cpp, draw_batch).
  uint32_t ray_reuse = default_u32(SettingId::RayReuse);
  uint32_t mlp_precision = default_u32(SettingId::MlpPrecision);  // kMlpPrecisionAuto / Bf16 / Fp32
  AdamSettings adam;               // adam.learning_rate: the rate the schedule starts from
  LrScheduleSettings lr_schedule;
  // The model kept: with a decay in (0, 1), the exponential moving average of the parameters over
  // the steps after lr_schedule.warm_fraction of them (ParameterAverage, optimizer.h), taken every
  // kAverageInterval-th step counted back from the last with the decay to that power; 0: the
  // parameters of the last step.
  float ema_decay = default_f32(SettingId::EmaDecay);
  LossSettings loss_settings;
  SamplerSettings sampler;
  float grid_init_range = default_f32(SettingId::GridInitRange);  // hash-table entries start in U(-range, range) (paper)
  // Seconds the training loop may take (0: no limit, `steps` steps): the run plans as many steps as
  // fit (at most `steps`) from the pace of its first ones, so that its learning-rate schedule spans
  // them, and stops at the budget should the pace slow (TrainReport::planned_steps, budget_cut).
  // At most kMaxTimeBudget.
  double time_budget = 0;
  bool loss_curve = false;         // true: TrainReport::loss_curve receives the loss curve (CSV)
  std::string describe() const;
};

// The parameters' average (TrainSettings::ema_decay) takes every 4th step: the steps of its ~100-step
// window differ little, and averaging all of them cost 1.5% of a default training's time.
inline constexpr uint32_t kAverageInterval = 4;

// The rays the trainer keeps with their ground truth for `batch` rays per step, each used
// `ray_reuse` times on average: the batch itself without reuse, else kRayPoolBatches batches (at
// most kRayPoolMaxRays, at least one batch), so that a ray's uses spread over about
// kRayPoolBatches * ray_reuse steps.
inline constexpr size_t kRayPoolBatches = 8, kRayPoolMaxRays = size_t(1) << 19;
inline size_t ray_pool_size(uint32_t batch, uint32_t ray_reuse) {
  if (ray_reuse <= 1) return batch;
  return std::max<size_t>(batch, std::min(kRayPoolBatches * batch, kRayPoolMaxRays));
}

// Whether a model of `mesh` learns surface channels (Config::surface_channels) under the setting
// `surface_maps` (kSurfaceMapsAuto: when a material has a metallic-roughness, emission or occlusion
// texture; kSurfaceMapsOn: always; kSurfaceMapsOff: never).
bool learns_surface_channels(const Mesh& mesh, uint32_t surface_maps);
// Whether the normal the network learns has the materials' normal maps applied (SurfaceSample::normal)
// under `surface_maps`: unless kSurfaceMapsOff.
inline bool bakes_normal_maps(uint32_t surface_maps) { return surface_maps != kSurfaceMapsOff; }

// Checks the mesh and the settings before any work, as train_model does first (a dry run or a plan
// refuses what training would): materials, the emission the surface channels can learn, the settings
// (check_train_settings, settings_io.h), and the config with the mesh's material count, surface
// channels and texture-coordinate materials, which `config` receives. `warnings` (when given)
// receives what the model will not learn as asked (a textured material left on learned colours).
Status check_training_inputs(const Mesh& mesh, const TrainSettings& settings, Config& config,
                             std::vector<std::string>* warnings = nullptr);

// The layout training `mesh` with `settings` starts from: the mesh's voxels (in its padded bounds)
// into `voxels`, and for the levels settings.indexed names the index built from them: `config` (in:
// settings.config or a copy of it) receives their table sizes, `grid_index` their displacements
// (index_grid_levels). Fails, naming the level, when an index cannot be built.
Status model_layout(const Mesh& mesh, const TrainSettings& settings, Config& config, VoxelGrid& voxels,
                    std::vector<uint16_t>& grid_index);

inline constexpr double kMaxTimeBudget = 7 * 86400.0;  // TrainSettings::time_budget: a week
// The most worker threads a caller may ask for (the tools' --threads, the Python module's threads;
// 0 = all cores). More than the cores only adds switching; far more exhausts the address space
// with thread stacks (each reserves megabytes).
inline constexpr uint32_t kMaxThreads = 256;

struct TrainReport {
  double seconds = 0;             // wall time of the training loop
  uint32_t steps = 0;             // steps run
  uint32_t planned_steps = 0;     // the steps the learning-rate schedule spanned (settings.steps without a budget)
  bool budget_cut = false;        // the time budget ran out before planned_steps
  double seconds_sampling = 0, seconds_encoding = 0, seconds_mlp = 0, seconds_loss = 0,
         seconds_optimizer = 0;
  uint64_t rays = 0;              // training rays used (batch x steps)
  uint64_t rays_cast = 0;         // of which fresh ones, with their ground truth (fewer with ray_reuse > 1)
  uint32_t occupied_voxels = 0;
  LossTerms final_loss;           // mean over the last 10% of steps
  // Textured materials the measurement after training left on learned colours (measure_uv_materials,
  // uv_materials.h), one line each: the tools print them as warnings.
  std::vector<std::string> uv_warnings;
  // With TrainSettings::loss_curve: "step,seconds,total,occlusion,...\n" and one row per step. The
  // trainer writes no file; the caller saves it next to the model.
  std::string loss_curve;
  double rays_per_second() const { return seconds > 0 ? double(rays) / seconds : 0.0; }
};

// Called after each step with (step index from 1, mean loss terms of that step, the model being
// trained: this step's fp32 parameters, not yet quantized nor averaged (TrainSettings::ema_decay));
// return false to stop early.
using TrainCallback = std::function<bool(uint32_t, const LossTerms&, const Model&)>;

// Voxelizes `mesh`, trains, and fills `model` (quantized to fp16, ready to save). The material
// table comes from the mesh (config.material_count is set from it). Training stops with an error
// as soon as a step's loss is not finite, and fails when the trained parameters are not finite or
// exceed the fp16 range of the model file (a diverged run, e.g. a learning rate far too high).
Status train_model(const Mesh& mesh, const TrainSettings& settings, Model& model,
                   TrainReport* report = nullptr, const TrainCallback& callback = nullptr);

}  // namespace lsnif
