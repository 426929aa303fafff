// trainer_test.cpp -- the trainer's guards on a cube: a learning rate far too high stops at the
// first non-finite loss with an error naming the step (instead of training to the end and failing
// at the save), invalid settings are refused before any work, and the loss curve comes back in the
// report, one row per step, without any file being written; the trainer prints nothing (progress
// goes to the caller's callback, step by step); each step runs at the learning-rate schedule's rate;
// the model does not depend on the number of threads; the model kept is the quantized average of the
// parameters of the steps after the learning rate's held share.
#include "lsnif/train/trainer.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "lsnif/core/mlp_gemm.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/train/evaluate.h"

namespace lsnif {
namespace {

Mesh cube() {
  Mesh m;
  for (int i = 0; i < 8; ++i) m.positions.emplace_back(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1));
  const uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    m.triangles.emplace_back(f[0], f[1], f[2]);
    m.triangles.emplace_back(f[0], f[2], f[3]);
  }
  EXPECT_TRUE(finalize_mesh(m, nullptr, "cube"));
  return m;
}

// src/lsnif/testing/test_support.h's tiny settings, smaller still for a cube.
TrainSettings small() {
  TrainSettings s = test::tiny_train_settings();
  s.config.hidden_width = 16;
  s.steps = 20;
  s.batch_size = 256;
  return s;
}

TEST(Trainer, DivergenceStopsAtTheFirstNonFiniteLoss) {
  TrainSettings s = small();
  s.adam.learning_rate = 1e30f;
  Model model;
  uint32_t steps_run = 0;
  Status st = train_model(cube(), s, model, nullptr, [&](uint32_t step, const LossTerms&, const Model&) {
    steps_run = step;
    return true;
  });
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("training diverged: the loss of step"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("lower the learning rate"), std::string::npos) << st.message();
  EXPECT_LT(steps_run, s.steps);  // stopped early, not after all the work
}

TEST(Trainer, InvalidSettingsAreRefusedBeforeTraining) {
  const Mesh mesh = cube();
  struct Case {
    const char* name;
    void (*change)(TrainSettings&);
    const char* expected;
  };
  const Case cases[] = {
      {"lr 0", [](TrainSettings& s) { s.adam.learning_rate = 0.0f; }, "learning rate 0"},
      {"lr negative", [](TrainSettings& s) { s.adam.learning_rate = -0.01f; }, "learning rate -0.01"},
      {"lr NaN", [](TrainSettings& s) { s.adam.learning_rate = std::nanf(""); }, "learning rate"},
      {"negative weight", [](TrainSettings& s) { s.loss_settings.normal = -1.0f; }, "loss weights"},
      {"all weights 0",
       [](TrainSettings& s) {
         s.loss_settings.occlusion = s.loss_settings.distance = s.loss_settings.normal = 0.0f;
         s.loss_settings.albedo = s.loss_settings.material = 0.0f;
       },
       "every loss weight is 0"},
      {"batch 0", [](TrainSettings& s) { s.batch_size = 0; }, "batch size (0)"},
      {"lr final 0", [](TrainSettings& s) { s.lr_schedule.final_fraction = 0.0f; }, "final fraction 0"},
      {"lr warm 1", [](TrainSettings& s) { s.lr_schedule.warm_fraction = 1.0f; }, "warm share 1"},
      {"lr schedule 7", [](TrainSettings& s) { s.lr_schedule.schedule = static_cast<LrSchedule>(7); },
       "unknown learning-rate schedule 7"},
  };
  for (const Case& c : cases) {
    TrainSettings s = small();
    c.change(s);
    Model model;
    uint32_t steps_run = 0;
    Status st = train_model(mesh, s, model, nullptr, [&](uint32_t, const LossTerms&, const Model&) {
      ++steps_run;
      return true;
    });
    ASSERT_FALSE(st) << c.name;
    EXPECT_NE(st.message().find(c.expected), std::string::npos) << c.name << ": " << st.message();
    EXPECT_EQ(steps_run, 0u) << c.name;
  }
}

// The fp32 parameters (grid, then MLP) after the last step.
std::vector<float> trained_parameters(const TrainSettings& s) {
  std::vector<float> params;
  Model model;
  EXPECT_TRUE(train_model(cube(), s, model, nullptr, [&](uint32_t step, const LossTerms&, const Model& m) {
    if (step == s.steps) {
      params = m.grid;
      params.insert(params.end(), m.mlp.begin(), m.mlp.end());
    }
    return true;
  }));
  return params;
}

