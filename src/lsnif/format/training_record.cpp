// training_record.cpp -- see training_record.h.
#include "lsnif/format/training_record.h"

#include <string>

#include <nlohmann/json.hpp>

#include "lsnif/format/setting_value.h"

namespace lsnif {

namespace {

// The record as JSON, its nesting bounded (the parser's callback sees every value's depth).
Status parse_record(std::string_view record, nlohmann::json& out) {
  bool too_deep = false;
  const nlohmann::json::parser_callback_t depth = [&](int d, nlohmann::json::parse_event_t, nlohmann::json&) {
    too_deep = too_deep || d > kMaxTrainingRecordDepth;
    return !too_deep;
  };
  out = nlohmann::json::parse(record.begin(), record.end(), depth, /*allow_exceptions=*/false);
  if (too_deep)
    return Status::error("training record nests JSON deeper than %d levels", kMaxTrainingRecordDepth);
  if (out.is_discarded()) return Status::error("training record is not valid JSON: \"%s\"",
                                               printable(record.substr(0, 200)).c_str());
  if (!out.is_object()) return Status::error("training record is %s, not a JSON object", out.type_name());
  return Status::ok();
}

// The value the header gives model setting `id` (per-level settings: one per level of the header),
// and how a message names it; false for the settings of the training run, which the header does not hold.
bool header_value(SettingId id, const Config& h, SettingValue& out, const char*& what) {
  using enum SettingId;
  out = SettingValue();
  uint32_t levels[LSNIF_MAX_LEVELS] = {};
  switch (id) {
    case Voxels: what = "voxel resolution"; out.u = h.voxel_resolution; return true;
    case Points: what = "max points"; out.u = h.max_points; return true;
    case Levels: what = "grid levels"; out.u = h.grid_levels; return true;
    case ResMin: what = "coarsest grid resolution"; out.u = h.grid_resolution[0]; return true;
    case ResMax: what = "finest grid resolution"; out.u = h.grid_resolution[h.grid_levels - 1]; return true;
    case Features: what = "features per entry"; out.u = h.features; return true;
    case Width: what = "hidden width"; out.u = h.hidden_width; return true;
    case Layers: what = "hidden layers"; out.u = h.hidden_layers; return true;
    case Hit: what = "hit parametrization"; out.u = static_cast<uint32_t>(h.hit_param); return true;
    case LeakySlope: what = "leaky slope"; out.f = h.leaky_slope; return true;
    case GridBits: what = "grid bits"; out.u = h.grid_bits; return true;
    case TableLog2:
    case Indexed:
      what = id == TableLog2 ? "table size (log2)" : "indexing";
      for (uint32_t l = 0; l < h.grid_levels; ++l) levels[l] = id == TableLog2 ? h.table_log2[l] : h.indexed(l);
      per_level_value(levels, h.grid_levels, out);
      return true;
    default: return false;
  }
}

// A per-level setting against the header, level by level (table-log2 only where the level is hashed:
// an indexed level's table is sized by its index).
Status check_levels(const SettingDef& d, const SettingValue& v, const SettingValue& h, const Config& header,
                    const char* what) {
  if (v.level_count != 0 && v.level_count != header.grid_levels)
    return Status::error("training record: %s %s gives %u values, the header has %u grid levels", d.name,
                         setting_text(d, v).c_str(), v.level_count, header.grid_levels);
  for (uint32_t l = 0; l < header.grid_levels; ++l) {
    if (d.id == SettingId::TableLog2 && header.indexed(l)) continue;
    if (v.at_level(l) != h.at_level(l))
      return Status::error("training record: %s is %s (level %u: %u), the header's %s of level %u is %u", d.name,
                           setting_text(d, v).c_str(), l, v.at_level(l), what, l, h.at_level(l));
  }
  return Status::ok();
}

// Setting `d` of value `v` against the header.
Status check_against_header(const SettingDef& d, const SettingValue& v, const Config& header) {
  if (d.id == SettingId::SurfaceMaps) {
    const bool forced = v.u == kSurfaceMapsOn, none = v.u == kSurfaceMapsOff;
    if ((forced && !header.surface_channels) || (none && header.surface_channels))
      return Status::error("training record: %s is %s, the header's model has %s", d.name, setting_text(d, v).c_str(),
                           header.surface_channels ? "surface channels" : "no surface channels");
    return Status::ok();
  }
  if (d.id == SettingId::TextureCoordinates) {
    if (v.u == kTextureCoordinatesOff && header.texture_coordinates())
      return Status::error("training record: %s is %s, the header's model has texture coordinates", d.name,
                           setting_text(d, v).c_str());
    return Status::ok();
  }
  SettingValue h;
  const char* what = "";
  if (!header_value(d.id, header, h, what)) return Status::ok();
  if (d.kind == SettingKind::U32PerLevel) return check_levels(d, v, h, header, what);
  const bool same = d.kind == SettingKind::F32 ? v.f == h.f : v.u == h.u;
  if (!same)
    return Status::error("training record: %s is %s, the header's %s is %s", d.name, setting_text(d, v).c_str(), what,
                         setting_text(d, h).c_str());
  return Status::ok();
}

// One recorded setting: its kind, its range, then the header.
Status check_setting(const SettingDef& d, const nlohmann::json& j, const Config& header) {
  const std::string label = std::string("training record: ") + d.name;
  SettingValue v;
  std::string choice;
  if (Status s = setting_from_json(d, j, v, choice); !s) return s.context(label);
  if (d.kind == SettingKind::Choice) {
    const SettingChoice* c = find_choice(d, choice);
    if (!c)
      return Status::error("%s: must be %s, not '%s'", label.c_str(),
                           quoted_alternatives(d.choice_count, [&](size_t k) { return d.choices[k].name; }).c_str(),
                           printable(choice).c_str());
    v.u = c->value;
  }
  if (Status s = check_setting_range(d, v, label); !s) return s;
  return check_against_header(d, v, header);
}

}  // namespace

Status check_training_record(std::string_view record, const Config& header) {
  if (record.empty()) return Status::ok();
  nlohmann::json j;
  if (Status s = parse_record(record, j); !s) return s;
  const auto settings = j.find("settings");
  if (settings == j.end()) return Status::ok();
  if (!settings->is_object())
    return Status::error("training record: \"settings\" is %s, not a JSON object", settings->type_name());
  for (const SettingDef& d : kSettingDefs) {
    const auto value = settings->find(d.name);
    if (value == settings->end()) continue;
    if (Status s = check_setting(d, *value, header); !s) return s;
  }
  return Status::ok();
}

}  // namespace lsnif
