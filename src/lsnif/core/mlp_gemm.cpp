// mlp_gemm.cpp -- see mlp_gemm.h. A tile of up to 64 rows (4 vectors of 16) by 6 columns of C is
// summed in 24 vector registers: per k, the tile's 4 vectors of A are loaded once and each of the 6
// values of B broadcast once, for 24 fused multiply-adds. K is cut into blocks of kKBlock so that a
// tile's slice of A (64 x 128 floats, 32 KB) stays in the L1 cache while the tile moves along the
// columns; partial sums of a block go through C. On this machine kind (AVX-512, one core: 222
// GFLOP/s of fused multiply-adds at most) the 128 x 128 layer's products over a 512-column chunk ran
// at 122-135 GFLOP/s through Eigen and at 188-213 here (docs/results.md, "Training time").
#include "lsnif/core/mlp_gemm.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <type_traits>
#include <utility>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace lsnif {
namespace {

constexpr int kLanes = 16;        // floats per vector (two AVX2 registers, or 16 plain floats)
constexpr int64_t kKBlock = 128;  // k values per pass over a tile

#if defined(__AVX512F__)
constexpr const char* kIsa = "avx512";
constexpr int kTileVectors = 4, kTileColumns = 6;  // 24 of the 32 registers sum
struct Vec {
  __m512 v;
};
struct Mask {
  __mmask16 k;
};
inline Mask lanes_mask(int n) { return {__mmask16((1u << n) - 1u)}; }
inline Vec vzero() { return {_mm512_setzero_ps()}; }
inline Vec vload(const float* p) { return {_mm512_loadu_ps(p)}; }
inline Vec vload(const float* p, Mask m) { return {_mm512_maskz_loadu_ps(m.k, p)}; }
inline void vstore(float* p, Vec a, Mask m) { _mm512_mask_storeu_ps(p, m.k, a.v); }
inline Vec vbroadcast(const float* p) { return {_mm512_set1_ps(*p)}; }
inline Vec vfma(Vec a, Vec b, Vec c) { return {_mm512_fmadd_ps(a.v, b.v, c.v)}; }
inline Vec vadd(Vec a, Vec b) { return {_mm512_add_ps(a.v, b.v)}; }
// The leaky ReLU and its derivative as a masked multiply (GCC 12 warns falsely inside _mm512_max_ps).
inline Vec vleaky(Vec a, float slope) {
  const __mmask16 not_positive = _mm512_cmp_ps_mask(a.v, _mm512_setzero_ps(), _CMP_NGT_UQ);
  return {_mm512_mask_mul_ps(a.v, not_positive, a.v, _mm512_set1_ps(slope))};
}
inline Vec vgate(Vec a, Vec g, float slope) {
  const __mmask16 not_positive = _mm512_cmp_ps_mask(g.v, _mm512_setzero_ps(), _CMP_NGT_UQ);
  return {_mm512_mask_mul_ps(a.v, not_positive, a.v, _mm512_set1_ps(slope))};
}
#elif defined(__AVX2__) && defined(__FMA__)
constexpr const char* kIsa = "avx2";
constexpr int kTileVectors = 1, kTileColumns = 6;  // 12 of the 16 registers sum
struct Vec {
  __m256 lo, hi;
};
struct Mask {
  __m256i lo, hi;
};
inline Mask lanes_mask(int n) {
  const __m256i first = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), count = _mm256_set1_epi32(n);
  return {_mm256_cmpgt_epi32(count, first), _mm256_cmpgt_epi32(count, _mm256_add_epi32(first, _mm256_set1_epi32(8)))};
}
inline Vec vzero() { return {_mm256_setzero_ps(), _mm256_setzero_ps()}; }
inline Vec vload(const float* p) { return {_mm256_loadu_ps(p), _mm256_loadu_ps(p + 8)}; }
inline Vec vload(const float* p, Mask m) { return {_mm256_maskload_ps(p, m.lo), _mm256_maskload_ps(p + 8, m.hi)}; }
inline void vstore(float* p, Vec a, Mask m) {
  _mm256_maskstore_ps(p, m.lo, a.lo);
  _mm256_maskstore_ps(p + 8, m.hi, a.hi);
}
inline Vec vbroadcast(const float* p) {
  const __m256 b = _mm256_broadcast_ss(p);
  return {b, b};
}
inline Vec vfma(Vec a, Vec b, Vec c) { return {_mm256_fmadd_ps(a.lo, b.lo, c.lo), _mm256_fmadd_ps(a.hi, b.hi, c.hi)}; }
inline Vec vadd(Vec a, Vec b) { return {_mm256_add_ps(a.lo, b.lo), _mm256_add_ps(a.hi, b.hi)}; }
inline Vec vleaky(Vec a, float slope) {
  const __m256 s = _mm256_set1_ps(slope);
  return {_mm256_max_ps(a.lo, _mm256_mul_ps(a.lo, s)), _mm256_max_ps(a.hi, _mm256_mul_ps(a.hi, s))};
}
inline Vec vgate(Vec a, Vec g, float slope) {
  const __m256 s = _mm256_set1_ps(slope), z = _mm256_setzero_ps();
  return {_mm256_blendv_ps(_mm256_mul_ps(a.lo, s), a.lo, _mm256_cmp_ps(g.lo, z, _CMP_GT_OQ)),
          _mm256_blendv_ps(_mm256_mul_ps(a.hi, s), a.hi, _mm256_cmp_ps(g.hi, z, _CMP_GT_OQ))};
}
#elif defined(__SSE2__)
constexpr const char* kIsa = "sse2";
constexpr int kTileVectors = 1, kTileColumns = 2;  // 8 of the 16 registers sum
struct Vec {
  __m128 q[4];
};
struct Mask {
  int n;
};
inline Mask lanes_mask(int n) { return {n}; }
inline Vec vzero() { return {{_mm_setzero_ps(), _mm_setzero_ps(), _mm_setzero_ps(), _mm_setzero_ps()}}; }
inline Vec vload(const float* p) {
  return {{_mm_loadu_ps(p), _mm_loadu_ps(p + 4), _mm_loadu_ps(p + 8), _mm_loadu_ps(p + 12)}};
}
inline Vec vload(const float* p, Mask m) {  // SSE2 has no masked load or store: the lanes one by one
  alignas(16) float v[kLanes] = {};
  for (int i = 0; i < m.n; ++i) v[i] = p[i];
  return vload(v);
}
inline void vstore(float* p, Vec a, Mask m) {
  alignas(16) float v[kLanes];
  for (int i = 0; i < 4; ++i) _mm_store_ps(v + 4 * i, a.q[i]);
  for (int i = 0; i < m.n; ++i) p[i] = v[i];
}
inline Vec vbroadcast(const float* p) {
  const __m128 b = _mm_set1_ps(*p);
  return {{b, b, b, b}};
}
inline Vec vfma(Vec a, Vec b, Vec c) {
  for (int i = 0; i < 4; ++i) c.q[i] = _mm_add_ps(c.q[i], _mm_mul_ps(a.q[i], b.q[i]));
  return c;
}
inline Vec vadd(Vec a, Vec b) {
  for (int i = 0; i < 4; ++i) a.q[i] = _mm_add_ps(a.q[i], b.q[i]);
  return a;
}
inline Vec vleaky(Vec a, float slope) {
  const __m128 s = _mm_set1_ps(slope);
  for (int i = 0; i < 4; ++i) a.q[i] = _mm_max_ps(a.q[i], _mm_mul_ps(a.q[i], s));
  return a;
}
inline Vec vgate(Vec a, Vec g, float slope) {
  const __m128 s = _mm_set1_ps(slope);
  for (int i = 0; i < 4; ++i) {
    const __m128 positive = _mm_cmpgt_ps(g.q[i], _mm_setzero_ps());
    a.q[i] = _mm_or_ps(_mm_and_ps(positive, a.q[i]), _mm_andnot_ps(positive, _mm_mul_ps(a.q[i], s)));
  }
  return a;
}
#else
constexpr const char* kIsa = "generic";  // not x86-64: plain loops
constexpr int kTileVectors = 1, kTileColumns = 2;
struct Vec {
  float v[kLanes];
};
struct Mask {
  int n;
};
inline Mask lanes_mask(int n) { return {n}; }
inline Vec vzero() { return Vec{}; }
inline Vec vload(const float* p, Mask m = {kLanes}) {
  Vec r{};
  for (int i = 0; i < m.n; ++i) r.v[i] = p[i];
  return r;
}
inline void vstore(float* p, Vec a, Mask m) {
  for (int i = 0; i < m.n; ++i) p[i] = a.v[i];
}
inline Vec vbroadcast(const float* p) {
  Vec r;
  for (float& x : r.v) x = *p;
  return r;
}
inline Vec vfma(Vec a, Vec b, Vec c) {
  for (int i = 0; i < kLanes; ++i) c.v[i] += a.v[i] * b.v[i];
  return c;
}
inline Vec vadd(Vec a, Vec b) {
  for (int i = 0; i < kLanes; ++i) a.v[i] += b.v[i];
  return a;
}
inline Vec vleaky(Vec a, float slope) {
  for (float& x : a.v) x = x > 0.0f ? x : slope * x;
  return a;
}
inline Vec vgate(Vec a, Vec g, float slope) {
  for (int i = 0; i < kLanes; ++i) a.v[i] = g.v[i] > 0.0f ? a.v[i] : slope * a.v[i];
  return a;
}
#endif

