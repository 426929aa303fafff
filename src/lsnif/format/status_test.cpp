// status_test.cpp -- messages and untrusted names: UTF-8 validity without control characters,
// escaping for printing, and cleaning for storage, against hand-written byte strings.
#include "lsnif/format/status.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "lsnif/format/numbers.h"

namespace lsnif {
namespace {

TEST(Text, CleanUtf8AcceptsTextAndRefusesControlAndBrokenSequences) {
  EXPECT_TRUE(is_clean_utf8(""));
  EXPECT_TRUE(is_clean_utf8("bunny_01"));
  EXPECT_TRUE(is_clean_utf8("caf\xc3\xa9 \xe2\x9c\x93 \xf0\x9f\x90\x87"));  // 2, 3 and 4 byte characters
  for (const std::string& bad : {std::string("a\nb"), std::string("\x1b[31m"), std::string("x\x7f"),
                                std::string("\xc2\x85"),          // C1 control U+0085
                                std::string("\xff"), std::string("\xc3"),  // invalid byte, truncated sequence
                                std::string("\xc0\xaf"),          // overlong '/'
                                std::string("\xed\xa0\x80"),      // surrogate
                                std::string("\xf4\x90\x80\x80"),  // beyond U+10FFFF
                                std::string("a\0b", 3)})
    EXPECT_FALSE(is_clean_utf8(bad)) << printable(bad);
}

TEST(Text, PrintableEscapesWhatATerminalWouldInterpret) {
  EXPECT_EQ(printable("node\x1b[2J\n"), "node\\x1b[2J\\x0a");
  EXPECT_EQ(printable("caf\xc3\xa9\xff"), "caf\xc3\xa9\\xff");
  EXPECT_EQ(printable(std::string("a\0b", 3)), "a\\x00b");
}

TEST(Text, CleanUtf8ReplacesAndCutsAtCharacterBoundaries) {
  EXPECT_EQ(clean_utf8("ok", 63), "ok");
  EXPECT_EQ(clean_utf8("a\x01\xff" "b", 63), "a??b");
  EXPECT_EQ(clean_utf8(std::string(100, 'x'), 63), std::string(63, 'x'));
  // A two-byte character that would straddle the limit is left out whole.
  EXPECT_EQ(clean_utf8("abc\xc3\xa9", 4), "abc");
  EXPECT_EQ(clean_utf8("abc\xc3\xa9", 5), "abc\xc3\xa9");
}

TEST(Text, ExcerptCutsAndMasksNonPrintableBytes) {
  EXPECT_EQ(excerpt("node"), "node");
  EXPECT_EQ(excerpt(std::string(40, 'n')), std::string(40, 'n'));
  EXPECT_EQ(excerpt(std::string(41, 'n')), std::string(40, 'n') + "...");
  EXPECT_EQ(excerpt("caf\xc3\xa9\x1b[2J"), "caf???[2J");
  EXPECT_EQ(excerpt("abcdef", 3), "abc...");
  EXPECT_EQ(excerpt("", 3), "");
}

TEST(Numbers, ToFloatSaturatesInsteadOfOverflowing) {
  EXPECT_EQ(to_float(1.5), 1.5f);
  EXPECT_EQ(to_float(1e300), std::numeric_limits<float>::infinity());
  EXPECT_EQ(to_float(-1e300), -std::numeric_limits<float>::infinity());
  EXPECT_EQ(to_float(double(std::numeric_limits<float>::max())), std::numeric_limits<float>::max());
  EXPECT_TRUE(std::isnan(to_float(std::nan(""))));
  EXPECT_EQ(to_float(0.1), 0.1f);  // rounded to nearest
}

}  // namespace
}  // namespace lsnif
