// A fixed pool of worker threads that runs one parallel-for at a time. The calling thread works too, so a pool
// of N threads has N−1 workers. Tasks are handed out dynamically through an atomic counter (no static split),
// so uneven tiles balance themselves.
#pragma once
#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace pt {

class ThreadPool {
 public:
  explicit ThreadPool(int threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return static_cast<int>(workers_.size()) + 1; }
  // Why fewer threads than asked for run (the system refused to create more: a process limit), or "".
  const std::string& start_error() const { return start_error_; }

  // Calls fn(task, thread) for task in [0, task_count) across all threads; returns when every call returned.
  // thread is in [0, size()). Not reentrant.
  void parallel_for(int task_count, const std::function<void(int task, int thread)>& fn);

 private:
  void worker_loop(int thread);
  void run_tasks(int thread);

  std::vector<std::thread> workers_;
  std::string start_error_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(int, int)>* job_ = nullptr;
  int task_count_ = 0;
  std::atomic<int> next_task_{0};
  int busy_workers_ = 0;
  uint64_t generation_ = 0;
  bool stop_ = false;
};

// Number of hardware threads (at least 1).
int hardware_threads();

}  // namespace pt