// Stores a tile's sums into C(m, n) = C[m + n * c_n], rows from m0 (the last vector's lanes in
// `tail`), columns from n0: the sums are C's when `first`, else added to C; the epilogue when `last`.
template <int MV, int NR>
inline void store_tile(Vec (&acc)[MV][NR], float* C, int64_t c_n, const GemmEpilogue& e, int64_t m0, Mask tail,
                       int64_t n0, bool first, bool last) {
  const Mask full = lanes_mask(kLanes);
#pragma GCC unroll 6
  for (int j = 0; j < NR; ++j)
#pragma GCC unroll 4
    for (int v = 0; v < MV; ++v) {
      const int64_t m = m0 + v * kLanes;
      const Mask mask = v + 1 < MV ? full : tail;
      float* c = C + m + (n0 + j) * c_n;
      Vec r = acc[v][j];
      if (!first) r = vadd(r, vload(c, mask));
      if (last) {
        if (e.bias) r = vadd(r, vload(e.bias + m, mask));
        if (e.leaky) r = vleaky(r, e.slope);
        if (e.gate) r = vgate(r, vload(e.gate + m + (n0 + j) * e.gate_n, mask), e.slope);
      }
      vstore(c, r, mask);
    }
}

// How a tile sums, for the two operand kinds. Fp32Sum: one k per step, A's 16 rows a vector, B's
// value broadcast, a fused multiply-add. Bf16Sum (AVX512_BF16): one pair of k per step, A's 16 rows
// of pairs a vector, B's pair broadcast, a two-pair dot product into the fp32 sums.
struct Fp32Sum {
  using Operands = GemmOperands;
  using Word = float;
  using AVec = Vec;
  using BVec = Vec;
  static constexpr int64_t kBlock = kKBlock;  // k per pass over a tile: 64 x 128 floats of A, 32 KB
  static int64_t steps(const Operands& op) { return op.K; }
  static int64_t a_step(const Operands& op) { return op.a_k; }
  static int64_t b_step(const Operands& op) { return op.b_k; }
  static AVec load(const float* p) { return vload(p); }
  static AVec load(const float* p, Mask m) { return vload(p, m); }
  static BVec broadcast(const float* p) { return vbroadcast(p); }
  static Vec madd(AVec a, BVec b, Vec acc) { return vfma(a, b, acc); }
};

