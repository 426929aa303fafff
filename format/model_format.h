// model_format.h -- the .lsnif file at the byte level (docs/model-format.md): one parser that checks
// every field and hands out the sections as they are stored (fp16 parameters stay fp16 bits), and
// one writer. The CPU side (core/model_file.cpp) converts to and from float; the Vulkan plugin
// packs the GPU block straight from the parsed sections (format/gpu_block.h). No glm, no Eigen.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "config.h"
#include "status.h"

namespace lsnif {

// Files without a training record are written as version 1 (the layout before the record existed),
// files with one as version 2; both are read.
constexpr uint32_t kModelFormatVersion = 2;
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
// view); their contents are little-endian as in the file: voxels as u32 words, grid and mlp as
// fp16 values (every one finite).
struct ModelFileView {
  Config config;
  float bounds_lo[3] = {}, bounds_hi[3] = {};  // padded object AABB, finite, lo < hi
  std::vector<ModelFileMaterial> materials;    // config.material_count records
  const uint8_t* voxels = nullptr;             // model_voxel_words(config) u32 words
  const uint8_t* grid = nullptr;               // config.grid_parameter_count() fp16 values
  const uint8_t* mlp = nullptr;                // config.mlp_parameter_count() fp16 values
  uint32_t version = 0;                        // 1 or 2
  std::string training;                        // the training record (version 2), else empty
};

// Words of the voxel section of a model with this config: ceil(V^3 / 32).
uint64_t model_voxel_words(const Config& config);

// Parses and validates a whole .lsnif file in memory (format version 1 or 2): magic, version,
// sizes, the config, the AABB,
// section table, zero padding, CRC-32, material names (valid UTF-8 without control characters),
// the AABB within +-kMaxModelCoordinate, no voxel bits beyond V^3, no NaN or
// infinite fp16 value. Never reads outside [data, data + size). Errors name the problem ("checksum
// mismatch ...", "truncated ...", "section grid has size ...").
Status parse_model_file(const uint8_t* data, size_t size, ModelFileView& out);

// Reads a whole .lsnif file into `bytes` (replaced): a regular file no larger than the largest
// valid model, read completely (an error if it changes size meanwhile). Errors start with
// "loading PATH: ". The bytes are not parsed.
Status read_model_file(const std::string& path, std::vector<uint8_t>& bytes);

// What a .lsnif file holds, for writing: fp16 parameters as bits.
struct ModelFileContents {
  Config config;
  float bounds_lo[3] = {}, bounds_hi[3] = {};
  std::vector<ModelFileMaterial> materials;
  const uint32_t* voxels = nullptr;     // model_voxel_words(config) words
  const uint16_t* grid = nullptr;       // config.grid_parameter_count() values
  const uint16_t* mlp = nullptr;        // config.mlp_parameter_count() values
  // The training record (train/settings_io.h): empty writes a version 1 file, else version 2 with
  // a training section (valid UTF-8 without control characters, at most kMaxTrainingRecordBytes).
  std::string training;
};

// Encodes `contents` as a .lsnif file into `bytes` (replaced). Fails, naming the problem, on an
// invalid config, a non-finite or empty AABB, a training record too long or not clean UTF-8, a
// material name of 64 bytes or more or with a NUL,
// a non-finite base color, voxel bits beyond V^3, or a non-finite fp16 value.
Status write_model_file(const ModelFileContents& contents, std::vector<uint8_t>& bytes);

}  // namespace lsnif
