#include "lsnif/apps/common/progress.h"

#include <unistd.h>

#include <cstdio>

#include "lsnif/format/status.h"

namespace lsnif {

ProgressBar::ProgressBar(std::string label, uint64_t total, bool enabled)
    : label_(std::move(label)), total_(total ? total : 1), enabled_(enabled),
      tty_(isatty(fileno(stderr)) != 0), start_(std::chrono::steady_clock::now()), last_draw_(start_) {}

double ProgressBar::elapsed_seconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void ProgressBar::update(uint64_t done, const std::string& status) {
  done_ = done;
  if (!enabled_) return;
  auto now = std::chrono::steady_clock::now();
  int decile = int(10 * done / total_);
  if (tty_) {
    if (now - last_draw_ < std::chrono::milliseconds(100)) return;
  } else if (decile == last_decile_) {
    return;
  }
  last_draw_ = now;
  last_decile_ = decile;
  draw(done, status, false);
}

void ProgressBar::finish(const std::string& status) {
  if (!enabled_) return;
  draw(done_, status, true);
}

void ProgressBar::draw(uint64_t done, const std::string& status, bool final) {
  const double elapsed = elapsed_seconds();
  const double frac = double(done) / double(total_);
  const int width = 28, filled = int(frac * width + 0.5);
  std::string bar(size_t(filled), '#');
  bar.resize(size_t(width), '.');
  std::string eta = "--";
  if (final) {
    eta = format("%.1fs", elapsed);
  } else if (done > 0) {
    eta = format("ETA %.0fs", elapsed * (1.0 - frac) / frac);
  }
  std::fprintf(stderr, "%s%s [%s] %3.0f%% %llu/%llu %s %s%s", tty_ ? "\r\033[2K" : "", label_.c_str(),
               bar.c_str(), 100.0 * frac, (unsigned long long)done, (unsigned long long)total_,
               eta.c_str(), status.c_str(), (final || !tty_) ? "\n" : "");
  std::fflush(stderr);
}

void print_validation_message(bool error, const char* message) {
  std::fprintf(stderr, "[vulkan validation %s] %s\n", error ? "error" : "warning", message);
}

}  // namespace lsnif
