// mlp_gemm.h -- the MLP's matrix products on the CPU (network.cpp): a register-blocked,
// single-threaded GEMM for the network's shapes (a few hundred rows and columns, one column chunk of
// a batch per thread), with what follows each product fused into its store: the bias and the leaky
// ReLU of a forward layer, the leaky ReLU's derivative of a backward one. AVX-512 where the build
// targets it, AVX2 with FMA, SSE2 (any x86-64), or plain loops elsewhere.
//
// Every operand is a strided view, so that one kernel serves the forward product (W x X), the
// input gradient (W^T x dY) and the weight gradient (dW^T = X x dY^T) without copies.
#pragma once
#include <cstdint>

namespace lsnif {

// C(m, n) = A(m, k) B(k, n), for m < M, n < N, summed over k < K, then the epilogue.
struct GemmOperands {
  int64_t M = 0, N = 0, K = 0;
  const float* A = nullptr;  // A(m, k) = A[m + k * a_k]: each k's M values contiguous
  int64_t a_k = 0;
  const float* B = nullptr;  // B(k, n) = B[k * b_k + n * b_n]
  int64_t b_k = 0, b_n = 0;
  float* C = nullptr;        // C(m, n) = C[m + n * c_n]
  int64_t c_n = 0;
};

// Applied to every C(m, n) after the sum, in this order.
struct GemmEpilogue {
  const float* bias = nullptr;  // + bias[m]
  bool leaky = false;           // max(v, slope * v) (a leaky ReLU, 0 <= slope < 1)
  const float* gate = nullptr;  // * (gate[m + n * gate_n] > 0 ? 1 : slope): the leaky ReLU's derivative at
  int64_t gate_n = 0;           //   the activation `gate` it produced
  float slope = 0.0f;
};

// Writes C (every C(m, n) of the ranges; C may hold anything before). M, N, K >= 0; K == 0 gives
// the epilogue of zero. A's reads stay within the M x K values it addresses.
void mlp_gemm(const GemmOperands& op, const GemmEpilogue& epilogue = {});

// The instruction set the kernel was built for: "avx512", "avx2", "sse2" or "generic" (not x86-64).
const char* mlp_gemm_isa();


}  // namespace lsnif
