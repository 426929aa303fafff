// network.h -- the LSNIF MLP (paper 5.1): input H*L*F, `hidden_layers` layers of width W with leaky
// ReLU, a linear output layer of 8 + Nmat raw values (activations are applied by the output heads,
// head.h). This is the one C++ definition of the network math: training and the CPU reference
// intersector both call mlp_forward; src/lsnif/shaders/lsnif_mlp.glsl mirrors it.
//
// Batches are column-major Eigen matrices, one ray per column. Parameters are a flat float array
// in the model.h layout: for each layer, W row-major [out][in] then b [out].
#pragma once
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "lsnif/format/config.h"

namespace lsnif {

using Matrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor>;

// Activations kept by the forward pass for the backward pass: layer_input[l] is the input of
// layer l (layer_input[0] is the encoded features); chunk_input_rows[c] the leading input rows the
// first layer read for column chunk c (the rest are zero: see mlp_forward's `input_rows`). The
// rest is the two passes' workspace, kept with the trace so that a training step allocates
// nothing; its contents between calls mean nothing.
struct MlpTrace {
  std::vector<Matrix> layer_input;
  std::vector<Eigen::Index> chunk_input_rows;
  std::vector<float> weights_t;             // every layer's W transposed (the products' left operand)
  std::vector<float> chunk_gradients;       // each column chunk's parameter gradient
  std::vector<std::vector<float>> deltas;   // per thread, two gradients of a layer's pre-activation
  // The products of every layer but the output layer (the first layer and those between two hidden
  // ones: ~9/10 of the multiply-adds) in bf16 (mlp_gemm_bf16: 8-bit mantissas, exact products, fp32
  // sums and activations) instead of fp32: a trainer's choice (set before mlp_forward) where the CPU
  // has the instructions; the output layer, and every product without a trace, stay fp32.
  bool bf16_layers = false;
  std::vector<uint32_t> weights_bf16;          // those layers' W packed for the forward and backward products
  std::vector<std::vector<uint32_t>> packed;   // per thread, two packed operands of a chunk
};

// Whether layer `layer` of the network is one that MlpTrace::bf16_layers computes in bf16.
bool mlp_layer_bf16(const Config& config, size_t layer);

// out = MLP(input): input is input_dim x B, out becomes output_dim x B (raw, pre-activation).
// When `trace` is given, keeps what mlp_backward needs (the input is copied into
// trace->layer_input[0] unless it is that matrix already: a caller may write its input there).
//
// `input_rows` (optional, B entries): the caller promises that rows input_rows[b] and beyond of
// column b are zero, as the encoding leaves the slots of the points a walk does not have
// (encoded_rows); counts beyond input_dim read as input_dim. The first layer then multiplies only
// the leading rows that some column of a column chunk uses, which changes no output (the skipped
// products are exact zeros) and saves the most when columns with similar counts are adjacent (a
// batch ordered by point count).
void mlp_forward(const Config& config, const float* params, const Matrix& input, Matrix& out,
                 MlpTrace* trace = nullptr, const uint32_t* input_rows = nullptr);

// Given d(loss)/d(out), writes d(loss)/d(params) into d_params (same layout; nothing read) and,
// if d_input is given, writes d(loss)/d(input). After a forward pass given `input_rows`, the
// gradients equal the full products' (to float rounding at most), and d_input is zero on the rows
// beyond those the column's chunk used.
void mlp_backward(const Config& config, const float* params, MlpTrace& trace, const Matrix& d_out,
                  float* d_params, Matrix* d_input);

// Kaiming-normal weights for leaky ReLU (std = sqrt(2 / (1 + a^2)) / sqrt(fan_in)), zero biases.
void mlp_init_kaiming(const Config& config, uint64_t seed, float* params);

}  // namespace lsnif
