#include "lsnif/train/optimizer.h"

#include <cmath>

#include "lsnif/format/status.h"

namespace lsnif {

std::string AdamSettings::describe() const {
  return format("Adam lr=%g beta1=%g beta2=%g eps=%g", double(learning_rate), double(beta1),
                double(beta2), double(epsilon));
}

Adam::Adam(size_t parameter_count, AdamSettings settings)
    : s_(settings), m_(parameter_count, 0.0f), v_(parameter_count, 0.0f) {}

void Adam::step(float* params, const float* gradients, float learning_rate) {
  ++t_;
  const float b1 = s_.beta1, b2 = s_.beta2;
  const float c1 = 1.0f / (1.0f - std::pow(b1, float(t_)));
  const float c2 = 1.0f / (1.0f - std::pow(b2, float(t_)));
  const float lr = learning_rate, eps = s_.epsilon;
  const long n = long(m_.size());
  float* m = m_.data();
  float* v = v_.data();
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) {
    const float g = gradients[i];
    m[i] = b1 * m[i] + (1.0f - b1) * g;
    v[i] = b2 * v[i] + (1.0f - b2) * g * g;
    params[i] -= lr * (m[i] * c1) / (std::sqrt(v[i] * c2) + eps);
  }
}

}  // namespace lsnif
