#include "core/thread_pool.h"

#include <system_error>

namespace pt {

int hardware_threads() {
  const unsigned n = std::thread::hardware_concurrency();
  return n == 0 ? 1 : static_cast<int>(n);
}

ThreadPool::ThreadPool(int threads) {
  for (int t = 1; t < std::max(1, threads); ++t) {
    try {
      workers_.emplace_back([this, t] { worker_loop(t); });
    } catch (const std::system_error& e) {
      // A process or memory limit: run with the threads there are (the caller, at least) and say why.
      start_error_ = "only " + std::to_string(t) + " of " + std::to_string(threads) + " threads could be started (" +
                     e.code().message() + ")";
      break;
    }
  }
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& w : workers_) w.join();
}

void ThreadPool::run_tasks(int thread) {
  for (int task; (task = next_task_.fetch_add(1, std::memory_order_relaxed)) < task_count_;) (*job_)(task, thread);
}

void ThreadPool::parallel_for(int task_count, const std::function<void(int, int)>& fn) {
  if (task_count <= 0) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &fn;
    task_count_ = task_count;
    next_task_.store(0);
    busy_workers_ = static_cast<int>(workers_.size());
    ++generation_;
  }
  wake_.notify_all();
  run_tasks(0);
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [this] { return busy_workers_ == 0; });
  job_ = nullptr;
}

void ThreadPool::worker_loop(int thread) {
  uint64_t seen = 0;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
    }
    run_tasks(thread);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (--busy_workers_ == 0) done_.notify_one();
    }
  }
}

}  // namespace pt
