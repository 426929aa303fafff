// optimizer.h -- Adam (Kingma & Ba) over a flat parameter array, as used for both the MLP and the
// hash tables (paper 5.2: lr 0.01). Dense update: entries without gradient still move with momentum.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace lsnif {

struct AdamSettings {
  float learning_rate = 0.01f;
  float beta1 = 0.9f;
  float beta2 = 0.99f;
  float epsilon = 1e-15f;
  std::string describe() const;
};

class Adam {
 public:
  Adam(size_t parameter_count, AdamSettings settings);
  // One step: params -= lr * mhat / (sqrt(vhat) + eps). Parallel (OpenMP), deterministic.
  void step(float* params, const float* gradients);
  size_t steps_taken() const { return t_; }

 private:
  AdamSettings s_;
  std::vector<float> m_, v_;
  size_t t_ = 0;
};

}  // namespace lsnif
