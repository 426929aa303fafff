// The HUD font: every glyph is a well-formed 5x7 bitmap, distinct characters look distinct, and
// drawn text lands where it should, clipped at the image's edges.
#include "lsnif/renderer/viewer/hud_text.h"

#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <string>
#include <vector>

namespace lsnif::viewer {
namespace {

const std::string kCharset = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ.:/+-%|()=,_<>[]";

TEST(HudText, EveryGlyphIsA5x7BitmapAndAllDiffer) {
  std::set<std::string> seen;
  for (char c : kCharset) {
    const char* rows = hud_glyph_rows(c);
    ASSERT_NE(rows, nullptr) << c;
    ASSERT_EQ(std::strlen(rows), 35u) << c;
    for (int i = 0; i < 35; ++i) ASSERT_TRUE(rows[i] == '#' || rows[i] == '.') << c;
    EXPECT_NE(std::string(rows).find('#'), std::string::npos) << c << " is empty";
    EXPECT_TRUE(seen.insert(rows).second) << c << " looks like another glyph";
  }
  EXPECT_STREQ(hud_glyph_rows('a'), hud_glyph_rows('A'));  // lower case is drawn upper case
  EXPECT_TRUE(hud_has_glyph(' '));
  EXPECT_FALSE(hud_has_glyph('~'));
  EXPECT_EQ(hud_glyph_rows('~'), nullptr);
}

// Draws one glyph on black and reads it back: the set pixels are exactly the glyph's '#'s.
TEST(HudText, DrawnGlyphMatchesItsBitmapAtEveryScale) {
  for (uint32_t scale : {1u, 2u, 3u}) {
    const uint32_t w = 40, h = 30;
    std::vector<uint8_t> img(size_t(w) * h * 4, 0);
    draw_hud_text(img.data(), w, h, 3, 2, "7", scale);
    const char* rows = hud_glyph_rows('7');
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        const int gx = (int(x) - 3 - int(scale)) / int(scale), gy = (int(y) - 2 - int(scale)) / int(scale);
        const bool inside = int(x) >= 3 + int(scale) && int(y) >= 2 + int(scale) && gx < 5 && gy < 7;
        const bool lit = inside && rows[gy * 5 + gx] == '#';
        EXPECT_EQ(img[(size_t(y) * w + x) * 4], lit ? 255 : 0) << "scale " << scale << " at " << x << "," << y;
      }
  }
}

TEST(HudText, BandDarkensAndTextIsClipped) {
  const uint32_t w = 20, h = 6;
  std::vector<uint8_t> img(size_t(w) * h * 4, 200);
  draw_hud_text(img.data(), w, h, -4, -3, "LONG TEXT THAT DOES NOT FIT", 1);  // must not write outside
  // The band covers the whole visible strip: every pixel is either white text or darkened.
  for (size_t i = 0; i < img.size(); i += 4) EXPECT_TRUE(img[i] == 255 || img[i] < 200) << i / 4;
  std::vector<uint8_t> untouched(size_t(w) * h * 4, 200);
  draw_hud_text(untouched.data(), w, h, int32_t(w), int32_t(h), "X", 1);  // entirely outside
  for (uint8_t v : untouched) EXPECT_EQ(v, 200);
}

}  // namespace
}  // namespace lsnif::viewer
