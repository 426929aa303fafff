#include "model.h"

#include "half.h"

namespace lsnif {

namespace {

// Words of VoxelGrid::bits for a V^3 grid: ceil(V^3 / 32).
uint64_t voxel_word_count(const Config& config) { return (config.voxel_count() + 31u) / 32u; }

uint64_t align16(uint64_t n) { return (n + 15u) & ~uint64_t(15u); }

}  // namespace

Status Model::validate() const {
  Status s = config.validate();
  if (!s) return s.context("model config");
  const uint32_t V = config.voxel_resolution;
  if (voxels.resolution != V)
    return Status::error("voxel grid resolution %u does not match the config's V=%u", voxels.resolution, V);
  const uint64_t words = voxel_word_count(config);
  if (voxels.bits.size() != words)
    return Status::error("voxel grid has %zu words of occupancy bits, V=%u needs %llu", voxels.bits.size(), V,
                         static_cast<unsigned long long>(words));
  const uint32_t used_bits = static_cast<uint32_t>(config.voxel_count() % 32u);
  if (used_bits != 0 && (voxels.bits.back() >> used_bits) != 0)
    return Status::error("voxel grid has bits set beyond voxel %llu (V^3) in its last word",
                         static_cast<unsigned long long>(config.voxel_count()));
  if (materials.size() != config.material_count)
    return Status::error("model has %zu materials, the config's material count is %u", materials.size(),
                         config.material_count);
  if (grid.size() != config.grid_parameter_count())
    return Status::error("hash grid has %zu values, the config needs %llu (L*2^M*F)", grid.size(),
                         static_cast<unsigned long long>(config.grid_parameter_count()));
  if (mlp.size() != config.mlp_parameter_count())
    return Status::error("MLP has %zu parameters, the config needs %llu", mlp.size(),
                         static_cast<unsigned long long>(config.mlp_parameter_count()));
  return Status::ok();
}

void Model::quantize() {
  for (float& v : grid) v = round_to_half(v);
  for (float& v : mlp) v = round_to_half(v);
}

// Mirrors the file layout of docs/model-format.md (written by model_file.cpp): a 168-byte header,
// then the materials (76 bytes each), voxel, grid and MLP sections, each starting at a 16-byte
// aligned offset, then the 4-byte CRC at the next 16-byte aligned offset. model_file_test checks
// that the file size equals total().
MemoryBreakdown memory_breakdown(const Model& model) {
  MemoryBreakdown out;
  const Config& c = model.config;
  if (!c.validate()) return out;  // sizes of an invalid config are meaningless (and may overflow)
  out.voxel_bytes = 4u * voxel_word_count(c);
  out.grid_bytes = 2u * c.grid_parameter_count();
  out.mlp_bytes = 2u * c.mlp_parameter_count();
  const uint64_t header = 168, material_record = 76, crc = 4;
  uint64_t end = align16(header);
  end = align16(end + material_record * c.material_count);
  end = align16(end + out.voxel_bytes);
  end = align16(end + out.grid_bytes);
  end = align16(end + out.mlp_bytes);
  const uint64_t file_size = end + crc;
  out.header_bytes = file_size - out.voxel_bytes - out.grid_bytes - out.mlp_bytes;
  return out;
}

}  // namespace lsnif
