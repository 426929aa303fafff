// MLP forward against a naive per-ray loop, and backward against central finite differences; a
// batch of many column chunks against one column at a time and across thread counts.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "lsnif/core/network.h"

namespace lsnif {
namespace {

Config tiny_config() {
  Config c;
  c.voxel_resolution = 2;
  c.max_points = 2;
  c.grid_levels = 1;
  c.grid_resolution[0] = 2;
  c.grid_resolution[1] = 0;
  c.table_log2[1] = 0;
  c.features = 3;          // input 6
  c.hidden_width = 5;
  c.hidden_layers = 2;
  c.material_count = 3;    // output 11
  c.leaky_slope = 0.1f;
  return c;
}

// Kaiming weights (seed) plus uniform noise of +-0.1 from `rng` on every parameter, so that the
// biases are non-zero too.
std::vector<float> perturbed_params(const Config& c, uint64_t seed, std::mt19937& rng) {
  std::vector<float> p(c.mlp_parameter_count());
  mlp_init_kaiming(c, seed, p.data());
  std::uniform_real_distribution<float> u(-1, 1);
  for (float& v : p) v += 0.1f * u(rng);
  return p;
}

// Independent forward: plain loops over the flat parameter layout documented in model.h.
std::vector<double> naive_forward(const Config& c, const std::vector<float>& p, const std::vector<double>& x) {
  std::vector<double> cur = x;
  size_t off = 0;
  uint32_t in = c.input_dim();
  for (uint32_t l = 0; l <= c.hidden_layers; ++l) {
    uint32_t out = l < c.hidden_layers ? c.hidden_width : c.output_dim();
    std::vector<double> next(out);
    for (uint32_t o = 0; o < out; ++o) {
      double s = p[off + size_t(in) * out + o];
      for (uint32_t i = 0; i < in; ++i) s += double(p[off + size_t(o) * in + i]) * cur[i];
      next[o] = (l < c.hidden_layers && s <= 0) ? c.leaky_slope * s : s;
    }
    off += size_t(in) * out + out;
    in = out;
    cur = next;
  }
  return cur;
}

TEST(Network, ForwardMatchesNaiveLoops) {
  Config c = tiny_config();
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-1, 1);
  const std::vector<float> p = perturbed_params(c, 5, rng);
  const int B = 7;
  Matrix X(c.input_dim(), B), O;
  for (int i = 0; i < X.size(); ++i) X.data()[i] = u(rng);
  mlp_forward(c, p.data(), X, O);
  ASSERT_EQ(O.rows(), c.output_dim());
  ASSERT_EQ(O.cols(), B);
  for (int b = 0; b < B; ++b) {
    std::vector<double> x(c.input_dim());
    for (uint32_t i = 0; i < c.input_dim(); ++i) x[i] = X(i, b);
    std::vector<double> ref = naive_forward(c, p, x);
    for (uint32_t o = 0; o < c.output_dim(); ++o) EXPECT_NEAR(O(o, b), ref[o], 1e-5) << o;
  }
}

TEST(Network, BackwardMatchesFiniteDifferences) {
  Config c = tiny_config();
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-1, 1);
  const std::vector<float> p = perturbed_params(c, 9, rng);
  const int B = 4;
  Matrix X(c.input_dim(), B), G(c.output_dim(), B);
  for (int i = 0; i < X.size(); ++i) X.data()[i] = u(rng);
  for (int i = 0; i < G.size(); ++i) G.data()[i] = u(rng);
  // loss = sum(G .* out), computed in double by the naive forward.
  auto loss = [&](const std::vector<float>& params, const Matrix& input) {
    double s = 0;
    for (int b = 0; b < B; ++b) {
      std::vector<double> x(c.input_dim());
      for (uint32_t i = 0; i < c.input_dim(); ++i) x[i] = input(i, b);
      std::vector<double> o = naive_forward(c, params, x);
      for (uint32_t k = 0; k < c.output_dim(); ++k) s += G(k, b) * o[k];
    }
    return s;
  };
  Matrix O, dX;
  MlpTrace trace;
  mlp_forward(c, p.data(), X, O, &trace);
  std::vector<float> dp(p.size(), 0.0f);
  mlp_backward(c, p.data(), trace, G, dp.data(), &dX);
  const float h = 1e-3f;
  for (size_t i = 0; i < p.size(); ++i) {
    std::vector<float> pp = p, pm = p;
    pp[i] += h;
    pm[i] -= h;
    double fd = (loss(pp, X) - loss(pm, X)) / (2.0 * h);
    ASSERT_NEAR(dp[i], fd, 2e-3 + 2e-3 * std::fabs(fd)) << "parameter " << i;
  }
  for (int i = 0; i < X.size(); ++i) {
    Matrix Xp = X, Xm = X;
    Xp.data()[i] += h;
    Xm.data()[i] -= h;
    double fd = (loss(p, Xp) - loss(p, Xm)) / (2.0 * h);
    ASSERT_NEAR(dX.data()[i], fd, 2e-3 + 2e-3 * std::fabs(fd)) << "input " << i;
  }
}

