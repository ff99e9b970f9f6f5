#pragma once
/// @file
/// ThreadPool: long-lived worker threads for parallel_for (core/parallel.hpp). Creating and joining
/// threads costs tens of microseconds each; a loop called thousands of times (RANSAC blocks, tile
/// pairs) paid that on every call. The pool keeps its workers between calls.
///
/// The pool only runs "helper" tasks. A parallel_for caller always works through its own items, so
/// it never waits for a worker to become free: a body that calls parallel_for again (nesting) makes
/// progress on its own thread even when every worker is busy, and cannot deadlock.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace diachron {

/// A set of worker threads running queued tasks in FIFO order. Workers are started on demand
/// (reserve()) and joined by the destructor after the queue has drained. Thread-safe.
class ThreadPool {
 public:
  ThreadPool() = default;
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  ~ThreadPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : workers_) t.join();
  }

  /// Starts workers until there are at least `workers` of them (never stops any).
  void reserve(std::size_t workers) {
    std::lock_guard<std::mutex> lock(mutex_);
    while (workers_.size() < workers) workers_.emplace_back([this] { run(); });
  }

  /// Number of worker threads started so far.
  std::size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return workers_.size();
  }

  /// Queues `task` for a worker. Tasks must not throw (parallel_for's helpers catch everything).
  void submit(std::function<void()> task) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      tasks_.push_back(std::move(task));
    }
    wake_.notify_one();
  }

  /// The process-wide pool parallel_for uses, created on first use; its workers live until exit.
  static ThreadPool& shared() {
    static ThreadPool pool;
    return pool;
  }

 private:
  void run() {
    for (;;) {
      std::function<void()> task;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return stopping_ || !tasks_.empty(); });
        if (tasks_.empty()) return;  // stopping and drained
        task = std::move(tasks_.front());
        tasks_.pop_front();
      }
      task();
    }
  }

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> tasks_;
  std::vector<std::thread> workers_;
  bool stopping_ = false;
};

}  // namespace diachron
