#pragma once
/// @file
/// Shared pieces of the benchmarks that score matches with the truth of a synthetic scene
/// (eval/match_truth.hpp): counts per error threshold, medians, a stopwatch, list arguments, finer
/// scans of a scene's epochs.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <diachron/eval/match_truth.hpp>
#include <diachron/synth/epoch.hpp>
#include <diachron/terrain/local_relief.hpp>

namespace diachron::bench {

/// The relief of `dsm` around a ground point (the transfer's master_point or secondary_point of a
/// match, nullopt when it has none): the plane-fit RMS over a disc of `radius_px` image px, in the
/// image's GSD `gsd` (metres or DSM units per px). NaN where it cannot be measured.
template <class Point>
double relief_gsd(const Dsm& dsm, const std::optional<Point>& ground, double radius_px, double gsd) {
  if (!ground) return std::nan("");
  const LocalRelief lr = local_relief(dsm, ground->template head<2>(), radius_px * gsd);
  return lr.valid ? lr.rms / gsd : std::nan("");
}

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// The non-empty items of a comma-separated command-line list ("a,b,,c" -> a, b, c).
inline std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

/// An epoch's images `k` times larger on the same footprints (focal length times k, GSD divided by k),
/// as a finer scan of the same photographs; its DSM keeps its cell of `dsm.cell_gsd` GSD.
inline void scale_images(EpochOptions& epoch, double k) {
  epoch.focal_px *= k;
  epoch.image_width_px = static_cast<int>(std::lround(epoch.image_width_px * k));
  epoch.image_height_px = static_cast<int>(std::lround(epoch.image_height_px * k));
}

/// Median of `v` (the mean of the two middle values for an even count); NaN when empty.
inline double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Counts of a set of matches scored against the truth. A match whose epoch-1 point is off the
/// epoch-2 image or hidden there is decidably wrong; one on a surface that changed between the
/// epochs cannot be decided, and is left out of the shares (counted as unscorable).
struct Scored {
  std::size_t matches = 0, scored = 0;
  std::size_t within[4] = {0, 0, 0, 0};  // 1, 3, 6, 10 px
  static constexpr double kThresholds[4] = {1.0, 3.0, 6.0, 10.0};
  std::vector<double> errors;  // px, of the matches the truth could score

  void add(const MatchTruth& t) {
    ++matches;
    if (t.status == MatchTruthStatus::off_image || t.status == MatchTruthStatus::occluded) ++scored;
    if (!t.scored()) return;
    ++scored;
    errors.push_back(t.error_px);
    for (int k = 0; k < 4; ++k)
      if (t.error_px < kThresholds[k]) ++within[k];
  }
  void add(const Scored& o) {
    matches += o.matches;
    scored += o.scored;
    for (int k = 0; k < 4; ++k) within[k] += o.within[k];
    errors.insert(errors.end(), o.errors.begin(), o.errors.end());
  }
  /// Share (%) of the decidable matches within kThresholds[k].
  double share(int k) const {
    return scored ? 100.0 * static_cast<double>(within[k]) / static_cast<double>(scored) : std::nan("");
  }
};

}  // namespace diachron::bench
