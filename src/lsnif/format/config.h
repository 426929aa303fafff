// config.h -- every hyperparameter of one LSNIF model (paper sections 3 and 5.1). Stored in the
// .lsnif header; the CPU reference, the trainer and the shaders all derive their layouts from it.
#pragma once
#include <cstdint>
#include <cstddef>
#include <string>
#include <vector>

#include "lsnif/host_device.h"
#include "lsnif/format/settings_table.h"
#include "lsnif/format/status.h"

namespace lsnif {

enum class HitParam : uint32_t {
  AabbInterval = LSNIF_HIT_PARAM_AABB_INTERVAL,    // paper: t as a fraction of the ray/AABB interval
  VoxelSegments = LSNIF_HIT_PARAM_VOXEL_SEGMENTS,  // ours: t as a position among the crossed segments
};
const char* to_string(HitParam p);

// The defaults and ranges are those of settings_table.h, but for the grid's layout (grid_bits, the
// indexed levels): a Config{} has the paper's grid, `lsnif train`'s default model another
// (TrainSettings, default_model_config).
struct Config {
  uint32_t voxel_resolution = default_u32(SettingId::Voxels);  // V: voxels per axis over the padded object AABB
  uint32_t max_points = default_u32(SettingId::Points);  // H: boundary points fed to the network (zero-filled after)
  uint32_t grid_levels = default_u32(SettingId::Levels);  // L: hash-grid levels
  // Per level; multiples of V. The default: set_grid_resolutions(res-min, res-max) of the default
  // 2 levels (config.cpp checks the level count).
  uint32_t grid_resolution[LSNIF_MAX_LEVELS] = {default_u32(SettingId::ResMin), default_u32(SettingId::ResMax), 0, 0};
  // Per level l < L: level l's hash table has 2^table_log2[l] entries (M_l); the levels' tables lie
  // one after another (hash_grid.h). 0 for unused levels. The default: every level
  // default_u32(TableLog2) (set_table_log2 of one value for all levels).
  uint32_t table_log2[LSNIF_MAX_LEVELS] = {default_u32(SettingId::TableLog2), default_u32(SettingId::TableLog2), 0, 0};
  uint32_t features = default_u32(SettingId::Features);           // F: features per entry
  uint32_t hidden_width = default_u32(SettingId::Width);          // W
  uint32_t hidden_layers = default_u32(SettingId::Layers);
  uint32_t material_count = 1;     // Nmat
  HitParam hit_param = static_cast<HitParam>(default_u32(SettingId::Hit));
  float leaky_slope = default_f32(SettingId::LeakySlope);  // leaky ReLU negative slope
  // Bits per stored hash-grid feature: 16 (fp16) or 8 (int8 codes times a per-level fp32 scale,
  // Model::grid_scales; .lsnif format version 3). A Config{} is the paper's layout (fp16, every level
  // hashed); `lsnif train`'s default model is 8-bit with the coarsest level indexed.
  uint32_t grid_bits = 16;
  // Per level l < L: 0 for a hashed level (hash_vertex into 2^table_log2[l] entries), else the level
  // is indexed (src/lsnif/core/perfect_hash.h): its table has index_slots[l] entries, one for every vertex the
  // encoder can read (and a few spare), addressed through index_buckets[l] displacements
  // (Model::grid_index). Both are set together by index_grid_levels (src/lsnif/core/grid_usage.h) from the
  // voxels; an indexed level's table_log2 is unused. 0 for unused levels.
  uint32_t index_slots[LSNIF_MAX_LEVELS] = {};
  uint32_t index_buckets[LSNIF_MAX_LEVELS] = {};
  // Surface channels (.lsnif format version 6): 1 when the network also learns the glTF material's
  // textured metallic, roughness, ambient occlusion and emission at the hit (LSNIF_OUT_SURFACE_*,
  // src/lsnif/core/head.h), else 0 (a model of base colour only; the renderer takes the other
  // channels from the material its material index names).
  uint32_t surface_channels = 0;
  // The emission head's scale: emission = sigmoid(raw) * emission_scale, the largest emission of the
  // object's materials (linear RGB), in [0, LSNIF_MAX_EMISSION_SCALE]; 0 without surface channels.
  float emission_scale = 0.0f;
  // Texture coordinates (.lsnif format version 7): bit m set when hits of material m report the
  // texture coordinate of the predicted hit point, read from the model's uv cells (Model::uv_cells,
  // src/lsnif/core/uv_cells.h), instead of the learned colours, so that a renderer samples the
  // material's own textures at full detail; 0 for a model without uv cells. Only bits below
  // material_count.
  uint64_t uv_materials = 0;
  // Uv cells per voxel edge (S, settings_table.h's uv-cells): the cells are a grid of V x S per axis;
  // 0 when uv_materials is 0.
  uint32_t uv_cells = 0;
  // The uv cells' size (src/lsnif/format/uv_cell_layout.h): voxel records (the occupied voxels) and
  // maps; 0 without texture-coordinate materials.
  uint32_t uv_cell_voxels = 0, uv_cell_maps = 0;

