#pragma once
/// @file
/// Quarter-turn rotation hypotheses (paper 3.2.1, MicMac's `Rotate=-1`): matchers are not invariant
/// to rotations beyond about 45 degrees, so the secondary image is rotated by 0, 90, 180 and 270
/// degrees, matched under each rotation, the matches mapped back to the unrotated secondary, and the
/// hypothesis whose 2D similarity RANSAC has the most inliers wins.
///
/// Direction and coordinates. Rotations are clockwise as seen on screen (x right, y down), i.e.
/// from +x towards +y, the same sense as angles in the library. A W x H raster rotated by k quarter
/// turns has size H x W for odd k. With the pixel-centre convention (pixel i covers
/// [i - 0.5, i + 0.5)), the point p = (x, y) of the original is found at p' in the rotated raster:
///   k = 1 (90 deg):  p' = (H - 1 - y, x)          inverse: p = (y', H - 1 - x')
///   k = 2 (180 deg): p' = (W - 1 - x, H - 1 - y)  inverse: p = (W - 1 - x', H - 1 - y')
///   k = 3 (270 deg): p' = (y, W - 1 - x)          inverse: p = (W - 1 - y', x')
/// These maps are exact for integer pixels and continuous points alike. MicMac's back-mapping
/// homographies use W and H where these use W - 1 and H - 1 (a one-pixel shift, harmless under its
/// 10 px RANSAC threshold); here the raster rotation and the point maps agree exactly.

#include <array>
#include <chrono>
#include <cstddef>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/similarity2.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/robust/ransac_options.hpp>
#include <diachron/robust/ransac_report.hpp>
#include <diachron/robust/robust_estimation.hpp>

namespace diachron {

namespace detail {
inline int normalize_quarter_turns(int quarter_turns) { return ((quarter_turns % 4) + 4) % 4; }
}  // namespace detail

/// `raster` rotated clockwise by `quarter_turns` x 90 degrees (any integer; taken modulo 4, so -1
/// is 270 degrees). Exact: pixels are moved, never resampled. Size H x W for odd turns.
template <class T>
Raster<T> rotate_quarter_turns(const Raster<T>& raster, int quarter_turns) {
  const int k = detail::normalize_quarter_turns(quarter_turns);
  const int w = raster.width(), h = raster.height();
  if (k == 0) return raster;
  Raster<T> out(k == 2 ? w : h, k == 2 ? h : w);
  // Walk the output and fetch through the inverse map: every output pixel is written once.
  for (int yr = 0; yr < out.height(); ++yr) {
    T* dst = out.row(yr);
    for (int xr = 0; xr < out.width(); ++xr) {
      int x, y;
      if (k == 1) {
        x = yr;
        y = h - 1 - xr;
      } else if (k == 2) {
        x = w - 1 - xr;
        y = h - 1 - yr;
      } else {
        x = w - 1 - yr;
        y = xr;
      }
      dst[xr] = raster(x, y);
    }
  }
  return out;
}

/// Where the point `p` of an unrotated `width` x `height` raster lands in that raster rotated
/// clockwise by `quarter_turns` (see the file comment for the maps). Pixels, pixel-centre convention.
inline Eigen::Vector2d rotate_point_quarter_turns(const Eigen::Vector2d& p, int quarter_turns, int width,
                                                  int height) {
  const double wm = width - 1.0, hm = height - 1.0;
  switch (detail::normalize_quarter_turns(quarter_turns)) {
    case 1:
      return {hm - p.y(), p.x()};
    case 2:
      return {wm - p.x(), hm - p.y()};
    case 3:
      return {p.y(), wm - p.x()};
    default:
      return p;
  }
}

/// Inverse of rotate_point_quarter_turns: the point of the unrotated `width` x `height` raster
/// (its size before rotation) that is at `p_rotated` in the rotated raster.
inline Eigen::Vector2d unrotate_point_quarter_turns(const Eigen::Vector2d& p_rotated, int quarter_turns,
                                                    int width, int height) {
  const double wm = width - 1.0, hm = height - 1.0;
  switch (detail::normalize_quarter_turns(quarter_turns)) {
    case 1:
      return {p_rotated.y(), hm - p_rotated.x()};
    case 2:
      return {wm - p_rotated.x(), hm - p_rotated.y()};
    case 3:
      return {wm - p_rotated.y(), p_rotated.x()};
    default:
      return p_rotated;
  }
}

/// rotate_point_quarter_turns as a Similarity2 (scale 1, angle k * pi / 2), for composing with
/// estimated transforms: rotated px = quarter_turn_similarity(k, W, H)(unrotated px).
inline Similarity2 quarter_turn_similarity(int quarter_turns, int width, int height) {
  const int k = detail::normalize_quarter_turns(quarter_turns);
  Similarity2 s = Similarity2::identity();
  const double wm = width - 1.0, hm = height - 1.0;
  // angle 0, pi/2, pi, -pi/2 (the library's wrapped range); translation = image of the origin.
  const double angles[4] = {0.0, 0.5 * kPi, kPi, -0.5 * kPi};
  const Eigen::Vector2d origins[4] = {{0.0, 0.0}, {hm, 0.0}, {wm, hm}, {0.0, wm}};
  s.angle = angles[k];
  s.translation = origins[k];
  return s;
}

/// Options of match_with_rotation_hypotheses.
struct RotationHypothesesOptions {
  /// 2D similarity RANSAC per hypothesis (master px -> secondary px). Default: the paper's and
  /// MicMac's 10 px threshold and 1000 iterations.
  RansacOptions ransac = [] {
    RansacOptions o;
    o.threshold = 10.0;
    o.max_iterations = 1000;
    return o;
  }();
  /// Clockwise rotations of the secondary image to try, in degrees, each one of 0, 90, 180, 270,
  /// no repeats, at least one. Ties in inlier count go to the earlier entry.
  std::vector<int> rotations_deg{0, 90, 180, 270};

