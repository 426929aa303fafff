// numbers.h -- conversions of numbers read from files.
#pragma once
#include <limits>

namespace lsnif {

// double -> float without undefined behaviour: magnitudes past the float range become +-infinity,
// NaN stays NaN, the rest rounds to nearest.
inline float to_float(double d) {
  constexpr double kMax = static_cast<double>(std::numeric_limits<float>::max());
  if (d > kMax) return std::numeric_limits<float>::infinity();
  if (d < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(d);
}

}  // namespace lsnif
