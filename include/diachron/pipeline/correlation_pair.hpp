#pragma once
/// @file
/// Correlation matching of one image pair as a composition (docs/two-image-matching.md): the
/// master's grid interest points (a cell sized from the image, a window's margin from the border,
/// off masked pixels), a first correlation pass around a Transfer's predictions, a refit of the
/// transfer on those matches, a second pass with a narrow search around the refitted transfer,
/// then a filter.
///
/// Two levels:
/// - the parts every correlation composition shares: effective_cell_px, correlation_points and
///   correlation_two_passes (any Transfer, any refit policy). precise_match_pair_correlation
///   (pipeline/precise_matching.hpp) composes them with the DSM transfer and the ground filter's
///   3D Helmert as its refit;
/// - correlation_match_pair: the composition for two images related by a 2D map (orthophotos, a
///   user's own SfM without DSMs): any 2D Transfer in, a similarity or a homography refitted by
///   RANSAC on the first pass, a second pass through it, the same RANSAC on the second pass as the
///   final filter.
///
/// Pixels follow docs/conventions.md; windows and searches are in master px, thresholds say theirs.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/geometry/similarity2.hpp>
#include <diachron/matching/correlation_matcher.hpp>
#include <diachron/matching/grid_interest_points.hpp>
#include <diachron/matching/image_mask.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/robust/ransac_options.hpp>
#include <diachron/robust/robust_estimation.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/transfer.hpp>

namespace diachron {

/// The side of the grid cell, master px, on a master image of width x height px: cell_px, or larger
/// so that the image has at most max_points_per_image cells (0: no bound), i.e.
/// max(cell_px, ceil(sqrt(width * height / max_points_per_image))).
/// @throws diachron::Error for an empty image.
inline int effective_cell_px(int cell_px, std::size_t max_points_per_image, int width, int height) {
  DIACHRON_CHECK(width > 0 && height > 0, "effective_cell_px: an empty image (" << width << " x " << height << ")");
  if (max_points_per_image == 0) return cell_px;
  const double area = static_cast<double>(width) * static_cast<double>(height);
  const double side = std::sqrt(area / static_cast<double>(max_points_per_image));
  // ceil, so that the bound holds; the small tolerance keeps an exact square from rounding up.
  return std::max(cell_px, static_cast<int>(std::ceil(side - 1e-9)));
}

/// The master points of correlation matching: grid_interest_points of `master` with `interest`
/// (its cell_px as given: see effective_cell_px), kept window_px / 2 + 2 px from the border at
/// least, so that a window of window_px master px fits whole around every point, and, when `mask`
/// is non-empty, only where that whole window is usable: a window reaching a masked pixel (a scan's
/// frame, a fiducial mark) would find its peak on it.
/// @throws diachron::Error for invalid options, a window_px < 1 or a mask of another size.
inline std::vector<Eigen::Vector2d> correlation_points(const Raster<std::uint8_t>& master,
                                                       GridInterestOptions interest, int window_px,
                                                       const ImageMask* mask = nullptr) {
  DIACHRON_CHECK(window_px >= 1, "correlation_points: window_px must be >= 1, got " << window_px);
  interest.border_px = std::max(interest.border_px, window_px / 2 + 2);
  const bool masked = mask && !mask->empty();
  if (masked) mask->check_size(master.width(), master.height(), "the master image");
  const Raster<std::uint8_t> allowed = masked ? mask->eroded(window_px / 2) : Raster<std::uint8_t>{};
  std::vector<Eigen::Vector2d> points;
  for (const InterestPoint& p : grid_interest_points(master, interest, masked ? &allowed : nullptr))
    points.push_back(p.position);
  return points;
}

/// What happened to the points of one correlation pass (correlation_match's verdicts).
struct CorrelationPassCounts {
  std::size_t matched = 0;  ///< matches correlation_match found (before the mask drop)
  std::size_t low_score = 0, ambiguous = 0, at_border = 0, outside_master = 0, outside_secondary = 0, flat = 0,
              no_prediction = 0;
  std::size_t masked = 0;  ///< of `matched`, dropped because their secondary window touches a masked pixel
  /// Peaks that passed in a pass whose matches chance explains (the pair test; then matched is 0).
  std::size_t chance = 0;
  /// The pass's score threshold and its pair test (whether adaptive, the null statistics, the points
  /// judged and passed, P(chance), rejected_as_chance), as correlation_match reported them.
  CorrelationThreshold threshold;