  bool texture_coordinates() const { return uv_materials != 0; }
  bool reports_uv(uint32_t material) const { return material < 64 && ((uv_materials >> material) & 1u) != 0; }
  bool indexed(uint32_t level) const { return index_slots[level] != 0; }
  bool any_indexed() const;
  // Displacements of all indexed levels together (Model::grid_index).
  uint64_t grid_index_count() const;
  // Entries of level l's table: 2^table_log2[l], or index_slots[l] for an indexed level.
  uint32_t table_size(uint32_t level) const { return indexed(level) ? index_slots[level] : 1u << table_log2[level]; }
  // Entries of the tables of the levels before `level`: where level `level`'s table starts.
  uint64_t level_entry_offset(uint32_t level) const;
  // Entries of all levels' tables together.
  uint64_t grid_entry_count() const { return level_entry_offset(grid_levels); }
  // The level whose table holds entry `entry` (< grid_entry_count()).
  uint32_t level_of_entry(uint64_t entry) const;
  // Every level's table has the same size 2^M (the layout before per-level sizes: any .lsnif
  // version); false when a level is indexed.
  bool uniform_table_log2() const;
  uint32_t input_dim() const { return max_points * grid_levels * features; }
  uint32_t output_dim() const {
    return LSNIF_OUT_FIXED + material_count + (surface_channels ? LSNIF_OUT_SURFACE_COUNT : 0u);
  }
  // Where the surface channels start in the output (LSNIF_OUT_SURFACE_* are offsets from here).
  uint32_t surface_output() const { return LSNIF_OUT_MATERIAL + material_count; }
  uint64_t voxel_count() const {
    return uint64_t(voxel_resolution) * voxel_resolution * voxel_resolution;
  }
  // Number of MLP parameters (weights and biases of all layers).
  uint64_t mlp_parameter_count() const;
  // Number of hash-grid parameters (sum over the levels of 2^M_l, times F).
  uint64_t grid_parameter_count() const { return grid_entry_count() * features; }

  // Checks ranges and consistency (for example every grid resolution a multiple of V so that voxel
  // faces lie on grid planes). The message names the offending field.
  Status validate() const;
  // One-line human-readable summary ("V=32 H=18 L=2 res=64,128 M=17 F=3 W=128x2 Nmat=1 ...").
  std::string describe() const;
};

// The layers of the MLP in order (hidden layers, then the output layer of output_dim()) and the offsets
// of their weights and biases in the flat parameter array (Model::mlp, the .lsnif mlp section): per
// layer the weight matrix row-major [out][in], then the bias [out].
struct LayerView {
  uint32_t in = 0, out = 0;
  size_t weight_offset = 0, bias_offset = 0;
};
std::vector<LayerView> mlp_layers(const Config& config);

// Floating-point operations of one network evaluation as the paper counts them: 2 x the
// multiply-adds of every layer's weights (biases and activations not counted). The paper's
// configuration (H=18, L=2, F=3, W=128x2, one material) is 62,720.
uint64_t mlp_flops_per_evaluation(const Config& config);

// Fills grid_resolution[0..L) geometrically from `coarsest` to `finest` (which should be multiples
// of V); the levels in between are rounded to the nearest multiple of V.
void set_grid_resolutions(Config& config, uint32_t coarsest, uint32_t finest);

// Sets table_log2 of levels [0, L) to the `count` values of `log2_sizes`: one value for every level,
// or one per level (count == L); unused levels get 0. Call after setting grid_levels. A count that is
// neither 1 nor L leaves table_log2 as it was (Config::validate then reports the levels).
void set_table_log2(Config& config, const uint32_t* log2_sizes, uint32_t count);
inline void set_table_log2(Config& config, uint32_t log2_size) { set_table_log2(config, &log2_size, 1); }

}  // namespace lsnif
