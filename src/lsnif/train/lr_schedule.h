// lr_schedule.h -- the learning rate of each training step: Adam's rate (--lr) held for the first
// share of the steps (--lr-warm), then decayed to --lr-final times it at the last step, either
// exponentially (a constant factor per step) or along a half cosine. `constant` keeps --lr
// throughout (the paper's training, 5.2).
#pragma once
#include <cstdint>
#include <string>

#include "lsnif/format/settings_table.h"

namespace lsnif {

enum class LrSchedule : uint32_t { Constant = 0, Exponential = 1, Cosine = 2 };

struct LrScheduleSettings {  // defaults: settings_table.h
  LrSchedule schedule = static_cast<LrSchedule>(default_u32(SettingId::LrSchedule));
  float final_fraction = default_f32(SettingId::LrFinal);  // lr at the last step / lr
  float warm_fraction = default_f32(SettingId::LrWarm);    // share of the steps at the full lr
  std::string describe() const;
};

// The learning rate of step `step` (1..steps) of a run of `steps` steps starting from `lr`. Steps
// 1..floor(warm * steps) use lr; with d = steps - that many decaying steps, step k of them
// (1..d) has progress p = k / d and the rate lr * final^p (exponential) or
// lr * (final + (1 - final) * (1 + cos(pi p)) / 2) (cosine); the last step has lr * final.
float scheduled_learning_rate(const LrScheduleSettings& s, float lr, uint32_t step, uint32_t steps);

}  // namespace lsnif
