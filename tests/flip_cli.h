// flip_cli.h -- the end-to-end tests' image comparison through the program: `lsnif flip`'s mean
// LDR-FLIP of `test` against `reference` (1 when it prints none, with a test failure when it fails).
#pragma once
#include <gtest/gtest.h>

#include <string>

#include "lsnif/testing/test_support.h"

namespace lsnif::test {

inline double flip_mean(const std::string& reference, const std::string& test) {
  CommandResult r = run_command(std::string(LSNIF_CLI) + " flip " + reference + " " + test + " 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  const size_t at = r.out.find("mean");
  return at == std::string::npos ? 1.0 : std::stod(r.out.substr(r.out.find_first_not_of(' ', at + 4)));
}

}  // namespace lsnif::test
