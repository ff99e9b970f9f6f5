// Helpers shared by the example programs (not part of the library): strict number options for
// CLI11 and progress on stderr. Programs include it from examples/; it needs CLI11 and diachron's
// core/progress.hpp.
#pragma once

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <system_error>
#include <type_traits>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include <diachron/core/progress.hpp>

namespace diachron::programs {

// A strict number option: the whole text a number of T (no "2px", no "-1" for a count), within
// [lo, hi]; the message names the range in the option's own words (`wants`).
template <class T>
CLI::Validator strict_number(T lo, T hi, const std::string& wants) {
  return CLI::Validator(
      [lo, hi, wants](std::string& text) -> std::string {
        T value{};
        bool parsed = false;
        if constexpr (std::is_integral_v<T>) {
          const char* end = text.data() + text.size();
          const auto [ptr, ec] = std::from_chars(text.data(), end, value);
          parsed = ec == std::errc() && ptr == end;
        } else {
          char* end = nullptr;
          errno = 0;
          value = static_cast<T>(std::strtod(text.c_str(), &end));
          parsed = !text.empty() && end == text.c_str() + text.size() && errno == 0 && std::isfinite(value);
        }
        if (!parsed) return "'" + text + "' is not " + (std::is_integral_v<T> ? "a whole number" : "a number") + "; it wants " + wants;
        if (value < lo || value > hi) return "it wants " + wants + ", got " + text;
        return std::string();
      },
      "", "strict_number");
}

// Progress on stderr. On a terminal one line rewritten in place; into a file or a pipe whole lines
// (a stage's start, every tenth of it, its end), since '\r' piles up in a log. break_line() ends an
// open line, so that a warning or an error starts on a line of its own.
struct Progress {
  static inline bool open = false;  // a '\r' line is on the terminal without its newline

  static void break_line() {
    if (open) std::fputc('\n', stderr);
    open = false;
  }

  static ProgressCallback callback() {
    const bool terminal = ::isatty(STDERR_FILENO) == 1;
    return [terminal, clock = std::make_shared<ProgressClock>(),
            shown = std::make_shared<std::map<std::string, std::size_t>>()](const ProgressEvent& e) {
      const std::string line = progress_line(e, (*clock)(e));
      if (terminal) {
        // Padded: a line shorter than the one it overwrites leaves no tail behind.
        std::fprintf(stderr, "\r%-72s", line.c_str());
        open = e.done < e.total;
        if (!open) std::fputc('\n', stderr);
        return;
      }
      std::size_t& tenth = (*shown)[e.stage];
      const std::size_t now = e.total == 0 ? 10 : e.done * 10 / e.total;
      if (e.done == 0 || e.done >= e.total || now > tenth) {
        std::fprintf(stderr, "%s\n", line.c_str());
        tenth = e.done == 0 ? 0 : now;
      }
    };
  }
};

}  // namespace diachron::programs
