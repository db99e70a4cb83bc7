// Ctrl-C and `kill` during long work (docs/reliability.md): the first SIGINT or SIGTERM sets a stop flag that
// the render polls (it then stops within a sample and writes what it has) and the viewer checks every frame (it
// then saves the image, as its S key does, and quits); a second one exits at once with status 128 + signal.
// (SIGXFSZ is ignored for the whole process by main().)
#pragma once
#include <atomic>

namespace pt {

class InterruptScope {
 public:
  InterruptScope();   // installs the handlers
  ~InterruptScope();  // restores the previous ones
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

  // Set by the first signal; others (a deadline) may set it too. Stays set.
  std::atomic<bool>& stop_flag();
  // The signal that asked to stop, or 0.
  int signal_received() const;
  // "SIGINT" / "SIGTERM" for messages.
  static const char* signal_name(int sig);
};

}  // namespace pt
