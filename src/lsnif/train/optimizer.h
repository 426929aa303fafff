// optimizer.h -- Adam (Kingma & Ba) over a flat parameter array, as used for both the MLP and the
// hash tables (paper 5.2: lr 0.01). Dense update: entries without gradient still move with momentum.
// ParameterAverage: an exponential moving average of the parameters over the steps (the model the
// trainer keeps, TrainSettings::ema_decay).
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "lsnif/format/settings_table.h"

namespace lsnif {

struct AdamSettings {  // defaults: settings_table.h
  float learning_rate = default_f32(SettingId::Lr);
  float beta1 = default_f32(SettingId::AdamBeta1);
  float beta2 = default_f32(SettingId::AdamBeta2);
  float epsilon = default_f32(SettingId::AdamEpsilon);
  std::string describe() const;
};

class Adam {
 public:
  Adam(size_t parameter_count, AdamSettings settings);
  // One step: params -= lr * mhat / (sqrt(vhat) + eps) with the settings' learning rate, or with
  // `learning_rate` (a schedule's rate for this step). Parallel (OpenMP), deterministic.
  void step(float* params, const float* gradients) { step(params, gradients, s_.learning_rate); }
  void step(float* params, const float* gradients, float learning_rate);
  size_t steps_taken() const { return t_; }

  // A step in pieces, for a caller that updates ranges as their gradients complete:
  // begin_step counts the step, then update() moves parameters [begin, end) with it. Every
  // parameter must be updated once per step; ranges may go to any threads in any order, and the
  // result is step()'s bit for bit (the update is per parameter).
  struct Step {
    float learning_rate, c1, c2;  // c1, c2: the bias corrections 1 / (1 - beta^t)
  };
  Step begin_step(float learning_rate);
  void update(const Step& step, float* params, const float* gradients, size_t begin, size_t end);
  size_t size() const { return m_.size(); }

 private:
  AdamSettings s_;
  std::vector<float> m_, v_;
  size_t t_ = 0;
};

// The exponential moving average of a flat parameter array over the steps: the first update copies
// the parameters, each later one moves the average by (1 - decay) toward them. Like Adam::update,
// per parameter and in ranges: every parameter updated once per step, in any order and on any
// thread, gives the same average bit for bit.
class ParameterAverage {
 public:
  explicit ParameterAverage(size_t parameter_count = 0) : values_(parameter_count) {}
  // first: this step starts the average (the range's values become the parameters').
  void update(const float* params, size_t begin, size_t end, float decay, bool first);
  std::vector<float>& values() { return values_; }
  size_t size() const { return values_.size(); }

 private:
  std::vector<float> values_;
};

}  // namespace lsnif
