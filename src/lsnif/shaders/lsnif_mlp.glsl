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
// lsnif_mlp_forward runs one ray (the intersection shader); the batched paths run two rays per
// invocation (lsnif_mlp_forward_pair), each weight loaded and converted once for both: 1.7-2.3x
// the MLP stage's speed on lavapipe (docs/batched-queries.md, "Two rays per invocation").
#ifndef LSNIF_MLP_GLSL
#define LSNIF_MLP_GLSL

#include "lsnif/shaders/lsnif_encoding.glsl"

// The weights of 4 rows in the 4 words q of a block half: for the pair's first input (LSNIF_MLP_W0)
// and its second (LSNIF_MLP_W1).
#define LSNIF_MLP_W0(q) vec4(unpackHalf2x16(q.x).x, unpackHalf2x16(q.y).x, unpackHalf2x16(q.z).x, unpackHalf2x16(q.w).x)
#define LSNIF_MLP_W1(q) vec4(unpackHalf2x16(q.x).y, unpackHalf2x16(q.y).y, unpackHalf2x16(q.z).y, unpackHalf2x16(q.w).y)
// One step of a block: accumulates rows 0-3 / 4-7 of the block's weights (lo / hi) for inputs x0, x1.
#define LSNIF_MLP_ROWS(acc, q, x0, x1) acc += LSNIF_MLP_W0(q) * x0 + LSNIF_MLP_W1(q) * x1

// The bias of block b's 8 rows: rows 0-3 (lo) and 4-7 (hi).
void lsnif_mlp_bias(LsnifModel m, uint bias_oct, uint b, out vec4 lo, out vec4 hi) {
  uvec4 bias, unused;
  lsnif_load_oct(m, bias_oct + b, bias, unused);
  lo = vec4(unpackHalf2x16(bias.x), unpackHalf2x16(bias.y));
  hi = vec4(unpackHalf2x16(bias.z), unpackHalf2x16(bias.w));
}

// A hidden layer's activation (leaky ReLU), or the output layer's identity.
vec4 lsnif_mlp_activate(vec4 y, bool hidden, float slope) { return hidden ? max(y, slope * y) : y; }

// Bias, activation and store of one block's 8 rows (acc_lo: rows 0-3, acc_hi: 4-7) of block b.
void lsnif_mlp_finish_block(LsnifModel m, uint bias_oct, uint b, bool hidden, float slope, uint out_base,
                            vec4 acc_lo, vec4 acc_hi) {
  vec4 lo, hi;
  lsnif_mlp_bias(m, bias_oct, b, lo, hi);
  acc_lo = lsnif_mlp_activate(acc_lo + lo, hidden, slope);
  acc_hi = lsnif_mlp_activate(acc_hi + hi, hidden, slope);
  const uint o = out_base + b * LSNIF_GPU_ROW_BLOCK;
  for (uint k = 0u; k < 4u; ++k) {
    lsnif_act[o + k] = acc_lo[k];
    lsnif_act[o + 4u + k] = acc_hi[k];
  }
}

// The input pairs of the first layer a walk of `points` boundary points uses: the encoding fills
// point j's L x F inputs at (j L + l) F + f and leaves the rest zero (lsnif_encode), so a walk of
// n < H points multiplies only its leading n L F inputs (src/lsnif/core/hash_grid.h encoded_rows on
// the CPU). A walk has 5 of the default 18 points on average (measured in training).
uint lsnif_mlp_used_pairs(LsnifModel m, uint points) {
  return LSNIF_GPU_ROW_WORDS(min(points, m.h.max_points) * m.h.grid_levels * m.h.features);
}

// The layer bookkeeping both forward passes share: the layer's shape, where its weights start (in
// octs of the block) and the two halves of lsnif_act its input and output take turns in.
struct LsnifMlpLayer {
  bool hidden;    // a hidden layer (leaky ReLU), else the output layer
  uint in_dim, out_dim;
  uint pairs;     // input pairs of a weight row
  uint used;      // the input pairs the loops run over (the first layer: those the walk filled)
  uint blocks;    // blocks of 8 output rows
  uint oct;       // first oct of the layer's weights
  uint bias_oct;  // first oct of its biases
  uint in_base, out_base;
};

// The state before the first layer: the network input at lsnif_act[0, input_dim).
LsnifMlpLayer lsnif_mlp_input_layer(LsnifModel m) {
  LsnifMlpLayer layer;
  layer.hidden = true;
  layer.in_dim = lsnif_input_dim(m);
  layer.out_dim = 0u;
  layer.pairs = layer.used = layer.blocks = layer.bias_oct = 0u;
  layer.oct = m.h.mlp_offset >> 3;
  layer.in_base = 0u;
  layer.out_base = LSNIF_MAX_INPUT;
  return layer;
}

