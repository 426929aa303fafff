#include "status.h"

#include <cstdio>
#include <vector>

namespace lsnif {

std::string vformat(const char* fmt, va_list args) {
  va_list copy;
  va_copy(copy, args);
  int n = std::vsnprintf(nullptr, 0, fmt, copy);
  va_end(copy);
  if (n <= 0) return std::string();
  std::vector<char> buf(static_cast<size_t>(n) + 1);
  std::vsnprintf(buf.data(), buf.size(), fmt, args);
  return std::string(buf.data(), static_cast<size_t>(n));
}

std::string format(const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  std::string s = vformat(fmt, args);
  va_end(args);
  return s;
}

Status Status::error(const char* fmt, ...) {
  Status s;
  s.failed_ = true;
  va_list args;
  va_start(args, fmt);
  s.message_ = vformat(fmt, args);
  va_end(args);
  return s;
}

}  // namespace lsnif
