// gpu_model.h -- the GPU block (src/lsnif/format/gpu_block.h) of an in-memory Model, for code that trains or
// edits models in process (tests, benchmarks); applications load .lsnif bytes through the plugin.
#pragma once
#include <cstdint>
#include <vector>

#include "lsnif/format/gpu_block.h"
#include "lsnif/core/model.h"
#include "lsnif/format/status.h"

namespace lsnif {

// Packs `model` into `words` (replaced): the block that the plugin would make from the model's
// .lsnif file. Fails, naming the problem, if the model is inconsistent (Model::validate) or a grid
// or MLP value is not exactly an fp16 value (the model was not quantized: the GPU would silently
// round it); `words` is empty then.
Status pack_gpu_model(const Model& model, std::vector<uint32_t>& words);

}  // namespace lsnif
