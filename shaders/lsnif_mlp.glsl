// lsnif_mlp.glsl -- the LSNIF MLP forward pass on the device (host/network.cpp mlp_forward):
// hidden layers y = leaky(W x + b) with leaky(y) = max(y, slope * y), then a linear output layer.
// Weights and biases are fp16 pairs in 32-bit words (layout: shaders/host_device.h), unpacked with
// unpackHalf2x16 (no 16-bit storage feature) and accumulated in fp32. Loops stay rolled: on
// lavapipe unrolling multiplies the pipeline compile time.
#ifndef LSNIF_MLP_GLSL
#define LSNIF_MLP_GLSL

#include "lsnif_encoding.glsl"

// Runs the network on lsnif_act[0, input_dim) (written by lsnif_encode). Returns the index in
// lsnif_act of the first of the output_dim raw outputs.
uint lsnif_mlp_forward(LsnifModel m) {
  const uint layers = m.h.hidden_layers + 1u;
  const float slope = m.h.leaky_slope;
  uint in_dim = lsnif_input_dim(m);
  uint in_base = 0u, out_base = LSNIF_MAX_INPUT;
  uint word = m.h.mlp_offset;  // first word of the current layer
  for (uint l = 0u; l < layers; ++l) {
    const bool last = l == m.h.hidden_layers;
    const uint out_dim = last ? lsnif_output_dim(m) : m.h.hidden_width;
    const uint row_words = LSNIF_GPU_ROW_WORDS(in_dim);
    const uint bias_word = word + out_dim * row_words;
    for (uint r = 0u; r < out_dim; ++r) {
      const uint row = word + r * row_words;
      float acc = 0.0;
      for (uint i = 0u; i < row_words; ++i) {
        const vec2 w = unpackHalf2x16(m.words.w[row + i]);
        acc += w.x * lsnif_act[in_base + 2u * i] + w.y * lsnif_act[in_base + 2u * i + 1u];
      }
      acc += lsnif_half(m, bias_word, r);
      if (!last) acc = max(acc, slope * acc);
      lsnif_act[out_base + r] = acc;
    }
    if ((out_dim & 1u) != 0u) lsnif_act[out_base + out_dim] = 0.0;  // pad slot read as a pair
    word = bias_word + LSNIF_GPU_ROW_WORDS(out_dim);
    in_dim = out_dim;
    const uint tmp = in_base;
    in_base = out_base;
    out_base = tmp;
  }
  return in_base;
}

#endif
