#pragma once
/// @file
/// Progress reporting for long work (tiling, matching, adjustment).

#include <cstddef>
#include <functional>
#include <mutex>
#include <string>
#include <utility>

namespace diachron {

/// One progress event: `done` of `total` units of the named stage are finished.
struct ProgressEvent {
  std::string stage;       ///< short stage name, e.g. "tile pairs (rotation 90)"
  std::size_t done = 0;    ///< units finished so far
  std::size_t total = 0;   ///< units in the stage
};

/// Called on progress; may be empty. The library serialises calls (never two at once), but they
/// may come from worker threads, so the callback must not assume the caller's thread.
using ProgressCallback = std::function<void(const ProgressEvent&)>;

/// Thread-safe counter that forwards to a ProgressCallback, serialising the calls.
class ProgressReporter {
 public:
  ProgressReporter(ProgressCallback callback, std::string stage, std::size_t total)
      : callback_(std::move(callback)), stage_(std::move(stage)), total_(total) {
    if (callback_) callback_(ProgressEvent{stage_, 0, total_});
  }
  /// Marks `units` more as done and reports.
  void advance(std::size_t units = 1) {
    if (!callback_) return;
    std::lock_guard<std::mutex> lock(mutex_);
    done_ += units;
    callback_(ProgressEvent{stage_, done_, total_});
  }

 private:
  ProgressCallback callback_;
  std::string stage_;
  std::size_t total_ = 0;
  std::size_t done_ = 0;
  std::mutex mutex_;
};

}  // namespace diachron