  /// The counts of `result`.
  static CorrelationPassCounts of(const CorrelationMatchResult& result) {
    CorrelationPassCounts c;
    c.chance = result.chance;
    c.threshold = result.threshold;
    c.matched = result.matches.size();
    c.low_score = result.low_score;
    c.ambiguous = result.ambiguous;
    c.at_border = result.at_border;
    c.outside_master = result.outside_master;
    c.outside_secondary = result.outside_secondary;
    c.flat = result.flat;
    c.no_prediction = result.no_prediction;
    return c;
  }

  /// "N matched, L low score, A ambiguous, B at the border, O outside the secondary, F flat, P
  /// without prediction (score >= S, adaptive)", and when the pair test refused the pass, "; C
  /// peaks refused as chance: R % of the judged points passed, as many as chance's bound of Q %".
  std::string describe() const {
    std::ostringstream text;
    text << matched << " matched, " << low_score << " low score, " << ambiguous << " ambiguous, " << at_border
         << " at the border, " << outside_secondary << " outside the secondary, " << flat << " flat, "
         << no_prediction << " without prediction (score >= " << std::fixed << std::setprecision(3)
         << threshold.min_score << (threshold.adaptive ? ", adaptive)" : ", fixed)");
    if (threshold.rejected_as_chance) {
      const double judged = static_cast<double>(threshold.judged);
      text << "; " << chance << " peaks refused as chance: " << std::setprecision(1)
           << (judged > 0.0 ? 100.0 * static_cast<double>(threshold.passed) / judged : 0.0)
           << " % of the judged points passed, no more than chance's " << 100.0 * threshold.null_match_rate_bound
           << " %";
    }
    return text.str();
  }
};

/// What a refit policy of correlation_two_passes returns: the transfer of the second pass (any
/// Transfer type), or none with a note saying why (empty: no note).
template <class Transfer>
struct CorrelationRefit {
  std::optional<Transfer> transfer;
  std::string note;
};

/// What correlation_two_passes did. The match lists are after the mask drop.
struct CorrelationPasses {
  PointMatches first;  ///< the first pass's matches
  CorrelationPassCounts first_counts;
  bool second_ran = false;  ///< a refitted transfer came back and the second pass ran
  PointMatches second;      ///< the second pass's matches (empty unless second_ran)
  CorrelationPassCounts second_counts;
  /// "first pass: <counts>; second pass: <counts>", or "first pass: <counts>; no second pass
  /// (<refit note>)".
  std::string message;

