// lr_schedule_test.cpp -- the learning-rate schedules against hand-computed values and their closed
// forms' properties: constant keeps the rate, the warm share keeps it for floor(warm * steps) steps,
// exponential decay multiplies by the same factor every step and ends at final * lr, cosine decay
// passes (1 + final) / 2 * lr halfway and is point-symmetric about it.
#include "lsnif/train/lr_schedule.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lsnif {
namespace {

LrScheduleSettings schedule(LrSchedule kind, float final_fraction, float warm) {
  LrScheduleSettings s;
  s.schedule = kind;
  s.final_fraction = final_fraction;
  s.warm_fraction = warm;
  return s;
}

TEST(LrSchedule, ConstantKeepsTheRate) {
  const LrScheduleSettings s = schedule(LrSchedule::Constant, 0.01f, 0.5f);
  for (uint32_t step : {1u, 7u, 100u}) EXPECT_EQ(scheduled_learning_rate(s, 0.01f, step, 100), 0.01f);
}

TEST(LrSchedule, HandComputedValues) {
  // 10 steps, warm 0.2: steps 1-2 at lr, then 8 decaying steps; step 6 is halfway (p = 4/8).
  const LrScheduleSettings e = schedule(LrSchedule::Exponential, 0.01f, 0.2f);
  EXPECT_EQ(scheduled_learning_rate(e, 0.02f, 1, 10), 0.02f);
  EXPECT_EQ(scheduled_learning_rate(e, 0.02f, 2, 10), 0.02f);
  EXPECT_NEAR(scheduled_learning_rate(e, 0.02f, 6, 10), 0.002f, 1e-8);            // 0.02 * sqrt(0.01)
  EXPECT_NEAR(scheduled_learning_rate(e, 0.02f, 10, 10), 0.0002f, 1e-9);          // 0.02 * 0.01
  EXPECT_NEAR(scheduled_learning_rate(e, 0.02f, 3, 10), 0.02f * 0.5623413f, 1e-8);  // 0.01^(1/8)
  const LrScheduleSettings c = schedule(LrSchedule::Cosine, 0.01f, 0.2f);
  EXPECT_EQ(scheduled_learning_rate(c, 0.02f, 2, 10), 0.02f);
  EXPECT_NEAR(scheduled_learning_rate(c, 0.02f, 6, 10), 0.02f * 0.505f, 1e-8);     // (1 + 0.01) / 2
  EXPECT_NEAR(scheduled_learning_rate(c, 0.02f, 4, 10), 0.02f * 0.8550178f, 1e-8);  // 0.01 + 0.99 (1 + cos(pi/4)) / 2
  EXPECT_NEAR(scheduled_learning_rate(c, 0.02f, 10, 10), 0.0002f, 1e-9);
}

TEST(LrSchedule, ExponentialDecaysByAConstantFactor) {
  const uint32_t steps = 2000;
  const LrScheduleSettings s = schedule(LrSchedule::Exponential, 0.03f, 0.25f);
  const uint32_t warm = 500;
  for (uint32_t k = 1; k <= warm; ++k) ASSERT_EQ(scheduled_learning_rate(s, 0.01f, k, steps), 0.01f) << k;
  const double factor = std::pow(0.03, 1.0 / (steps - warm));
  for (uint32_t k = warm; k < steps; ++k)
    ASSERT_NEAR(scheduled_learning_rate(s, 0.01f, k + 1, steps) / scheduled_learning_rate(s, 0.01f, k, steps),
                factor, 1e-6) << k;
  EXPECT_NEAR(scheduled_learning_rate(s, 0.01f, steps, steps), 0.0003f, 1e-9);
}

TEST(LrSchedule, CosineIsSymmetricAboutItsMidpoint) {
  const uint32_t steps = 1000;
  const LrScheduleSettings s = schedule(LrSchedule::Cosine, 0.05f, 0.0f);
  for (uint32_t k = 0; k <= steps; ++k) {
    // Progress k / steps and 1 - k / steps; step 0 would be progress 0, i.e. the full rate.
    const float a = k == 0 ? 0.01f : scheduled_learning_rate(s, 0.01f, k, steps);
    const float b = k == steps ? 0.01f : scheduled_learning_rate(s, 0.01f, steps - k, steps);
    ASSERT_NEAR(a + b, 0.01f * 1.05f, 1e-8) << k;
    if (k > 0) {  // decreasing
      ASSERT_LE(a, k == 1 ? 0.01f : scheduled_learning_rate(s, 0.01f, k - 1, steps)) << k;
    }
  }
}

}  // namespace
}  // namespace lsnif
