// number_text.h -- numbers typed by people (command-line options, settings, "X,Y,Z" lists): one
// reading for every program, decimal only. A whole number is decimal digits alone (no sign, no
// "0x", no leading zero but in "0", no spaces); a real number is an optional sign, digits with an
// optional point and an optional exponent ("1e-3"), never a hex float, "inf" or "nan". strtoul and
// strtod take far more ("010" as octal eight with base 0, " 12", "0x1p3", "nan"), silently.
#pragma once
#include <cstdint>
#include <string>

namespace lsnif {

// "" when `text` is a whole number (at most 2^64 - 1), else why not: "a decimal whole number
// expected", "leading zeros are not allowed (...)", "too large a number", ...
std::string whole_number_error(const std::string& text);
// "" when `text` is a real number of the form above and finite as a double, else why not.
std::string real_number_error(const std::string& text);
// The same for a 32-bit float: also "beyond the range of a 32-bit float".
std::string float_error(const std::string& text);

// `text` as a number of the forms above; false (and `out` unchanged) when it is not one or does
// not fit the type.
bool parse_u64(const std::string& text, uint64_t& out);
bool parse_u32(const std::string& text, uint32_t& out);
bool parse_f64(const std::string& text, double& out);
bool parse_f32(const std::string& text, float& out);

}  // namespace lsnif