TEST(Trainer, StepsUseTheScheduledLearningRate) {
  // One step of a decaying schedule runs at final * lr: the same parameters as a constant rate of
  // final * lr (same initialization and rays).
  TrainSettings scheduled = small(), constant = small();
  scheduled.steps = constant.steps = 1;
  scheduled.lr_schedule.schedule = LrSchedule::Exponential;
  scheduled.lr_schedule.final_fraction = 0.25f;
  scheduled.lr_schedule.warm_fraction = 0.0f;
  constant.lr_schedule.schedule = LrSchedule::Constant;
  constant.adam.learning_rate = scheduled.adam.learning_rate * 0.25f;
  const std::vector<float> a = trained_parameters(scheduled), b = trained_parameters(constant);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_FALSE(a.empty());
  for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], b[i], 1e-7f) << i;
  // A schedule decaying to 1 x lr is the constant rate, bit for bit, over many steps; decaying to
  // 0.1 x lr is not.
  scheduled = constant = small();
  scheduled.steps = constant.steps = 6;
  constant.lr_schedule.schedule = LrSchedule::Constant;
  scheduled.lr_schedule.schedule = LrSchedule::Cosine;
  scheduled.lr_schedule.final_fraction = 1.0f;
  EXPECT_EQ(trained_parameters(scheduled), trained_parameters(constant));
  scheduled.lr_schedule.final_fraction = 0.1f;
  EXPECT_NE(trained_parameters(scheduled), trained_parameters(constant));
}

TEST(Trainer, LossCurveComesBackInTheReport) {
  TrainSettings s = small();
  s.steps = 5;
  s.loss_curve = true;
  Model model;
  TrainReport report;
  Status st = train_model(cube(), s, model, &report);
  ASSERT_TRUE(st) << st.message();
  ASSERT_EQ(report.loss_curve.rfind("step,seconds,total,occlusion,distance,normal,albedo,material,surface\n", 0), 0u);
  size_t rows = 0;
  for (char c : report.loss_curve) rows += c == '\n';
  EXPECT_EQ(rows, 1u + s.steps);
  EXPECT_NE(report.loss_curve.find("\n5,"), std::string::npos);
  s.loss_curve = false;
  ASSERT_TRUE(train_model(cube(), s, model, &report));
  EXPECT_TRUE(report.loss_curve.empty());
}

// The evaluation refuses a mesh other than the training mesh (here: moved by a tenth of its size,
// or scaled): its metrics would mean nothing.
TEST(Trainer, EvaluationRefusesAMeshTheModelWasNotTrainedOn) {
  Model model;
  ASSERT_TRUE(train_model(cube(), small(), model));
  EvalSettings es;
  es.rays = 500;
  EvalReport report;
  Status st = evaluate_model(model, cube(), es, report);
  ASSERT_TRUE(st) << st.message();
  Mesh moved = cube(), scaled = cube();
  for (glm::vec3& p : moved.positions) p += glm::vec3(0.1f, 0.0f, 0.0f);
  for (glm::vec3& p : scaled.positions) p *= 2.0f;
  for (const Mesh* other : {&moved, &scaled}) {
    st = evaluate_model(model, *other, es, report);
    ASSERT_FALSE(st);
    EXPECT_NE(st.message().find("not the one the model was trained on"), std::string::npos) << st.message();
  }
}

TEST(Trainer, ReportsThroughTheCallbackAndPrintsNothing) {
  TrainSettings s = small();
  s.steps = 6;
  std::vector<uint32_t> steps;
  Model model;
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  Status st = train_model(cube(), s, model, nullptr, [&](uint32_t step, const LossTerms& loss, const Model&) {
    steps.push_back(step);
    EXPECT_TRUE(std::isfinite(loss.total()));
    return true;
  });
  const std::string out = testing::internal::GetCapturedStdout(), err = testing::internal::GetCapturedStderr();
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(out, "");
  EXPECT_EQ(err, "");
  ASSERT_EQ(steps.size(), size_t(s.steps));
  for (uint32_t i = 0; i < s.steps; ++i) EXPECT_EQ(steps[i], i + 1);
  // Returning false stops after that step.
  steps.clear();
  ASSERT_TRUE(train_model(cube(), s, model, nullptr, [&](uint32_t step, const LossTerms&, const Model&) {
    steps.push_back(step);
    return step < 2;
  }));
  EXPECT_EQ(steps.size(), 2u);
}