// A batch spanning several column chunks (and a partial last one) gives, column by column, what
// that column alone gives (forward output and input gradient), weight gradients equal to the sum of
// the single columns' within float rounding, and the same bits with one thread as with two.
TEST(Network, ChunkedBatchesMatchSingleColumnsAndAnyThreadCount) {
  Config c = tiny_config();
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1, 1);
  const std::vector<float> p = perturbed_params(c, 11, rng);
  const int B = 1300;
  Matrix X(c.input_dim(), B), G(c.output_dim(), B);
  for (int i = 0; i < X.size(); ++i) X.data()[i] = u(rng);
  for (int i = 0; i < G.size(); ++i) G.data()[i] = u(rng);
  auto run = [&](int threads, std::vector<float>& dp, Matrix& O, Matrix& dX) {
    const int before = omp_get_max_threads();
    omp_set_num_threads(threads);
    MlpTrace trace;
    mlp_forward(c, p.data(), X, O, &trace);
    dp.assign(p.size(), 0.0f);
    mlp_backward(c, p.data(), trace, G, dp.data(), &dX);
    omp_set_num_threads(before);
  };
  std::vector<float> dp1, dp2;
  Matrix O1, O2, dX1, dX2;
  run(1, dp1, O1, dX1);
  run(2, dp2, O2, dX2);
  EXPECT_EQ(dp1, dp2);
  EXPECT_TRUE(O1 == O2);
  EXPECT_TRUE(dX1 == dX2);
  {  // A batch with wider chunks (beyond 64 x 512 columns): the same across thread counts.
    Matrix X_big(c.input_dim(), 40000), G_big(c.output_dim(), 40000);
    for (int i = 0; i < X_big.size(); ++i) X_big.data()[i] = u(rng);
    for (int i = 0; i < G_big.size(); ++i) G_big.data()[i] = u(rng);
    std::swap(X, X_big);
    std::swap(G, G_big);
    std::vector<float> a, b;
    Matrix Oa, Ob, dXa, dXb;
    run(1, a, Oa, dXa);
    run(3, b, Ob, dXb);
    EXPECT_EQ(a, b);
    EXPECT_TRUE(dXa == dXb);
    std::swap(X, X_big);
    std::swap(G, G_big);
  }
  std::vector<double> dp_sum(p.size(), 0.0);
  for (int b = 0; b < B; ++b) {
    Matrix x = X.col(b), g = G.col(b), o, dx;
    MlpTrace trace;
    mlp_forward(c, p.data(), x, o, &trace);
    std::vector<float> dp(p.size(), 0.0f);
    mlp_backward(c, p.data(), trace, g, dp.data(), &dx);
    for (size_t i = 0; i < p.size(); ++i) dp_sum[i] += dp[i];
    for (uint32_t k = 0; k < c.output_dim(); ++k) ASSERT_NEAR(O1(k, b), o(k, 0), 1e-5) << "column " << b;
    for (uint32_t k = 0; k < c.input_dim(); ++k) ASSERT_NEAR(dX1(k, b), dx(k, 0), 1e-5) << "column " << b;
  }
  for (size_t i = 0; i < p.size(); ++i) EXPECT_NEAR(dp1[i], dp_sum[i], 1e-3 + 1e-5 * std::fabs(dp_sum[i])) << i;
}

