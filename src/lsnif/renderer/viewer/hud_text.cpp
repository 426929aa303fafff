// hud_text.cpp -- a 5x7 pixel font (drawn for this project) and text drawing into an RGBA8 image.
#include "lsnif/renderer/viewer/hud_text.h"

#include <cctype>
#include <cstring>

namespace lsnif::viewer {

namespace {

struct Glyph {
  char c;
  const char* rows;  // 7 rows of 5 pixels, '#' set, '.' clear, concatenated
};

// clang-format off
constexpr Glyph kGlyphs[] = {
  {'0', ".###.#...##..###.#.###..##...#.###."}, {'1', "..#...##....#....#....#....#...###."},
  {'2', ".###.#...#....#...#...#...#...#####"}, {'3', "####.....#....#.###.....#....#####."},
  {'4', "...#...##..#.#.#..#.#####...#....#."}, {'5', "######....####.....#....##...#.###."},
  {'6', "..##..#...#....####.#...##...#.###."}, {'7', "#####....#...#...#...#....#....#..."},
  {'8', ".###.#...##...#.###.#...##...#.###."}, {'9', ".###.#...##...#.####....#...#..##.."},
  {'A', ".###.#...##...#######...##...##...#"}, {'B', "####.#...##...#####.#...##...#####."},
  {'C', ".###.#...##....#....#....#...#.###."}, {'D', "###..#..#.#...##...##...##..#.###.."},
  {'E', "######....#....####.#....#....#####"}, {'F', "######....#....####.#....#....#...."},
  {'G', ".###.#...##....#.####...##...#.####"}, {'H', "#...##...##...#######...##...##...#"},
  {'I', ".###...#....#....#....#....#...###."}, {'J', "..###...#....#....#....#.#..#..##.."},
  {'K', "#...##..#.#.#..##...#.#..#..#.#...#"}, {'L', "#....#....#....#....#....#....#####"},
  {'M', "#...###.###.#.##.#.##...##...##...#"}, {'N', "#...##...###..##.#.##..###...##...#"},
  {'O', ".###.#...##...##...##...##...#.###."}, {'P', "####.#...##...#####.#....#....#...."},
  {'Q', ".###.#...##...##...##.#.##..#..##.#"}, {'R', "####.#...##...#####.#.#..#..#.#...#"},
  {'S', ".#####....#.....###.....#....#####."}, {'T', "#####..#....#....#....#....#....#.."},
  {'U', "#...##...##...##...##...##...#.###."}, {'V', "#...##...##...##...##...#.#.#...#.."},
  {'W', "#...##...##...##.#.##.#.##.#.#.#.#."}, {'X', "#...##...#.#.#...#...#.#.#...##...#"},
  {'Y', "#...##...#.#.#...#....#....#....#.."}, {'Z', "#####....#...#...#...#...#....#####"},
  {'.', "..........................##...##.."}, {':', "......##...##........##...##......."},
  {'/', "....#....#...#...#...#...#....#...."}, {'+', ".......#....#..#####..#....#......."},
  {'-', "...............#####..............."}, {'%', "##..###..#...#...#...#...#..###..##"},
  {'|', "..#....#....#....#....#....#....#.."}, {'(', "...#...#...#....#....#.....#.....#."},
  {')', ".#.....#.....#....#....#...#...#..."}, {'=', "..........#####.....#####.........."},
  {',', ".....................##....#...#..."}, {'_', "..............................#####"},
  {'<', "...#...#...#...#.....#.....#.....#."}, {'>', ".#.....#.....#.....#...#...#...#..."},
  {'[', ".###..#....#....#....#....#....###."}, {']', ".###....#....#....#....#....#..###."},
};
// clang-format on

const Glyph* find_glyph(char c) {
  const char u = char(std::toupper(static_cast<unsigned char>(c)));
  for (const Glyph& g : kGlyphs)
    if (g.c == u) return &g;
  return nullptr;
}

void blend(uint8_t* px, const uint8_t rgb[3], float alpha) {
  for (int k = 0; k < 3; ++k) px[k] = uint8_t(float(px[k]) * (1.0f - alpha) + float(rgb[k]) * alpha + 0.5f);
}

}  // namespace

bool hud_has_glyph(char c) { return c == ' ' || find_glyph(c) != nullptr; }

const char* hud_glyph_rows(char c) {
  const Glyph* g = find_glyph(c);
  return g ? g->rows : nullptr;
}

void draw_hud_text(uint8_t* rgba, uint32_t width, uint32_t height, int32_t x, int32_t y, const std::string& text,
                   uint32_t scale) {
  if (!rgba || scale == 0) return;
  const uint8_t white[3] = {255, 255, 255}, black[3] = {0, 0, 0};
  const int32_t s = int32_t(scale);
  const int32_t box_w = int32_t(text.size()) * kHudAdvance * s + 2 * s, box_h = kHudLineHeight * s;
  // A half-transparent dark band behind the text keeps it readable on any image.
  for (int32_t py = y; py < y + box_h; ++py)
    for (int32_t px = x; px < x + box_w; ++px)
      if (px >= 0 && py >= 0 && px < int32_t(width) && py < int32_t(height))
        blend(rgba + (size_t(py) * width + size_t(px)) * 4, black, 0.55f);
  int32_t pen = x + s;
  for (char c : text) {
    const char* rows = hud_glyph_rows(c);
    if (!rows && c != ' ') rows = hud_glyph_rows('_');  // an unknown character shows as a bar, not nothing
    for (int32_t gy = 0; rows && gy < 7; ++gy)
      for (int32_t gx = 0; gx < 5; ++gx) {
        if (rows[gy * 5 + gx] != '#') continue;
        for (int32_t sy = 0; sy < s; ++sy)
          for (int32_t sx = 0; sx < s; ++sx) {
            const int32_t px = pen + gx * s + sx, py = y + s + gy * s + sy;
            if (px >= 0 && py >= 0 && px < int32_t(width) && py < int32_t(height))
              std::memcpy(rgba + (size_t(py) * width + size_t(px)) * 4, white, 3);
          }
      }
    pen += kHudAdvance * s;
  }
}

}  // namespace lsnif::viewer
