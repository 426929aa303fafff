// json_text.cpp -- see json_text.h.
#include "lsnif/import/json_text.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <vector>

namespace lsnif::json {

Status check_depth(std::string_view text, const std::string& name, size_t max_depth) {
  size_t depth = 0;
  bool in_string = false, escaped = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth)
        return Status::error("%s: JSON nested deeper than %zu levels (at byte %zu); refusing to parse it", name.c_str(),
                             max_depth, i);
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return Status::ok();
}

Status parse(std::string_view text, const std::string& name, nlohmann::json& out) {
  if (Status s = check_depth(text, name); !s) return s;
  // The keys of each open object, innermost last: a key seen twice in one object is recorded
  // (nlohmann would keep the last value silently).
  std::vector<std::set<std::string>> open_objects;
  std::string duplicate;
  const auto watch = [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
    using Event = nlohmann::json::parse_event_t;
    if (event == Event::object_start) open_objects.emplace_back();
    if (event == Event::object_end && !open_objects.empty()) open_objects.pop_back();
    if (event == Event::key && !open_objects.empty() && !open_objects.back().insert(parsed.get<std::string>()).second &&
        duplicate.empty())
      duplicate = parsed.get<std::string>();
    return true;
  };
  out = nlohmann::json::parse(text.begin(), text.end(), watch, /*allow_exceptions=*/false);
  if (out.is_discarded()) return Status::error("%s: not valid JSON", name.c_str());
  if (!duplicate.empty())
    return Status::error("%s: the key \"%s\" appears twice in one object (which value is meant?)", name.c_str(),
                         excerpt(duplicate, 60).c_str());
  return Status::ok();
}

nlohmann::ordered_json measured(double v) {
  if (v < 0 || !std::isfinite(v)) return nullptr;
  return v;
}

double float32(float f) {
  // The shortest "%.Ng" (N >= 6) that reads back as `f`, as settings files have always written it.
  char buf[32];
  for (int precision = 6; precision <= 9; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, double(f));
    if (std::strtof(buf, nullptr) == f) break;
  }
  return std::strtod(buf, nullptr);
}

std::string dump(const nlohmann::json& j) { return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace); }

std::string dump(const nlohmann::ordered_json& j) {
  return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace lsnif::json
