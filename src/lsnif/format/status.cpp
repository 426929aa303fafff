#include "lsnif/format/status.h"

#include <cstdint>
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

namespace {

// Length of the valid UTF-8 character at s[i] that is not a control character, or 0.
size_t clean_char_length(std::string_view s, size_t i) {
  const auto b = [&](size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = b(i);
  if (c < 0x20 || c == 0x7f) return 0;
  if (c < 0x80) return 1;
  size_t n;
  uint32_t cp;
  if ((c & 0xe0) == 0xc0) n = 2, cp = c & 0x1f;
  else if ((c & 0xf0) == 0xe0) n = 3, cp = c & 0x0f;
  else if ((c & 0xf8) == 0xf0) n = 4, cp = c & 0x07;
  else return 0;
  if (i + n > s.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    if ((b(i + k) & 0xc0) != 0x80) return 0;
    cp = cp << 6 | (b(i + k) & 0x3f);
  }
  static const uint32_t kMin[5] = {0, 0, 0x80, 0x800, 0x10000};
  if (cp < kMin[n] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
  if (cp >= 0x80 && cp < 0xa0) return 0;  // C1 control characters
  return n;
}

// The code point of the clean character of `n` bytes at s[i] (clean_char_length(s, i) == n > 0).
uint32_t code_point(std::string_view s, size_t i, size_t n) {
  static const unsigned char kLeadMask[5] = {0, 0x7f, 0x1f, 0x0f, 0x07};
  uint32_t cp = static_cast<unsigned char>(s[i]) & kLeadMask[n];
  for (size_t k = 1; k < n; ++k) cp = cp << 6 | (static_cast<unsigned char>(s[i + k]) & 0x3f);
  return cp;
}

// Characters a terminal shows as nothing, or that reorder or break the text around them: Unicode's
// format characters (general category Cf: the bidirectional embeddings, overrides and isolates
// U+202A..U+202E and U+2066..U+2069, the marks U+200E / U+200F, zero-width spaces and joiners,
// the byte order mark, tags, ...) and the line and paragraph separators U+2028 / U+2029.
bool is_invisible_format(uint32_t cp) {
  static const uint32_t kRanges[][2] = {
      {0x00ad, 0x00ad},   {0x0600, 0x0605},   {0x061c, 0x061c},   {0x06dd, 0x06dd},   {0x070f, 0x070f},
      {0x0890, 0x0891},   {0x08e2, 0x08e2},   {0x180e, 0x180e},   {0x200b, 0x200f},   {0x2028, 0x202e},
      {0x2060, 0x2064},   {0x2066, 0x206f},   {0xfeff, 0xfeff},   {0xfff9, 0xfffb},   {0x110bd, 0x110bd},
      {0x110cd, 0x110cd}, {0x13430, 0x1343f}, {0x1bca0, 0x1bca3}, {0x1d173, 0x1d17a}, {0xe0001, 0xe0001},
      {0xe0020, 0xe007f}};
  for (const auto& r : kRanges)
    if (cp >= r[0] && cp <= r[1]) return true;
  return false;
}

// printable(s) appended to `out`.
void append_printable(std::string_view s, std::string& out) {
  for (size_t i = 0; i < s.size();) {
    const size_t n = clean_char_length(s, i);
    if (n == 0) {
      out += format("\\x%02x", static_cast<unsigned>(static_cast<unsigned char>(s[i])));
      ++i;
      continue;
    }
    const uint32_t cp = n > 1 ? code_point(s, i, n) : 0;
    if (n > 1 && is_invisible_format(cp)) out += format("\\u{%x}", cp);
    else out.append(s.substr(i, n));
    i += n;
  }
}

// The start of the character that holds byte `i` of `s` (continuation bytes skipped back, at most 3).
size_t character_start(std::string_view s, size_t i) {
  for (int k = 0; k < 3 && i > 0 && i < s.size() && (static_cast<unsigned char>(s[i]) & 0xc0) == 0x80; ++k) --i;
  return i;
}

}  // namespace

bool is_clean_utf8(std::string_view s) {
  for (size_t i = 0; i < s.size();) {
    const size_t n = clean_char_length(s, i);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

std::string printable(std::string_view s) {
  std::string out;
  append_printable(s, out);
  return out;
}

std::string elided(std::string_view s, size_t head, size_t tail) {
  std::string out;
  // Eliding fewer bytes than the marker takes would not shorten anything.
  if (s.size() <= head + tail + 32) {
    append_printable(s, out);
    return out;
  }
  const size_t head_end = character_start(s, head), tail_start = character_start(s, s.size() - tail);
  append_printable(s.substr(0, head_end), out);
  out += format("...(%zu bytes)...", tail_start - head_end);
  append_printable(s.substr(tail_start), out);
  return out;
}

std::string excerpt(std::string_view s, size_t max_chars) {
  std::string out(s.substr(0, max_chars));
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = '?';
  if (s.size() > max_chars) out += "...";
  return out;
}

std::string clean_utf8(std::string_view s, size_t max_bytes) {
  std::string out;
  for (size_t i = 0; i < s.size();) {
    const size_t n = clean_char_length(s, i);
    const size_t take = n == 0 ? 1 : n;
    if (out.size() + take > max_bytes) break;
    if (n == 0) out += '?';
    else out.append(s.substr(i, n));
    i += take;
  }
  return out;
}

}  // namespace lsnif
