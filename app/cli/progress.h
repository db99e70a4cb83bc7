// A progress line on stderr. On a terminal it redraws one line in place a few times per second; otherwise
// (logs, CI) it prints a full line at most every `log_interval` seconds, so redirected output is not flooded.
#pragma once
#include <chrono>
#include <string>

namespace pt {

class Progress {
 public:
  explicit Progress(bool enabled, double log_interval_seconds = 10.0);
  // fraction in [0,1] (negative if unknown); the rest is shown as given.
  void update(double fraction, double elapsed, uint64_t spp, double samples_per_second);
  void finish();

 private:
  bool enabled_, tty_;
  double log_interval_;
  double last_print_ = -1e9;
  bool line_open_ = false;
};

std::string format_seconds(double s);

}  // namespace pt
