// settings_table.h -- the one definition of every setting of a trained model: its name (the flag
// `--NAME` of `lsnif train` / `lsnif convert` and the key of `--config` files and of the settings
// recorded in a model), default, range and help text, and the presets (--quality, --paper, --tiny)
// as lists of values. Config (config.h), TrainSettings and its parts (src/lsnif/train/) and the command line
// take their defaults and ranges from here; src/lsnif/train/settings_io.h reads and writes the values.
// Plain constexpr data, no dependencies beyond the shader limits.
#pragma once
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <limits>
#include <string_view>

#include "lsnif/host_device.h"

namespace lsnif {

enum class SettingKind : uint8_t {
  U32,     // unsigned integer in [min, max]
  U32PerLevel,  // U32 for every grid level, or a list of one per level (each in [min, max])
  U64,     // any unsigned 64-bit integer (min, max unused)
  F32,     // finite float in [min, max], either end open with min_open / max_open
  Choice,  // one of `choices` by name; the value is the choice's `value`
};

struct SettingChoice {
  const char* name;
  uint32_t value;
};

// In table order (kSettingDefs[i].id == i).
enum class SettingId : uint32_t {
  Voxels, Points, Levels, ResMin, ResMax, TableLog2, Features, Width, Layers, Hit, LeakySlope, GridBits, Indexed,
  SurfaceMaps, TextureCoordinates, UvCells,
  Steps, Batch, Seed, RayReuse, MlpPrecision, Lr, LrSchedule, LrFinal, LrWarm, AdamBeta1, AdamBeta2, AdamEpsilon,
  EmaDecay, NormalLoss,
  WOcclusion, WDistance, WNormal, WAlbedo, WMaterial, WSurface,
  SurfaceFraction, SphereScale, SurfaceOffset, SurfaceRays, GridInitRange,
  Count
};
inline constexpr size_t kSettingCount = static_cast<size_t>(SettingId::Count);

struct SettingDef {
  SettingId id;
  const char* name;
  SettingKind kind;
  double def, min, max;  // Choice: def is a choice's value
  bool min_open, max_open;
  const SettingChoice* choices;
  uint32_t choice_count;
  const char* noun;  // F32 with an open upper end: what the value is, for messages ("learning rate")
  const char* help;
};

inline constexpr SettingChoice kHitChoices[] = {{"segments", LSNIF_HIT_PARAM_VOXEL_SEGMENTS},
                                                {"aabb", LSNIF_HIT_PARAM_AABB_INTERVAL}};
// Bits per stored hash-grid feature: fp16, or int8 codes times one fp32 scale per level.
inline constexpr SettingChoice kGridBitsChoices[] = {{"16", 16}, {"8", 8}};
// The precision of the training's products of every layer but the output layer (MlpTrace::bf16_layers,
// src/lsnif/core/network.h): auto: bf16 where the CPU has bf16 instructions (AVX512_BF16 in the
// build's kernel), else fp32; bf16: an error where it has not; fp32 everywhere. Inference is fp32.
inline constexpr uint32_t kMlpPrecisionAuto = 0, kMlpPrecisionBf16 = 1, kMlpPrecisionFp32 = 2;
inline constexpr SettingChoice kMlpPrecisionChoices[] = {
    {"auto", kMlpPrecisionAuto}, {"bf16", kMlpPrecisionBf16}, {"fp32", kMlpPrecisionFp32}};
// NormalLoss (src/lsnif/train/loss.h) values.
inline constexpr SettingChoice kNormalLossChoices[] = {{"angle", 1}, {"cosine", 0}};
// What the model learns of the mesh's material textures (SurfaceMaps, src/lsnif/train/trainer.h):
// auto: surface channels when a material has a metallic-roughness, occlusion or emissive texture,
// and normal maps baked into the normal; on: surface channels always (and normal maps baked); off:
// base colour only (the albedo), every other texture ignored.
inline constexpr uint32_t kSurfaceMapsOff = 0, kSurfaceMapsOn = 1, kSurfaceMapsAuto = 2;
inline constexpr SettingChoice kSurfaceMapsChoices[] = {
    {"auto", kSurfaceMapsAuto}, {"on", kSurfaceMapsOn}, {"off", kSurfaceMapsOff}};
// Which materials' hits report their texture coordinate (read from uv cells) instead of learned colours
// (TextureCoordinates, src/lsnif/train/uv_materials.h): auto: every textured material whose uv layout
// allows it (the renderer samples the material's own textures there); off: none.
inline constexpr uint32_t kTextureCoordinatesOff = 0, kTextureCoordinatesAuto = 1;
inline constexpr SettingChoice kTextureCoordinatesChoices[] = {{"auto", kTextureCoordinatesAuto},
                                                               {"off", kTextureCoordinatesOff}};
// LrSchedule (src/lsnif/train/lr_schedule.h) values.
inline constexpr SettingChoice kLrScheduleChoices[] = {{"constant", 0}, {"exponential", 1}, {"cosine", 2}};

inline constexpr double kU32Max = std::numeric_limits<uint32_t>::max();
inline constexpr uint32_t kMaxGridResolution = 4096;
inline constexpr double kF32Max = std::numeric_limits<float>::max();

namespace setting_detail {
constexpr SettingDef u32(SettingId id, const char* name, uint32_t def, uint32_t min, uint32_t max, const char* help) {
  return {id, name, SettingKind::U32, double(def), double(min), double(max), false, false, nullptr, 0, "", help};
}
constexpr SettingDef u32_per_level(SettingId id, const char* name, uint32_t def, uint32_t min, uint32_t max,
                                   const char* help) {
  return {id, name, SettingKind::U32PerLevel, double(def), double(min), double(max), false, false, nullptr, 0, "",
          help};
}
constexpr SettingDef f32(SettingId id, const char* name, double def, double min, bool min_open, double max,
                         bool max_open, const char* noun, const char* help) {
  return {id, name, SettingKind::F32, def, min, max, min_open, max_open, nullptr, 0, noun, help};
}
template <size_t N>
constexpr SettingDef choice(SettingId id, const char* name, uint32_t def, const SettingChoice (&c)[N],
                            const char* help) {
  return {id, name, SettingKind::Choice, double(def), 0, 0, false, false, c, uint32_t(N), "", help};
}
}  // namespace setting_detail

inline constexpr SettingDef kSettingDefs[] = {
    // The model (Config, stored in the .lsnif header).
    setting_detail::u32(SettingId::Voxels, "voxels", 32, 1, 256, "voxel resolution V"),
    setting_detail::u32(SettingId::Points, "points", 18, 1, LSNIF_MAX_POINTS, "max boundary points H"),
    setting_detail::u32(SettingId::Levels, "levels", 2, 1, LSNIF_MAX_LEVELS, "hash-grid levels L"),
    setting_detail::u32(SettingId::ResMin, "res-min", 64, 1, kMaxGridResolution,
                        "coarsest grid resolution (a multiple of the voxel resolution)"),
    setting_detail::u32(SettingId::ResMax, "res-max", 128, 1, kMaxGridResolution,
                        "finest grid resolution (a multiple of the voxel resolution)"),
    setting_detail::u32_per_level(SettingId::TableLog2, "table-log2", 17, 4, 24,
                                  "log2 hash-table entries M of every level, or a comma list of one per level "
                                  "(e.g. 15,17)"),
    setting_detail::u32(SettingId::Features, "features", 3, 1, LSNIF_MAX_FEATURES, "features per entry F"),
    // The paper's 128. Narrower networks on the default grid (64: 37% of the FLOPs; 96 with H=14:
    // 58%) matched the former default on one seed but lost t error, occlusion or FLIP on the dragon
    // with a second (docs/results.md, "The network's cost").
    setting_detail::u32(SettingId::Width, "width", 128, 1, LSNIF_MAX_HIDDEN_WIDTH, "hidden layer width W"),
    setting_detail::u32(SettingId::Layers, "layers", 2, 1, LSNIF_MAX_HIDDEN_LAYERS, "hidden layers"),
    setting_detail::choice(SettingId::Hit, "hit", LSNIF_HIT_PARAM_VOXEL_SEGMENTS, kHitChoices,
                           "hit distance parametrization: segments (ours) or aabb (paper)"),
    setting_detail::f32(SettingId::LeakySlope, "leaky-slope", 0.01, 0, false, 1, true, "",
                        "leaky ReLU negative slope"),
    // The default grid, 8-bit with the coarsest level indexed, is 2.5-2.8x smaller than the paper's
    // (fp16, both levels hashed: `--paper`) and better on every eval metric and FLIP on the bunny,
    // the armadillo and the dragon (docs/results.md, "An indexed coarse level").
    setting_detail::choice(SettingId::GridBits, "grid-bits", 8, kGridBitsChoices,
                           "bits per stored hash-grid feature: 8 (int8 times a per-level scale) or 16 (fp16, the "
                           "paper's: twice the grid's bytes)"),
    // Per level (default_indexed): the coarsest level indexed, the finer ones hashed.
    setting_detail::u32_per_level(SettingId::Indexed, "indexed", 1, 0, 1,
                                  "1: the level's table is indexed (a perfect hash of the grid vertices the model "
                                  "can read: no collisions, sized to the mesh), 0: hashed into 2^table-log2 entries "
                                  "(the paper's); one value for every level or a comma list of one per level; by "
                                  "default the coarsest level indexed, the others hashed"),
    setting_detail::choice(SettingId::SurfaceMaps, "surface-maps", kSurfaceMapsAuto, kSurfaceMapsChoices,
                           "what the model learns of the material textures: auto (metallic, roughness, occlusion "
                           "and emission as extra network outputs when a material has such a texture, normal maps "
                           "baked into the normal), on (those outputs always), off (base colour only)"),
    // auto: on four textured assets made elsewhere (docs/convert.md, "Textures at full detail") the
    // framed views' FLIP fell from 0.033-0.126 (learned colours) to 0.031-0.105 and close-ups' from
    // 0.106-0.144 to 0.066-0.070, at 1.5-2x the model's bytes (the textures the hits sample are kept).
    setting_detail::choice(SettingId::TextureCoordinates, "texture-coordinates", kTextureCoordinatesAuto,
                           kTextureCoordinatesChoices,
                           "auto: hits of every textured material whose uv layout allows it report the texture "
                           "coordinate of the predicted hit point, read from uv cells stored with the model (a "
                           "renderer samples the material's own textures there, at full detail); off: learned "
                           "colours only"),
    // 2: on the spider's close-up the albedo image's FLIP was 0.052 (4: 0.044 at ~4x the cells' bytes,
    // 1: 0.064; learned colours 0.096) (docs/convert.md, "Textures at full detail").
    setting_detail::u32(SettingId::UvCells, "uv-cells", 2, 1, 4,
                        "uv cells per voxel edge: where the texture coordinate of a hit is read (with "
                        "--texture-coordinates auto); more cells follow the uv layout more closely at S^3 "
                        "times the cells' bytes"),
    // The training run (TrainSettings).
    // 4000 steps of 2^11 rays: more steps of fewer rays give a better model per ray than 2400 of
    // 2^12 (docs/results.md, "Rays drawn through the box; more steps of fewer rays": 0.83x the
    // rays, lower t and normal errors and FLIP over bunny, armadillo and dragon, two seeds).
    setting_detail::u32(SettingId::Steps, "steps", 4000, 1, 10000000, "training steps"),
    // Paper: 2^18 on a GPU. On 2 CPU cores the quality per step hardly depends on the batch, so a
    // small one with a decaying learning rate trains fastest (docs/results.md: 2^12 with the
    // default schedule reaches the quality of 2^14 at a constant rate in ~41% of its time; 2^11
    // over more steps, above).
    // At most 2^18 (the paper's GPU batch): a step holds ~4 KiB per ray at the default network (2^20
    // rays measured 4.4 GB resident on the elephant).
    setting_detail::u32(SettingId::Batch, "batch", 1u << 11, 1, 1u << 18, "rays per step"),
    {SettingId::Seed, "seed", SettingKind::U64, 1, 0, 0, false, false, nullptr, 0, "", "random seed"},
    // Up to --batch (a cross check). Reuse costs quality on the bunny (pool of 8 batches: 2 -> median
    // normal error 4.61 deg, 4 -> 5.49, against 3.74 with fresh rays; docs/results.md, "Training time").
    setting_detail::u32(SettingId::RayReuse, "ray-reuse", 1, 1, 1u << 18,
                        "steps each training ray is used in on average, drawn at random from a pool of recent rays "
                        "(1 = fresh rays every step)"),
    // bf16 trains in ~0.9x the time at the same held-out metrics and FLIP within the seeds' spread
    // (docs/results.md, "Two surface rays from each found point; the hidden layers in bf16" and
    // "The first layer in bf16 too").
    setting_detail::choice(SettingId::MlpPrecision, "mlp-precision", kMlpPrecisionAuto, kMlpPrecisionChoices,
                           "precision of the training's products in all but the output layer: auto (bf16 where the "
                           "CPU has AVX512_BF16, else fp32), bf16 or fp32; inference is always fp32"),
    setting_detail::f32(SettingId::Lr, "lr", 0.01, 0, true, kF32Max, false, "learning rate", "Adam learning rate"),
    setting_detail::choice(SettingId::LrSchedule, "lr-schedule", kLrScheduleChoices[1].value, kLrScheduleChoices,
                           "learning rate over the steps: constant (paper), or held at --lr for --lr-warm of the "
                           "steps, then exponential or cosine decay to --lr-final times --lr"),
    setting_detail::f32(SettingId::LrFinal, "lr-final", 0.1, 0, true, 1, false, "",
                        "learning rate at the last step as a fraction of --lr (with a decaying --lr-schedule)"),
    setting_detail::f32(SettingId::LrWarm, "lr-warm", 0.5, 0, false, 1, true, "",
                        "share of the steps at the full --lr before the decay (with a decaying --lr-schedule)"),
    setting_detail::f32(SettingId::AdamBeta1, "adam-beta1", 0.9, 0, false, 1, true, "", "Adam beta1"),
    setting_detail::f32(SettingId::AdamBeta2, "adam-beta2", 0.99, 0, false, 1, true, "", "Adam beta2"),
    setting_detail::f32(SettingId::AdamEpsilon, "adam-epsilon", 1e-15, 0, true, 1, false, "", "Adam epsilon"),
    // 0.99: the model kept is the average of about the last 100 steps' parameters; it lowered the
    // armadillo's FLIP and held-out errors at the same steps (docs/results.md, "The average of the
    // last steps' parameters").
    setting_detail::f32(SettingId::EmaDecay, "ema-decay", 0.99, 0, false, 1, true, "",
                        "the model kept is the exponential moving average of the parameters over the steps "
                        "after --lr-warm's share, decaying by this a step (0: the last step's parameters)"),
    setting_detail::choice(SettingId::NormalLoss, "normal-loss", kNormalLossChoices[0].value, kNormalLossChoices,
                           "normal loss: angle (ours) or cosine (paper)"),
    setting_detail::f32(SettingId::WOcclusion, "w-occlusion", 1, 0, false, kF32Max, false, "weight",
                        "loss weight of occlusion"),
    setting_detail::f32(SettingId::WDistance, "w-distance", 1, 0, false, kF32Max, false, "weight",
                        "loss weight of hit distance"),
    setting_detail::f32(SettingId::WNormal, "w-normal", 1, 0, false, kF32Max, false, "weight",
                        "loss weight of the normal"),
    setting_detail::f32(SettingId::WAlbedo, "w-albedo", 1, 0, false, kF32Max, false, "weight",
                        "loss weight of albedo"),
    setting_detail::f32(SettingId::WMaterial, "w-material", 1, 0, false, kF32Max, false, "weight",
                        "loss weight of the material"),
    setting_detail::f32(SettingId::WSurface, "w-surface", 1, 0, false, kF32Max, false, "weight",
                        "loss weight of the surface channels (metallic, roughness, occlusion, emission)"),
    setting_detail::f32(SettingId::SurfaceFraction, "surface-fraction", 0.5, 0, false, 1, false, "",
                        "share of training rays starting on the surface"),
    setting_detail::f32(SettingId::SphereScale, "sphere-scale", 1, 0, true, 100, false, "",
                        "radius of the sphere other training rays start on, in half diagonals of the padded AABB"),
    setting_detail::f32(SettingId::SurfaceOffset, "surface-offset", 1e-4, 0, false, 1, false, "",
                        "surface ray origins pushed off by this times the AABB diagonal"),
    // 2: half the finding rays per surface ray (the sampler's traces were the largest share of a
    // training's time) at the same held-out metrics and FLIP within the seeds' spread
    // (docs/results.md, "Two surface rays from each found point"); 3 trained the dragon worse on
    // every seed ("Surface points from the outer rays' own hits").
    setting_detail::u32(SettingId::SurfaceRays, "surface-rays", 2, 1, 16,
                        "surface rays cast from each surface point a finding ray hits, each in its own "
                        "direction (their share of all rays stays --surface-fraction's)"),
    setting_detail::f32(SettingId::GridInitRange, "grid-init-range", 1e-4, 0, false, 1, false, "",
                        "hash-table entries start uniform in (-range, range)"),
};
static_assert(std::size(kSettingDefs) == kSettingCount, "one definition per SettingId");

constexpr const SettingDef& setting_def(SettingId id) { return kSettingDefs[static_cast<size_t>(id)]; }
constexpr uint32_t default_u32(SettingId id) { return static_cast<uint32_t>(setting_def(id).def); }
constexpr uint64_t default_u64(SettingId id) { return static_cast<uint64_t>(setting_def(id).def); }
constexpr float default_f32(SettingId id) { return static_cast<float>(setting_def(id).def); }
constexpr uint32_t min_u32(SettingId id) { return static_cast<uint32_t>(setting_def(id).min); }
constexpr uint32_t max_u32(SettingId id) { return static_cast<uint32_t>(setting_def(id).max); }
// The default of --indexed at grid level `level`: the coarsest level (0) indexed, the finer levels
// hashed (their vertices outnumber a hashed table's entries: bunny level 1 has 204,459).
constexpr uint32_t default_indexed(uint32_t level) { return level == 0 ? default_u32(SettingId::Indexed) : 0; }

namespace setting_detail {
constexpr bool table_in_id_order() {
  for (size_t i = 0; i < kSettingCount; ++i)
    if (static_cast<size_t>(kSettingDefs[i].id) != i) return false;
  return true;
}
}  // namespace setting_detail
static_assert(setting_detail::table_in_id_order(), "kSettingDefs must list the settings in SettingId order");

// A preset sets several settings at once: `--quality low` (option "quality", choice "low") or the
// flags `--paper` and `--tiny` (choice nullptr). In a `--config` file: "quality": "low", "paper": true.
struct PresetValue {
  SettingId id;
  double value;  // Choice: the choice's value
};
struct Preset {
  const char* option;
  const char* choice;  // nullptr: a flag
  const PresetValue* values;
  uint32_t count;
  const char* help;
};

// The paper's two network configurations (section 6): "high" is the default network (W=128,
// H=18), "low" reduces the hidden width W and the boundary points H. Both keep the default grid.
inline constexpr PresetValue kLowQualityValues[] = {{SettingId::Width, 64}, {SettingId::Points, 10}};
// The paper's model and training: its grid (fp16, every level hashed), 2000 steps, batch, constant
// learning rate, hit parametrization and normal loss (slow on a CPU).
inline constexpr PresetValue kPaperValues[] = {{SettingId::GridBits, 16},
                                               {SettingId::Indexed, 0},
                                               {SettingId::Steps, 2000},
                                               {SettingId::Batch, 1u << 18},
                                               {SettingId::LrSchedule, kLrScheduleChoices[0].value},
                                               {SettingId::Hit, LSNIF_HIT_PARAM_AABB_INTERVAL},
                                               {SettingId::NormalLoss, kNormalLossChoices[1].value},
                                               {SettingId::RayReuse, 1}};
// A tiny model trained in seconds, for tests and first trials (and the models of `lsnif bench
// --quick`): V=16, the grid 32..64 with 2^12 entries, a 32-wide MLP, 30 steps of 1024 rays.
inline constexpr PresetValue kTinyValues[] = {{SettingId::Voxels, 16}, {SettingId::ResMin, 32},
                                              {SettingId::ResMax, 64}, {SettingId::TableLog2, 12},
                                              {SettingId::Width, 32},  {SettingId::Steps, 30},
                                              {SettingId::Batch, 1024}};
inline constexpr Preset kPresets[] = {
    {"quality", "high", nullptr, 0, "the paper's network configurations (with the default grid)"},
    {"quality", "low", kLowQualityValues, uint32_t(std::size(kLowQualityValues)), ""},
    {"paper", nullptr, kPaperValues, uint32_t(std::size(kPaperValues)), "the paper's grid and training settings"},
    {"tiny", nullptr, kTinyValues, uint32_t(std::size(kTinyValues)),
     "a tiny model trained in seconds, for tests and first trials"},
};
// The flag `--tiny` ("tiny": true in a settings file).
inline constexpr const Preset& kTinyPreset = kPresets[3];
static_assert(std::string_view(kTinyPreset.option) == "tiny" && kTinyPreset.choice == nullptr, "kTinyPreset is --tiny");

// The value preset `p` gives setting `id`, or the setting's default when it gives none.
constexpr double preset_value(const Preset& p, SettingId id) {
  for (uint32_t k = 0; k < p.count; ++k)
    if (p.values[k].id == id) return p.values[k].value;
  return setting_def(id).def;
}

}  // namespace lsnif
