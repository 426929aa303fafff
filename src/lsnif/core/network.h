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
// layer l (layer_input[0] is the encoded features).
struct MlpTrace {
  std::vector<Matrix> layer_input;
};

// out = MLP(input): input is input_dim x B, out becomes output_dim x B (raw, pre-activation).
// When `trace` is given, keeps what mlp_backward needs.
void mlp_forward(const Config& config, const float* params, const Matrix& input, Matrix& out,
                 MlpTrace* trace = nullptr);

// Given d(loss)/d(out), accumulates d(loss)/d(params) into d_params (same layout, not cleared) and,
// if d_input is given, writes d(loss)/d(input).
void mlp_backward(const Config& config, const float* params, const MlpTrace& trace,
                  const Matrix& d_out, float* d_params, Matrix* d_input);

// Kaiming-normal weights for leaky ReLU (std = sqrt(2 / (1 + a^2)) / sqrt(fan_in)), zero biases.
void mlp_init_kaiming(const Config& config, uint64_t seed, float* params);

}  // namespace lsnif
