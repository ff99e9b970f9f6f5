#pragma once
/// @file
/// The ground filter of precise matching (paper 3.2.2 (2)): both keypoints of every match are
/// lifted to 3D, master and secondary in one frame, and a 3D Helmert RANSAC (1000 iterations,
/// 10 x the secondary image's GSD) keeps the matches whose 3D points agree.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/robust/ransac_options.hpp>
#include <diachron/robust/robust_estimation.hpp>
#include <diachron/validation/match_filter.hpp>

namespace diachron {

/// @name Requirements for Lift
/// A Lift is an object `l` with
///   `std::optional<Eigen::Vector3d> l(const Eigen::Vector2d& px) const`
/// that gives the 3D point an image pixel sees, or nullopt (off the DSM, a hole, no ray). It must be
/// safe to call concurrently. Models: DsmLift (terrain/transfer.hpp), a lambda around
/// DsmTransfer::secondary_point (master pixel -> master DSM -> Helmert epoch 1 -> epoch 2).
/// @{
namespace detail {
template <class L, class = void>
struct is_lift : std::false_type {};
template <class L>
struct is_lift<L, std::void_t<decltype(std::declval<const L&>()(std::declval<const Eigen::Vector2d&>()))>>
    : std::is_same<std::decay_t<decltype(std::declval<const L&>()(std::declval<const Eigen::Vector2d&>()))>,
                   std::optional<Eigen::Vector3d>> {};
}  // namespace detail

/// True when L satisfies the Lift requirements (the call returns exactly optional<Vector3d>).
template <class L>
inline constexpr bool is_lift_v = detail::is_lift<L>::value;
/// @}

/// Options of ground_filter(). Defaults are the paper's and MicMac's (R3D: 3DIter = 1000,
/// 3DRANTh = 10 x GSD2, MinPt = 10).
struct GroundFilterOptions {
  /// Inlier threshold in multiples of the secondary image's GSD (dimensionless, finite, > 0): a
  /// match is kept when its 3D residual is at most max(`threshold_gsd * secondary_gsd`, `min_threshold`).
  double threshold_gsd = 10.0;
  /// Least inlier threshold, secondary-frame units (finite, >= 0; 0 = none): for matches whose
  /// precision the secondary GSD does not set, e.g. correlation matches against a much finer
  /// secondary image (precise matching puts 1.5 master GSD here), or DSMs whose errors are known.
  double min_threshold = 0.0;
  /// Fewest matches lifted on both sides for a verdict, >= 4 (one more than a Helmert's minimal
  /// sample, so that one model is tested by at least one other pair). Below it the result has
  /// success == false and keeps nothing, as MicMac writes no tie points for such a pair.
  std::size_t min_pairs = 10;
  /// The RANSAC (robust/ransac_options.hpp). `threshold` is ignored: it is set from threshold_gsd.
  /// Default: the paper's exactly 1000 iterations (confidence 1 never stops early), seed 0.
  /// A lower confidence lets the adaptive rule stop early.
  RansacOptions ransac = paper_ransac_options();
  /// Threads for lifting the keypoints (0 = all cores). The result does not depend on it.
  std::size_t threads = 1;

  /// 1000 iterations, never stopping early, seed 0.
  static RansacOptions paper_ransac_options() {
    RansacOptions options;
    options.max_iterations = 1000;
    options.confidence = 1.0;
    options.seed = 0;
    return options;
  }

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    DIACHRON_CHECK(std::isfinite(threshold_gsd) && threshold_gsd > 0.0,
                   "GroundFilterOptions::threshold_gsd must be finite and > 0, got " << threshold_gsd);
    DIACHRON_CHECK(std::isfinite(min_threshold) && min_threshold >= 0.0,
                   "GroundFilterOptions::min_threshold must be finite and >= 0, got " << min_threshold);
    DIACHRON_CHECK(min_pairs >= 4, "GroundFilterOptions::min_pairs must be >= 4, got " << min_pairs);
    RansacOptions r = ransac;
    r.threshold = 1.0;  // replaced by the GSD threshold, so its own value does not matter
    r.check();
  }
};

/// What ground_filter() returns. Index-aligned with the input matches (MatchFilterResult): `score[i]`
/// is match i's 3D residual |model(P_master) - P_secondary| in secondary-frame units (metres), NaN
/// when either keypoint did not lift or there is no model; `keep[i]` is 1 for the inliers.
/// A default-constructed result means failure.
struct GroundFilterResult : MatchFilterResult {
  /// True when the RANSAC ran on at least min_pairs lifted matches and found a supported model.
  bool success = false;
  /// Why there is no verdict (empty on success).
  std::string message = "not run";
  /// Matches whose two keypoints both lifted to a finite 3D point (the RANSAC's data).
  std::size_t lifted = 0;
  /// Matches whose master keypoint did not lift; of the others, those whose secondary one did not.
  std::size_t master_not_lifted = 0;
  std::size_t secondary_not_lifted = 0;
  /// The Helmert that moves the lifted master points (already in the secondary frame) onto the
  /// secondary points, in uncentred secondary-frame coordinates: the correction to the Helmert the
  /// master lift went through. Identity when there is none.
  Helmert3 model = Helmert3::identity();
  /// The inlier threshold used, secondary-frame units: max(threshold_gsd x secondary_gsd, min_threshold).
  double threshold = std::numeric_limits<double>::quiet_NaN();
  /// RMS of the kept matches' residuals, secondary-frame units; +inf without a model.
  double rms = std::numeric_limits<double>::infinity();
  /// RANSAC iterations run (0 when it did not run).
  std::size_t iterations = 0;
};