// mlp_gemm's operands rounded to bf16 and packed in pairs of k (pack_bf16_*): A's pair (m, p) =
// A[m + p * a_p], B's pair (p, n) = B[p * b_p + n * b_n].
struct PairOperands {
  int64_t M = 0, N = 0, P = 0;
  const uint32_t* A = nullptr;
  int64_t a_p = 0;
  const uint32_t* B = nullptr;
  int64_t b_p = 0, b_n = 0;
  float* C = nullptr;
  int64_t c_n = 0;
};

#if defined(__AVX512BF16__) && defined(__AVX512F__)
constexpr bool kBf16Native = true;
struct Bf16Sum {
  using Operands = PairOperands;
  using Word = uint32_t;
  using AVec = __m512bh;
  using BVec = __m512bh;
  static constexpr int64_t kBlock = 128;  // pairs per pass: 64 x 128 words of A, 32 KB
  static int64_t steps(const Operands& op) { return op.P; }
  static int64_t a_step(const Operands& op) { return op.a_p; }
  static int64_t b_step(const Operands& op) { return op.b_p; }
  static AVec load(const uint32_t* p) { return (__m512bh)_mm512_loadu_si512(p); }
  static AVec load(const uint32_t* p, Mask m) { return (__m512bh)_mm512_maskz_loadu_epi32(m.k, p); }
  static BVec broadcast(const uint32_t* p) { return (__m512bh)_mm512_set1_epi32(int(*p)); }
  static Vec madd(AVec a, BVec b, Vec acc) { return {_mm512_dpbf16_ps(acc.v, a, b)}; }
};
#else
constexpr bool kBf16Native = false;
#endif

