// hud_text.h -- the viewer's on-screen text (frame time, mode, controls): a 5x7 pixel font drawn
// into an RGBA8 image over a half-transparent dark band. Letters are drawn upper case.
#pragma once
#include <cstdint>
#include <string>

namespace lsnif::viewer {

constexpr int32_t kHudAdvance = 6;     // pixels from one character to the next (scale 1)
constexpr int32_t kHudLineHeight = 9;  // pixels of one line of text with its band (scale 1)

// Whether `c` (either case) has a glyph; characters without one are drawn as an underscore bar.
bool hud_has_glyph(char c);
// The glyph of `c`: 7 rows of 5 pixels, '#' set and '.' clear, concatenated; null without one.
const char* hud_glyph_rows(char c);

// Draws `text` with its top-left corner at (x, y) into `rgba` (width x height, 4 bytes per pixel,
// row 0 at the top), each font pixel `scale` x `scale` pixels; what falls outside is clipped.
void draw_hud_text(uint8_t* rgba, uint32_t width, uint32_t height, int32_t x, int32_t y, const std::string& text,
                   uint32_t scale = 1);

}  // namespace lsnif::viewer
