// gpu_block.h -- the GPU block of one model: the layout of src/lsnif/host_device.h (LsnifGpuModelHeader,
// then voxel bits, fp16 or int8 hash tables and fp16 MLP rows) that src/lsnif/shaders/lsnif_model.glsl reads through a
// buffer device address, packed straight from a parsed .lsnif file (fp16 bits are moved, never
// converted). No Vulkan here: the block is a plain vector of 32-bit words that the caller uploads.
#pragma once
#include <cstdint>
#include <vector>

#include "lsnif/format/config.h"
#include "lsnif/host_device.h"
#include "lsnif/format/model_format.h"
#include "lsnif/format/status.h"

namespace lsnif {

// Word offsets of one MLP layer inside the mlp section (relative to header.mlp_offset), row-block
// layout of src/lsnif/host_device.h.
struct GpuLayerLayout {
  uint32_t in = 0, out = 0;
  uint32_t weight_word = 0;  // first word of block 0 (a multiple of 8)
  uint32_t row_words = 0;    // input pairs P = LSNIF_GPU_ROW_WORDS(in)
  uint32_t blocks = 0;       // LSNIF_GPU_ROW_BLOCKS(out)
  uint32_t bias_word = 0;    // first word of the bias (8 words per block)
  uint32_t end_word = 0;     // one past the layer (a multiple of 8)
  // Word (relative to the mlp section) holding W[r][i] (half i & 1 of it).
  uint32_t weight_word_of(uint32_t r, uint32_t i) const {
    return weight_word + ((r / LSNIF_GPU_ROW_BLOCK) * row_words + i / 2) * LSNIF_GPU_ROW_BLOCK +
           r % LSNIF_GPU_ROW_BLOCK;
  }
};
// The layers in order (hidden, then output), as the shader walks them.
std::vector<GpuLayerLayout> gpu_layer_layout(const Config& config);

// Packs the parsed model `view` (parse_model_file) into `words` (replaced). Fails if the block
// would exceed 2^32 - 1 words (never for a valid config) ; `words` is empty then.
Status pack_gpu_block(const ModelFileView& view, std::vector<uint32_t>& words);

// The header at the start of a packed block (words.size() >= LSNIF_GPU_HEADER_WORDS, else zeros).
LsnifGpuModelHeader gpu_block_header(const std::vector<uint32_t>& words);

// Ok when `words` starts with a header of this build's layout (magic LSNIF_GPU_MAGIC, version
// LSNIF_GPU_VERSION) whose total_words equals words.size(); else an error naming the mismatch
// (e.g. "GPU block layout version 3, this build reads version 4").
Status check_gpu_block_header(const std::vector<uint32_t>& words);

}  // namespace lsnif
