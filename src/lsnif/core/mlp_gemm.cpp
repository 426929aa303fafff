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

// C's tile of rows [m0, m0 + 16 (MV - 1) + last_lanes) and columns [n0, n0 + NR), summed over
// k in [k0, k1): the sum is C's when `first`, else added to C; the epilogue when `last`.
template <int MV, int NR>
void gemm_tile(const GemmOperands& op, const GemmEpilogue& e, int64_t m0, int last_lanes, int64_t n0, int64_t k0,
               int64_t k1, bool first, bool last) {
  Vec acc[MV][NR];
#pragma GCC unroll 4
  for (int v = 0; v < MV; ++v)
#pragma GCC unroll 6
    for (int j = 0; j < NR; ++j) acc[v][j] = vzero();
  const Mask tail = lanes_mask(last_lanes);
  auto sum = [&](auto whole) {  // whole: the last vector of rows is whole (no masked loads)
    const float* a = op.A + m0 + k0 * op.a_k;
    const float* b = op.B + k0 * op.b_k + n0 * op.b_n;
    for (int64_t k = k0; k < k1; ++k, a += op.a_k, b += op.b_k) {
      Vec av[MV];
#pragma GCC unroll 4
      for (int v = 0; v < MV; ++v)
        av[v] = decltype(whole)::value || v + 1 < MV ? vload(a + v * kLanes) : vload(a + v * kLanes, tail);
#pragma GCC unroll 6
      for (int j = 0; j < NR; ++j) {
        const Vec bj = vbroadcast(b + j * op.b_n);
#pragma GCC unroll 4
        for (int v = 0; v < MV; ++v) acc[v][j] = vfma(av[v], bj, acc[v][j]);
      }
    }
  };
  if (last_lanes == kLanes)
    sum(std::true_type{});
  else
    sum(std::false_type{});
  store_tile<MV, NR>(acc, op.C, op.c_n, e, m0, tail, n0, first, last);
}

using TileFn = void (*)(const GemmOperands&, const GemmEpilogue&, int64_t, int, int64_t, int64_t, int64_t, bool, bool);

template <int MV, int... NR>
constexpr auto tile_row(std::integer_sequence<int, NR...>) {
  return std::array<TileFn, sizeof...(NR)>{&gemm_tile<MV, NR + 1>...};
}
template <int... MV>
constexpr auto tile_table(std::integer_sequence<int, MV...>) {
  return std::array<std::array<TileFn, kTileColumns>, sizeof...(MV)>{
      tile_row<MV + 1>(std::make_integer_sequence<int, kTileColumns>{})...};
}
// kTiles[vectors - 1][columns - 1]: the tile of that many vectors of rows and columns.
const auto kTiles = tile_table(std::make_integer_sequence<int, kTileVectors>{});

}  // namespace

void mlp_gemm(const GemmOperands& op, const GemmEpilogue& epilogue) {
  if (op.M <= 0 || op.N <= 0 || op.K < 0) return;
  constexpr int64_t tile_rows = int64_t(kTileVectors) * kLanes;
  int64_t k0 = 0;
  do {  // one pass with an empty sum when K == 0
    const int64_t k1 = std::min(op.K, k0 + kKBlock);
    const bool first = k0 == 0, last = k1 >= op.K;
    for (int64_t m0 = 0; m0 < op.M; m0 += tile_rows) {
      const int64_t rows = std::min(tile_rows, op.M - m0);
      const int vectors = int((rows + kLanes - 1) / kLanes);
      const int last_lanes = int(rows - int64_t(vectors - 1) * kLanes);
      for (int64_t n0 = 0; n0 < op.N; n0 += kTileColumns) {
        const int cols = int(std::min<int64_t>(kTileColumns, op.N - n0));
        kTiles[size_t(vectors - 1)][size_t(cols - 1)](op, epilogue, m0, last_lanes, n0, k0, k1, first, last);
      }
    }
    k0 = k1;
  } while (k0 < op.K);
}

const char* mlp_gemm_isa() { return kIsa; }

}  // namespace lsnif