// Layer l's shape, its first layer bounded by a walk of `points` boundary points.
void lsnif_mlp_shape_layer(LsnifModel m, uint l, uint points, inout LsnifMlpLayer layer) {
  layer.hidden = l < m.h.hidden_layers;
  layer.out_dim = layer.hidden ? m.h.hidden_width : lsnif_output_dim(m);
  layer.pairs = LSNIF_GPU_ROW_WORDS(layer.in_dim);
  layer.used = l == 0u ? min(layer.pairs, lsnif_mlp_used_pairs(m, points)) : layer.pairs;
  layer.blocks = LSNIF_GPU_ROW_BLOCKS(layer.out_dim);
  layer.bias_oct = layer.oct + layer.blocks * layer.pairs;
}

// After a layer: its output is the next one's input. Padded rows are zero (zero weights and bias),
// so the slot after an odd out_dim, read as the high half of the last pair by the next layer, is zero.
void lsnif_mlp_next_layer(inout LsnifMlpLayer layer) {
  layer.oct = layer.bias_oct + layer.blocks;
  layer.in_dim = layer.out_dim;
  const uint previous_input = layer.in_base;
  layer.in_base = layer.out_base;
  layer.out_base = previous_input;
}

// Runs the network on lsnif_act[0, input_dim) (written by lsnif_encode) of a walk of `points`
// boundary points: the first layer reads only the inputs the walk filled (lsnif_mlp_used_pairs; the
// others are zero). Returns the index in lsnif_act of the first of the output_dim raw outputs
// (followed by zeros up to the row block).
uint lsnif_mlp_forward(LsnifModel m, uint points) {
  const float slope = m.h.leaky_slope;
  LsnifMlpLayer layer = lsnif_mlp_input_layer(m);
  for (uint l = 0u; l <= m.h.hidden_layers; ++l) {
    lsnif_mlp_shape_layer(m, l, points, layer);
    uint b = 0u;
    for (; b + 4u <= layer.blocks; b += 4u) {  // 32 rows per pass over the input
      const uint first = layer.oct + b * layer.pairs;
      vec4 a0 = vec4(0.0), a1 = vec4(0.0), a2 = vec4(0.0), a3 = vec4(0.0);
      vec4 a4 = vec4(0.0), a5 = vec4(0.0), a6 = vec4(0.0), a7 = vec4(0.0);
      for (uint i = 0u; i < layer.used; ++i) {
        const float x0 = lsnif_act[layer.in_base + 2u * i], x1 = lsnif_act[layer.in_base + 2u * i + 1u];
        uvec4 lo, hi;
        lsnif_load_oct(m, first + i, lo, hi);
        LSNIF_MLP_ROWS(a0, lo, x0, x1);
        LSNIF_MLP_ROWS(a1, hi, x0, x1);
        lsnif_load_oct(m, first + layer.pairs + i, lo, hi);
        LSNIF_MLP_ROWS(a2, lo, x0, x1);
        LSNIF_MLP_ROWS(a3, hi, x0, x1);
        lsnif_load_oct(m, first + 2u * layer.pairs + i, lo, hi);
        LSNIF_MLP_ROWS(a4, lo, x0, x1);
        LSNIF_MLP_ROWS(a5, hi, x0, x1);
        lsnif_load_oct(m, first + 3u * layer.pairs + i, lo, hi);
        LSNIF_MLP_ROWS(a6, lo, x0, x1);
        LSNIF_MLP_ROWS(a7, hi, x0, x1);
      }
      lsnif_mlp_finish_block(m, layer.bias_oct, b, layer.hidden, slope, layer.out_base, a0, a1);
      lsnif_mlp_finish_block(m, layer.bias_oct, b + 1u, layer.hidden, slope, layer.out_base, a2, a3);
      lsnif_mlp_finish_block(m, layer.bias_oct, b + 2u, layer.hidden, slope, layer.out_base, a4, a5);
      lsnif_mlp_finish_block(m, layer.bias_oct, b + 3u, layer.hidden, slope, layer.out_base, a6, a7);
    }
    for (; b < layer.blocks; ++b) {  // the remaining blocks, 8 rows per pass
      const uint first = layer.oct + b * layer.pairs;
      vec4 a0 = vec4(0.0), a1 = vec4(0.0);
      for (uint i = 0u; i < layer.used; ++i) {
        const float x0 = lsnif_act[layer.in_base + 2u * i], x1 = lsnif_act[layer.in_base + 2u * i + 1u];
        uvec4 lo, hi;
        lsnif_load_oct(m, first + i, lo, hi);
        LSNIF_MLP_ROWS(a0, lo, x0, x1);
        LSNIF_MLP_ROWS(a1, hi, x0, x1);
      }
      lsnif_mlp_finish_block(m, layer.bias_oct, b, layer.hidden, slope, layer.out_base, a0, a1);
    }
    lsnif_mlp_next_layer(layer);
  }
  return layer.in_base;
}

// The batched paths' kernel: the network on two rays at once, A in lsnif_act and B in lsnif_act_b
// (inputs of walks of points_a and points_b boundary points), so that every weight loaded and
// converted feeds the FMAs of both rays (a 2-ray x 16-row register block per invocation: on a CPU
// driver each weight is a full SIMD value per lane group, its load and fp16 conversion the cost to
// share). Each ray's sums run in the single-ray order (lsnif_mlp_forward): the results are the same
// bits. The first layer runs over the inputs the longer walk uses; the shorter walk's are zero there.
// Returns the index of the first raw output in both arrays.
float lsnif_act_b[LSNIF_ACT_SIZE];

