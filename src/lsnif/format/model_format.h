// model_format.h -- the .lsnif file at the byte level (docs/model-format.md): one parser that checks
// every field and hands out the sections as they are stored (fp16 parameters stay fp16 bits), and
// one writer. The CPU side (src/lsnif/core/model_file.cpp) converts to and from float; the Vulkan plugin
// packs the GPU block straight from the parsed sections (src/lsnif/format/gpu_block.h). No glm, no Eigen.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/format/config.h"
#include "lsnif/format/file_io.h"
#include "lsnif/format/status.h"

namespace lsnif {

// Models with 16-bit grid features are written as version 1 without a training record (the layout
// before the record existed) and as version 2 with one; models with 8-bit grid features as version 3
// (int8 codes and per-level fp32 scales, the record optional); models whose levels' hash tables
// differ in size (Config::table_log2) as version 4 (the layout of version 3 plus the size of every
// level's table; 16- or 8-bit features); models with an indexed grid level (Config::index_slots) as
// version 5 (the layout of version 4 plus every level's index sizes and the grid index section);
// models with surface channels as version 6 (the layout of version 5 plus the surface channels and
// the emission scale); models with texture-coordinate outputs (Config::uv_materials) as version 7
// (the layout of version 6 plus those materials and the uv box). All seven are read.
constexpr uint32_t kModelFormatVersion = 7;
// The training section (version 2): compact JSON text, at most this many bytes.
constexpr size_t kMaxTrainingRecordBytes = 65536;
constexpr size_t kModelMaterialNameBytes = 64;  // NUL-terminated: at most 63 bytes of name
// The stored AABB lies within +-this on every axis (float ray math squares distances).
constexpr double kMaxModelCoordinate = 1e18;

struct ModelFileMaterial {
  std::string name;
  float base_color[3] = {1.0f, 1.0f, 1.0f};  // linear RGB
};

// A parsed .lsnif file. The section pointers point into the caller's bytes (which must outlive the
// view); their contents are little-endian as in the file: voxels as u32 words, mlp as fp16 values
// (every one finite), grid as fp16 values (config.grid_bits 16, every one finite) or int8 codes in
// [-127, 127] (grid_bits 8, level l's codes times grid_scales[l]).
struct ModelFileView {
  Config config;
  float bounds_lo[3] = {}, bounds_hi[3] = {};  // padded object AABB, finite, lo < hi
  std::vector<ModelFileMaterial> materials;    // config.material_count records
  const uint8_t* voxels = nullptr;             // model_voxel_words(config) u32 words
  const uint8_t* grid = nullptr;               // config.grid_parameter_count() fp16 values or int8 codes
  const uint8_t* mlp = nullptr;                // config.mlp_parameter_count() fp16 values
  float grid_scales[LSNIF_MAX_LEVELS] = {};    // grid_bits 8: per level, finite, >= 0 (else 0)
  const uint8_t* grid_index = nullptr;         // version 5: config.grid_index_count() u16 displacements
  std::vector<uint32_t> uv_cells;              // version 7: uv_cell_words(config) words (uv_cell_layout.h), checked
  uint32_t version = 0;                        // 1 to 7
  std::string training;                        // the training record (version 2), else empty
};

// Words of the voxel section of a model with this config: ceil(V^3 / 32).
uint64_t model_voxel_words(const Config& config);

// A per-level scale of 8-bit grid features: finite, +0 or positive, and 127 times it finite.
bool grid_scale_usable(float scale);

// Bytes of the parts of the .lsnif file of a model with this (valid) config and a training record
// of `training_bytes`: voxel section, grid (values and, for 8-bit features, the scales;
// for indexed levels also the displacements), MLP, the whole file, and its format version.
struct ModelFileSizes {
  uint64_t voxels = 0, grid = 0, mlp = 0, uv_cells = 0, file = 0;
  uint32_t version = 0;
};
ModelFileSizes model_file_sizes(const Config& config, uint64_t training_bytes);

// Parses and validates a whole .lsnif file in memory (format version 1 to 6): magic, version,
// sizes, the config, the AABB,
// section table, zero padding, CRC-32, material names (valid UTF-8 without control characters),
// the AABB within +-kMaxModelCoordinate, no voxel bits beyond V^3, no NaN or
// infinite fp16 value, int8 grid codes in [-127, 127], grid scales finite and >= 0 (127 times a
// scale finite), and the training record a JSON object whose settings agree with the header
// (check_training_record, training_record.h). Never reads outside [data, data + size). Errors name
// the problem ("checksum mismatch ...", "truncated ...", "section grid has size ...").
Status parse_model_file(const uint8_t* data, size_t size, ModelFileView& out);

// Reads a whole .lsnif file into `bytes` (replaced on success) with read_file (file_io.h): a
// regular file whose header is read first, so that a file that is not a model, or whose size is not
// the one its header declares, or is more than `max_bytes` (default: the largest valid model), is
// refused before its body is read; then read completely (an error if it changes size meanwhile).
// Memory is bounded by the header's size. Errors start with "loading PATH: "; `failure`, when not
// null, receives read_file's problem (None for a refused header). The bytes are not otherwise parsed.
Status read_model_file(const std::string& path, std::vector<uint8_t>& bytes, uint64_t max_bytes = 0,
                       ReadFailure* failure = nullptr);

// What a .lsnif file holds, for writing: fp16 parameters as bits.
struct ModelFileContents {
  Config config;
  float bounds_lo[3] = {}, bounds_hi[3] = {};
  std::vector<ModelFileMaterial> materials;
  const uint32_t* voxels = nullptr;     // model_voxel_words(config) words
  const uint16_t* grid = nullptr;       // grid_bits 16: config.grid_parameter_count() values
  const int8_t* grid_codes = nullptr;   // grid_bits 8: config.grid_parameter_count() codes in [-127, 127]
  float grid_scales[LSNIF_MAX_LEVELS] = {};  // grid_bits 8: per level, finite, >= 0
  const uint16_t* grid_index = nullptr;  // config.grid_index_count() displacements (an indexed level)
  const uint32_t* uv_cells = nullptr;    // uv_cell_words(config) words (texture-coordinate materials)
  const uint16_t* mlp = nullptr;        // config.mlp_parameter_count() values
  // The training record (src/lsnif/train/settings_io.h): empty writes a version 1 file, else version 2 with
  // a training section (valid UTF-8 without control characters, at most kMaxTrainingRecordBytes).
  // grid_bits 8 always writes version 3, its training section possibly empty; levels with tables of
  // different sizes version 4 (its training section possibly empty); an indexed level version 5;
  // surface channels version 6.
  std::string training;
};

// Encodes `contents` as a .lsnif file into `bytes` (replaced). Fails, naming the problem, on an
// invalid config, a non-finite or empty AABB, a training record too long or not clean UTF-8, a
// material name of 64 bytes or more or with a NUL,
// a non-finite base color, voxel bits beyond V^3, or a non-finite fp16 value.
Status write_model_file(const ModelFileContents& contents, std::vector<uint8_t>& bytes);

}  // namespace lsnif
