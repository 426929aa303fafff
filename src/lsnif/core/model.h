// model.h -- one trained LSNIF object in memory: its config, padded AABB, material table, voxel
// occupancy, hash tables and MLP parameters. Parameters are kept as float but, once a model has
// been quantized (after training, or when loaded), every MLP value is exactly an fp16 value and
// every grid value exactly what the file stores: an fp16 value (config.grid_bits 16) or an int8
// code in [-127, 127] times its level's fp32 scale (grid_bits 8; the product in fp32, which the
// GPU computes the same way).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/format/config.h"
#include "lsnif/core/hash_grid.h"
#include "lsnif/format/status.h"
#include "lsnif/core/voxel_grid.h"

namespace lsnif {

struct ModelMaterial {
  std::string name;               // at most 63 bytes in the file
  glm::vec3 base_color{1.0f};     // linear RGB, informative (the network predicts albedo)
};

struct Model {
  Config config;
  VoxelGrid voxels;               // resolution == config.voxel_resolution; bounds = object AABB
  std::vector<ModelMaterial> materials;  // size == config.material_count
  std::vector<float> grid;        // config.grid_parameter_count() values, hash_grid.h layout
  // grid_bits 8: one scale per level (config.grid_levels values, finite, >= 0), set by quantize();
  // empty for grid_bits 16.
  std::vector<float> grid_scales;
  // The displacements of the indexed levels' perfect hashes (Config::index_buckets of each, in level
  // order; src/lsnif/core/perfect_hash.h); empty when no level is indexed.
  std::vector<uint16_t> grid_index;
  // MLP parameters, config.mlp_parameter_count() values. For each layer in order (hidden layers,
  // then the output layer): the weight matrix row-major [out][in], then the bias [out].
  std::vector<float> mlp;
  // Where hits of the texture-coordinate materials (Config::uv_materials) read their texture
  // coordinate: uv_cell_words(config) words as src/lsnif/format/uv_cell_layout.h lays them out
  // (src/lsnif/core/uv_cells.h reads them); empty without such materials.
  std::vector<uint32_t> uv_cells;
  // How it was trained: compact JSON {"settings", "mesh", "threads"} (src/lsnif/train/settings_io.h), stored
  // in the file's training section (format version 2); empty when not recorded (version 1 files).
  std::string training;

  const Aabb& bounds() const { return voxels.bounds; }
  // How the encoder addresses this model's tables (hash_grid.h).
  GridLayout layout() const { return GridLayout(config, grid_index.data()); }
  // Consistency of sizes with the config; the message names the mismatch.
  Status validate() const;
  // Rounds mlp to fp16 precision in place, and the grid to what config.grid_bits stores: fp16, or
  // (8) per level symmetric int8: scale = (max |value| of the level) / 127 in fp32, each value
  // replaced by code * scale with code = round(value / scale) in [-127, 127]. A level whose values
  // are all zero (or whose scale underflows to 0) gets scale 0 and all codes 0. Sets grid_scales.
  void quantize();
  // grid_bits 8: the int8 code of grid value e (value / its level's scale, rounded; 0 where the
  // scale is 0). For a quantized model code * scale == grid[e] exactly.
  int32_t grid_code(uint64_t e) const;
};

struct MemoryBreakdown {
  uint64_t voxel_bytes = 0, grid_bytes = 0, mlp_bytes = 0, header_bytes = 0;
  uint64_t uv_cell_bytes = 0;  // where texture-coordinate hits read their uv (0 without)
  uint64_t total() const { return voxel_bytes + grid_bytes + mlp_bytes + header_bytes + uv_cell_bytes; }
};
// Bytes the model's parts take in the .lsnif file (= on the GPU, fp16 parameters, 1 bit/voxel). The
// training record is not counted: it never reaches the GPU.
MemoryBreakdown memory_breakdown(const Model& model);

// .lsnif files: versioned little-endian binary (see model_file.cpp for the exact layout) with a
// CRC-32 over everything before it. Loading validates every field and never trusts a size it has
// not checked against the file's length: truncated, corrupted, wrong-version or inconsistent
// files return an error that names the problem. save_model writes through write_file_atomic
// (src/lsnif/format/atomic_file.h): the whole file or, on any failure, the previous file left as it was.
Status save_model(const Model& model, const std::string& path);
Status save_model_to_memory(const Model& model, std::vector<uint8_t>& bytes);
Status load_model(const std::string& path, Model& model);
Status load_model_from_memory(const uint8_t* data, size_t size, Model& model);

}  // namespace lsnif
