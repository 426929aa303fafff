#include "lsnif/format/config.h"

#include <cmath>

namespace lsnif {

static_assert(default_u32(SettingId::Levels) == 2, "Config::grid_resolution's default is set for 2 levels");

const char* to_string(HitParam p) {
  for (const SettingChoice& c : kHitChoices)
    if (c.value == static_cast<uint32_t>(p)) return c.name;
  return "unknown";
}

uint64_t Config::mlp_parameter_count() const {
  uint64_t n = 0, in = input_dim();
  for (uint32_t l = 0; l < hidden_layers; ++l) {
    n += in * hidden_width + hidden_width;
    in = hidden_width;
  }
  return n + in * output_dim() + output_dim();
}

std::vector<LayerView> mlp_layers(const Config& config) {
  std::vector<LayerView> layers;
  uint32_t in = config.input_dim();
  size_t offset = 0;
  for (uint32_t l = 0; l <= config.hidden_layers; ++l) {
    LayerView v;
    v.in = in;
    v.out = l < config.hidden_layers ? config.hidden_width : config.output_dim();
    v.weight_offset = offset;
    v.bias_offset = offset + size_t(v.in) * v.out;
    offset = v.bias_offset + v.out;
    in = v.out;
    layers.push_back(v);
  }
  return layers;
}

uint64_t mlp_flops_per_evaluation(const Config& config) {
  uint64_t flops = 0;
  for (const LayerView& v : mlp_layers(config)) flops += 2ull * v.in * v.out;
  return flops;
}

namespace {
// An error when `value` lies outside the range of `id` in settings_table.h; `what` names it.
Status check_range(SettingId id, uint32_t value, const char* what) {
  if (value < min_u32(id) || value > max_u32(id))
    return Status::error("%s=%u out of range [%u, %u]", what, value, min_u32(id), max_u32(id));
  return Status::ok();
}
}  // namespace

Status Config::validate() const {
  if (Status s = check_range(SettingId::Voxels, voxel_resolution, "voxel resolution V"); !s) return s;
  if (Status s = check_range(SettingId::Points, max_points, "max points H"); !s) return s;
  if (Status s = check_range(SettingId::Levels, grid_levels, "grid levels L"); !s) return s;
  for (uint32_t l = 0; l < grid_levels; ++l) {
    uint32_t r = grid_resolution[l];
    if (r < voxel_resolution || r > max_u32(SettingId::ResMax) || r % voxel_resolution != 0)
      return Status::error(
          "grid resolution %u of level %u must be a multiple of the voxel resolution %u (and <= %u)",
          r, l, voxel_resolution, max_u32(SettingId::ResMax));
  }
  for (uint32_t l = grid_levels; l < LSNIF_MAX_LEVELS; ++l)
    if (grid_resolution[l] != 0) return Status::error("grid resolution of unused level %u is not 0", l);
  for (uint32_t l = 0; l < grid_levels; ++l)
    if (table_log2[l] < min_u32(SettingId::TableLog2) || table_log2[l] > max_u32(SettingId::TableLog2))
      return Status::error("hash table size (log2 entries) M=%u of level %u out of range [%u, %u]", table_log2[l], l,
                           min_u32(SettingId::TableLog2), max_u32(SettingId::TableLog2));
  for (uint32_t l = grid_levels; l < LSNIF_MAX_LEVELS; ++l)
    if (table_log2[l] != 0) return Status::error("hash table size (log2 entries) of unused level %u is not 0", l);
  if (Status s = check_range(SettingId::Features, features, "features F"); !s) return s;
  if (Status s = check_range(SettingId::Width, hidden_width, "hidden width W"); !s) return s;
  if (Status s = check_range(SettingId::Layers, hidden_layers, "hidden layers"); !s) return s;
  if (material_count < 1 || material_count > LSNIF_MAX_MATERIALS)
    return Status::error("material count %u out of range [1, %u]", material_count, LSNIF_MAX_MATERIALS);
  if (hit_param != HitParam::AabbInterval && hit_param != HitParam::VoxelSegments)
    return Status::error("unknown hit parametrization %u", static_cast<uint32_t>(hit_param));
  const SettingDef& slope = setting_def(SettingId::LeakySlope);
  if (!(leaky_slope >= slope.min && leaky_slope < slope.max))
    return Status::error("leaky ReLU slope %g out of range [%g, %g)", double(leaky_slope), slope.min, slope.max);
  if (grid_bits != 8 && grid_bits != 16) return Status::error("grid bits %u is neither 8 nor 16", grid_bits);
  if (surface_channels > 1) return Status::error("surface channels %u is neither 0 nor 1", surface_channels);
  if (!(emission_scale >= 0.0f && emission_scale <= float(LSNIF_MAX_EMISSION_SCALE)))
    return Status::error("emission scale %g out of range [0, %g]", double(emission_scale), LSNIF_MAX_EMISSION_SCALE);
  if (!surface_channels && emission_scale != 0.0f)
    return Status::error("emission scale %g without surface channels (must be 0)", double(emission_scale));
  if (material_count < 64 && (uv_materials >> material_count) != 0)
    return Status::error("texture-coordinate materials 0x%llx name a material beyond the %u of the model",
                         (unsigned long long)uv_materials, material_count);
  if (texture_coordinates() ? uv_cells < min_u32(SettingId::UvCells) || uv_cells > max_u32(SettingId::UvCells)
                            : uv_cells != 0)
    return Status::error("uv cells per voxel %u out of range [%u, %u] (0 without texture-coordinate materials)", uv_cells,
                         min_u32(SettingId::UvCells), max_u32(SettingId::UvCells));
  if (!texture_coordinates() && (uv_cell_voxels || uv_cell_maps))
    return Status::error("%u uv cell voxels and %u maps without texture-coordinate materials (must be 0)",
                         uv_cell_voxels, uv_cell_maps);
  if (uint64_t(uv_cell_voxels) > voxel_count() ||
      uint64_t(uv_cell_maps) > 2ull * uv_cell_voxels * uv_cells * uv_cells * uv_cells ||
      uv_cell_maps > LSNIF_MAX_UV_CELL_MAPS)
    return Status::error("%u uv cell voxels and %u maps exceed the %llu voxels, 2 maps per cell or %u maps",
                         uv_cell_voxels, uv_cell_maps, (unsigned long long)voxel_count(), LSNIF_MAX_UV_CELL_MAPS);
  const uint32_t max_slots = 1u << max_u32(SettingId::TableLog2);
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) {
    const uint32_t slots = index_slots[l], buckets = index_buckets[l];
    if (l >= grid_levels && (slots || buckets))
      return Status::error("unused level %u has an index (%u slots, %u buckets)", l, slots, buckets);
    if ((slots == 0) != (buckets == 0))
      return Status::error("level %u's index has %u slots and %u buckets (both 0 for a hashed level, else both "
                           "positive)", l, slots, buckets);
    if (slots > max_slots || buckets > slots)
      return Status::error("level %u's index has %u slots and %u buckets: at most 2^%u slots and at most one bucket "
                           "per slot", l, slots, buckets, max_u32(SettingId::TableLog2));
  }
  return Status::ok();
}

