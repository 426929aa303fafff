// optimizer.h -- Adam (Kingma & Ba) over a flat parameter array, as used for both the MLP and the
// hash tables (paper 5.2: lr 0.01). Dense update: entries without gradient still move with momentum.
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

 private:
  AdamSettings s_;
  std::vector<float> m_, v_;
  size_t t_ = 0;
};

}  // namespace lsnif