  /// The matches the composition goes on with: the second pass's when it ran, else the first's.
  const PointMatches& tentative() const { return second_ran ? second : first; }
  /// Matches of that pass dropped on the secondary mask.
  std::size_t masked() const { return second_ran ? second_counts.masked : first_counts.masked; }
};

/// `match` with a search of +-radius_px master px, and an exclusion radius that leaves room for a
/// second peak inside it (at most radius_px - 1, at least 1).
inline CorrelationMatchOptions narrow_correlation_options(const CorrelationMatchOptions& match, int radius_px) {
  CorrelationMatchOptions narrow = match;
  narrow.search_radius_px = radius_px;
  narrow.exclusion_px = std::min(narrow.exclusion_px, std::max(1, narrow.search_radius_px - 1));
  return narrow;
}

/// Two correlation passes over `points`: correlation_match through `transfer` with `match`; the
/// matches whose secondary window (half side secondary_half_px secondary px) touches a masked pixel
/// of `secondary_mask` dropped; then, when second_pass_radius_px > 0, `refit(first matches)` (any
/// callable returning a CorrelationRefit<T> for a Transfer T, e.g. a corrected DSM transfer or a
/// MapTransfer of a fitted homography) and, when it gives a transfer, a second pass around it with
/// a search of +-second_pass_radius_px master px (narrow_correlation_options), masked likewise.
/// Deterministic whatever match.threads (correlation_match is).
/// @throws diachron::Error as correlation_match, or for a second_pass_radius_px out of [0, 128].
template <class T, class Transfer, class Refit>
CorrelationPasses correlation_two_passes(const Raster<T>& master, const Raster<T>& secondary,
                                         const std::vector<Eigen::Vector2d>& points, const Transfer& transfer,
                                         const CorrelationMatchOptions& match, int second_pass_radius_px,
                                         Refit&& refit, const ImageMask* secondary_mask = nullptr,
                                         int secondary_half_px = 0) {
  static_assert(check_transfer<Transfer>());
  DIACHRON_CHECK(second_pass_radius_px >= 0 && second_pass_radius_px <= 128,
                 "correlation_two_passes: second_pass_radius_px must be in [0, 128], got " << second_pass_radius_px);
  const bool masked = secondary_mask && !secondary_mask->empty();
  const auto drop_masked = [&](PointMatches& matches) -> std::size_t {
    if (!masked) return 0;
    const std::size_t before = matches.size();
    matches.erase(std::remove_if(matches.begin(), matches.end(),
                                 [&](const PointMatch& m) { return !secondary_mask->box_usable(m.b, secondary_half_px); }),
                  matches.end());
    return before - matches.size();
  };
  CorrelationPasses out;
  CorrelationMatchResult first = correlation_match(master, secondary, points, transfer, match);
  out.first_counts = CorrelationPassCounts::of(first);
  out.first = std::move(first.matches);
  out.first_counts.masked = drop_masked(out.first);
  out.message = "first pass: " + out.first_counts.describe() + "; no second pass";
  if (second_pass_radius_px == 0) return out;
  auto refitted = refit(static_cast<const PointMatches&>(out.first));
  if (!refitted.transfer) {
    if (!refitted.note.empty()) out.message += " (" + refitted.note + ")";
    return out;
  }
  CorrelationMatchResult again = correlation_match(master, secondary, points, *refitted.transfer,
                                                   narrow_correlation_options(match, second_pass_radius_px));
  out.second_counts = CorrelationPassCounts::of(again);
  out.second = std::move(again.matches);
  out.second_counts.masked = drop_masked(out.second);
  out.second_ran = true;
  out.message = "first pass: " + out.first_counts.describe() + "; second pass: " + out.second_counts.describe();
  return out;
}

/// The 2D map correlation_match_pair refits on the first pass and filters the second with.
enum class PairRefitModel {
  similarity,  ///< scale, rotation, translation (ransac_similarity2): orthophotos, north-up or not
  homography,  ///< a plane projective map (ransac_homography2): frame images of flat ground, tilted views
};

/// "similarity" or "homography".
inline const char* to_string(PairRefitModel model) {
  return model == PairRefitModel::similarity ? "similarity" : "homography";
}

/// Options of correlation_match_pair. Defaults: those of precise matching's correlation
/// (PreciseCorrelationOptions, measured on the decades scenes; docs/correlation-matching.md), with
/// the DSM ground filter's 3 GSD turned into 3 secondary px.
struct CorrelationPairOptions {
  /// The master points: the strongest structure tensor (over 15 px) per 6 px cell (about 53000
  /// candidates on a 1600 x 1200 image); denser cells give more matches at proportional cost.
  GridInterestOptions interest = [] {
    GridInterestOptions o;
    o.cell_px = 6;
    o.window_px = 15;  // the structure tensor of precise matching's points, as measured
    return o;
  }();
  /// At most about this many master points (0: no bound): on a larger image the cell grows
  /// (effective_cell_px), so that a fine scan costs about what a 1600 x 1200 image does at 6 px.
  std::size_t max_points_per_image = 60000;
  /// The correlation: orientation measure (survives contrast inversion), 21 px window, search
  /// +-12 master px around the transfer's prediction. Its `threads` is replaced by `threads`.
  CorrelationMatchOptions match{};
  /// Half side of the second pass's search around the refitted map, master px (in [0, 128]; 0: no
  /// second pass, the filter judges the first pass). Around a map fitted to the first pass, a narrow
  /// search admits fewer false peaks (decades scenes: 67 % of the matches within 3 px instead of 46 %).
  int second_pass_radius_px = 6;
  /// The model of the refit and of the final filter. A similarity by default: it is what relates two
  /// orthophotos, and its 2-point samples stay robust on few matches; a homography (4-point
  /// samples) where the views are tilted frame images of flat ground.
  PairRefitModel model = PairRefitModel::similarity;
  /// Inlier threshold of the refit and of the final filter, secondary px (finite, > 0). Correlation
  /// peaks are mostly within a pixel or two of the truth: 3 px is the DSM path's 3 GSD (which kept
  /// 96 % of the matches within 3 px, against 69 % at the paper's 10). Raise it where the 2D model
  /// is only an approximation (relief seen from different viewpoints).
  double threshold_px = 3.0;
  /// ... but never below this many master px, in secondary px through the transfer's scale at the
  /// master image's centre (finite, >= 0; 0 = no floor). The window lives in master px, so a match is
  /// precise to a fraction of a master px however fine the secondary image is: against a secondary
  /// image eight times finer, 3 secondary px would be 0.4 master px. 1.5 binds only where the
  /// secondary is more than twice as fine as the master.
  double min_threshold_master_px = 1.5;
  /// Fewest matches the refit and the final filter need (>= 4): below, no model (the report fails
  /// honestly rather than trusting a map through a handful of points).
  std::size_t min_matches = 10;
  /// The RANSAC of the refit and of the final filter (robust/ransac_options.hpp); `threshold` and
  /// `threads` are ignored (threshold_px and threads set them). Default: exactly 1000 iterations,
  /// seed 0, as the ground filter.
  RansacOptions ransac = [] {
    RansacOptions o;
    o.max_iterations = 1000;
    o.confidence = 1.0;
    o.seed = 0;
    return o;
  }();
  /// Worker threads over points and RANSAC hypotheses (0 = all cores). Results do not depend on it.
  std::size_t threads = 0;

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    interest.check();
    match.check();
    DIACHRON_CHECK(second_pass_radius_px >= 0 && second_pass_radius_px <= 128,
                   "CorrelationPairOptions::second_pass_radius_px must be in [0, 128], got " << second_pass_radius_px);
    DIACHRON_CHECK(std::isfinite(threshold_px) && threshold_px > 0.0,
                   "CorrelationPairOptions::threshold_px must be finite and > 0, got " << threshold_px);
    DIACHRON_CHECK(std::isfinite(min_threshold_master_px) && min_threshold_master_px >= 0.0,
                   "CorrelationPairOptions::min_threshold_master_px must be finite and >= 0, got "
                       << min_threshold_master_px);
    DIACHRON_CHECK(min_matches >= 4, "CorrelationPairOptions::min_matches must be >= 4, got " << min_matches);
    RansacOptions r = ransac;
    r.threshold = 1.0;  // replaced by threshold_px
    r.check();
  }
};

