// optimizer_test.cpp -- Adam's first step moves every parameter with a gradient by the learning
// rate against the gradient's sign (m_hat = g, v_hat = g^2), with the settings' rate or the rate
// given for the step (a schedule's), and a parameter without gradient stays; a step taken in
// ranges, in any order, is the whole step bit for bit and follows Adam's update in double precision;
// the parameters' average likewise, against the moving average in double precision.
#include "lsnif/train/optimizer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

namespace lsnif {
namespace {

TEST(Adam, FirstStepMovesByTheStepsLearningRate) {
  const std::vector<float> g = {0.5f, -2.0f, 1e-3f, 0.0f};
  for (float rate : {0.0f, 0.003f}) {  // 0: the settings' rate
    AdamSettings s;
    s.learning_rate = 0.01f;
    Adam adam(g.size(), s);
    std::vector<float> p = {1.0f, 1.0f, 1.0f, 1.0f};
    if (rate > 0.0f) adam.step(p.data(), g.data(), rate);
    else adam.step(p.data(), g.data());
    const float lr = rate > 0.0f ? rate : 0.01f;
    EXPECT_FLOAT_EQ(p[0], 1.0f - lr);
    EXPECT_FLOAT_EQ(p[1], 1.0f + lr);
    EXPECT_FLOAT_EQ(p[2], 1.0f - lr);
    EXPECT_EQ(p[3], 1.0f);
  }
}

TEST(Adam, AStepInRangesIsTheWholeStep) {
  const size_t n = 50000;  // several ranges of the update, not a multiple of a vector's width
  std::mt19937 rng(7);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::vector<float> p0(n);
  for (float& x : p0) x = normal(rng);
  AdamSettings s;
  Adam whole(n, s), pieces(n, s);
  std::vector<float> pw = p0, pp = p0;
  std::vector<double> ref(p0.begin(), p0.end()), m(n, 0.0), v(n, 0.0);
  // Ranges of uneven sizes, updated in a shuffled order.
  std::vector<size_t> bounds = {0, 1, 17, 4096, 4100, 20000, 33333, n};
  std::vector<size_t> order(bounds.size() - 1);
  std::iota(order.begin(), order.end(), size_t(0));
  for (int step = 1; step <= 5; ++step) {
    std::vector<float> g(n);
    for (float& x : g) x = normal(rng) * (step % 2 ? 1.0f : 1e-3f);
    const float lr = 0.01f / float(step);
    whole.step(pw.data(), g.data(), lr);
    const Adam::Step st = pieces.begin_step(lr);
    std::shuffle(order.begin(), order.end(), rng);
    for (size_t r : order) pieces.update(st, pp.data(), g.data(), bounds[r], bounds[r + 1]);
    ASSERT_EQ(pw, pp) << "step " << step;
    const double b1 = s.beta1, b2 = s.beta2;
    for (size_t i = 0; i < n; ++i) {
      m[i] = b1 * m[i] + (1 - b1) * g[i];
      v[i] = b2 * v[i] + (1 - b2) * double(g[i]) * g[i];
      ref[i] -= lr * (m[i] / (1 - std::pow(b1, step))) / (std::sqrt(v[i] / (1 - std::pow(b2, step))) + s.epsilon);
    }
  }
  EXPECT_EQ(whole.steps_taken(), 5u);
  EXPECT_EQ(pieces.steps_taken(), 5u);
  double worst = 0;
  for (size_t i = 0; i < n; ++i) worst = std::max(worst, std::abs(double(pp[i]) - ref[i]));
  EXPECT_LT(worst, 1e-5) << "against Adam in double precision";
}

TEST(ParameterAverage, RangesInAnyOrderGiveTheMovingAverage) {
  const size_t n = 30001;
  const float decay = 0.75f;
  std::mt19937 rng(11);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  ParameterAverage whole(n), pieces(n);
  std::vector<double> ref(n);
  std::vector<size_t> bounds = {0, 5, 8192, 8200, 16384, 29999, n};
  std::vector<size_t> order(bounds.size() - 1);
  std::iota(order.begin(), order.end(), size_t(0));
  for (int step = 0; step < 6; ++step) {
    std::vector<float> p(n);
    for (float& x : p) x = normal(rng) + float(step);
    whole.update(p.data(), 0, n, decay, step == 0);
    std::shuffle(order.begin(), order.end(), rng);
    for (size_t r : order) pieces.update(p.data(), bounds[r], bounds[r + 1], decay, step == 0);
    ASSERT_EQ(whole.values(), pieces.values()) << "step " << step;
    for (size_t i = 0; i < n; ++i) ref[i] = step == 0 ? p[i] : decay * ref[i] + (1.0 - decay) * p[i];
  }
  double worst = 0;
  for (size_t i = 0; i < n; ++i) worst = std::max(worst, std::abs(double(whole.values()[i]) - ref[i]));
  EXPECT_LT(worst, 1e-5) << "against the moving average in double precision";
}

}  // namespace
}  // namespace lsnif
