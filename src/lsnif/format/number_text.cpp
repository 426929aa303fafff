// number_text.cpp -- see number_text.h.
#include "lsnif/format/number_text.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace lsnif {

namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// True when `v` has the real-number form of number_text.h: [+-] digits [. digits] [(e|E) [+-] digits],
// with at least one digit before the exponent.
bool real_form(const std::string& v) {
  size_t i = 0, digits = 0;
  if (i < v.size() && (v[i] == '+' || v[i] == '-')) ++i;
  for (; i < v.size() && is_digit(v[i]); ++i) ++digits;
  if (i < v.size() && v[i] == '.')
    for (++i; i < v.size() && is_digit(v[i]); ++i) ++digits;
  if (!digits) return false;
  if (i < v.size() && (v[i] == 'e' || v[i] == 'E')) {
    ++i;
    if (i < v.size() && (v[i] == '+' || v[i] == '-')) ++i;
    size_t exponent_digits = 0;
    for (; i < v.size() && is_digit(v[i]); ++i) ++exponent_digits;
    if (!exponent_digits) return false;
  }
  return i == v.size();
}

}  // namespace

std::string whole_number_error(const std::string& v) {
  if (v.empty()) return "a decimal whole number expected, not an empty value";
  if (v[0] == '-') return "a whole number of at least 0 expected";
  if (v.size() > 1 && v[0] == '0' && (v[1] == 'x' || v[1] == 'X'))
    return "a decimal whole number expected (hexadecimal is not read)";
  for (char c : v)
    if (!is_digit(c)) return "a decimal whole number expected";
  if (v.size() > 1 && v[0] == '0') return "leading zeros are not allowed (decimal only: 010 is ten, not octal eight)";
  errno = 0;
  (void)std::strtoull(v.c_str(), nullptr, 10);
  if (errno == ERANGE) return "too large a number";
  return "";
}

std::string real_number_error(const std::string& v) {
  if (!real_form(v)) return "a decimal number expected (like 0.5, -2 or 1e-3)";
  errno = 0;
  const double x = std::strtod(v.c_str(), nullptr);
  if (!std::isfinite(x)) return "beyond the range of a 64-bit float";
  return "";
}

std::string float_error(const std::string& v) {
  if (std::string why = real_number_error(v); !why.empty()) return why;
  if (!std::isfinite(std::strtof(v.c_str(), nullptr))) return "beyond the range of a 32-bit float";
  return "";
}

bool parse_u64(const std::string& v, uint64_t& out) {
  if (!whole_number_error(v).empty()) return false;
  out = uint64_t(std::strtoull(v.c_str(), nullptr, 10));
  return true;
}

bool parse_u32(const std::string& v, uint32_t& out) {
  uint64_t x = 0;
  if (!parse_u64(v, x) || x > 0xffffffffull) return false;
  out = uint32_t(x);
  return true;
}

bool parse_f64(const std::string& v, double& out) {
  if (!real_number_error(v).empty()) return false;
  out = std::strtod(v.c_str(), nullptr);
  return true;
}

bool parse_f32(const std::string& v, float& out) {
  if (!float_error(v).empty()) return false;
  out = std::strtof(v.c_str(), nullptr);
  return true;
}

}  // namespace lsnif