/// A fitted 2D map and its support (the refit on the first pass, or the final filter).
struct PairMapFit {
  bool success = false;           ///< a model with at least min_matches inliers was found
  std::string message = "not run";
  /// The map master px -> secondary px as a homography, whatever the model (exact for a similarity).
  Homography2 homography{};
  /// The model when it is PairRefitModel::similarity (identity otherwise).
  Similarity2 similarity{};
  std::vector<std::size_t> inliers;  ///< indices into the matches it was fitted on, increasing
  double rms = std::numeric_limits<double>::infinity();  ///< of the inliers' residuals, secondary px
};

/// What correlation_match_pair did: every stage's matches and counts. Default: not run (success false).
struct CorrelationPairReport {
  bool success = false;  ///< at least one final match
  std::string message = "not run";
  int cell_px = 0;          ///< the grid cell used (effective_cell_px), master px
  std::size_t points = 0;   ///< master interest points correlated
  double threshold_px = std::numeric_limits<double>::quiet_NaN();  ///< the inlier threshold used, secondary px
  PointMatches first_pass;  ///< the first pass's matches (off masks)
  CorrelationPassCounts first_counts;
  PairMapFit refit;          ///< the model fitted on first_pass (not run without a second pass)
  bool second_ran = false;   ///< the second pass ran (refit.success and second_pass_radius_px > 0)
  PointMatches second_pass;  ///< its matches (off masks)
  CorrelationPassCounts second_counts;
  PairMapFit final_fit;      ///< the filter's model, on second_pass when it ran, else on first_pass
  PointMatches matches;      ///< the final matches: the filter's inliers, in their order

