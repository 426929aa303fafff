// setting_value.h -- one value of a setting of settings_table.h: read from JSON (a `--config` file's
// value, or the settings a model's training record holds), checked against the setting's declared
// range, and written as text. src/lsnif/train/settings_io.h builds the settings files and the
// training record on these; the model loader (training_record.h) checks a stored record with them.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

#include "lsnif/format/settings_table.h"
#include "lsnif/format/status.h"

namespace lsnif {

// One setting's value: U32, U64 and Choice (the choice's value) in `u`, F32 in `f`. U32PerLevel:
// one value for every level in `u` (level_count 0), or level_count (>= 2) values, one per level, in
// per_level.
struct SettingValue {
  uint64_t u = 0;
  float f = 0.0f;
  uint32_t level_count = 0;
  std::array<uint32_t, LSNIF_MAX_LEVELS> per_level{};
  bool operator==(const SettingValue&) const = default;

  // U32PerLevel: the value of grid level `level` (< LSNIF_MAX_LEVELS).
  uint32_t at_level(uint32_t level) const { return level_count ? per_level[level] : static_cast<uint32_t>(u); }
};

// A U32PerLevel value from `count` numbers (at most LSNIF_MAX_LEVELS; one: every level). False when
// `count` is 0 or more than LSNIF_MAX_LEVELS.
bool per_level_value(const uint32_t* values, size_t count, SettingValue& out);

// One value as text: "32", "0.01", "segments", "15,17".
std::string setting_text(const SettingDef& def, const SettingValue& value);

// "'a' or 'b'", "'a', 'b' or 'c'": `count` names, name(i) the i-th.
template <class Name>
std::string quoted_alternatives(size_t count, Name name) {
  std::string s;
  for (size_t i = 0; i < count; ++i) {
    if (i) s += i + 1 == count ? " or " : ", ";
    s += '\'';
    s += name(i);
    s += '\'';
  }
  return s;
}

// The choice of Choice setting `def` called `name`, or nullptr.
const SettingChoice* find_choice(const SettingDef& def, std::string_view name);

// Reads the JSON value `j` of setting `def`: an unsigned integer (U32, U64; U32PerLevel: one, or a
// list of 1 to LSNIF_MAX_LEVELS), a number within the float range (F32), or a string (Choice: its
// name in `choice`, `out.u` left for the caller to look up). Errors say what the value must be;
// ranges are not checked here (check_setting_range).
Status setting_from_json(const SettingDef& def, const nlohmann::json& j, SettingValue& out, std::string& choice);

// The declared range of `def` (settings_table.h); `label` names the value in the message
// ("--voxels", "\"voxels\""). A Choice is checked when its name is looked up.
Status check_setting_range(const SettingDef& def, const SettingValue& value, const std::string& label);

}  // namespace lsnif