// Ground-truth reuse: the pool is cast on the first step, then every step casts batch / R fresh
// rays; without reuse every step casts its whole batch. Counted against the schedule itself.
TEST(Trainer, GroundTruthReuseCastsBatchOverReuseFreshRaysPerStep) {
  const Mesh mesh = cube();
  for (uint32_t reuse : {1u, 4u}) {
    TrainSettings s = small();
    s.ray_reuse = reuse;
    Model model;
    TrainReport rep;
    ASSERT_TRUE(train_model(mesh, s, model, &rep)) << "ray reuse " << reuse;
    EXPECT_EQ(rep.rays, uint64_t(s.steps) * s.batch_size);
    const uint64_t pool = reuse == 1 ? s.batch_size : kRayPoolBatches * s.batch_size;
    EXPECT_EQ(ray_pool_size(s.batch_size, reuse), pool);
    EXPECT_EQ(rep.rays_cast, pool + uint64_t(s.steps - 1) * (s.batch_size / reuse)) << "ray reuse " << reuse;
    EXPECT_TRUE(std::isfinite(rep.final_loss.total()));
  }
  // The pool is capped (at most kRayPoolMaxRays, never below one batch).
  EXPECT_EQ(ray_pool_size(1u << 18, 2), kRayPoolMaxRays);
  EXPECT_EQ(ray_pool_size(1u << 18, 1), size_t(1) << 18);
}

// Which thread does which share of a step (the encoder's blocks and the loss's as threads come
// free, the backward scatter's ranges by the threads' pace, the Adam updates in chunks as ranges
// complete, the sampler's chunks) never changes the model: 1, 2 and 3 threads (more threads than
// levels: equal shares of the entries) train the same parameters bit for bit.
TEST(Trainer, TheModelIsTheSameForAnyThreadCount) {
  TrainSettings s = small();
  s.batch_size = 2048;  // several blocks of the encoder and chunks of the network a step
  s.steps = 12;
  const int before = omp_get_max_threads();
  std::vector<std::vector<float>> params, kept;
  for (int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    params.push_back(trained_parameters(s));
    Model model;
    EXPECT_TRUE(train_model(cube(), s, model));  // the average of the last steps, quantized
    kept.push_back(model.grid);
    kept.back().insert(kept.back().end(), model.mlp.begin(), model.mlp.end());
  }
  omp_set_num_threads(before);
  ASSERT_FALSE(params[0].empty());
  EXPECT_EQ(params[0], params[1]);
  EXPECT_EQ(params[0], params[2]);
  EXPECT_EQ(kept[0], kept[1]);
  EXPECT_EQ(kept[0], kept[2]);
}

// The model kept against the moving average of the parameters the callback saw, taken in double
// precision every kAverageInterval-th step back from the last, from the first after the held share
// (steps 16, 20 and 24 of 24 with lr-warm 0.5), with the decay to that power, at most (1 + n) /
// (10 + n) for the n-th update after the first: within the
// quantization's rounding (half an int8 step of the level's scale for the grid, half an fp16 unit
// for the network), where the last step's parameters are not; with decay 0, the last step's.
TEST(Trainer, TheModelKeptIsTheAverageOfTheLastSteps) {
  ASSERT_EQ(kAverageInterval, 4u) << "the steps below";
  TrainSettings s = small();
  s.steps = 24;
  s.lr_schedule.schedule = LrSchedule::Exponential;
  s.lr_schedule.warm_fraction = 0.5f;
  s.ema_decay = 0.9f;
  // The decay of the n-th update after the first: 0.9^4, but at most (1 + n) / (10 + n).
  auto decay = [&](int n) { return std::min(std::pow(double(s.ema_decay), 4.0), (1.0 + n) / (10.0 + n)); };
  std::vector<double> average;
  std::vector<float> last;
  Model model;
  ASSERT_TRUE(train_model(cube(), s, model, nullptr, [&](uint32_t step, const LossTerms&, const Model& m) {
    last = m.grid;
    last.insert(last.end(), m.mlp.begin(), m.mlp.end());
    if (step == 16) average.assign(last.begin(), last.end());
    if (step == 20 || step == 24) {
      const double d = decay(step == 20 ? 1 : 2);
      for (size_t i = 0; i < last.size(); ++i) average[i] = d * average[i] + (1.0 - d) * double(last[i]);
    }
    return true;
  }));
  ASSERT_EQ(average.size(), model.grid.size() + model.mlp.size());
  const Config& c = model.config;
  ASSERT_EQ(c.grid_bits, 8u);
  auto rounding = [&](size_t i) {  // how far quantization may move parameter i of the average
    if (i < model.grid.size()) return 0.5 * double(model.grid_scales[c.level_of_entry(uint32_t(i / c.features))]) * 1.001 + 1e-7;
    return std::abs(average[i]) * std::ldexp(1.0, -11) * 1.001 + 1e-7;
  };
  size_t off_average = 0, off_last = 0;
  for (size_t i = 0; i < average.size(); ++i) {
    const double kept = i < model.grid.size() ? model.grid[i] : model.mlp[i - model.grid.size()];
    off_average += std::abs(kept - average[i]) > rounding(i);
    off_last += std::abs(kept - double(last[i])) > rounding(i);
  }
  EXPECT_EQ(off_average, 0u) << "of " << average.size() << " parameters";
  EXPECT_GT(off_last, average.size() / 10) << "the average should differ from the last step";

  s.ema_decay = 0.0f;  // the last step's parameters, quantized
  Model plain;
  ASSERT_TRUE(train_model(cube(), s, plain, nullptr, [&](uint32_t, const LossTerms&, const Model& m) {
    last = m.grid;
    last.insert(last.end(), m.mlp.begin(), m.mlp.end());
    return true;
  }));
  Model expected = plain;
  expected.grid.assign(last.begin(), last.begin() + std::ptrdiff_t(plain.grid.size()));
  expected.mlp.assign(last.begin() + std::ptrdiff_t(plain.grid.size()), last.end());
  expected.quantize();
  EXPECT_EQ(expected.grid, plain.grid);
  EXPECT_EQ(expected.mlp, plain.mlp);
}

