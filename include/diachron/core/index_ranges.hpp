#pragma once
/// @file
/// Ranges of indices as people and job schedulers write them: "17", "0-99" (both ends included),
/// "0-3,7,9-12" for a list. Used for pair jobs (match_epochs run-pair --range, the missing pairs
/// merge names, Slurm array chunks). Standard library only.

#include <algorithm>
#include <cstddef>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <diachron/core/error.hpp>

namespace diachron {

/// An inclusive range of indices [first, last].
struct IndexRange {
  std::size_t first = 0;
  std::size_t last = 0;
  std::size_t size() const { return last - first + 1; }
  bool operator==(const IndexRange& o) const { return first == o.first && last == o.last; }
};

namespace detail {

inline std::size_t parse_index(const std::string& text, const std::string& whole) {
  DIACHRON_CHECK(!text.empty() && text.size() <= 18 && text.find_first_not_of("0123456789") == std::string::npos,
                 "'" << whole << "' is not an index range (I or A-B, whole numbers from 0)");
  return static_cast<std::size_t>(std::stoull(text));
}

}  // namespace detail

/// "I" -> [I, I]; "A-B" -> [A, B] with A <= B. Throws diachron::Error for anything else (signs,
/// spaces, B < A).
inline IndexRange parse_index_range(const std::string& text) {
  const std::size_t dash = text.find('-');
  if (dash == std::string::npos) {
    const std::size_t i = detail::parse_index(text, text);
    return {i, i};
  }
  const std::size_t a = detail::parse_index(text.substr(0, dash), text);
  const std::size_t b = detail::parse_index(text.substr(dash + 1), text);
  DIACHRON_CHECK(a <= b, "'" << text << "': the range ends before it starts");
  return {a, b};
}

/// The ranges of consecutive indices in `sorted` (ascending, no duplicates).
inline std::vector<IndexRange> index_ranges(const std::vector<std::size_t>& sorted) {
  std::vector<IndexRange> out;
  for (std::size_t i : sorted) {
    if (!out.empty() && out.back().last + 1 == i) out.back().last = i;
    else out.push_back({i, i});
  }
  return out;
}

/// "0-3,7,9-12": the ranges as text, at most `max_ranges` of them, then ",..." when there are more.
inline std::string index_ranges_text(const std::vector<IndexRange>& ranges,
                                     std::size_t max_ranges = std::numeric_limits<std::size_t>::max()) {
  std::string out;
  for (std::size_t k = 0; k < ranges.size(); ++k) {
    if (k == max_ranges) return out + ",...";
    out += (k ? "," : "") + std::to_string(ranges[k].first);
    if (ranges[k].last != ranges[k].first) out += "-" + std::to_string(ranges[k].last);
  }
  return out;
}

/// [0, count) cut into consecutive chunks of at most `chunk` indices (e.g. Slurm arrays below
/// MaxArraySize). `chunk` >= 1.
inline std::vector<IndexRange> index_chunks(std::size_t count, std::size_t chunk) {
  DIACHRON_CHECK(chunk >= 1, "index_chunks: chunks of at least one index");
  std::vector<IndexRange> out;
  for (std::size_t first = 0; first < count; first += chunk) out.push_back({first, std::min(count, first + chunk) - 1});
  return out;
}

}  // namespace diachron