// A batch whose columns have zero rows beyond a per-column count (a walk's unused point slots),
// given those counts as input_rows: outputs and gradients equal the plain run's to float rounding,
// across chunks of very different counts. The skipped rows
// are not read (the same results with garbage beyond each chunk's largest count), and d_input is
// zero beyond the chunk's rows.
TEST(Network, InputRowsSkipTheZeroSlotsAndChangeNoResult) {
  Config c = tiny_config();
  c.max_points = 6;  // input 18: rows in steps of 3 per point
  c.hidden_width = 16;
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1, 1);
  const std::vector<float> p = perturbed_params(c, 21, rng);
  const int B = 1701, chunk = 426;  // 4 chunks (an even number of at most 512 columns), the last partial
  const uint32_t in = c.input_dim();
  std::vector<uint32_t> rows(B);
  for (int b = 0; b < B; ++b)  // descending counts as the trainer orders them, a few out of order
    rows[size_t(b)] = (b % 97 == 0 ? 1u : uint32_t(c.max_points - (b * c.max_points) / B)) * c.features;
  std::vector<uint32_t> chunk_max((B + chunk - 1) / chunk, 0);
  for (int b = 0; b < B; ++b) chunk_max[size_t(b / chunk)] = std::max(chunk_max[size_t(b / chunk)], rows[size_t(b)]);
  Matrix X(in, B), garbage(in, B), G(c.output_dim(), B);
  for (int b = 0; b < B; ++b)
    for (uint32_t k = 0; k < in; ++k) {
      X(k, b) = k < rows[size_t(b)] ? u(rng) : 0.0f;
      garbage(k, b) = k < chunk_max[size_t(b / chunk)] ? X(k, b) : 1e3f + u(rng);
    }
  for (int i = 0; i < G.size(); ++i) G.data()[i] = u(rng);
  auto run = [&](const Matrix& input, const uint32_t* input_rows, std::vector<float>& dp, Matrix& O, Matrix& dX) {
    MlpTrace trace;
    mlp_forward(c, p.data(), input, O, &trace, input_rows);
    dp.assign(p.size(), std::numeric_limits<float>::quiet_NaN());  // written, not accumulated
    mlp_backward(c, p.data(), trace, G, dp.data(), &dX);
    return trace.chunk_input_rows;
  };
  std::vector<float> dp_full, dp_rows, dp_garbage;
  Matrix O_full, O_rows, O_garbage, dX_full, dX_rows, dX_garbage;
  run(X, nullptr, dp_full, O_full, dX_full);
  const std::vector<Eigen::Index> chunk_rows = run(X, rows.data(), dp_rows, O_rows, dX_rows);
  run(garbage, rows.data(), dp_garbage, O_garbage, dX_garbage);
  ASSERT_EQ(chunk_rows.size(), chunk_max.size());
  for (size_t k = 0; k < chunk_max.size(); ++k) EXPECT_EQ(chunk_rows[k], Eigen::Index(chunk_max[k])) << "chunk " << k;
  EXPECT_LT(chunk_max.back(), in);  // the last chunks really skip rows
  // Equal to float rounding (with AVX-512, Eigen's kernels split the sum over the rows differently
  // for another row count), and bit for bit whatever lies beyond the rows (never read).
  for (Eigen::Index i = 0; i < O_full.size(); ++i)
    ASSERT_NEAR(O_rows.data()[i], O_full.data()[i], 1e-5f * (1.0f + std::fabs(O_full.data()[i]))) << i;
  EXPECT_TRUE(O_garbage == O_rows);
  for (size_t i = 0; i < p.size(); ++i) {
    EXPECT_NEAR(dp_rows[i], dp_full[i], 1e-5f * (1.0f + std::fabs(dp_full[i]))) << i;
    EXPECT_EQ(dp_garbage[i], dp_rows[i]) << i;
  }
  for (int b = 0; b < B; ++b)
    for (uint32_t k = 0; k < in; ++k) {
      if (k < chunk_max[size_t(b / chunk)])
        ASSERT_NEAR(dX_rows(k, b), dX_full(k, b), 1e-6f * (1.0f + std::fabs(dX_full(k, b)))) << k << ", " << b;
      else
        ASSERT_EQ(dX_rows(k, b), 0.0f) << k << ", " << b;
      ASSERT_EQ(dX_garbage(k, b), dX_rows(k, b)) << k << ", " << b;
    }
  // The garbage does change a run without input_rows (the checks above are not vacuous).
  Matrix O_plain;
  mlp_forward(c, p.data(), garbage, O_plain);
  EXPECT_FALSE(O_plain == O_full);
}


TEST(Network, KaimingInitHasExpectedScale) {
  Config c;  // defaults: 108 -> 128 -> 128 -> 9
  std::vector<float> p(c.mlp_parameter_count());
  mlp_init_kaiming(c, 1, p.data());
  auto layers = mlp_layers(c);
  const LayerView& v = layers[1];
  double s2 = 0;
  for (size_t i = 0; i < size_t(v.in) * v.out; ++i) s2 += double(p[v.weight_offset + i]) * p[v.weight_offset + i];
  double std_measured = std::sqrt(s2 / double(v.in * v.out));
  double expected = std::sqrt(2.0 / (1.0 + 0.01 * 0.01)) / std::sqrt(double(v.in));
  EXPECT_NEAR(std_measured, expected, 0.03 * expected);
  for (uint32_t i = 0; i < v.out; ++i) EXPECT_EQ(p[v.bias_offset + i], 0.0f);
}