uint64_t Config::level_entry_offset(uint32_t level) const {
  uint64_t n = 0;
  for (uint32_t l = 0; l < level && l < LSNIF_MAX_LEVELS; ++l) n += table_size(l);
  return n;
}

bool Config::any_indexed() const {
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l)
    if (indexed(l)) return true;
  return false;
}

uint64_t Config::grid_index_count() const {
  uint64_t n = 0;
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) n += index_buckets[l];
  return n;
}

uint32_t Config::level_of_entry(uint64_t entry) const {
  uint32_t l = 0;
  while (l + 1 < grid_levels && entry >= level_entry_offset(l + 1)) ++l;
  return l;
}

bool Config::uniform_table_log2() const {
  if (any_indexed()) return false;
  for (uint32_t l = 1; l < grid_levels && l < LSNIF_MAX_LEVELS; ++l)
    if (table_log2[l] != table_log2[0]) return false;
  return true;
}

std::string Config::describe() const {
  std::string res, m;
  for (uint32_t l = 0; l < grid_levels && l < LSNIF_MAX_LEVELS; ++l) {
    if (l) res.push_back(',');
    res.append(std::to_string(grid_resolution[l]));
    if (l == 0 || !uniform_table_log2())
      m.append(l ? "," : "").append(indexed(l) ? format("indexed:%u", index_slots[l]) : std::to_string(table_log2[l]));
  }
  return format("V=%u H=%u L=%u res=%s M=%s F=%u W=%ux%u Nmat=%u hit=%s leaky=%g%s%s%s", voxel_resolution,
                max_points, grid_levels, res.c_str(), m.c_str(), features, hidden_width,
                hidden_layers, material_count, to_string(hit_param), double(leaky_slope),
                grid_bits == 16 ? "" : format(" grid-bits=%u", grid_bits).c_str(),
                surface_channels ? format(" surface emission-scale=%g", double(emission_scale)).c_str() : "",
                texture_coordinates()
                    ? format(" uv-materials=0x%llx uv-cells=%u", (unsigned long long)uv_materials, uv_cells).c_str()
                    : "");
}

void set_grid_resolutions(Config& config, uint32_t coarsest, uint32_t finest) {
  uint32_t L = config.grid_levels, V = config.voxel_resolution;
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) config.grid_resolution[l] = 0;
  for (uint32_t l = 0; l < L; ++l) {
    double r = coarsest;
    if (L > 1) r = coarsest * std::pow(double(finest) / coarsest, double(l) / (L - 1));
    uint32_t rounded = static_cast<uint32_t>(std::lround(r / V)) * V;
    config.grid_resolution[l] = rounded < V ? V : rounded;
  }
}

void set_table_log2(Config& config, const uint32_t* log2_sizes, uint32_t count) {
  const uint32_t L = config.grid_levels;
  if (L > LSNIF_MAX_LEVELS || (count != 1 && count != L)) return;
  for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l) config.table_log2[l] = l < L ? log2_sizes[count == 1 ? 0 : l] : 0;
}

}  // namespace lsnif
