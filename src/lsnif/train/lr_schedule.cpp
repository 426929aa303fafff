#include "lsnif/train/lr_schedule.h"

#include <cmath>
#include <numbers>

#include "lsnif/format/status.h"

namespace lsnif {

std::string LrScheduleSettings::describe() const {
  const char* name = schedule == LrSchedule::Constant      ? "constant"
                     : schedule == LrSchedule::Exponential ? "exponential"
                                                           : "cosine";
  if (schedule == LrSchedule::Constant) return "lr schedule constant";
  return format("lr schedule %s to %g after %g of the steps", name, double(final_fraction), double(warm_fraction));
}

float scheduled_learning_rate(const LrScheduleSettings& s, float lr, uint32_t step, uint32_t steps) {
  if (s.schedule == LrSchedule::Constant) return lr;
  const uint32_t warm = uint32_t(std::floor(double(s.warm_fraction) * steps));
  if (step <= warm || steps <= warm) return lr;
  const double p = double(step - warm) / double(steps - warm);
  const double f = s.final_fraction;
  const double factor = s.schedule == LrSchedule::Exponential
                            ? std::pow(f, p)
                            : f + (1.0 - f) * 0.5 * (1.0 + std::cos(std::numbers::pi * p));
  return float(double(lr) * factor);
}

}  // namespace lsnif
