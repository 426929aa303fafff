// mlp_gemm.h -- the MLP's matrix products on the CPU (network.cpp): a register-blocked,
// single-threaded GEMM for the network's shapes (a few hundred rows and columns, one column chunk of
// a batch per thread), with what follows each product fused into its store: the bias and the leaky
// ReLU of a forward layer, the leaky ReLU's derivative of a backward one. AVX-512 where the build
// targets it, AVX2 with FMA, SSE2 (any x86-64), or plain loops elsewhere.
//
// Every operand is a strided view, so that one kernel serves the forward product (W x X), the
// input gradient (W^T x dY) and the weight gradient (dW^T = X x dY^T) without copies.
#pragma once
#include <cstddef>
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

// The same product with A and B rounded to bf16 (8 bits of mantissa; the products exact, the sums,
// C and the epilogue fp32): twice the multiply-adds per instruction where the CPU has AVX512_BF16.
// `packed_a` holds A as pack_bf16_a wrote it for an op of the same A, a_k and K and `packed_m` rows
// (0: op.M; packed_m x ceil(K / 2) words: a caller that multiplies by the same A again packs it
// once, and may cut M or K of it); B is packed into `scratch` (mlp_gemm_bf16_scratch(op) words).
void mlp_gemm_bf16(const GemmOperands& op, const GemmEpilogue& epilogue, const uint32_t* packed_a, uint32_t* scratch,
                   int64_t packed_m = 0);
void pack_bf16_a(const GemmOperands& op, uint32_t* dst);
size_t mlp_gemm_bf16_scratch(const GemmOperands& op);
// Whether mlp_gemm_bf16 runs on bf16 instructions (AVX512_BF16 builds); elsewhere it emulates
// them in plain loops (the same sums up to denormals, far slower: for tests).
bool mlp_gemm_bf16_native();

// The bf16 value nearest to x (ties to even), as the bf16 instructions round; NaN stays NaN.
uint16_t bf16_from_float(float x);
float float_from_bf16(uint16_t h);

// The packing, from an fp32 matrix S(r, c) = src[r + c * ld], r < R, c < C, into words of two bf16
// (the even k in the low half): pairs of adjacent columns, dst[r + p * R] = (S(r, 2p), S(r, 2p + 1))
// for p < ceil(C / 2) (A with k = c; B whose rows are contiguous) ...
void pack_bf16_column_pairs(const float* src, int64_t ld, int64_t R, int64_t C, uint32_t* dst);
// ... or pairs of adjacent rows, dst[p + c * ceil(R / 2)] = (S(2p, c), S(2p + 1, c)) (B whose
// columns are contiguous, k = r). A missing last column or row gives 0.
void pack_bf16_row_pairs(const float* src, int64_t ld, int64_t R, int64_t C, uint32_t* dst);


}  // namespace lsnif
