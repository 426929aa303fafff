// The MLP's GEMM kernel against a brute-force double-precision product, over shapes that exercise
// every tile size and remainder, both operand layouts the network uses, strided outputs and each
// epilogue; nothing outside C's M x N values is written, and operands are read only where they
// are addressed (exact-size buffers, which the sanitizer build checks).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "lsnif/core/mlp_gemm.h"

namespace lsnif {
namespace {

struct Case {
  int64_t M, N, K;
  bool b_columns;  // B(k, n) = B[k + n * K] (a column per n), else B[k * N + n] (a row per k)
  int64_t c_pad;   // C's column stride is M + c_pad
  bool bias, leaky, gate;
};

void check(const Case& t, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const int64_t a_k = t.M + (seed % 3);  // A's k stride may exceed M: the rows between are never read
  std::vector<float> A(size_t(t.K > 0 ? (t.K - 1) * a_k + t.M : 0)), B(size_t(t.K * t.N)), bias(size_t(t.M));
  const int64_t c_n = t.M + t.c_pad;
  std::vector<float> C(size_t(t.N * c_n), 12345.0f), gate(size_t(t.N * c_n));
  for (float& v : A) v = u(rng);
  for (float& v : B) v = u(rng);
  for (float& v : bias) v = u(rng);
  for (float& v : gate) v = u(rng) < 0.0f ? -1.0f : (u(rng) < 0.0f ? 0.0f : 0.5f);  // zero counts as not positive
  GemmOperands op;
  op.M = t.M;
  op.N = t.N;
  op.K = t.K;
  op.A = A.data();
  op.a_k = a_k;
  op.B = B.data();
  op.b_k = t.b_columns ? 1 : t.N;
  op.b_n = t.b_columns ? t.K : 1;
  op.C = C.data();
  op.c_n = c_n;
  GemmEpilogue e;
  e.bias = t.bias ? bias.data() : nullptr;
  e.leaky = t.leaky;
  e.gate = t.gate ? gate.data() : nullptr;
  e.gate_n = c_n;
  e.slope = 0.125f;
  mlp_gemm(op, e);
  for (int64_t n = 0; n < t.N; ++n)
    for (int64_t m = 0; m < c_n; ++m) {
      const float got = C[size_t(m + n * c_n)];
      if (m >= t.M) {
        ASSERT_EQ(got, 12345.0f) << "row " << m << " beyond M written, column " << n;
        continue;
      }
      double sum = 0.0, magnitude = 0.0;
      for (int64_t k = 0; k < t.K; ++k) {
        const double term = double(A[size_t(m + k * a_k)]) * double(B[size_t(k * op.b_k + n * op.b_n)]);
        sum += term;
        magnitude += std::fabs(term);
      }
      if (t.bias) {
        sum += bias[size_t(m)];
        magnitude += std::fabs(bias[size_t(m)]);
      }
      if (t.leaky && sum <= 0.0) sum *= 0.125;
      if (t.gate && !(gate[size_t(m + n * c_n)] > 0.0f)) sum *= 0.125;
      ASSERT_NEAR(got, sum, 1e-6 * (1.0 + magnitude)) << "M " << t.M << " N " << t.N << " K " << t.K << " at (" << m
                                                      << ", " << n << ")";
    }
}

TEST(MlpGemm, MatchesBruteForceOverTileSizesAndRemainders) {
  uint32_t seed = 1;
  for (int64_t M : {1, 9, 15, 16, 17, 33, 64, 65, 108, 128, 130})
    for (int64_t N : {1, 5, 6, 7, 13, 24})
      for (int64_t K : {1, 30, 128, 129, 300}) {
        check({M, N, K, true, 0, true, true, false}, seed++);
        check({M, N, K, false, 3, false, false, M % 2 == 1}, seed++);
      }
}

TEST(MlpGemm, EmptySumGivesTheEpilogueOfZero) {
  check({20, 7, 0, true, 1, true, true, false}, 7);
  check({5, 3, 0, false, 0, false, false, false}, 8);  // plain zeros
}

TEST(MlpGemm, NothingHappensForEmptyShapes) {
  std::vector<float> C(4, 3.0f);
  GemmOperands op;
  op.M = 0;
  op.N = 2;
  op.K = 5;
  op.C = C.data();
  mlp_gemm(op);
  op.M = 2;
  op.N = 0;
  mlp_gemm(op);
  for (float v : C) EXPECT_EQ(v, 3.0f);
}

TEST(MlpGemm, NamesItsInstructionSet) {
  const std::string isa = mlp_gemm_isa();
  EXPECT_TRUE(isa == "avx512" || isa == "avx2" || isa == "sse2" || isa == "generic") << isa;
#if defined(__AVX512F__)
  EXPECT_EQ(isa, "avx512");
#endif
}

// bf16: rounding to the nearest value, ties to even, as the instructions round.
TEST(MlpGemmBf16, RoundsToNearestTiesToEven) {
  EXPECT_EQ(bf16_from_float(1.0f), 0x3F80);
  EXPECT_EQ(float_from_bf16(0x3F80), 1.0f);
  EXPECT_EQ(bf16_from_float(-2.0f), 0xC000);
  // 1 + 2^-8 lies halfway between 1 and 1 + 2^-7: to the even (1); 1 + 3 * 2^-8 halfway between
  // 1 + 2^-7 and 1 + 2^-6: to the even (1 + 2^-6); a hair above halfway rounds up.
  EXPECT_EQ(float_from_bf16(bf16_from_float(1.0f + 0x1p-8f)), 1.0f);
  EXPECT_EQ(float_from_bf16(bf16_from_float(1.0f + 3 * 0x1p-8f)), 1.0f + 0x1p-6f);
  EXPECT_EQ(float_from_bf16(bf16_from_float(1.0f + 0x1p-8f + 0x1p-20f)), 1.0f + 0x1p-7f);
  EXPECT_TRUE(std::isnan(float_from_bf16(bf16_from_float(std::nanf("")))));
  EXPECT_TRUE(std::isinf(float_from_bf16(bf16_from_float(INFINITY))));
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-100.0f, 100.0f);
  for (int i = 0; i < 10000; ++i) {
    const float x = u(rng), r = float_from_bf16(bf16_from_float(x));
    EXPECT_LE(std::fabs(r - x), std::ldexp(std::fabs(x), -8)) << x;  // half a unit in the 8th bit
  }
}

// The packers against the scalar rounding, over odd and even sizes (a missing column or row is 0).
TEST(MlpGemmBf16, PackersPairColumnsAndRows) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  for (int64_t R : {1, 15, 16, 17, 31, 32, 33, 128})
    for (int64_t C : {1, 2, 7, 8}) {
      const int64_t ld = R + 2;
      std::vector<float> src(size_t(ld * C));
      for (float& v : src) v = u(rng);
      auto bits = [&](int64_t r, int64_t c) -> uint32_t { return r < R && c < C ? bf16_from_float(src[size_t(r + c * ld)]) : 0u; };
      std::vector<uint32_t> cols(size_t(R * ((C + 1) / 2))), rows(size_t(((R + 1) / 2) * C));
      pack_bf16_column_pairs(src.data(), ld, R, C, cols.data());
      pack_bf16_row_pairs(src.data(), ld, R, C, rows.data());
      for (int64_t p = 0; p < (C + 1) / 2; ++p)
        for (int64_t r = 0; r < R; ++r)
          ASSERT_EQ(cols[size_t(r + p * R)], bits(r, 2 * p) | bits(r, 2 * p + 1) << 16) << R << " " << C;
      for (int64_t c = 0; c < C; ++c)
        for (int64_t p = 0; p < (R + 1) / 2; ++p)
          ASSERT_EQ(rows[size_t(p + c * ((R + 1) / 2))], bits(2 * p, c) | bits(2 * p + 1, c) << 16) << R << " " << C;
    }
}

