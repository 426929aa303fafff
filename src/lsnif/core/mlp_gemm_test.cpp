// The MLP's GEMM kernel against a brute-force double-precision product, over shapes that exercise
// every tile size and remainder, both operand layouts the network uses, strided outputs and each
// epilogue; nothing outside C's M x N values is written, and operands are read only where they
// are addressed (exact-size buffers, which the sanitizer build checks).
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace lsnif
