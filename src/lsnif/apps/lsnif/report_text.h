// report_text.h -- number formats of the benchmark reports: byte counts with thousands separators
// and MiB.
#pragma once
#include <cstdint>
#include <string>

namespace lsnif::cli {

// 1234567 -> "1,234,567".
inline std::string grouped(uint64_t v) {
  const std::string digits = std::to_string(v);
  std::string out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

inline double mib(uint64_t bytes) { return double(bytes) / 1048576.0; }

}  // namespace lsnif::cli