void lsnif_mlp_finish_pair(LsnifModel m, uint bias_oct, uint b, bool hidden, float slope, uint out_base,
                           vec4 a_lo, vec4 a_hi, vec4 b_lo, vec4 b_hi) {
  vec4 lo, hi;
  lsnif_mlp_bias(m, bias_oct, b, lo, hi);
  a_lo = lsnif_mlp_activate(a_lo + lo, hidden, slope);
  a_hi = lsnif_mlp_activate(a_hi + hi, hidden, slope);
  b_lo = lsnif_mlp_activate(b_lo + lo, hidden, slope);
  b_hi = lsnif_mlp_activate(b_hi + hi, hidden, slope);
  const uint o = out_base + b * LSNIF_GPU_ROW_BLOCK;
  for (uint k = 0u; k < 4u; ++k) {
    lsnif_act[o + k] = a_lo[k];
    lsnif_act[o + 4u + k] = a_hi[k];
    lsnif_act_b[o + k] = b_lo[k];
    lsnif_act_b[o + 4u + k] = b_hi[k];
  }
}

uint lsnif_mlp_forward_pair(LsnifModel m, uint points_a, uint points_b) {
  const float slope = m.h.leaky_slope;
  LsnifMlpLayer layer = lsnif_mlp_input_layer(m);
  for (uint l = 0u; l <= m.h.hidden_layers; ++l) {
    lsnif_mlp_shape_layer(m, l, max(points_a, points_b), layer);
    uint b = 0u;
    for (; b + 2u <= layer.blocks; b += 2u) {  // 16 rows of both rays per pass over the input
      const uint first = layer.oct + b * layer.pairs;
      vec4 a0 = vec4(0.0), a1 = vec4(0.0), a2 = vec4(0.0), a3 = vec4(0.0);
      vec4 b0 = vec4(0.0), b1 = vec4(0.0), b2 = vec4(0.0), b3 = vec4(0.0);
      for (uint i = 0u; i < layer.used; ++i) {
        const float x0 = lsnif_act[layer.in_base + 2u * i], x1 = lsnif_act[layer.in_base + 2u * i + 1u];
        const float y0 = lsnif_act_b[layer.in_base + 2u * i], y1 = lsnif_act_b[layer.in_base + 2u * i + 1u];
        uvec4 q0, q1, q2, q3;
        lsnif_load_oct(m, first + i, q0, q1);
        lsnif_load_oct(m, first + layer.pairs + i, q2, q3);
        const vec4 w0x = LSNIF_MLP_W0(q0), w0y = LSNIF_MLP_W1(q0), w1x = LSNIF_MLP_W0(q1), w1y = LSNIF_MLP_W1(q1);
        const vec4 w2x = LSNIF_MLP_W0(q2), w2y = LSNIF_MLP_W1(q2), w3x = LSNIF_MLP_W0(q3), w3y = LSNIF_MLP_W1(q3);
        a0 += w0x * x0 + w0y * x1;
        a1 += w1x * x0 + w1y * x1;
        a2 += w2x * x0 + w2y * x1;
        a3 += w3x * x0 + w3y * x1;
        b0 += w0x * y0 + w0y * y1;
        b1 += w1x * y0 + w1y * y1;
        b2 += w2x * y0 + w2y * y1;
        b3 += w3x * y0 + w3y * y1;
      }
      lsnif_mlp_finish_pair(m, layer.bias_oct, b, layer.hidden, slope, layer.out_base, a0, a1, b0, b1);
      lsnif_mlp_finish_pair(m, layer.bias_oct, b + 1u, layer.hidden, slope, layer.out_base, a2, a3, b2, b3);
    }
    for (; b < layer.blocks; ++b) {  // an odd last block
      const uint first = layer.oct + b * layer.pairs;
      vec4 a0 = vec4(0.0), a1 = vec4(0.0), b0 = vec4(0.0), b1 = vec4(0.0);
      for (uint i = 0u; i < layer.used; ++i) {
        const float x0 = lsnif_act[layer.in_base + 2u * i], x1 = lsnif_act[layer.in_base + 2u * i + 1u];
        const float y0 = lsnif_act_b[layer.in_base + 2u * i], y1 = lsnif_act_b[layer.in_base + 2u * i + 1u];
        uvec4 q0, q1;
        lsnif_load_oct(m, first + i, q0, q1);
        const vec4 w0x = LSNIF_MLP_W0(q0), w0y = LSNIF_MLP_W1(q0), w1x = LSNIF_MLP_W0(q1), w1y = LSNIF_MLP_W1(q1);
        a0 += w0x * x0 + w0y * x1;
        a1 += w1x * x0 + w1y * x1;
        b0 += w0x * y0 + w0y * y1;
        b1 += w1x * y0 + w1y * y1;
      }
      lsnif_mlp_finish_pair(m, layer.bias_oct, b, layer.hidden, slope, layer.out_base, a0, a1, b0, b1);
    }
    lsnif_mlp_next_layer(layer);
  }
  return layer.in_base;
}

#endif