/// The paper's ground filter. Each match's master keypoint goes through `master_lift` (which must
/// deliver points in the secondary epoch's frame: the master DSM then the Helmert epoch 1 -> 2) and
/// its secondary keypoint through `secondary_lift` (the secondary DSM); a 3D Helmert RANSAC
/// (ransac_helmert3, LO-MSAC with the options' iterations) runs on the pairs lifted on both sides
/// and the matches within max(`threshold_gsd * secondary_gsd`, `min_threshold`) of its model are
/// kept, each once (MicMac lists its 3 seeds twice; this does not).
///
/// Coordinates are centred on the lifted points' centroid before the solve, so UTM or ECEF frames
/// lose no precision; residuals and `model` are in the original frame. Deterministic: the same
/// seed gives the same result whatever `options.threads`.
///
/// @param matches         a = master pixel, b = secondary pixel (finite).
/// @param master_lift     a Lift (see is_lift_v) into the secondary frame.
/// @param secondary_lift  a Lift into the secondary frame.
/// @param secondary_gsd   the secondary image's GSD, secondary-frame units per pixel (finite, > 0),
///                        e.g. from gsd_at_height() (terrain/gsd.hpp).
/// @throws diachron::Error for invalid options, a non-positive GSD or a non-finite keypoint.
/// @return success == false with a message when fewer than options.min_pairs matches lift or
///         the RANSAC finds no model; then nothing is kept.
template <class MasterLift, class SecondaryLift>
GroundFilterResult ground_filter(const PointMatches& matches, const MasterLift& master_lift,
                                 const SecondaryLift& secondary_lift, double secondary_gsd,
                                 const GroundFilterOptions& options = {}) {
  static_assert(is_lift_v<MasterLift>,
                "ground_filter: MasterLift must have `std::optional<Eigen::Vector3d> operator()(const "
                "Eigen::Vector2d& px) const`");
  static_assert(is_lift_v<SecondaryLift>,
                "ground_filter: SecondaryLift must have `std::optional<Eigen::Vector3d> operator()(const "
                "Eigen::Vector2d& px) const`");
  options.check();
  DIACHRON_CHECK(std::isfinite(secondary_gsd) && secondary_gsd > 0.0,
                 "ground_filter: secondary_gsd must be finite and > 0, got " << secondary_gsd);
  for (std::size_t i = 0; i < matches.size(); ++i)
    DIACHRON_CHECK(matches[i].a.allFinite() && matches[i].b.allFinite(),
                   "ground_filter: match " << i << " has a non-finite keypoint");

  const std::size_t n = matches.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  GroundFilterResult result;
  result.keep.assign(n, 0);
  result.score.assign(n, nan);
  result.threshold = std::max(options.threshold_gsd * secondary_gsd, options.min_threshold);

  // 0 = lifted, 1 = master failed, 2 = secondary failed; one slot per match so threads never meet.
  std::vector<std::uint8_t> failure(n, 0);
  std::vector<Eigen::Vector3d> master_points(n), secondary_points(n);
  parallel_for(n, options.threads, [&](std::size_t i) {
    const std::optional<Eigen::Vector3d> p = master_lift(matches[i].a);
    if (!p || !p->allFinite()) {
      failure[i] = 1;
      return;
    }
    const std::optional<Eigen::Vector3d> q = secondary_lift(matches[i].b);
    if (!q || !q->allFinite()) {
      failure[i] = 2;
      return;
    }
    master_points[i] = *p;
    secondary_points[i] = *q;
  });

  std::vector<std::size_t> index;  // lifted match -> input index
  index.reserve(n);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    if (failure[i] == 1) ++result.master_not_lifted;
    if (failure[i] == 2) ++result.secondary_not_lifted;
    if (failure[i] != 0) continue;
    index.push_back(i);
    centre += secondary_points[i];
  }
  result.lifted = index.size();
  if (index.size() < options.min_pairs) {
    std::ostringstream why;
    why << "ground_filter: " << index.size() << " of " << n << " matches lifted on both sides, fewer than "
        << options.min_pairs;
    result.message = why.str();
    return result;
  }
  centre /= static_cast<double>(index.size());

  // Both point sets are in the secondary frame, so one centre serves both and residuals are unchanged.
  std::vector<PointPair3> pairs(index.size());
  for (std::size_t k = 0; k < index.size(); ++k)
    pairs[k] = PointPair3{master_points[index[k]] - centre, secondary_points[index[k]] - centre};

  RansacOptions ransac = options.ransac;
  ransac.threshold = result.threshold;
  const RansacReport<Helmert3> report = ransac_helmert3(pairs, ransac);
  result.iterations = report.iterations;
  if (!report.success) {
    result.message = "ground_filter: no Helmert found: " + report.message;
    return result;
  }

  // x2 - c = s R (x1 - c) + t  <=>  x2 = s R x1 + (t + c - s R c)
  result.model = report.model;
  result.model.translation = report.model.translation + centre - report.model.scale * (report.model.rotation * centre);

  // The report's mask, not a second threshold test here, decides: the two can never disagree.
  double sum_squares = 0.0;
  std::size_t kept = 0;
  for (std::size_t k = 0; k < index.size(); ++k) {
    const double r = (report.model(pairs[k].source) - pairs[k].target).norm();
    result.score[index[k]] = r;
    if (report.inlier_mask[k]) {
      result.keep[index[k]] = 1;
      sum_squares += r * r;
      ++kept;
    }
  }
  result.rms = std::sqrt(sum_squares / static_cast<double>(kept));
  result.success = true;
  result.message.clear();
  return result;
}

}  // namespace diachron