// The bf16 product against a double sum of the bf16 values (products exact in fp32, so only the
// sums' rounding differs), over B's layouts (a column per n, a row per k, or neither), each
// epilogue, nothing written beyond M.
void check_bf16(int64_t M, int64_t N, int64_t K, int b_layout, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const int64_t a_k = M + (seed % 3);
  std::vector<float> A(size_t(K > 0 ? (K - 1) * a_k + M : 0)), bias(static_cast<size_t>(M)), gate(size_t(M * N));
  // b_layout 0: B(k, n) = B[k + n * K]; 1: B[k * N + n]; 2: B[k * 2 + n * 2 * K] (strided both ways).
  const int64_t b_k = b_layout == 0 ? 1 : b_layout == 1 ? N : 2;
  const int64_t b_n = b_layout == 0 ? K : b_layout == 1 ? 1 : 2 * K;
  std::vector<float> B(size_t(std::max<int64_t>(1, b_layout == 2 ? 2 * K * N : K * N)));
  for (float& v : A) v = u(rng);
  for (float& v : B) v = u(rng);
  for (float& v : bias) v = u(rng);
  for (float& v : gate) v = u(rng);
  const int64_t c_n = M + 1;
  std::vector<float> C(size_t(N * c_n), 12345.0f);
  GemmOperands op;
  op.M = M;
  op.N = N;
  op.K = K;
  op.A = A.data();
  op.a_k = a_k;
  op.B = B.data();
  op.b_k = b_k;
  op.b_n = b_n;
  op.C = C.data();
  op.c_n = c_n;
  GemmEpilogue e;
  e.bias = seed % 2 ? bias.data() : nullptr;
  e.leaky = seed % 3 == 0;
  e.gate = seed % 3 == 1 ? gate.data() : nullptr;
  e.gate_n = M;
  e.slope = 0.125f;
  std::vector<uint32_t> packed_a(size_t(M * ((K + 1) / 2))), scratch(mlp_gemm_bf16_scratch(op));
  pack_bf16_a(op, packed_a.data());
  mlp_gemm_bf16(op, e, packed_a.data(), scratch.data());
  auto r = [](float x) { return double(float_from_bf16(bf16_from_float(x))); };
  for (int64_t n = 0; n < N; ++n)
    for (int64_t m = 0; m < c_n; ++m) {
      const float got = C[size_t(m + n * c_n)];
      if (m >= M) {
        ASSERT_EQ(got, 12345.0f) << "row " << m << " beyond M written";
        continue;
      }
      double sum = 0.0, magnitude = 0.0;
      for (int64_t k = 0; k < K; ++k) {
        const double term = r(A[size_t(m + k * a_k)]) * r(B[size_t(k * b_k + n * b_n)]);
        sum += term;
        magnitude += std::fabs(term);
      }
      if (e.bias) sum += bias[size_t(m)], magnitude += std::fabs(bias[size_t(m)]);
      if (e.leaky && sum <= 0.0) sum *= 0.125;
      if (e.gate && !(gate[size_t(m + n * M)] > 0.0f)) sum *= 0.125;
      ASSERT_NEAR(got, sum, 1e-6 * (1.0 + magnitude)) << "M " << M << " N " << N << " K " << K << " layout " << b_layout
                                                      << " at (" << m << ", " << n << ")";
    }
}

TEST(MlpGemmBf16, MatchesBruteForceOverTileSizesAndRemainders) {
  uint32_t seed = 1;
  for (int64_t M : {1, 15, 16, 17, 64, 65, 128, 130})
    for (int64_t N : {1, 5, 6, 7, 13})
      for (int64_t K : {0, 1, 2, 31, 128, 257, 300})
        for (int b_layout : {0, 1, 2}) check_bf16(M, N, K, b_layout, seed++);
}

}  // namespace
}  // namespace lsnif