  void check() const {
    ransac.check();
    DIACHRON_CHECK(!rotations_deg.empty(), "rotations_deg is empty: give at least one rotation");
    std::array<bool, 4> seen{};
    for (int deg : rotations_deg) {
      DIACHRON_CHECK(deg == 0 || deg == 90 || deg == 180 || deg == 270,
                     "rotations_deg entries must be 0, 90, 180 or 270, got " << deg);
      DIACHRON_CHECK(!seen[static_cast<std::size_t>(deg / 90)], "rotation " << deg << " given twice");
      seen[static_cast<std::size_t>(deg / 90)] = true;
    }
  }
};

/// The outcome of one rotation hypothesis.
struct RotationHypothesisResult {
  int rotation_deg = 0;         ///< clockwise rotation applied to the secondary image, degrees
  std::size_t matches = 0;      ///< tentative matches the match function returned
  std::size_t inliers = 0;      ///< RANSAC inliers (0 when RANSAC failed)
  std::size_t iterations = 0;   ///< RANSAC iterations run
  bool ransac_success = false;  ///< whether RANSAC found a model
  double rms = 0.0;             ///< rms of inlier residuals, px (+inf without inliers)
  /// master px -> unrotated secondary px (meaningful when ransac_success).
  Similarity2 similarity = Similarity2::identity();
  std::string message;  ///< RANSAC's message when it failed
};

/// What match_with_rotation_hypotheses found. `success` is false when no hypothesis gave a model;
/// then `message` says why and the winner fields keep their defaults.
struct RotationHypothesesReport {
  bool success = false;
  std::string message = "not run";
  /// One entry per tried rotation, in RotationHypothesesOptions::rotations_deg order.
  std::vector<RotationHypothesisResult> hypotheses;
  int best_rotation_deg = -1;  ///< the winner's clockwise rotation, -1 when none won
  /// The winner's similarity: secondary px (unrotated) = similarity(master px).
  Similarity2 similarity = Similarity2::identity();
  std::size_t best_matches = 0;    ///< the winner's tentative match count
  PointMatches matches;            ///< the winner's matches, b in unrotated secondary px
  std::vector<std::size_t> inliers;  ///< indices into `matches` of the RANSAC inliers, increasing
  PointMatches inlier_matches;     ///< the inlier matches themselves
  double seconds_matching = 0.0;   ///< wall-clock time in the match function, all hypotheses
  double seconds_ransac = 0.0;     ///< wall-clock time in RANSAC, all hypotheses

