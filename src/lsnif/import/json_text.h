// json_text.h -- the one entry for JSON read from files (glTF scenes and meshes through tinygltf,
// the converter's sidecars): the nesting depth is bounded before any parser sees the text, since
// tinygltf (and any recursive consumer) turns deep nesting into deep recursion: a 40 KB file of
// "[[[[..." would overflow the stack.
#pragma once
#include <cstddef>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "lsnif/format/status.h"

namespace lsnif::json {

// Deepest nesting of arrays and objects accepted (glTF needs fewer than 10 levels; extras rarely
// more than a few more).
inline constexpr size_t kMaxDepth = 128;

// An error when `text` nests arrays / objects deeper than `max_depth`: one pass over the bytes
// counting '[' and '{' outside strings (nothing else is validated). The message names `name`,
// the limit and the byte offset.
Status check_depth(std::string_view text, const std::string& name, size_t max_depth = kMaxDepth);

// check_depth, then nlohmann's parser without exceptions. Errors name `name` and what is wrong.
Status parse(std::string_view text, const std::string& name, nlohmann::json& out);

}  // namespace lsnif::json
