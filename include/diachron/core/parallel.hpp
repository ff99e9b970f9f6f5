#pragma once
/// @file
/// The library's one threading facility: a parallel loop over independent items, run on a shared
/// pool of reused threads (core/thread_pool.hpp).
///
/// Results must never depend on the thread count: callers write item i's result to slot i and
/// derive any randomness from (seed, i). `threads == 0` means all cores.

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>

#include <diachron/core/thread_pool.hpp>

namespace diachron {

/// The number of worker threads `threads` resolves to (0 = hardware concurrency, at least 1).
inline std::size_t resolve_threads(std::size_t threads) {
  if (threads != 0) return threads;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<std::size_t>(hw);
}

namespace detail {

// One parallel_for call, shared with its helper tasks. Helpers hold it by shared_ptr because a
// helper may still sit in the pool's queue after the call has returned; such a late helper sees
// `closed` and leaves without touching `fn`, which lives on the caller's stack.
struct ParallelJob {
  std::size_t count = 0;
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr first_error;
  std::mutex mutex;  // guards first_error, closed, active
  std::condition_variable idle;
  bool closed = false;
  std::size_t active = 0;

  template <class Fn>
  void work(Fn& fn) {
    for (;;) {
      if (failed.load(std::memory_order_relaxed)) return;
      const std::size_t i = next.fetch_add(1, std::memory_order_relaxed);
      if (i >= count) return;
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!first_error) first_error = std::current_exception();
        failed.store(true, std::memory_order_relaxed);
      }
    }
  }
};

// Most helpers parallel_for starts in the shared pool, whatever `threads` asks for.
inline constexpr std::size_t kMaxPoolWorkers = 256;

}  // namespace detail

/// Calls `fn(i)` for every i in [0, count), on up to `threads` threads (0 = all cores): the caller
/// and up to threads - 1 workers of ThreadPool::shared(), which are created once and reused, so a
/// call costs microseconds, not a thread start and join per worker.
/// Items are handed out dynamically, so uneven items balance. The first exception thrown by any
/// call is rethrown in the caller after all workers have stopped; remaining items are skipped.
/// `fn` may itself call parallel_for: the caller works through the items too and never waits for a
/// queued helper to start, so nesting cannot deadlock.
/// @tparam Fn callable as `void(std::size_t)`; must be safe to call concurrently for distinct i.
template <class Fn>
void parallel_for(std::size_t count, std::size_t threads, Fn&& fn) {
  const std::size_t workers = std::min({resolve_threads(threads), count, detail::kMaxPoolWorkers + 1});
  if (workers <= 1) {
    for (std::size_t i = 0; i < count; ++i) fn(i);
    return;
  }
  auto job = std::make_shared<detail::ParallelJob>();
  job->count = count;
  ThreadPool& pool = ThreadPool::shared();
  pool.reserve(workers - 1);
  auto* body = &fn;
  for (std::size_t t = 0; t + 1 < workers; ++t) {
    pool.submit([job, body] {
      {
        std::lock_guard<std::mutex> lock(job->mutex);
        if (job->closed) return;
        ++job->active;
      }
      job->work(*body);
      std::lock_guard<std::mutex> lock(job->mutex);
      if (--job->active == 0) job->idle.notify_all();
    });
  }
  job->work(fn);
  // Every item is claimed (or the loop failed): helpers that have not started yet must not start,
  // and the ones running finish their current item.
  std::unique_lock<std::mutex> lock(job->mutex);
  job->closed = true;
  job->idle.wait(lock, [&] { return job->active == 0; });
  if (job->first_error) std::rethrow_exception(job->first_error);
}

}  // namespace diachron
