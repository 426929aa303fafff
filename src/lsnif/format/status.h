// status.h -- error reporting inside the host library: a Status is either ok or carries a message
// that names the problem (file, value, what was expected). No exceptions cross module boundaries.
#pragma once
#include <cstdarg>
#include <string>
#include <string_view>

namespace lsnif {

class Status {
 public:
  Status() = default;
  static Status ok() { return Status(); }
  // printf-style message; the message should name the input and what was wrong with it.
  static Status error(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
  bool is_ok() const { return !failed_; }
  explicit operator bool() const { return !failed_; }
  const std::string& message() const { return message_; }
  // Prefixes context ("loading model.lsnif: ...") to an error; no-op on ok.
  Status& context(const std::string& prefix) {
    if (failed_) message_ = prefix + ": " + message_;
    return *this;
  }

 private:
  bool failed_ = false;
  std::string message_;
};

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string vformat(const char* fmt, va_list args);

// Names from files (nodes, meshes, materials) are untrusted text.
// True when `s` is valid UTF-8 (no overlong forms, surrogates or code points past U+10FFFF) with no
// control character (U+0000..U+001F, U+007F).
bool is_clean_utf8(std::string_view s);
// `s` for a message or a terminal: control characters and bytes that are not valid UTF-8 as
// "\xNN"; characters a terminal shows as nothing or that reorder the text around them (Unicode
// format characters such as the bidirectional overrides U+202A..U+202E, isolates U+2066..U+2069 and
// marks U+200E / U+200F, zero-width spaces, the byte order mark; the line and paragraph separators
// U+2028 / U+2029) as "\u{202e}"; the rest as it is.
std::string printable(std::string_view s);
// printable(s), shortened when `s` is long (untrusted text of any length: a data URI, a token): its
// first `head` and last `tail` bytes (cut at character boundaries) around "...(N bytes)...", N the
// bytes left out. Text of at most head + tail + 32 bytes is kept whole.
std::string elided(std::string_view s, size_t head = 60, size_t tail = 20);
// `s` with every control character and invalid UTF-8 byte replaced by '?', cut to at most
// `max_bytes` bytes at a character boundary.
std::string clean_utf8(std::string_view s, size_t max_bytes);
// A short excerpt of a name or token for a message: its first `max_chars` bytes, each byte outside
// printable ASCII (32..126) as '?', and "..." when it was cut.
std::string excerpt(std::string_view s, size_t max_chars = 40);

}  // namespace lsnif