  /// The matches the filter judged: second_pass when it ran, else first_pass.
  const PointMatches& tentative() const { return second_ran ? second_pass : first_pass; }
};

namespace detail {

// The robust fit of `model` to matches (a -> b) at `threshold` secondary px.
inline PairMapFit fit_pair_map(const PointMatches& matches, PairRefitModel model, RansacOptions ransac,
                               double threshold, std::size_t min_matches) {
  PairMapFit fit;
  if (matches.size() < min_matches) {
    fit.message = std::to_string(matches.size()) + " matches, fewer than " + std::to_string(min_matches);
    return fit;
  }
  std::vector<PointPair2> data;
  data.reserve(matches.size());
  for (const PointMatch& m : matches) data.push_back({m.a, m.b});
  ransac.threshold = threshold;
  ransac.min_inliers = std::max(ransac.min_inliers, min_matches);
  const auto keep = [&fit, model](const auto& r) {
    if (!r.success) {
      fit.message = std::string(to_string(model)) + " RANSAC: " + r.message;
      return false;
    }
    fit.success = true;
    fit.message.clear();
    fit.inliers = r.inliers;
    fit.rms = r.rms;
    return true;
  };
  if (model == PairRefitModel::similarity) {
    const RansacReport<Similarity2> r = ransac_similarity2(data, ransac);
    if (keep(r)) {
      fit.similarity = r.model;
      fit.homography = Homography2{r.model.matrix()};
    }
  } else {
    const RansacReport<Homography2> r = ransac_homography2(data, ransac);
    if (keep(r)) fit.homography = r.model;
  }
  return fit;
}

// The transfer's linear scale (sqrt |det| of its local affine, secondary px per master px) at the
// master image's centre, or at the first of a few points where it answers; 1 where it nowhere does.
template <class Transfer>
double transfer_scale(const Transfer& transfer, int width, int height) {
  const Eigen::Vector2d centre(0.5 * (width - 1), 0.5 * (height - 1));
  for (const Eigen::Vector2d& p : {centre, Eigen::Vector2d(0.25 * (width - 1), 0.25 * (height - 1)),
                                   Eigen::Vector2d(0.75 * (width - 1), 0.75 * (height - 1))}) {
    if (const std::optional<Eigen::Matrix2d> a = local_affine(transfer, p, 1.0)) {
      const double s = std::sqrt(std::abs(a->determinant()));
      if (std::isfinite(s) && s > 0.0) return s;
    }
  }
  return 1.0;
}

// A length in px for messages, 3 significant digits.
inline std::string pair_px_text(double px) {
  std::ostringstream out;
  out << std::setprecision(3) << px;
  return out.str();
}

inline PointMatches select_matches(const PointMatches& matches, const std::vector<std::size_t>& indices) {
  PointMatches out;
  out.reserve(indices.size());
  for (const std::size_t i : indices) out.push_back(matches[i]);
  return out;
}

}  // namespace detail

