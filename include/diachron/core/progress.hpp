#pragma once
/// @file
/// Progress reporting for long work (tiling, matching, adjustment).

#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
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

/// Time spent in a stage and a linear estimate of the time left (seconds).
struct ProgressTimes {
  double elapsed_s = 0.0;                                    ///< since the stage's first event
  double left_s = std::numeric_limits<double>::quiet_NaN();  ///< NaN until a unit is done
};

/// The clock of a program's progress printer: for each event, the time since its stage's first
/// event and the time left if the remaining units take as long as the done ones did on average
/// (stages are told apart by name; a name seen again after its last unit starts anew). Call it from
/// the ProgressCallback: the library serialises those calls, so it needs no lock of its own.
class ProgressClock {
 public:
  /// `now_s`: the clock in seconds (steady_clock by default; tests pass their own).
  explicit ProgressClock(std::function<double()> now_s = [] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  })
      : now_s_(std::move(now_s)) {}

  ProgressTimes operator()(const ProgressEvent& event) {
    const double now = now_s_();
    auto it = start_s_.find(event.stage);
    if (it == start_s_.end() || finished_[event.stage]) {
      it = start_s_.insert_or_assign(event.stage, now).first;
      finished_[event.stage] = false;
    }
    ProgressTimes out;
    out.elapsed_s = now - it->second;
    if (event.done > 0 && event.done <= event.total)
      out.left_s = out.elapsed_s / static_cast<double>(event.done) * static_cast<double>(event.total - event.done);
    if (event.done >= event.total) finished_[event.stage] = true;
    return out;
  }

 private:
  std::function<double()> now_s_;
  std::map<std::string, double> start_s_;
  std::map<std::string, bool> finished_;
};

/// "42 s", "3 min 05 s", "1 h 02 min": a duration for progress lines ("?" when not finite or < 0).
inline std::string format_duration(double seconds) {
  if (!(seconds >= 0.0) || seconds > 1e9) return "?";
  const auto s = static_cast<long long>(seconds + 0.5);
  char buffer[32];
  if (s < 60) std::snprintf(buffer, sizeof buffer, "%lld s", s);
  else if (s < 3600) std::snprintf(buffer, sizeof buffer, "%lld min %02lld s", s / 60, s % 60);
  else std::snprintf(buffer, sizeof buffer, "%lld h %02lld min", s / 3600, (s % 3600) / 60);
  return buffer;
}

/// "stage: 13/34, 1 min 02 s, about 2 min 10 s left" while a stage runs, "stage: 34/34 in 2 min
/// 58 s" when it is done: the line match_epochs and rough_coregistration print on stderr.
inline std::string progress_line(const ProgressEvent& event, const ProgressTimes& times) {
  std::string line = event.stage + ": " + std::to_string(event.done) + "/" + std::to_string(event.total);
  if (event.done >= event.total) return line + " in " + format_duration(times.elapsed_s);
  line += ", " + format_duration(times.elapsed_s);
  if (!std::isnan(times.left_s)) line += ", about " + format_duration(times.left_s) + " left";
  return line;
}

}  // namespace diachron
