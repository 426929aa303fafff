// setting_value.cpp -- see setting_value.h.
#include "lsnif/format/setting_value.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <nlohmann/json.hpp>

namespace lsnif {

namespace {

// The shortest "%.Ng" text that reads back as `f`.
std::string float_text(float f) {
  char buf[32];
  for (int precision = 6; precision <= 9; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, double(f));
    if (std::strtof(buf, nullptr) == f) break;
  }
  return buf;
}

Status check_u32_range(const SettingDef& d, const SettingValue& v, const std::string& label) {
  const double x = static_cast<double>(v.u);  // at most 2^32 - 1: exact
  if (d.max == kU32Max && x < d.min)
    return Status::error("%s (%llu) must be at least %u", label.c_str(), (unsigned long long)v.u, uint32_t(d.min));
  if (x < d.min || x > d.max)
    return Status::error("%s %llu out of range [%u, %u]", label.c_str(), (unsigned long long)v.u, uint32_t(d.min),
                         uint32_t(d.max));
  return Status::ok();
}

Status check_per_level_range(const SettingDef& d, const SettingValue& v, const std::string& label) {
  if (v.level_count == 0) {
    if (v.u < uint64_t(d.min) || v.u > uint64_t(d.max))
      return Status::error("%s %llu out of range [%u, %u]", label.c_str(), (unsigned long long)v.u, uint32_t(d.min),
                           uint32_t(d.max));
    return Status::ok();
  }
  for (uint32_t l = 0; l < v.level_count; ++l)
    if (v.per_level[l] < uint32_t(d.min) || v.per_level[l] > uint32_t(d.max))
      return Status::error("%s %s: %u (level %u) out of range [%u, %u]", label.c_str(), setting_text(d, v).c_str(),
                           v.per_level[l], l, uint32_t(d.min), uint32_t(d.max));
  return Status::ok();
}

Status check_f32_range(const SettingDef& d, const SettingValue& v, const std::string& label) {
  const double x = v.f;
  const bool ok = std::isfinite(v.f) && (d.min_open ? x > d.min : x >= d.min) && (d.max_open ? x < d.max : x <= d.max);
  if (ok) return Status::ok();
  if (d.max == kF32Max && d.min == 0 && d.min_open)
    return Status::error("%s %g must be a positive, finite %s", label.c_str(), x, d.noun);
  if (d.max == kF32Max && d.min == 0) return Status::error("%s %g must be a finite %s >= 0", label.c_str(), x, d.noun);
  return Status::error("%s %g out of range %c%g, %g%c", label.c_str(), x, d.min_open ? '(' : '[', d.min, d.max,
                       d.max_open ? ')' : ']');
}

Status per_level_from_json(const nlohmann::json& j, SettingValue& out) {
  if (j.is_number_unsigned() && j.get<uint64_t>() <= 0xffffffffull) {
    out.u = j.get<uint64_t>();
    return Status::ok();
  }
  uint32_t values[LSNIF_MAX_LEVELS] = {};
  bool ok = j.is_array() && !j.empty() && j.size() <= LSNIF_MAX_LEVELS;
  for (size_t i = 0; ok && i < j.size(); ++i) {
    ok = j[i].is_number_unsigned() && j[i].get<uint64_t>() <= 0xffffffffull;
    if (ok) values[i] = static_cast<uint32_t>(j[i].get<uint64_t>());
  }
  if (!ok || !per_level_value(values, j.size(), out))
    return Status::error("must be an unsigned integer or a list of 1 to %u of them (one per level), not %s",
                         LSNIF_MAX_LEVELS, printable(j.dump()).c_str());
  return Status::ok();
}

}  // namespace

bool per_level_value(const uint32_t* values, size_t count, SettingValue& out) {
  if (count == 0 || count > LSNIF_MAX_LEVELS) return false;
  out = SettingValue();
  if (count == 1) {
    out.u = values[0];
    return true;
  }
  out.level_count = static_cast<uint32_t>(count);
  for (size_t l = 0; l < count; ++l) out.per_level[l] = values[l];
  return true;
}

std::string setting_text(const SettingDef& d, const SettingValue& v) {
  switch (d.kind) {
    case SettingKind::U32:
    case SettingKind::U64: return std::to_string(v.u);
    case SettingKind::U32PerLevel: {
      if (v.level_count == 0) return std::to_string(v.u);
      std::string text;
      for (uint32_t l = 0; l < v.level_count && l < LSNIF_MAX_LEVELS; ++l) {
        if (l) text += ',';
        text += std::to_string(v.per_level[l]);
      }
      return text;
    }
    case SettingKind::F32: return float_text(v.f);
    case SettingKind::Choice:
      for (uint32_t c = 0; c < d.choice_count; ++c)
        if (d.choices[c].value == v.u) return d.choices[c].name;
      return std::to_string(v.u);
  }
  return {};
}

const SettingChoice* find_choice(const SettingDef& d, std::string_view name) {
  for (uint32_t c = 0; c < d.choice_count; ++c)
    if (name == d.choices[c].name) return &d.choices[c];
  return nullptr;
}

Status setting_from_json(const SettingDef& d, const nlohmann::json& j, SettingValue& out, std::string& choice) {
  const auto type_error = [&](const char* want) {
    return Status::error("must be %s, not %s", want, j.is_number() ? j.dump().c_str() : j.type_name());
  };
  switch (d.kind) {
    case SettingKind::U32:
    case SettingKind::U64:
      if (!j.is_number_unsigned()) return type_error("an unsigned integer");
      out.u = j.get<uint64_t>();
      if (d.kind == SettingKind::U32 && out.u > 0xffffffffull)
        return Status::error("%llu is larger than %u", (unsigned long long)out.u, uint32_t(kU32Max));
      return Status::ok();
    case SettingKind::U32PerLevel: return per_level_from_json(j, out);
    case SettingKind::F32: {
      if (!j.is_number()) return type_error("a number");
      const double x = j.get<double>();
      if (!(std::abs(x) <= kF32Max)) return Status::error("%g is beyond the range of a 32-bit float", x);
      out.f = static_cast<float>(x);
      return Status::ok();
    }
    case SettingKind::Choice:
      if (!j.is_string())
        return type_error(
            ("one of " + quoted_alternatives(d.choice_count, [&](size_t k) { return d.choices[k].name; })).c_str());
      choice = j.get<std::string>();
      return Status::ok();
  }
  return Status::ok();
}

Status check_setting_range(const SettingDef& d, const SettingValue& v, const std::string& label) {
  switch (d.kind) {
    case SettingKind::U32: return check_u32_range(d, v, label);
    case SettingKind::U32PerLevel: return check_per_level_range(d, v, label);
    case SettingKind::F32: return check_f32_range(d, v, label);
    case SettingKind::U64:
    case SettingKind::Choice: return Status::ok();
  }
  return Status::ok();
}

}  // namespace lsnif
