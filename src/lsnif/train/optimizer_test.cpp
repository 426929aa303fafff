// optimizer_test.cpp -- Adam's first step moves every parameter with a gradient by the learning
// rate against the gradient's sign (m_hat = g, v_hat = g^2), with the settings' rate or the rate
// given for the step (a schedule's), and a parameter without gradient stays.
#include "lsnif/train/optimizer.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace lsnif