// C's tile of rows [m0, m0 + 16 (MV - 1) + last_lanes) and columns [n0, n0 + NR), summed over the
// steps (k, or pairs of k) [s0, s1): the sum is C's when `first`, else added to C; the epilogue
// when `last`. Per step, the tile's MV vectors of A are loaded once and each of the NR values of B
// broadcast once, for MV x NR multiply-adds.
template <class S, int MV, int NR>
void gemm_tile(const typename S::Operands& op, const GemmEpilogue& e, int64_t m0, int last_lanes, int64_t n0,
               int64_t s0, int64_t s1, bool first, bool last) {
  Vec acc[MV][NR];
#pragma GCC unroll 4
  for (int v = 0; v < MV; ++v)
#pragma GCC unroll 6
    for (int j = 0; j < NR; ++j) acc[v][j] = vzero();
  const Mask tail = lanes_mask(last_lanes);
  auto sum = [&](auto whole) {  // whole: the last vector of rows is whole (no masked loads)
    const typename S::Word* a = op.A + m0 + s0 * S::a_step(op);
    const typename S::Word* b = op.B + s0 * S::b_step(op) + n0 * op.b_n;
    for (int64_t k = s0; k < s1; ++k, a += S::a_step(op), b += S::b_step(op)) {
      typename S::AVec av[MV];
#pragma GCC unroll 4
      for (int v = 0; v < MV; ++v)
        av[v] = decltype(whole)::value || v + 1 < MV ? S::load(a + v * kLanes) : S::load(a + v * kLanes, tail);
#pragma GCC unroll 6
      for (int j = 0; j < NR; ++j) {
        const typename S::BVec bj = S::broadcast(b + j * op.b_n);
#pragma GCC unroll 4
        for (int v = 0; v < MV; ++v) acc[v][j] = S::madd(av[v], bj, acc[v][j]);
      }
    }
  };
  if (last_lanes == kLanes)
    sum(std::true_type{});
  else
    sum(std::false_type{});
  store_tile<MV, NR>(acc, op.C, op.c_n, e, m0, tail, n0, first, last);
}

template <class S>
using TileFn = void (*)(const typename S::Operands&, const GemmEpilogue&, int64_t, int, int64_t, int64_t, int64_t,
                        bool, bool);
template <class S, int MV, int... NR>
constexpr auto tile_row(std::integer_sequence<int, NR...>) {
  return std::array<TileFn<S>, sizeof...(NR)>{&gemm_tile<S, MV, NR + 1>...};
}
template <class S, int... MV>
constexpr auto tile_table(std::integer_sequence<int, MV...>) {
  return std::array<std::array<TileFn<S>, kTileColumns>, sizeof...(MV)>{
      tile_row<S, MV + 1>(std::make_integer_sequence<int, kTileColumns>{})...};
}

