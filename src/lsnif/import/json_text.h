// json_text.h -- the one entry for JSON. Read from files (glTF scenes and meshes through tinygltf,
// the converter's sidecars): the nesting depth is bounded before any parser sees the text, since
// tinygltf (and any recursive consumer) turns deep nesting into deep recursion: a 40 KB file of
// "[[[[..." would overflow the stack. Written (every `--json` output, sidecars, scene files): built
// as an nlohmann value (`nlohmann::ordered_json` where the key order is part of the output) and
// turned into text by dump() below, never printed by hand.
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

// check_depth, then nlohmann's parser without exceptions. Errors name `name` and what is wrong; a
// key given twice in one object is an error (it names the key), not "the last one wins".
Status parse(std::string_view text, const std::string& name, nlohmann::json& out);

// `v`, or null when it is negative or not finite: a time, rate or ratio that was not measured.
// (Any non-finite double is written as null by nlohmann anyway; a plain number needs no helper.)
nlohmann::ordered_json measured(double v);

// `f` as the double of its shortest decimal ("%.Ng", N >= 6) that reads back as `f`: 0.01f is
// written 0.01, not 0.009999999776482582 (the settings' floats, the flip command's).
double float32(float f);

// The text of `j` as the product writes a document (stdout, sidecars, scene files): indented by 2
// spaces, no trailing newline; control characters in strings escaped, bytes that are not UTF-8 (a
// path, a driver's name) replaced by U+FFFD instead of throwing. JSON kept inside other data (the
// model's training record, a .glb's JSON chunk, the converter's hash key) stays nlohmann's compact
// dump() of values that are UTF-8 already.
std::string dump(const nlohmann::json& j);
std::string dump(const nlohmann::ordered_json& j);

}  // namespace lsnif::json
