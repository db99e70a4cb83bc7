#include "cli/progress.h"

#include <unistd.h>

#include <cstdio>

namespace pt {

std::string format_seconds(double s) {
  char buf[32];
  if (s < 60) std::snprintf(buf, sizeof buf, "%.1fs", s);
  else if (s < 3600) std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  else std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(s) / 3600, (static_cast<int>(s) / 60) % 60);
  return buf;
}

Progress::Progress(bool enabled, double log_interval_seconds)
    : enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0), log_interval_(log_interval_seconds) {}

void Progress::update(double fraction, double elapsed, uint64_t spp, double samples_per_second) {
  if (!enabled_) return;
  const double interval = tty_ ? 0.2 : log_interval_;
  if (elapsed - last_print_ < interval) return;
  last_print_ = elapsed;
  std::string eta = "?";
  if (fraction > 0.0 && fraction <= 1.0) eta = format_seconds(elapsed * (1.0 - fraction) / fraction);
  char line[160];
  std::snprintf(line, sizeof line, "  %5.1f%%  %llu spp  elapsed %s  ETA %s  %.2f Msamples/s", fraction >= 0 ? 100.0 * fraction : 0.0,
                static_cast<unsigned long long>(spp), format_seconds(elapsed).c_str(), eta.c_str(),
                samples_per_second * 1e-6);
  if (tty_) {
    std::fprintf(stderr, "\r%s\033[K", line);
    line_open_ = true;
  } else {
    std::fprintf(stderr, "%s\n", line);
  }
  std::fflush(stderr);
}

void Progress::finish() {
  if (enabled_ && tty_ && line_open_) std::fprintf(stderr, "\r\033[K");
  line_open_ = false;
}

}  // namespace pt