/// Correlation matching of two images related by a 2D map (docs/two-image-matching.md): the
/// master's grid interest points (cell from effective_cell_px, a window's margin from the border,
/// off `master_mask`), a first pass around `transfer`'s predictions (search +-match.search_radius_px
/// master px), options.model fitted by RANSAC on it at the threshold, a second pass around that
/// model (a MapTransfer of it, search +-second_pass_radius_px), and the same RANSAC on the second
/// pass as the final filter. Matches whose secondary window touches a masked pixel of
/// `secondary_mask` are dropped. Masks may be null or empty (every pixel usable).
///
/// @param transfer any Transfer master px -> secondary px (terrain/transfer.hpp), e.g.
///        make_map_transfer(similarity) from a rough co-registration, several px off at most
///        match.search_radius_px.
/// @return a report with success == false and a message when no stage had enough matches.
/// Deterministic: the same inputs give the same report whatever options.threads.
/// @throws diachron::Error for invalid options, images smaller than 3 x 3, a mask of another size
///         than its image, or a transfer that returns a non-finite position.
template <class Transfer>
CorrelationPairReport correlation_match_pair(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                                             const Transfer& transfer, const CorrelationPairOptions& options = {},
                                             const ImageMask* master_mask = nullptr,
                                             const ImageMask* secondary_mask = nullptr) {
  static_assert(check_transfer<Transfer>());
  options.check();
  DIACHRON_CHECK(!master.empty() && !secondary.empty(), "correlation_match_pair: an empty image");
  if (secondary_mask) secondary_mask->check_size(secondary.width(), secondary.height(), "the secondary image");
  CorrelationPairReport report;
  CorrelationMatchOptions match = options.match;
  match.threads = options.threads;
  RansacOptions ransac = options.ransac;
  ransac.threads = options.threads;
  const double scale = detail::transfer_scale(transfer, master.width(), master.height());
  report.threshold_px = std::max(options.threshold_px, options.min_threshold_master_px * scale);

  GridInterestOptions interest = options.interest;
  interest.cell_px =
      effective_cell_px(options.interest.cell_px, options.max_points_per_image, master.width(), master.height());
  report.cell_px = interest.cell_px;
  const std::vector<Eigen::Vector2d> points = correlation_points(master, interest, match.window_px, master_mask);
  report.points = points.size();
  // The master window seen in the secondary image, for its mask.
  const int half = match.window_px / 2;
  const int secondary_half = static_cast<int>(std::ceil(std::min(scale, 64.0) * half));

  const auto refit = [&](const PointMatches& first) {
    report.refit = detail::fit_pair_map(first, options.model, ransac, report.threshold_px, options.min_matches);
    // The refitted map as a homography serves every model (exact for a similarity).
    CorrelationRefit<MapTransfer<Homography2>> out;
    if (report.refit.success)
      out.transfer = make_map_transfer(report.refit.homography);
    else
      out.note = "refit: " + report.refit.message;
    return out;
  };
  CorrelationPasses passes = correlation_two_passes(master, secondary, points, transfer, match,
                                                    options.second_pass_radius_px, refit, secondary_mask,
                                                    secondary_half);
  report.first_pass = std::move(passes.first);
  report.first_counts = passes.first_counts;
  report.second_ran = passes.second_ran;
  report.second_pass = std::move(passes.second);
  report.second_counts = passes.second_counts;

  report.final_fit = detail::fit_pair_map(report.tentative(), options.model, ransac, report.threshold_px,
                                          options.min_matches);
  if (report.final_fit.success) report.matches = detail::select_matches(report.tentative(), report.final_fit.inliers);
  report.success = !report.matches.empty();
  report.message = std::to_string(points.size()) + " points (" + std::to_string(report.cell_px) + " px cells), " +
                   passes.message + "; " +
                   (report.success ? std::to_string(report.matches.size()) + " final within " +
                                         detail::pair_px_text(report.threshold_px) + " px of the " +
                                         to_string(options.model)
                                   : "no final match (filter: " + report.final_fit.message + ")");
  return report;
}

}  // namespace diachron
