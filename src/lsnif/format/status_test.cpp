// status_test.cpp -- messages and untrusted names: UTF-8 validity without control characters,
// escaping for printing, and cleaning for storage, against hand-written byte strings.
#include "lsnif/format/status.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <utility>

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

// Each bidirectional control and invisible format character, written out as its UTF-8 bytes by
// hand, comes out as \u{...}; visible neighbours (U+2027, U+2030, U+00AC, U+00AE) stay as they are.
TEST(Text, PrintableEscapesBidiControlsAndInvisibleFormatCharacters) {
  EXPECT_EQ(printable("evil\xe2\x80\xaetxt.exe"), "evil\\u{202e}txt.exe");  // right-to-left override
  const std::pair<const char*, const char*> escaped[] = {
      {"\xe2\x80\xaa", "\\u{202a}"}, {"\xe2\x80\xab", "\\u{202b}"}, {"\xe2\x80\xac", "\\u{202c}"},
      {"\xe2\x80\xad", "\\u{202d}"}, {"\xe2\x81\xa6", "\\u{2066}"}, {"\xe2\x81\xa7", "\\u{2067}"},
      {"\xe2\x81\xa8", "\\u{2068}"}, {"\xe2\x81\xa9", "\\u{2069}"}, {"\xe2\x80\x8e", "\\u{200e}"},
      {"\xe2\x80\x8f", "\\u{200f}"}, {"\xe2\x80\x8b", "\\u{200b}"}, {"\xef\xbb\xbf", "\\u{feff}"},
      {"\xc2\xad", "\\u{ad}"},         {"\xd8\x9c", "\\u{61c}"},        {"\xe2\x80\xa8", "\\u{2028}"},
      {"\xe2\x80\xa9", "\\u{2029}"}, {"\xf3\xa0\x80\x81", "\\u{e0001}"}};
  for (const auto& [in, out] : escaped) EXPECT_EQ(printable(std::string("a") + in + "b"), std::string("a") + out + "b");
  for (const char* kept : {"\xe2\x80\xa7", "\xe2\x80\xb0", "\xc2\xac", "\xc2\xae", "\xe2\x9c\x93"})
    EXPECT_EQ(printable(kept), kept);
}

TEST(Text, ElidedKeepsHeadAndTailAndCountsWhatItLeavesOut) {
  EXPECT_EQ(elided("short"), "short");
  const std::string kept(60 + 20 + 32, 'k');  // the longest text kept whole
  EXPECT_EQ(elided(kept), kept);
  const std::string uri = "data:application/octet-stream;base64," + std::string(1000000, 'A') + "==";
  const std::string e = elided(uri);
  EXPECT_EQ(e, uri.substr(0, 60) + "...(" + std::to_string(uri.size() - 80) + " bytes)..." + uri.substr(uri.size() - 20));
  EXPECT_LT(e.size(), 110u);
  // Escapes as printable() does, on both sides.
  std::string control(200, 'x');
  control.front() = '\x1b';
  control += "\xe2\x80\xae";
  EXPECT_EQ(elided(control, 4, 4), "\\x1bxxx...(195 bytes)...x\\u{202e}");
  // Never cuts a character: a 3-byte character across the head's end moves out whole, one across the
  // tail's start moves in whole.
  const std::string check = "\xe2\x9c\x93";
  std::string text = "ab";
  text += check + std::string(100, 'x') + check + "cd";
  EXPECT_EQ(elided(text, 3, 3), "ab...(103 bytes)..." + check + "cd");
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
