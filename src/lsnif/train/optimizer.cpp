#include "lsnif/train/optimizer.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "lsnif/format/status.h"

namespace lsnif {

std::string AdamSettings::describe() const {
  return format("Adam lr=%g beta1=%g beta2=%g eps=%g", double(learning_rate), double(beta1),
                double(beta2), double(epsilon));
}

Adam::Adam(size_t parameter_count, AdamSettings settings)
    : s_(settings), m_(parameter_count, 0.0f), v_(parameter_count, 0.0f) {}

Adam::Step Adam::begin_step(float learning_rate) {
  ++t_;
  return {learning_rate, 1.0f / (1.0f - std::pow(s_.beta1, float(t_))), 1.0f / (1.0f - std::pow(s_.beta2, float(t_)))};
}

void Adam::update(const Step& step, float* params, const float* gradients, size_t begin, size_t end) {
  const float b1 = s_.beta1, b2 = s_.beta2, c1 = step.c1, c2 = step.c2, lr = step.learning_rate, eps = s_.epsilon;
  float* m = m_.data();
  float* v = v_.data();
  for (size_t i = begin; i < end; ++i) {
    const float g = gradients[i];
    m[i] = b1 * m[i] + (1.0f - b1) * g;
    v[i] = b2 * v[i] + (1.0f - b2) * g * g;
    params[i] -= lr * (m[i] * c1) / (std::sqrt(v[i] * c2) + eps);
  }
}

void Adam::step(float* params, const float* gradients, float learning_rate) {
  const Step s = begin_step(learning_rate);
  const size_t n = m_.size();
#pragma omp parallel
  {
    const size_t nt = size_t(omp_get_num_threads()), t = size_t(omp_get_thread_num());
    update(s, params, gradients, n * t / nt, n * (t + 1) / nt);
  }
}

void ParameterAverage::update(const float* params, size_t begin, size_t end, float decay, bool first) {
  float* a = values_.data();
  if (first) {
    std::copy(params + begin, params + end, a + begin);
    return;
  }
  const float w = 1.0f - decay;
  for (size_t i = begin; i < end; ++i) a[i] += w * (params[i] - a[i]);
}

}  // namespace lsnif
