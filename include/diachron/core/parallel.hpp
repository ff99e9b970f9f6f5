#pragma once
/// @file
/// The library's one threading facility: a parallel loop over independent items.
///
/// Results must never depend on the thread count: callers write item i's result to slot i and
/// derive any randomness from (seed, i). `threads == 0` means all cores.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace diachron {

/// The number of worker threads `threads` resolves to (0 = hardware concurrency, at least 1).
inline std::size_t resolve_threads(std::size_t threads) {
  if (threads != 0) return threads;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<std::size_t>(hw);
}

/// Calls `fn(i)` for every i in [0, count), on up to `threads` threads (0 = all cores).
/// Items are handed out dynamically, so uneven items balance. The first exception thrown by any
/// call is rethrown in the caller after all workers have stopped; remaining items are skipped.
/// @tparam Fn callable as `void(std::size_t)`; must be safe to call concurrently for distinct i.
template <class Fn>
void parallel_for(std::size_t count, std::size_t threads, Fn&& fn) {
  const std::size_t workers = std::min(resolve_threads(threads), count);
  if (workers <= 1) {
    for (std::size_t i = 0; i < count; ++i) fn(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr first_error;
  std::mutex error_mutex;
  auto work = [&]() {
    for (;;) {
      if (failed.load(std::memory_order_relaxed)) return;
      const std::size_t i = next.fetch_add(1, std::memory_order_relaxed);
      if (i >= count) return;
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!first_error) first_error = std::current_exception();
        failed.store(true, std::memory_order_relaxed);
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  for (std::size_t t = 0; t + 1 < workers; ++t) pool.emplace_back(work);
  work();
  for (auto& thread : pool) thread.join();
  if (first_error) std::rethrow_exception(first_error);
}

}  // namespace diachron
