#pragma once
/// @file
/// Memory of the process (current and peak resident set size) and byte sizes as people write them:
/// parse_byte_size("8G") for options, format_bytes(n) for reports.

#include <cctype>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

#include <diachron/core/error.hpp>

namespace diachron {

/// Resident set size of this process now, bytes (VmRSS of /proc/self/status); nullopt where it
/// cannot be read (not Linux).
inline std::optional<std::size_t> current_resident_bytes();

/// The largest resident set size of this process so far, bytes (VmHWM of /proc/self/status);
/// nullopt where it cannot be read (not Linux).
inline std::optional<std::size_t> peak_resident_bytes();

/// Bytes written as a whole or decimal number and an optional unit, e.g. "1000000", "512M",
/// "1.5GiB", "8 GB". Units, as GNU coreutils reads them (dd, head, sort -S):
///   B (or none) = 1;  K, KiB = 1024;  M, MiB = 1024^2;  G, GiB = 1024^3;  T, TiB = 1024^4;
///   P, PiB = 1024^5;  E, EiB = 1024^6;  kB, KB = 1000;  MB = 1000^2;  GB = 1000^3;  TB = 1000^4;
///   PB = 1000^5;  EB = 1000^6.
/// So "8G" is 8 GiB (as Slurm's --mem=8G). Blanks around the text and between number and unit are
/// allowed; a fraction is rounded to the nearest byte ("0.1K" = 102).
/// @throws diachron::Error naming the text when it is empty, negative, not a number with one of
///   these units ("1e9", "0x10", ".5G", "5.", "8 GiBs"), has more than 9 decimals, or exceeds
///   std::size_t.
inline std::size_t parse_byte_size(const std::string& text);

/// `bytes` for people: three significant digits in decimal units, "512 B", "1.76 GB", "17.6 GB",
/// "176 GB" (units B, kB, MB, GB, TB, PB, EB). parse_byte_size reads it back to within 0.5 %.
inline std::string format_bytes(std::size_t bytes);

// Implementation ---------------------------------------------------------------------------------

namespace detail {

/// The value of a "Name:   123 kB" line of /proc/<pid>/status text, in bytes; nullopt when the
/// field is missing or not in kB.
inline std::optional<std::size_t> proc_status_bytes(const std::string& status, const std::string& field) {
  std::istringstream lines(status);
  std::string line;
  const std::string prefix = field + ":";
  while (std::getline(lines, line)) {
    if (line.compare(0, prefix.size(), prefix) != 0) continue;
    std::istringstream rest(line.substr(prefix.size()));
    unsigned long long kib = 0;
    std::string unit;
    if (!(rest >> kib >> unit) || unit != "kB") return std::nullopt;
    if (kib > std::numeric_limits<std::size_t>::max() / 1024) return std::nullopt;
    return static_cast<std::size_t>(kib) * 1024;
  }
  return std::nullopt;
}

inline std::optional<std::size_t> self_status_bytes(const char* field) {
  std::ifstream in("/proc/self/status");
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return proc_status_bytes(text.str(), field);
}

}  // namespace detail

inline std::optional<std::size_t> current_resident_bytes() { return detail::self_status_bytes("VmRSS"); }

inline std::optional<std::size_t> peak_resident_bytes() { return detail::self_status_bytes("VmHWM"); }

inline std::size_t parse_byte_size(const std::string& text) {
  constexpr std::uint64_t kMax = std::numeric_limits<std::size_t>::max() < std::numeric_limits<std::uint64_t>::max()
                                     ? std::numeric_limits<std::size_t>::max()
                                     : std::numeric_limits<std::uint64_t>::max();
  const auto blank = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  std::size_t i = 0;
  std::size_t end = text.size();
  while (i < end && blank(text[i])) ++i;
  while (end > i && blank(text[end - 1])) --end;
  DIACHRON_CHECK(i < end, "a byte size is a number with an optional unit (e.g. 512M, 1.5GiB), got '" << text << "'");
  // The whole part.
  std::uint64_t whole = 0;
  const std::size_t whole_begin = i;
  for (; i < end && digit(text[i]); ++i) {
    const std::uint64_t d = static_cast<std::uint64_t>(text[i] - '0');
    DIACHRON_CHECK(whole <= (kMax - d) / 10, "the byte size '" << text << "' is too large");
    whole = whole * 10 + d;
  }
  DIACHRON_CHECK(i > whole_begin, "a byte size starts with a digit (e.g. 512M, 0.5G), got '" << text << "'");
  // The fraction: at most 9 decimals, so that its products below fit 64 bits.
  std::uint64_t fraction = 0;
  std::uint64_t scale = 1;
  if (i < end && text[i] == '.') {
    ++i;
    const std::size_t fraction_begin = i;
    for (; i < end && digit(text[i]); ++i) {
      DIACHRON_CHECK(i - fraction_begin < 9, "the byte size '" << text << "' has more than 9 decimals");
      fraction = fraction * 10 + static_cast<std::uint64_t>(text[i] - '0');
      scale *= 10;
    }
    DIACHRON_CHECK(i > fraction_begin, "a decimal point in a byte size needs digits after it, got '" << text << "'");
  }
  while (i < end && blank(text[i])) ++i;
  const std::string unit = text.substr(i, end - i);
  std::uint64_t multiplier = 0;
  const std::uint64_t kKi = 1024, kK = 1000;
  if (unit.empty() || unit == "B") multiplier = 1;
  else if (unit == "K" || unit == "KiB") multiplier = kKi;
  else if (unit == "M" || unit == "MiB") multiplier = kKi * kKi;
  else if (unit == "G" || unit == "GiB") multiplier = kKi * kKi * kKi;
  else if (unit == "T" || unit == "TiB") multiplier = kKi * kKi * kKi * kKi;
  else if (unit == "kB" || unit == "KB") multiplier = kK;
  else if (unit == "MB") multiplier = kK * kK;
  else if (unit == "GB") multiplier = kK * kK * kK;
  else if (unit == "TB") multiplier = kK * kK * kK * kK;
  else if (unit == "P" || unit == "PiB") multiplier = kKi * kKi * kKi * kKi * kKi;
  else if (unit == "PB") multiplier = kK * kK * kK * kK * kK;
  else if (unit == "E" || unit == "EiB") multiplier = kKi * kKi * kKi * kKi * kKi * kKi;
  else if (unit == "EB") multiplier = kK * kK * kK * kK * kK * kK;
  DIACHRON_CHECK(multiplier != 0, "unknown unit '" << unit << "' in the byte size '" << text
                                                   << "' (B, K, M, G, T, P, E, KiB ... EiB, kB, MB ... EB)");
  DIACHRON_CHECK(whole <= kMax / multiplier, "the byte size '" << text << "' is too large");
  std::uint64_t bytes = whole * multiplier;
  if (fraction > 0) {
    // fraction * multiplier / scale, rounded, without overflow: multiplier = q * scale + r.
    const std::uint64_t q = multiplier / scale, r = multiplier % scale;
    const std::uint64_t low = r * fraction;  // < 1e9 * 1e9
    std::uint64_t part = q * fraction + low / scale;
    if (2 * (low % scale) >= scale) ++part;
    DIACHRON_CHECK(bytes <= kMax - part, "the byte size '" << text << "' is too large");
    bytes += part;
  }
  return static_cast<std::size_t>(bytes);
}

inline std::string format_bytes(std::size_t bytes) {
  static const char* const kUnits[] = {"B", "kB", "MB", "GB", "TB", "PB", "EB"};
  if (bytes < 1000) return std::to_string(bytes) + " B";
  double value = static_cast<double>(bytes);
  int unit = 0;
  while (value >= 999.5 && unit < 6) {  // 999.5 kB would print as "1000 kB": take the next unit
    value /= 1000.0;
    ++unit;
  }
  char out[32];
  const int decimals = value < 9.995 ? 2 : value < 99.95 ? 1 : 0;
  std::snprintf(out, sizeof out, "%.*f %s", decimals, value, kUnits[unit]);
  return out;
}

}  // namespace diachron
