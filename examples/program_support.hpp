// Helpers shared by the example programs (not part of the library): strict number and number-pair
// options for CLI11, error messages for people, and progress on stderr. Programs include it from
// examples/; it needs CLI11 and diachron's core/error.hpp and core/progress.hpp.
#pragma once

#include <cerrno>
#include <charconv>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <type_traits>
#include <utility>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/progress.hpp>

namespace diachron::programs {

namespace detail {

// `text` as a number of T, all of it: no sign for an unsigned T, no leading space, no unit, finite.
template <class T>
bool parse_strict(const std::string& text, T& value) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return false;
  if constexpr (std::is_integral_v<T>) {
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    return ec == std::errc() && ptr == end;
  } else {
    char* end = nullptr;
    errno = 0;
    value = static_cast<T>(std::strtod(text.c_str(), &end));
    return end == text.c_str() + text.size() && errno == 0 && std::isfinite(value);
  }
}

template <class T>
const char* number_kind() {
  return std::is_integral_v<T> ? "a whole number" : "a number";
}

}  // namespace detail

// A strict number option: the whole text a number of T (no "2px", no "-1" for a count), within
// [lo, hi]; the message names the range in the option's own words (`wants`).
template <class T>
CLI::Validator strict_number(T lo, T hi, const std::string& wants) {
  return CLI::Validator(
      [lo, hi, wants](std::string& text) -> std::string {
        T value{};
        if (!detail::parse_strict(text, value))
          return "'" + text + "' is not " + detail::number_kind<T>() + "; it wants " + wants;
        if (value < lo || value > hi) return "it wants " + wants + ", got " + text;
        return std::string();
      },
      "", "strict_number");
}

// Two numbers of T in one word, "<first><separator><second>" (a size 640x480, an offset 10.5,-3),
// or nothing when `text` is not that, strictly as strict_number reads each.
template <class T>
std::optional<std::pair<T, T>> parse_pair(const std::string& text, char separator) {
  const std::size_t at = text.find(separator);
  if (at == std::string::npos) return std::nullopt;
  std::pair<T, T> value;
  if (!detail::parse_strict(text.substr(0, at), value.first) || !detail::parse_strict(text.substr(at + 1), value.second))
    return std::nullopt;
  return value;
}

// A strict pair option, e.g. --tile WxH: two numbers of T written as `form` says (its letters
// joined by `separator`, e.g. "WxH"), each within [lo, hi]; the message names the form and the range
// in the option's own words (`wants`).
template <class T>
CLI::Validator strict_pair(T lo, T hi, char separator, const std::string& form, const std::string& wants) {
  return CLI::Validator(
      [lo, hi, separator, form, wants](std::string& text) -> std::string {
        const std::optional<std::pair<T, T>> value = parse_pair<T>(text, separator);
        if (!value)
          return "'" + text + "' is not " + form + " (two " + (std::is_integral_v<T> ? "whole " : "") +
                 "numbers joined by '" + separator + "'); it wants " + wants;
        if (value->first < lo || value->first > hi || value->second < lo || value->second > hi)
          return "it wants " + wants + ", got " + text;
        return std::string();
      },
      "", "strict_pair");
}

// Adds a strict pair option (strict_pair) that stores its two numbers into `value` once parsed;
// `value` keeps what it held when the option is not given.
template <class T>
CLI::Option* add_pair_option(CLI::App& app, const std::string& name, std::pair<T, T>& value, T lo, T hi, char separator,
                             const std::string& form, const std::string& wants, const std::string& description) {
  return app
      .add_option_function<std::string>(
          name, [&value, separator](const std::string& text) { value = *parse_pair<T>(text, separator); },
          description)
      ->check(strict_pair<T>(lo, hi, separator, form, wants))
      ->type_name(form);
}

// Parses the command line into `app`: nullopt to go on, or the exit status to return at once (0
// after printing the help; `failure` after printing the error on one line with a hint to --help).
inline std::optional<int> parse_options(CLI::App& app, int argc, char** argv, int failure) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) {
      std::fputs(app.help().c_str(), stdout);
      return 0;
    }
    std::fprintf(stderr, "%s: %s\n(%s --help lists the options)\n", app.get_name().c_str(), e.what(),
                 app.get_name().c_str());
    return failure;
  }
  return std::nullopt;
}

// The message of an exception for the people who run a program: diachron::Error's message()
// (without the library's internal condition), or its what() when `verbose` (for bug reports).
inline std::string error_text(const std::exception& e, bool verbose) {
  const auto* error = dynamic_cast<const Error*>(&e);
  return error && !verbose ? error->message() : std::string(e.what());
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
