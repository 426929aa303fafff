// gpu_model.cpp -- pack_gpu_model (gpu_model.h): exactness check, then the model's .lsnif bytes
// through the one packer of src/lsnif/format/gpu_block.cpp.
#include "lsnif/testing/gpu_model.h"

#include <cstring>

#include "lsnif/core/half.h"
#include "lsnif/format/model_format.h"

namespace lsnif {

namespace {

// Fails on the first value that fp16 does not hold exactly.
Status check_exact_halves(const std::vector<float>& values, const char* what) {
  for (size_t i = 0; i < values.size(); ++i) {
    const float back = half_to_float(float_to_half(values[i]));
    if (std::memcmp(&back, &values[i], sizeof back) != 0)
      return Status::error("%s value %zu (%.9g) is not an fp16 value: quantize the model first", what, i,
                           double(values[i]));
  }
  return Status::ok();
}

}  // namespace

Status pack_gpu_model(const Model& model, std::vector<uint32_t>& words) {
  words.clear();
  if (Status s = model.validate(); !s) return s.context("packing GPU model");
  // 8-bit grids: saving checks that every value is its code times its level's scale.
  if (model.config.grid_bits == 16)
    if (Status s = check_exact_halves(model.grid, "hash grid"); !s) return s.context("packing GPU model");
  if (Status s = check_exact_halves(model.mlp, "MLP"); !s) return s.context("packing GPU model");
  std::vector<uint8_t> bytes;
  ModelFileView view;
  if (Status s = save_model_to_memory(model, bytes); !s) return s.context("packing GPU model");
  if (Status s = parse_model_file(bytes.data(), bytes.size(), view); !s) return s.context("packing GPU model");
  return pack_gpu_block(view, words);
}

}  // namespace lsnif
