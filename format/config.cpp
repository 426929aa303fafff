#include "config.h"

#include <cmath>

namespace lsnif {

const char* to_string(HitParam p) {
  switch (p) {
    case HitParam::AabbInterval: return "aabb";
    case HitParam::VoxelSegments: return "segments";
  }
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

Status Config::validate() const {
  if (voxel_resolution < 1 || voxel_resolution > 256)
    return Status::error("voxel resolution V=%u out of range [1, 256]", voxel_resolution);
  if (max_points < 1 || max_points > LSNIF_MAX_POINTS)
    return Status::error("max points H=%u out of range [1, %u]", max_points, LSNIF_MAX_POINTS);
  if (grid_levels < 1 || grid_levels > LSNIF_MAX_LEVELS)
    return Status::error("grid levels L=%u out of range [1, %u]", grid_levels, LSNIF_MAX_LEVELS);
  for (uint32_t l = 0; l < grid_levels; ++l) {
    uint32_t r = grid_resolution[l];
    if (r < voxel_resolution || r > 4096 || r % voxel_resolution != 0)
      return Status::error(
          "grid resolution %u of level %u must be a multiple of the voxel resolution %u (and <= 4096)",
          r, l, voxel_resolution);
  }
  for (uint32_t l = grid_levels; l < LSNIF_MAX_LEVELS; ++l)
    if (grid_resolution[l] != 0) return Status::error("grid resolution of unused level %u is not 0", l);
  if (log2_table_size < 4 || log2_table_size > 24)
    return Status::error("hash table size M=%u out of range [4, 24] (log2 entries)", log2_table_size);
  if (features < 1 || features > LSNIF_MAX_FEATURES)
    return Status::error("features F=%u out of range [1, %u]", features, LSNIF_MAX_FEATURES);
  if (hidden_width < 1 || hidden_width > LSNIF_MAX_HIDDEN_WIDTH)
    return Status::error("hidden width W=%u out of range [1, %u]", hidden_width, LSNIF_MAX_HIDDEN_WIDTH);
  if (hidden_layers < 1 || hidden_layers > LSNIF_MAX_HIDDEN_LAYERS)
    return Status::error("hidden layers %u out of range [1, %u]", hidden_layers, LSNIF_MAX_HIDDEN_LAYERS);
  if (material_count < 1 || material_count > LSNIF_MAX_MATERIALS)
    return Status::error("material count %u out of range [1, %u]", material_count, LSNIF_MAX_MATERIALS);
  if (hit_param != HitParam::AabbInterval && hit_param != HitParam::VoxelSegments)
    return Status::error("unknown hit parametrization %u", static_cast<uint32_t>(hit_param));
  if (!(leaky_slope >= 0.0f && leaky_slope < 1.0f))
    return Status::error("leaky ReLU slope %g out of range [0, 1)", double(leaky_slope));
  return Status::ok();
}

std::string Config::describe() const {
  std::string res;
  for (uint32_t l = 0; l < grid_levels; ++l) {
    if (l) res.push_back(',');
    res.append(std::to_string(grid_resolution[l]));
  }
  return format("V=%u H=%u L=%u res=%s M=%u F=%u W=%ux%u Nmat=%u hit=%s leaky=%g", voxel_resolution,
                max_points, grid_levels, res.c_str(), log2_table_size, features, hidden_width,
                hidden_layers, material_count, to_string(hit_param), double(leaky_slope));
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

}  // namespace lsnif
