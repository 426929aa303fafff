// progress.h -- a progress bar for long work on stderr: fraction, rate, ETA and a caller-supplied
// status (e.g. the current loss). Redraws in place on a terminal; on a pipe or log file it prints a
// line every 10% so CI logs stay short.
#pragma once
#include <chrono>
#include <cstdint>
#include <string>

namespace lsnif {

class ProgressBar {
 public:
  ProgressBar(std::string label, uint64_t total, bool enabled = true);
  // Reports `done` units finished; redraws at most ~10 times per second.
  void update(uint64_t done, const std::string& status = std::string());
  // Draws the final state and ends the line: the units last reported by update() (report the
  // total before finishing work that completed), so work that stopped early (a failure) ends at
  // the unit it reached, not at 100%.
  void finish(const std::string& status = std::string());
  double elapsed_seconds() const;

 private:
  void draw(uint64_t done, const std::string& status, bool final);
  std::string label_;
  uint64_t total_;
  uint64_t done_ = 0;  // the last count update() was given
  bool enabled_, tty_;
  std::chrono::steady_clock::time_point start_, last_draw_;
  int last_decile_ = -1;
};

// A validation-layer message of the tools' Vulkan context (vk::ContextOptions::on_validation_message)
// on stderr: "[vulkan validation error] ..." or "[vulkan validation warning] ...".
void print_validation_message(bool error, const char* message);

}  // namespace lsnif