  /// Inlier counts indexed by quarter turns (0, 90, 180, 270 degrees); -1 for rotations not tried.
  std::array<long long, 4> inlier_counts() const {
    std::array<long long, 4> out{-1, -1, -1, -1};
    for (const auto& h : hypotheses) out[static_cast<std::size_t>(h.rotation_deg / 90)] = static_cast<long long>(h.inliers);
    return out;
  }
  /// Match counts indexed by quarter turns; -1 for rotations not tried.
  std::array<long long, 4> match_counts() const {
    std::array<long long, 4> out{-1, -1, -1, -1};
    for (const auto& h : hypotheses) out[static_cast<std::size_t>(h.rotation_deg / 90)] = static_cast<long long>(h.matches);
    return out;
  }
};

namespace detail {
inline double seconds_between(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}
}  // namespace detail

/// Runs `match_fn` on `master` and each clockwise rotation of `secondary`, maps the matches back to
/// the unrotated secondary, fits a 2D similarity (master px -> secondary px) with
/// ransac_similarity2 on each, and keeps the hypothesis with the most inliers.
/// @param match_fn callable as `match_fn(master, rotated_secondary, rotation_deg)` or
///        `match_fn(master, rotated_secondary)`, returning a std::vector<PointMatch> with a in
///        master px and b in rotated-secondary px; typically a lambda around match_one_to_many.
///        Called once per hypothesis, in order, from the calling thread.
/// Throws diachron::Error for invalid options or empty images; rethrows what match_fn throws.
template <class T, class MatchFn>
RotationHypothesesReport match_with_rotation_hypotheses(const Raster<T>& master, const Raster<T>& secondary,
                                                        MatchFn&& match_fn,
                                                        const RotationHypothesesOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!master.empty(), "master image is empty");
  DIACHRON_CHECK(!secondary.empty(), "secondary image is empty");
  using Clock = std::chrono::steady_clock;

  RotationHypothesesReport report;
  std::vector<PointMatches> hypothesis_matches;
  std::vector<std::vector<std::size_t>> hypothesis_inliers;
  for (int deg : options.rotations_deg) {
    const int k = deg / 90;
    const auto t0 = Clock::now();
    const Raster<T> rotated = rotate_quarter_turns(secondary, k);
    PointMatches matches;
    if constexpr (std::is_invocable_v<MatchFn&, const Raster<T>&, const Raster<T>&, int>)
      matches = match_fn(master, rotated, deg);
    else
      matches = match_fn(master, rotated);
    for (PointMatch& m : matches) m.b = unrotate_point_quarter_turns(m.b, k, secondary.width(), secondary.height());
    const auto t1 = Clock::now();

    std::vector<PointPair2> pairs;
    pairs.reserve(matches.size());
    for (const PointMatch& m : matches) pairs.push_back(PointPair2{m.a, m.b});
    const RansacReport<Similarity2> ransac = ransac_similarity2(pairs, options.ransac);
    const auto t2 = Clock::now();
    report.seconds_matching += detail::seconds_between(t0, t1);
    report.seconds_ransac += detail::seconds_between(t1, t2);

    RotationHypothesisResult h;
    h.rotation_deg = deg;
    h.matches = matches.size();
    h.iterations = ransac.iterations;
    h.ransac_success = ransac.success;
    h.rms = ransac.rms;
    if (ransac.success) {
      h.inliers = ransac.inliers.size();
      h.similarity = ransac.model;
    } else {
      h.message = ransac.message;
    }
    report.hypotheses.push_back(h);
    hypothesis_matches.push_back(std::move(matches));
    hypothesis_inliers.push_back(ransac.success ? ransac.inliers : std::vector<std::size_t>{});
  }

  std::size_t best = report.hypotheses.size();
  for (std::size_t i = 0; i < report.hypotheses.size(); ++i) {
    const auto& h = report.hypotheses[i];
    if (!h.ransac_success) continue;
    if (best == report.hypotheses.size() || h.inliers > report.hypotheses[best].inliers) best = i;
  }
  if (best == report.hypotheses.size()) {
    std::string why = "no rotation hypothesis gave a similarity:";
    for (const auto& h : report.hypotheses)
      why += " " + std::to_string(h.rotation_deg) + " deg (" + std::to_string(h.matches) + " matches): " + h.message + ";";
    why.pop_back();
    report.message = why;
    return report;
  }
  const RotationHypothesisResult& w = report.hypotheses[best];
  report.success = true;
  report.best_rotation_deg = w.rotation_deg;
  report.similarity = w.similarity;
  report.best_matches = w.matches;
  report.matches = std::move(hypothesis_matches[best]);
  report.inliers = std::move(hypothesis_inliers[best]);
  report.inlier_matches.reserve(report.inliers.size());
  for (std::size_t i : report.inliers) report.inlier_matches.push_back(report.matches[i]);
  report.message = "";
  return report;
}

/// The same with the RANSAC options and the rotations (clockwise degrees) given directly.
template <class T, class MatchFn>
RotationHypothesesReport match_with_rotation_hypotheses(const Raster<T>& master, const Raster<T>& secondary,
                                                        MatchFn&& match_fn, const RansacOptions& ransac_options,
                                                        const std::vector<int>& rotations_deg = {0, 90, 180, 270}) {
  RotationHypothesesOptions options;
  options.ransac = ransac_options;
  options.rotations_deg = rotations_deg;
  return match_with_rotation_hypotheses(master, secondary, std::forward<MatchFn>(match_fn), options);
}

}  // namespace diachron