// --mlp-precision: auto trains what bf16 trains where the CPU has bf16 instructions (else what
// fp32 trains), the two precisions train different models, and bf16 is refused with a message
// naming the instructions where the kernel has none.
TEST(Trainer, MlpPrecisionAutoIsBf16WhereTheCpuHasIt) {
  const Mesh mesh = cube();
  auto train = [&](uint32_t precision, Model& model) {
    TrainSettings s = small();
    s.mlp_precision = precision;
    return train_model(mesh, s, model);
  };
  Model automatic, fp32, bf16;
  ASSERT_TRUE(train(kMlpPrecisionAuto, automatic));
  ASSERT_TRUE(train(kMlpPrecisionFp32, fp32));
  const Status s = train(kMlpPrecisionBf16, bf16);
  if (mlp_gemm_bf16_native()) {
    ASSERT_TRUE(s) << s.message();
    EXPECT_EQ(automatic.mlp, bf16.mlp);
    EXPECT_NE(automatic.mlp, fp32.mlp);
  } else {
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("AVX512_BF16"), std::string::npos) << s.message();
    EXPECT_EQ(automatic.mlp, fp32.mlp);
  }
}

// A time budget plans the steps that fit from the pace of the first ones; a run that was not cut
// short is the run of the steps it planned, bit for bit (the plan changes only while the learning
// rate is held, so the schedule spans the planned steps exactly).
TEST(Trainer, ATimeBudgetTrainsTheRunOfTheStepsItPlanned) {
  TrainSettings budget = small();
  budget.steps = 1000000;  // far more than fit
  budget.time_budget = 0.4;
  budget.loss_curve = true;  // each step's time since the loop started
  std::vector<float> params;
  Model model;
  TrainReport rep;
  ASSERT_TRUE(train_model(cube(), budget, model, &rep, [&](uint32_t, const LossTerms&, const Model& m) {
    params = m.grid;
    params.insert(params.end(), m.mlp.begin(), m.mlp.end());
    return true;
  }));
  EXPECT_LE(rep.steps, rep.planned_steps);
  EXPECT_EQ(rep.rays, uint64_t(rep.steps) * budget.batch_size);
  // No step started after the budget ran out: every step but the last ended within it (each
  // step's time in the loss curve). A bound on the total would fail on a loaded host, where a
  // single step may take longer than the budget.
  {
    std::istringstream curve(rep.loss_curve);
    std::string line;
    std::getline(curve, line);  // the header
    std::vector<double> seconds;
    while (std::getline(curve, line)) seconds.push_back(std::stod(line.substr(line.find(',') + 1)));
    ASSERT_EQ(seconds.size(), rep.steps);
    for (size_t k = 0; k + 1 < seconds.size(); ++k)
      ASSERT_LT(seconds[k], budget.time_budget) << "step " << k + 1 << " ended past the budget, and step " << k + 2 << " ran";
  }
  if (rep.budget_cut) {
    EXPECT_LT(rep.steps, rep.planned_steps);  // a slowed host (a sanitizer build): stopped at the budget
  } else {
    EXPECT_GE(rep.planned_steps, 8u);  // planned first after step 8
    EXPECT_LT(rep.planned_steps, budget.steps);
    EXPECT_EQ(rep.steps, rep.planned_steps);
    TrainSettings fixed = small();
    fixed.steps = rep.planned_steps;
    EXPECT_EQ(params, trained_parameters(fixed));
  }
  // Out of range: refused before any work.
  budget.time_budget = -1.0;
  EXPECT_FALSE(train_model(cube(), budget, model));
  budget.time_budget = kMaxTimeBudget * 2;
  const Status s = train_model(cube(), budget, model);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("time budget"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace lsnif
