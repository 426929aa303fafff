// model_file.cpp -- .lsnif files to and from a Model (model.h). The bytes are read and written by
// src/lsnif/format/model_format.cpp; this file only converts between fp16 bits or int8 codes and the Model's
// floats.
#include "lsnif/format/atomic_file.h"
#include "lsnif/core/half.h"
#include "lsnif/core/model.h"
#include "lsnif/format/model_format.h"

namespace lsnif {

namespace {

// Converts `count` little-endian fp16 values at p to float.
void halves_to_floats(const uint8_t* p, uint64_t count, std::vector<float>& out) {
  out.resize(size_t(count));
  for (uint64_t i = 0; i < count; ++i)
    out[size_t(i)] = half_to_float(static_cast<uint16_t>(p[2 * i] | (p[2 * i + 1] << 8)));
}

// fp16 bits of `values`; fails on a value fp16 cannot hold (NaN, infinite, or beyond its range).
Status floats_to_halves(const std::vector<float>& values, const char* section, std::vector<uint16_t>& out) {
  out.resize(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    const uint16_t h = float_to_half(values[i]);
    if ((h & 0x7c00u) == 0x7c00u)
      return Status::error("%s value %zu is %g, which is not a finite fp16 value", section, i, double(values[i]));
    out[i] = h;
  }
  return Status::ok();
}

// The int8 codes of a quantized 8-bit grid; fails on a value that is not exactly code * scale.
Status grid_codes(const Model& model, std::vector<int8_t>& out) {
  out.resize(model.grid.size());
  const Config& c = model.config;
  for (size_t e = 0; e < model.grid.size(); ++e) {
    const int32_t code = model.grid_code(e);
    if (float(code) * model.grid_scales[c.level_of_entry(e / c.features)] != model.grid[e])
      return Status::error("grid value %zu (%g) is not an int8 code times its level's scale: quantize the model "
                           "first", e, double(model.grid[e]));
    out[e] = static_cast<int8_t>(code);
  }
  return Status::ok();
}

}  // namespace

Status save_model_to_memory(const Model& model, std::vector<uint8_t>& bytes) {
  if (Status s = model.validate(); !s) return s.context("cannot save model");
  ModelFileContents c;
  c.config = model.config;
  const Aabb& box = model.bounds();
  for (int a = 0; a < 3; ++a) {
    c.bounds_lo[a] = box.lo[a];
    c.bounds_hi[a] = box.hi[a];
  }
  c.materials.resize(model.materials.size());
  for (size_t i = 0; i < model.materials.size(); ++i) {
    c.materials[i].name = model.materials[i].name;
    for (int k = 0; k < 3; ++k) c.materials[i].base_color[k] = model.materials[i].base_color[k];
  }
  std::vector<uint16_t> grid, mlp;
  std::vector<int8_t> codes;
  if (model.config.grid_bits == 8) {
    if (Status s = grid_codes(model, codes); !s) return s.context("cannot save model");
    for (size_t l = 0; l < model.grid_scales.size(); ++l) c.grid_scales[l] = model.grid_scales[l];
  } else if (Status s = floats_to_halves(model.grid, "grid", grid); !s) {
    return s.context("cannot save model");
  }
  if (Status s = floats_to_halves(model.mlp, "mlp", mlp); !s) return s.context("cannot save model");
  c.voxels = model.voxels.bits.data();
  c.grid = grid.data();
  c.grid_codes = codes.data();
  c.mlp = mlp.data();
  c.grid_index = model.grid_index.data();
  c.uv_cells = model.uv_cells.data();
  c.training = model.training;
  return write_model_file(c, bytes);
}

Status save_model(const Model& model, const std::string& path) {
  std::vector<uint8_t> bytes;
  if (Status s = save_model_to_memory(model, bytes); !s) return s.context("saving " + path);
  return write_file_atomic(path, bytes.data(), bytes.size());
}

Status load_model_from_memory(const uint8_t* data, size_t size, Model& model) {
  ModelFileView v;
  if (Status s = parse_model_file(data, size, v); !s) return s;
  Model m;
  m.config = v.config;
  m.voxels.resolution = v.config.voxel_resolution;
  m.voxels.bounds.lo = {v.bounds_lo[0], v.bounds_lo[1], v.bounds_lo[2]};
  m.voxels.bounds.hi = {v.bounds_hi[0], v.bounds_hi[1], v.bounds_hi[2]};
  m.voxels.bits.resize(size_t(model_voxel_words(v.config)));
  for (size_t w = 0; w < m.voxels.bits.size(); ++w) {
    const uint8_t* p = v.voxels + 4 * w;
    m.voxels.bits[w] = uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
  }
  m.materials.resize(v.materials.size());
  for (size_t i = 0; i < v.materials.size(); ++i) {
    m.materials[i].name = v.materials[i].name;
    m.materials[i].base_color = {v.materials[i].base_color[0], v.materials[i].base_color[1],
                                 v.materials[i].base_color[2]};
  }
  if (v.config.grid_bits == 8) {
    const uint64_t count = v.config.grid_parameter_count();
    const Config& c = v.config;
    m.grid_scales.assign(v.grid_scales, v.grid_scales + c.grid_levels);
    m.grid.resize(size_t(count));
    for (uint32_t l = 0; l < c.grid_levels; ++l)
      for (uint64_t e = c.level_entry_offset(l) * c.features; e < c.level_entry_offset(l + 1) * c.features; ++e)
        m.grid[size_t(e)] = float(static_cast<int8_t>(v.grid[e])) * v.grid_scales[l];
  } else {
    halves_to_floats(v.grid, v.config.grid_parameter_count(), m.grid);
  }
  halves_to_floats(v.mlp, v.config.mlp_parameter_count(), m.mlp);
  m.grid_index.resize(size_t(v.config.grid_index_count()));
  for (size_t i = 0; i < m.grid_index.size(); ++i)
    m.grid_index[i] = static_cast<uint16_t>(v.grid_index[2 * i] | (v.grid_index[2 * i + 1] << 8));
  m.uv_cells = std::move(v.uv_cells);
  m.training = std::move(v.training);
  if (Status s = m.validate(); !s) return s.context("internal error: loaded model is inconsistent");
  model = std::move(m);
  return Status::ok();
}

Status load_model(const std::string& path, Model& model) {
  std::vector<uint8_t> bytes;
  if (Status s = read_model_file(path, bytes); !s) return s;
  return load_model_from_memory(bytes.data(), bytes.size(), model).context("loading " + path);
}

}  // namespace lsnif
