// lsnif_mlp.glsl -- the LSNIF MLP forward pass on the device (src/lsnif/core/network.cpp mlp_forward):
// hidden layers y = leaky(W x + b) with leaky(y) = max(y, slope * y), then a linear output layer.
// Weights and biases are fp16 pairs in 32-bit words, unpacked with unpackHalf2x16 (no 16-bit
// storage feature needed) and accumulated in fp32.
//
// The portable inference path (every device, lavapipe included): rows are computed in groups of
// 4 blocks of 8 (then single blocks for the rest), their weights interleaved per input pair
// (layout: src/lsnif/host_device.h) so that each step of the inner loop reads two activations and,
// per block, one 32-byte load feeding 16 FMAs into two vec4 accumulators. On lavapipe the loads
// (one per lane) and the private-array reads, not the arithmetic, bound the speed: measured with
// lsnif bench-trace (docs/bench-trace.md), row by row with one 4-byte load per 2 FMAs was ~4-5x
// slower. Loops stay rolled: on lavapipe unrolling multiplies the pipeline compile time.
#ifndef LSNIF_MLP_GLSL
#define LSNIF_MLP_GLSL

#include "lsnif/shaders/lsnif_encoding.glsl"

// Runs the network on lsnif_act[0, input_dim) (written by lsnif_encode). Returns the index in
// lsnif_act of the first of the output_dim raw outputs (followed by zeros up to the row block).
// One step of a block: accumulates rows 0-3 / 4-7 of the block's weights (lo / hi) for inputs x0, x1.
#define LSNIF_MLP_ROWS(acc, q, x0, x1)                                                             \
  acc += vec4(unpackHalf2x16(q.x).x, unpackHalf2x16(q.y).x, unpackHalf2x16(q.z).x, unpackHalf2x16(q.w).x) * \
             x0 +                                                                                 \
         vec4(unpackHalf2x16(q.x).y, unpackHalf2x16(q.y).y, unpackHalf2x16(q.z).y, unpackHalf2x16(q.w).y) * x1

// Bias, activation and store of one block's 8 rows (acc_lo: rows 0-3, acc_hi: 4-7) of block b.
void lsnif_mlp_finish_block(LsnifModel m, uint bias_oct, uint b, bool hidden, float slope, uint out_base,
                            vec4 acc_lo, vec4 acc_hi) {
  uvec4 bias, unused;
  lsnif_load_oct(m, bias_oct + b, bias, unused);
  acc_lo += vec4(unpackHalf2x16(bias.x), unpackHalf2x16(bias.y));
  acc_hi += vec4(unpackHalf2x16(bias.z), unpackHalf2x16(bias.w));
  if (hidden) {
    acc_lo = max(acc_lo, slope * acc_lo);
    acc_hi = max(acc_hi, slope * acc_hi);
  }
  const uint o = out_base + b * LSNIF_GPU_ROW_BLOCK;
  for (uint k = 0u; k < 4u; ++k) {
    lsnif_act[o + k] = acc_lo[k];
    lsnif_act[o + 4u + k] = acc_hi[k];
  }
}

// Runs the network on lsnif_act[0, input_dim) (written by lsnif_encode). Returns the index in
// lsnif_act of the first of the output_dim raw outputs (followed by zeros up to the row block).
uint lsnif_mlp_forward(LsnifModel m) {
  const uint layers = m.h.hidden_layers + 1u;
  const float slope = m.h.leaky_slope;
  uint in_dim = lsnif_input_dim(m);
  uint in_base = 0u, out_base = LSNIF_MAX_INPUT;
  uint oct = m.h.mlp_offset >> 3;  // first oct of the current layer
  for (uint l = 0u; l < layers; ++l) {
    const bool hidden = l < m.h.hidden_layers;
    const uint out_dim = hidden ? m.h.hidden_width : lsnif_output_dim(m);
    const uint pairs = LSNIF_GPU_ROW_WORDS(in_dim);
    const uint blocks = LSNIF_GPU_ROW_BLOCKS(out_dim);
    const uint bias_oct = oct + blocks * pairs;
    uint b = 0u;
    for (; b + 4u <= blocks; b += 4u) {  // 32 rows per pass over the input
      const uint first = oct + b * pairs;
      vec4 a0 = vec4(0.0), a1 = vec4(0.0), a2 = vec4(0.0), a3 = vec4(0.0);
      vec4 a4 = vec4(0.0), a5 = vec4(0.0), a6 = vec4(0.0), a7 = vec4(0.0);
      for (uint i = 0u; i < pairs; ++i) {
        const float x0 = lsnif_act[in_base + 2u * i], x1 = lsnif_act[in_base + 2u * i + 1u];
        uvec4 lo, hi;
        lsnif_load_oct(m, first + i, lo, hi);
        LSNIF_MLP_ROWS(a0, lo, x0, x1);
        LSNIF_MLP_ROWS(a1, hi, x0, x1);
        lsnif_load_oct(m, first + pairs + i, lo, hi);
        LSNIF_MLP_ROWS(a2, lo, x0, x1);
        LSNIF_MLP_ROWS(a3, hi, x0, x1);
        lsnif_load_oct(m, first + 2u * pairs + i, lo, hi);
        LSNIF_MLP_ROWS(a4, lo, x0, x1);
        LSNIF_MLP_ROWS(a5, hi, x0, x1);
        lsnif_load_oct(m, first + 3u * pairs + i, lo, hi);
        LSNIF_MLP_ROWS(a6, lo, x0, x1);
        LSNIF_MLP_ROWS(a7, hi, x0, x1);
      }
      lsnif_mlp_finish_block(m, bias_oct, b, hidden, slope, out_base, a0, a1);
      lsnif_mlp_finish_block(m, bias_oct, b + 1u, hidden, slope, out_base, a2, a3);
      lsnif_mlp_finish_block(m, bias_oct, b + 2u, hidden, slope, out_base, a4, a5);
      lsnif_mlp_finish_block(m, bias_oct, b + 3u, hidden, slope, out_base, a6, a7);
    }
    for (; b < blocks; ++b) {  // the remaining blocks, 8 rows per pass
      const uint first = oct + b * pairs;
      vec4 a0 = vec4(0.0), a1 = vec4(0.0);
      for (uint i = 0u; i < pairs; ++i) {
        const float x0 = lsnif_act[in_base + 2u * i], x1 = lsnif_act[in_base + 2u * i + 1u];
        uvec4 lo, hi;
        lsnif_load_oct(m, first + i, lo, hi);
        LSNIF_MLP_ROWS(a0, lo, x0, x1);
        LSNIF_MLP_ROWS(a1, hi, x0, x1);
      }
      lsnif_mlp_finish_block(m, bias_oct, b, hidden, slope, out_base, a0, a1);
    }
    // Padded rows are zero (zero weights and bias), so the slot after an odd out_dim, read as the
    // high half of the last pair by the next layer, is zero.
    oct = bias_oct + blocks;
    in_dim = out_dim;
    const uint tmp = in_base;
    in_base = out_base;
    out_base = tmp;
  }
  return in_base;
}

#endif
