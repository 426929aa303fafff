// number_text_test.cpp -- numbers typed by people: every u64 written in decimal reads back as
// itself, and every form the C library would take besides decimal (octal, hex, signs, spaces, inf,
// nan, hex floats) is refused with a reason.
#include "lsnif/format/number_text.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

namespace lsnif {
namespace {

TEST(NumberText, EveryDecimalU64ReadsBack) {
  std::mt19937_64 rng(7);
  for (int i = 0; i < 20000; ++i) {
    const uint64_t x = rng() >> (rng() % 64);
    uint64_t back = 1;
    ASSERT_TRUE(parse_u64(std::to_string(x), back)) << x;
    EXPECT_EQ(back, x);
    EXPECT_EQ(whole_number_error(std::to_string(x)), "");
  }
  uint64_t top = 0;
  EXPECT_TRUE(parse_u64("18446744073709551615", top));
  EXPECT_EQ(top, UINT64_MAX);
  uint32_t u = 5;
  EXPECT_TRUE(parse_u32("4294967295", u));
  EXPECT_EQ(u, UINT32_MAX);
  EXPECT_FALSE(parse_u32("4294967296", u));
  EXPECT_EQ(u, UINT32_MAX);  // unchanged
}

TEST(NumberText, OtherWholeNumberFormsAreRefused) {
  const struct {
    const char* text;
    const char* why;
  } cases[] = {
      {"010", "leading zeros"}, {"00", "leading zeros"},  {"0x20", "hexadecimal"}, {"0X1F", "hexadecimal"},
      {"-1", "at least 0"},     {"+5", "decimal whole"},  {" 5", "decimal whole"}, {"5 ", "decimal whole"},
      {"1e3", "decimal whole"}, {"1.0", "decimal whole"}, {"", "empty"},           {"18446744073709551616", "too large"},
  };
  for (const auto& c : cases) {
    uint64_t out = 42;
    EXPECT_FALSE(parse_u64(c.text, out)) << c.text;
    EXPECT_EQ(out, 42u);
    EXPECT_NE(whole_number_error(c.text).find(c.why), std::string::npos) << c.text << ": " << whole_number_error(c.text);
  }
}

// Reals: what strtod reads for the decimal forms, and nothing else.
TEST(NumberText, RealsAreDecimalAndFinite) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> mantissa(-10.0, 10.0);
  for (int i = 0; i < 5000; ++i) {
    char text[64];
    std::snprintf(text, sizeof text, i % 2 ? "%.17g" : "%.6e", mantissa(rng) * std::pow(10.0, int(rng() % 40) - 20));
    double x = 0.0;
    ASSERT_TRUE(parse_f64(text, x)) << text;
    EXPECT_EQ(x, std::strtod(text, nullptr)) << text;
  }
  for (const char* ok : {"0", "-0", "+2.5", ".5", "5.", "1e-3", "1E+3", "007.5"}) {
    double x = 0.0;
    EXPECT_TRUE(parse_f64(ok, x)) << ok;
  }
  for (const char* bad : {"", ".", "e3", "1e", "1e+", "0x1p3", "inf", "-inf", "nan", "NAN", " 1", "1 ", "1,5", "1..2",
                          "--1", "1e400"}) {
    double x = 7.0;
    EXPECT_FALSE(parse_f64(bad, x)) << bad;
    EXPECT_EQ(x, 7.0) << bad;
    EXPECT_NE(real_number_error(bad), "") << bad;
  }
  float f = 0.0f;
  EXPECT_TRUE(parse_f32("3.4e38", f));
  EXPECT_FALSE(parse_f32("3.5e38", f));  // a double, not a float
  EXPECT_NE(float_error("3.5e38").find("32-bit float"), std::string::npos);
}

}  // namespace
}  // namespace lsnif
