#include "cli/interrupt.h"

#include <signal.h>
#include <unistd.h>

#include <cstring>

namespace pt {

namespace {

// Lock-free atomics are safe to touch from a signal handler.
std::atomic<bool> g_stop{false};
std::atomic<int> g_signal{0};
static_assert(std::atomic<bool>::is_always_lock_free && std::atomic<int>::is_always_lock_free);

struct sigaction g_old_int, g_old_term;

void on_signal(int sig) {
  if (g_signal.exchange(sig) != 0) {
    // The second signal: the user means it. Only async-signal-safe calls here.
    const char msg[] = "\ninterrupted again: exiting without writing\n";
    [[maybe_unused]] const ssize_t n = ::write(STDERR_FILENO, msg, sizeof msg - 1);
    ::_exit(128 + sig);
  }
  g_stop.store(true);
}

}  // namespace

InterruptScope::InterruptScope() {
  g_stop.store(false);
  g_signal.store(0);
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &g_old_int);
  sigaction(SIGTERM, &sa, &g_old_term);
}

InterruptScope::~InterruptScope() {
  sigaction(SIGINT, &g_old_int, nullptr);
  sigaction(SIGTERM, &g_old_term, nullptr);
}

std::atomic<bool>& InterruptScope::stop_flag() { return g_stop; }

int InterruptScope::signal_received() const { return g_signal.load(); }

const char* InterruptScope::signal_name(int sig) {
  return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "a signal";
}

}  // namespace pt