// The product of `op`: tiles of up to kTileVectors x 16 rows and kTileColumns columns, the steps
// in blocks of S::kBlock so that a tile's slice of A stays in the L1 cache while the tile moves
// along the columns (partial sums of a block go through C).
template <class S>
void run_gemm(const typename S::Operands& op, const GemmEpilogue& epilogue) {
  // kTiles[vectors - 1][columns - 1]: the tile of that many vectors of rows and columns.
  static constexpr auto kTiles = tile_table<S>(std::make_integer_sequence<int, kTileVectors>{});
  constexpr int64_t tile_rows = int64_t(kTileVectors) * kLanes;
  const int64_t steps = S::steps(op);
  int64_t s0 = 0;
  do {  // one pass with an empty sum when there are no steps
    const int64_t s1 = std::min(steps, s0 + S::kBlock);
    const bool first = s0 == 0, last = s1 >= steps;
    for (int64_t m0 = 0; m0 < op.M; m0 += tile_rows) {
      const int64_t rows = std::min(tile_rows, op.M - m0);
      const int vectors = int((rows + kLanes - 1) / kLanes);
      const int last_lanes = int(rows - int64_t(vectors - 1) * kLanes);
      for (int64_t n0 = 0; n0 < op.N; n0 += kTileColumns) {
        const int cols = int(std::min<int64_t>(kTileColumns, op.N - n0));
        kTiles[size_t(vectors - 1)][size_t(cols - 1)](op, epilogue, m0, last_lanes, n0, s0, s1, first, last);
      }
    }
    s0 = s1;
  } while (s0 < steps);
}

}  // namespace

uint16_t bf16_from_float(float x) {
  uint32_t u;
  std::memcpy(&u, &x, 4);
  if ((u & 0x7FFFFFFFu) > 0x7F800000u) return uint16_t((u >> 16) | 0x40u);  // NaN: quiet, stays NaN
  return uint16_t((u + 0x7FFFu + ((u >> 16) & 1u)) >> 16);
}

float float_from_bf16(uint16_t h) {
  const uint32_t u = uint32_t(h) << 16;
  float x;
  std::memcpy(&x, &u, 4);
  return x;
}

void pack_bf16_column_pairs(const float* src, int64_t ld, int64_t R, int64_t C, uint32_t* dst) {
  const int64_t P = (C + 1) / 2;
  for (int64_t p = 0; p < P; ++p) {
    const float* lo = src + 2 * p * ld;
    const float* hi = 2 * p + 1 < C ? lo + ld : nullptr;
    uint32_t* out = dst + p * R;
    int64_t r = 0;
#if defined(__AVX512BF16__) && defined(__AVX512F__)
    for (; r < R; r += kLanes) {
      const __mmask16 m = R - r >= kLanes ? __mmask16(0xFFFF) : __mmask16((1u << (R - r)) - 1u);
      const __m512 x0 = _mm512_maskz_loadu_ps(m, lo + r);
      const __m512 x1 = hi ? _mm512_maskz_loadu_ps(m, hi + r) : _mm512_setzero_ps();
      // Zero-masked forms: GCC 12 warns falsely inside the unmasked ones (_mm512_undefined_epi32).
      const __m512i w0 = _mm512_maskz_cvtepu16_epi32(0xFFFF, (__m256i)_mm512_cvtneps_pbh(x0));
      const __m512i w1 = _mm512_maskz_cvtepu16_epi32(0xFFFF, (__m256i)_mm512_cvtneps_pbh(x1));
      _mm512_mask_storeu_epi32(out + r, m, _mm512_or_si512(w0, _mm512_maskz_slli_epi32(0xFFFF, w1, 16)));
    }
#endif
    for (; r < R; ++r)
      out[r] = uint32_t(bf16_from_float(lo[r])) | (hi ? uint32_t(bf16_from_float(hi[r])) << 16 : 0u);
  }
}

void pack_bf16_row_pairs(const float* src, int64_t ld, int64_t R, int64_t C, uint32_t* dst) {
  const int64_t P = (R + 1) / 2;
  for (int64_t c = 0; c < C; ++c) {
    const float* in = src + c * ld;
    uint32_t* out = dst + c * P;
    int64_t p = 0;
#if defined(__AVX512BF16__) && defined(__AVX512F__)
    for (; 2 * p < R; p += kLanes) {  // 32 values (16 pairs) at a time
      const int64_t left = R - 2 * p;
      const __mmask16 m0 = left >= kLanes ? __mmask16(0xFFFF) : __mmask16((1u << left) - 1u);
      const __mmask16 m1 = left >= 2 * kLanes ? __mmask16(0xFFFF)
                           : left > kLanes    ? __mmask16((1u << (left - kLanes)) - 1u)
                                              : __mmask16(0);
      const __m512 x0 = _mm512_maskz_loadu_ps(m0, in + 2 * p), x1 = _mm512_maskz_loadu_ps(m1, in + 2 * p + kLanes);
      const int64_t pairs = std::min<int64_t>(kLanes, P - p);
      const __mmask16 mp = pairs >= kLanes ? __mmask16(0xFFFF) : __mmask16((1u << pairs) - 1u);
      _mm512_mask_storeu_epi32(out + p, mp, (__m512i)_mm512_cvtne2ps_pbh(x1, x0));
    }
#endif
    for (; p < P; ++p)
      out[p] = uint32_t(bf16_from_float(in[2 * p])) | (2 * p + 1 < R ? uint32_t(bf16_from_float(in[2 * p + 1])) << 16 : 0u);
  }
}

