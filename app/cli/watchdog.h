// A deadline for long work: raises a flag once the given seconds have passed, unless finish() came first. `render
// --time` uses it so that the limit holds within a sample even when one pass or one path would run far longer.
#pragma once
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

namespace pt {

class Watchdog {
 public:
  // No deadline (and no thread) when `seconds` is empty.
  Watchdog(std::atomic<bool>& flag, std::optional<double> seconds) {
    if (!seconds) return;
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(*seconds));
    thread_ = std::thread([this, &flag, deadline] {
      std::unique_lock<std::mutex> lock(mutex_);
      if (!done_cv_.wait_until(lock, deadline, [this] { return done_; })) flag.store(true);
    });
  }
  ~Watchdog() { finish(); }
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;

  void finish() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    done_cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::mutex mutex_;
  std::condition_variable done_cv_;
  bool done_ = false;
  std::thread thread_;
};

}  // namespace pt
