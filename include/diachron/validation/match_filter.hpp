#pragma once
/// @file
/// The one shape every match filter returns (the ground filter, the NCC validator, and users' own):
/// a verdict and a score per input match, in input order. A filter never drops a match silently, so
/// a pipeline report can count what each stage removed and a user can re-threshold the scores.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <diachron/core/error.hpp>

namespace diachron {

/// Per-match verdicts of a match filter, index-aligned with the matches it was given.
///
/// `keep[i]` is 1 when match i passes. `score[i]` is the filter's measure of match i in the unit
/// its filter documents (the ground filter: 3D residual in secondary-frame units; NCC: the
/// correlation in [-1, 1]); NaN when the filter could not measure it (no DSM point, a window
/// outside the image), and such a match is never kept. A default-constructed result holds no
/// verdict at all, which describes an empty input only.
struct MatchFilterResult {
  std::vector<std::uint8_t> keep;
  std::vector<double> score;

  /// Number of matches kept.
  std::size_t kept() const {
    std::size_t n = 0;
    for (std::uint8_t k : keep) n += k != 0;
    return n;
  }
  /// Number of matches given to the filter.
  std::size_t size() const { return keep.size(); }
};

/// The elements of `items` (matches, or anything index-aligned with them) that `result` keeps, in
/// their order. Throws diachron::Error when the sizes differ (a result of another match list).
template <class T>
std::vector<T> select_kept(const std::vector<T>& items, const MatchFilterResult& result) {
  DIACHRON_CHECK(items.size() == result.keep.size(),
                 "select_kept: " << items.size() << " items but the filter judged " << result.keep.size());
  std::vector<T> out;
  out.reserve(result.kept());
  for (std::size_t i = 0; i < items.size(); ++i)
    if (result.keep[i]) out.push_back(items[i]);
  return out;
}

}  // namespace diachron