TEST(Network, FlopsPerEvaluationMatchThePaperAndTheLayerShapes) {
  Config c;
  c.max_points = 18;
  c.grid_levels = 2;
  c.features = 3;
  c.hidden_width = 128;
  c.hidden_layers = 2;
  EXPECT_EQ(mlp_flops_per_evaluation(c), 62720u);  // 62.7 kFLOP: 108 -> 128 -> 128 -> 9
  // Table 1's L configuration, W=64 and H=10: 60 -> 64 -> 64 -> 9.
  c.hidden_width = 64;
  c.max_points = 10;
  EXPECT_EQ(mlp_flops_per_evaluation(c), 2u * (60 * 64 + 64 * 64 + 64 * 9));
  c.hidden_layers = 1;
  c.material_count = 3;  // 60 -> 64 -> 11
  EXPECT_EQ(mlp_flops_per_evaluation(c), 2u * (60 * 64 + 64 * 11));
}

// The layers in bf16 (MlpTrace::bf16_layers): every layer but the output layer, and outputs,
// activations, weight and input gradients within bf16's rounding of the fp32 passes' (which the
// tests above check against naive loops and finite differences), over several column chunks, an
// odd width and an odd chunk (pairs padded with zero) and the first layer's skipped input rows (odd
// and even counts: its input gradient's W cut to them).
TEST(Network, Bf16LayersMatchFp32WithinTheirRounding) {
  Config c = tiny_config();
  c.hidden_width = 21;
  c.hidden_layers = 3;
  EXPECT_TRUE(mlp_layer_bf16(c, 0));
  EXPECT_TRUE(mlp_layer_bf16(c, 1));
  EXPECT_TRUE(mlp_layer_bf16(c, 2));
  EXPECT_FALSE(mlp_layer_bf16(c, 3));
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-1, 1);
  const std::vector<float> p = perturbed_params(c, 3, rng);
  const int B = 1201;  // 4 chunks of 301 (the last 298)
  Matrix X(c.input_dim(), B), G(c.output_dim(), B);
  std::vector<uint32_t> rows(B);
  // Chunk c's columns read c + 1 or c + 2 input rows: the chunks' first layers are cut to 2, 3, 4
  // and 5 of the 6 rows (odd counts pad their last pair).
  for (int b = 0; b < B; ++b) {
    rows[size_t(b)] = 1 + uint32_t(b / 301 + b % 2) % c.input_dim();
    for (uint32_t i = 0; i < c.input_dim(); ++i) X(i, b) = i < rows[size_t(b)] ? u(rng) : 0.0f;
  }
  for (int i = 0; i < G.size(); ++i) G.data()[i] = u(rng);
  // The forward pass in fp32 and in bf16; the backward pass in both over the bf16 forward's trace
  // (the same activations, so the same leaky ReLU slopes: between two forward passes an activation
  // near zero may change sign, and its unit's gradient by the slope, which no tolerance covers).
  Matrix O, O_bf16;
  MlpTrace fp32_trace, trace;
  mlp_forward(c, p.data(), X, O, &fp32_trace, rows.data());
  trace.bf16_layers = true;
  mlp_forward(c, p.data(), X, O_bf16, &trace, rows.data());
  struct Pass {
    Matrix dX;
    std::vector<float> dp;
  };
  auto backward = [&](bool bf16) {
    Pass r;
    MlpTrace t = trace;
    t.bf16_layers = bf16;
    r.dp.assign(p.size(), 0.0f);
    mlp_backward(c, p.data(), t, G, r.dp.data(), &r.dX);
    return r;
  };
  const Pass f = backward(false), h = backward(true);
  // Each value within 2% of the largest magnitude of its kind (bf16 keeps 8 significant bits: 0.4%
  // per operand, through two layers and sums), and not bit-identical where bf16 products led to it.
  auto expect_close = [](const float* a, const float* b, size_t n, const char* what, bool bf16_before = true) {
    double scale = 0.0;
    bool differ = false;
    for (size_t i = 0; i < n; ++i) scale = std::max(scale, std::fabs(double(a[i])));
    for (size_t i = 0; i < n; ++i) {
      ASSERT_NEAR(b[i], a[i], 0.02 * scale) << what << " " << i;
      differ = differ || a[i] != b[i];
    }
    EXPECT_EQ(differ, bf16_before) << what;
  };
  expect_close(O.data(), O_bf16.data(), size_t(O.size()), "output");
  for (size_t l = 1; l < trace.layer_input.size(); ++l)
    expect_close(fp32_trace.layer_input[l].data(), trace.layer_input[l].data(), size_t(O.cols()) * c.hidden_width,
                 "activation");
  expect_close(f.dX.data(), h.dX.data(), size_t(f.dX.size()), "input gradient");
  const std::vector<LayerView> layers = mlp_layers(c);
  for (size_t l = 0; l < layers.size(); ++l)  // the output layer's gradient comes before any bf16 product
    expect_close(f.dp.data() + layers[l].weight_offset, h.dp.data() + layers[l].weight_offset,
                 size_t(layers[l].in) * layers[l].out + layers[l].out, "layer gradient", l + 1 < layers.size());
}

}  // namespace
}  // namespace lsnif
