// status.h -- error reporting inside the host library: a Status is either ok or carries a message
// that names the problem (file, value, what was expected). No exceptions cross module boundaries.
#pragma once
#include <cstdarg>
#include <string>

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

}  // namespace lsnif
