#pragma once
/// @file
/// The one error type of the library and the check macro that raises it.
///
/// Two channels (docs/conventions.md): invalid input at an API boundary throws `diachron::Error`;
/// "no answer exists" is reported in a result (`success == false`, `std::nullopt`), never thrown.

#include <sstream>
#include <stdexcept>
#include <string>

namespace diachron {

/// Thrown for invalid input at an API boundary: the message says what is wrong and where.
/// Derives from std::invalid_argument so callers that already catch that keep working.
/// what() is for developers: "diachron: <message> [in <function>: <condition>]" from
/// DIACHRON_CHECK. message() is for the people a program shows it to: the message alone, without
/// the "diachron: " prefix nor the internal condition.
class Error : public std::invalid_argument {
 public:
  explicit Error(const std::string& what) : std::invalid_argument(what), message_(strip_prefix(what)) {}
  Error(const std::string& what, const std::string& message) : std::invalid_argument(what), message_(message) {}

  /// The message without the library's prefix and internal condition.
  const std::string& message() const noexcept { return message_; }

 private:
  static std::string strip_prefix(const std::string& what) {
    const std::string prefix = "diachron: ";
    return what.compare(0, prefix.size(), prefix) == 0 ? what.substr(prefix.size()) : what;
  }
  std::string message_;
};

namespace detail {

[[noreturn]] inline void throw_check_failure(const char* condition, const char* function,
                                             const std::string& message) {
  std::ostringstream out;
  out << "diachron: " << message << " [in " << function << ": " << condition << "]";
  throw Error(out.str(), message);
}

}  // namespace detail
}  // namespace diachron

/// Precondition check: throws diachron::Error naming the function, the condition and a message.
/// `message` is a stream expression, e.g. DIACHRON_CHECK(n > 0, "empty raster " << name).
#define DIACHRON_CHECK(condition, message)                                          \
  do {                                                                              \
    if (!(condition)) {                                                             \
      std::ostringstream diachron_check_stream_;                                    \
      diachron_check_stream_ << message;                                            \
      ::diachron::detail::throw_check_failure(#condition, __func__,                 \
                                              diachron_check_stream_.str());        \
    }                                                                               \
  } while (false)