void pack_bf16_a(const GemmOperands& op, uint32_t* dst) { pack_bf16_column_pairs(op.A, op.a_k, op.M, op.K, dst); }

size_t mlp_gemm_bf16_scratch(const GemmOperands& op) { return size_t(op.N) * size_t((op.K + 1) / 2); }

void mlp_gemm_bf16(const GemmOperands& op, const GemmEpilogue& e, const uint32_t* packed_a, uint32_t* scratch,
                   int64_t packed_m) {
  if (op.M <= 0 || op.N <= 0 || op.K < 0) return;
  PairOperands q;
  q.M = op.M;
  q.N = op.N;
  q.P = (op.K + 1) / 2;
  q.A = packed_a;
  q.a_p = std::max(op.M, packed_m);
  q.C = op.C;
  q.c_n = op.c_n;
  q.B = scratch;
  if (op.b_n == 1) {  // B's rows contiguous (a row per k): pairs of those rows, N words a pair
    pack_bf16_column_pairs(op.B, op.b_k, op.N, op.K, scratch);
    q.b_p = op.N;
    q.b_n = 1;
  } else {  // pairs within each column, ceil(K / 2) words a column
    if (op.b_k == 1)
      pack_bf16_row_pairs(op.B, op.b_n, op.K, op.N, scratch);
    else
      for (int64_t n = 0; n < op.N; ++n)
        for (int64_t p = 0; p < q.P; ++p) {
          const float lo = op.B[2 * p * op.b_k + n * op.b_n];
          const float hi = 2 * p + 1 < op.K ? op.B[(2 * p + 1) * op.b_k + n * op.b_n] : 0.0f;
          scratch[p + n * q.P] = uint32_t(bf16_from_float(lo)) | uint32_t(bf16_from_float(hi)) << 16;
        }
    q.b_p = 1;
    q.b_n = q.P;
  }
#if defined(__AVX512BF16__) && defined(__AVX512F__)
  run_gemm<Bf16Sum>(q, e);
#else
  // The instructions' arithmetic in plain loops: per pair, the high halves' product added first,
  // then the low halves' (each product exact in fp32, each sum rounded).
  auto low = [](uint32_t w) { return float_from_bf16(uint16_t(w & 0xFFFFu)); };
  auto high = [](uint32_t w) { return float_from_bf16(uint16_t(w >> 16)); };
  for (int64_t n = 0; n < q.N; ++n)
    for (int64_t m = 0; m < q.M; ++m) {
      float sum = 0.0f;
      for (int64_t p = 0; p < q.P; ++p) {
        const uint32_t a = q.A[m + p * q.a_p], b = q.B[p * q.b_p + n * q.b_n];
        sum += high(a) * high(b);
        sum += low(a) * low(b);
      }
      if (e.bias) sum += e.bias[m];
      if (e.leaky && !(sum > 0.0f)) sum *= e.slope;
      if (e.gate && !(e.gate[m + n * e.gate_n] > 0.0f)) sum *= e.slope;
      q.C[m + n * q.c_n] = sum;
    }
#endif
}

bool mlp_gemm_bf16_native() { return kBf16Native; }

void mlp_gemm(const GemmOperands& op, const GemmEpilogue& epilogue) {
  if (op.M <= 0 || op.N <= 0 || op.K < 0) return;
  run_gemm<Fp32Sum>(op, epilogue);
}

const char* mlp_gemm_isa() { return kIsa; }

}  // namespace lsnif
