// pooling.cpp -- statistics of an error map: mean, min, max and the error-weighted median and
// quartiles reported by the FLIP tool (each pixel weighted by its own error, so that they say
// where the bulk of the total error lies rather than where most pixels lie).
#include <algorithm>

#include "lsnif/apps/flip/flip.h"

namespace lsnif::flip {
namespace {

// The first value (ascending) whose running sum exceeds p * total; 0 for a zero total.
double weighted_percentile(const std::vector<float>& sorted, double total, double p) {
  if (!(total > 0)) return 0.0;
  double running = 0;
  for (float v : sorted) {
    running += double(v);
    if (running > p * total) return double(v);
  }
  return double(sorted.back());
}

}  // namespace

FlipStatistics pool_errors(const std::vector<float>& errors) {
  FlipStatistics s;
  if (errors.empty()) return s;
  std::vector<float> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  double total = 0;
  for (float v : sorted) total += double(v);
  s.mean = total / double(sorted.size());
  s.min = double(sorted.front());
  s.max = double(sorted.back());
  s.weighted_median = weighted_percentile(sorted, total, 0.5);
  s.weighted_quartile1 = weighted_percentile(sorted, total, 0.25);
  s.weighted_quartile3 = weighted_percentile(sorted, total, 0.75);
  return s;
}

}  // namespace lsnif::flip
