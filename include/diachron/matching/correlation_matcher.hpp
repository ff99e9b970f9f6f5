#pragma once
/// @file
/// Correlation-guided matching: each master point is predicted into the secondary image through a
/// Transfer, the secondary neighbourhood is resampled into the master geometry through the
/// transfer's local affine, and a correlation surface over integer shifts of +-R master pixels
/// around the prediction gives the match: its peak, when high and distinct, refined to sub-pixel.
/// No descriptor is involved, so it survives the radiometric changes of decades (inverted land
/// cover, film tone curves) as far as the similarity measure does. docs/correlation-matching.md.
///
/// Conventions: pixels as in docs/conventions.md; shifts and windows are in MASTER pixels; the
/// secondary sample of master offset o around a prediction b0 lies at b0 + A o (A = local affine).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/matching/correlation_kernel.hpp>
#include <diachron/matching/grid_interest_points.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/matching/window_sampler.hpp>
#include <diachron/robust/chance_inliers.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/transfer.hpp>

namespace diachron {

/// Options of correlation matching. Defaults: docs/correlation-matching.md measures them on the
/// decades-apart scenes.
struct CorrelationMatchOptions {
  /// The similarity (see CorrelationMeasure).
  CorrelationMeasure measure = CorrelationMeasure::orientation;
  /// Side of the square correlation window, master pixels (odd, in [5, 255]); offsets
  /// [-w/2, w/2] around the point.
  int window_px = 21;
  /// Half-side of the square search, master pixels (integer, in [1, 128]): shifts in [-R, R]^2 of
  /// the prediction. The DSM + rough-Helmert transfer lands a median 3.4 to 8.8 epoch-2 px (1.7 to
  /// 4.4 master px at the local scale of 2) from the truth on the decades scenes, with a tail to
  /// about twice that, hence 12.
  int search_radius_px = 12;
  /// A peak is kept when its score is at least this, in [-1, 1]: the fixed threshold. With
  /// adaptive_threshold on, it serves only when too few null surfaces could be computed.
  double min_score = 0.3;
  /// ... and exceeds every other local maximum of the surface (farther than exclusion_px from it)
  /// by at least this, in [0, 2]: repetitive or ambiguous texture has several near-equal peaks.
  double min_margin = 0.05;
  /// Chebyshev radius around the peak whose local maxima belong to the peak itself, master px (>= 1).
  int exclusion_px = 3;
  /// Average k x k bilinear samples per secondary sample when the local affine shrinks the
  /// secondary image (k = ceil of its largest singular value, at most 4), so a 2x finer secondary
  /// image is low-pass filtered instead of aliased.
  bool antialias = true;
  /// Sub-pixel refinement of a kept peak: after the parabola through the integer surface, this many
  /// rounds of a parabola per axis through the scores at the current estimate and 0.5, 0.25, 0.125,
  /// ... master px either side of it (each score resampled afresh), in [0, 8]. The integer-grid parabola alone
  /// is biased by up to ~0.2 master px on peaks that are not parabolic; 3 rounds bring it under 0.05
  /// on the tests' textures.
  int subpixel_rounds = 3;
  /// Central-difference step of local_affine, master pixels (>= 0; 0 = half the window). A DSM's
  /// height noise tilts each cell's facet, and a 1 px step puts that tilt into the window's scale and
  /// shear; half the window averages it. Decades scenes (2 m DSM cells, 0.4 m noise), 30 pairs: median
  /// error 1.14 epoch-2 px at 1 px, 1.03 px at half the window, with 18 % more correct matches. Yet the
  /// combined adjustment's check points got worse with those matches in 7 of 10 runs, so 1 px stays
  /// the default (docs/correlation-matching.md, "The window's affine").
  double affine_step_px = 1.0;
  /// Side of the square master tiles whose points may share one resampled secondary patch, master px
  /// (in [0, 256]; 0, the default: every point resamples its own). In a tile, a point whose local
  /// affine is within shared_affine_tolerance_px of a group's first point joins that group: the
  /// secondary image is resampled once around all their searches through the first point's affine,
  /// and each member's search is centred on its prediction rounded to that patch's master-pixel
  /// grid (at most half a master px off per axis); its peak is then refined through its own
  /// prediction and affine. Members' scores thus differ from correlate_point's in the last digits,
  /// and their integer surfaces by the rounding. On the decades scenes (6 px cells, 6 pairs) 24 px
  /// tiles at 1 px grouped 3.4 points per patch and took 7 % off a pair's time, the matches as good;
  /// the sampling that remains is the sub-pixel rounds' and the null surfaces', so it is an option
  /// (docs/correlation-matching.md, "Speed").
  int shared_tile_px = 0;
  /// The largest move of a window's sample, secondary px (>= 0), between a point's own local affine
  /// and its group's: half the window times the largest row sum of the absolute difference of the
  /// two affines. The affines of a DSM transfer at a 1 px step carry the DSM's height noise: on the
  /// decades scenes 0.25 px grouped 1.5 points per patch, 1 px 3.4.
  double shared_affine_tolerance_px = 1.0;
  /// Worker threads over points (0 = all cores). The result does not depend on it.
  std::size_t threads = 0;

  /// Judge the peaks against chance instead of min_score. Each call correlates null_surfaces of its
  /// points around predictions displaced well outside the search (a square ring of Chebyshev radius
  /// 2 R + window_px to twice that, master px, through the point's own local affine), where any
  /// peak is a wrong one, and requires the (1 - false_alarm_rate) quantile of those surfaces' best
  /// scores, clamped to [adaptive_floor, adaptive_ceiling]. The same search, window, measure and
  /// images give the null scores, so the threshold follows what chance gives on this pair: on a real
  /// inter-epoch orthophoto pair (AppearanceChange) the orientation measure's correct peaks have a
  /// median of 0.23 and chance's 99th percentile is 0.21, where a fixed 0.3 rejects most of them
  /// (docs/correlation-matching.md, "A threshold against chance"). With pair_significance, a pair
  /// where chance explains the matches gives none.
  bool adaptive_threshold = true;
  /// The share of wrong places whose best score passes the adaptive threshold, per point, in
  /// (0, 0.5]: the threshold is the null maximum that at most floor(rate * n) of the n null maxima
  /// exceed. 0.05: on the decades scenes (30 pairs) 210 correct final matches per pair at 95.7 %
  /// within 3 px, against 118 at 96.2 % for 0.01 and 242 at 95.0 % for 0.1 (docs/correlation-matching.md).
  double false_alarm_rate = 0.05;
  /// The least adaptive threshold, in [-1, 1]: below it, a peak is too weak to be refined to
  /// sub-pixel whatever chance gives.
  double adaptive_floor = 0.1;
  /// The largest adaptive threshold, in [adaptive_floor, 1] (1: none). A peak this high is kept
  /// whatever chance gives; at min_score (0.3) the adaptive threshold only ever lowers the fixed one.
  double adaptive_ceiling = 1.0;
  /// Null surfaces per call, at most (>= 1): a call with n eligible points (prediction and window
  /// inside both images) correlates min(null_surfaces, max(256, n / 4)) of them, spread evenly over
  /// the list; their cost is about that many points' matching (at most a quarter more, fewer on
  /// small calls). The pair test needs many: 256 bound chance's rate only to about +-3 %, and
  /// refused 19 of 34 decades pairs that hold real matches; 2048 refused 5 weak ones (22 to 53
  /// final matches) and still every unrelated pair tried (docs/correlation-matching.md).
  int null_surfaces = 2048;
  /// With fewer usable null surfaces than this (in [1, null_surfaces]), the call keeps min_score and
  /// its threshold says adaptive = false. It should be at least 1 / false_alarm_rate.
  int min_null_surfaces = 100;
  /// Seed of the null displacements: surface j draws from RandomStream(seed, j), so the threshold
  /// does not depend on the threads.
  std::uint64_t seed = 0;
  /// With an adaptive threshold, the call's matches stand only when more of its points match than
  /// chance explains: with n points judged (a surface computed) and k matched, P(X >= k) for X
  /// binomial(n, p), p the upper 99.9 % bound of the share of null surfaces whose peak would have
  /// been matched, must be at most this, in [0, 1) (0: no test). Otherwise the call has no match
  /// and its peaks say `chance`. A per-point threshold at a 5 % false-alarm rate lets about 5 % of
  /// the points of an unrelated pair through by construction; this is what refuses such a pair
  /// (docs/correlation-matching.md, "A threshold against chance").
  double pair_significance = 1e-3;

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    DIACHRON_CHECK(window_px >= 5 && window_px <= 255 && window_px % 2 == 1,
                   "CorrelationMatchOptions::window_px must be odd and in [5, 255], got " << window_px);
    DIACHRON_CHECK(search_radius_px >= 1 && search_radius_px <= 128,
                   "CorrelationMatchOptions::search_radius_px must be in [1, 128], got " << search_radius_px);
    DIACHRON_CHECK(min_score >= -1.0 && min_score <= 1.0,
                   "CorrelationMatchOptions::min_score must be in [-1, 1], got " << min_score);
    DIACHRON_CHECK(min_margin >= 0.0 && min_margin <= 2.0,
                   "CorrelationMatchOptions::min_margin must be in [0, 2], got " << min_margin);
    DIACHRON_CHECK(subpixel_rounds >= 0 && subpixel_rounds <= 8,
                   "CorrelationMatchOptions::subpixel_rounds must be in [0, 8], got " << subpixel_rounds);
    DIACHRON_CHECK(exclusion_px >= 1, "CorrelationMatchOptions::exclusion_px must be >= 1, got " << exclusion_px);
    DIACHRON_CHECK(std::isfinite(affine_step_px) && affine_step_px >= 0.0,
                   "CorrelationMatchOptions::affine_step_px must be finite and >= 0, got " << affine_step_px);
    DIACHRON_CHECK(shared_tile_px >= 0 && shared_tile_px <= 256,
                   "CorrelationMatchOptions::shared_tile_px must be in [0, 256], got " << shared_tile_px);
    DIACHRON_CHECK(std::isfinite(shared_affine_tolerance_px) && shared_affine_tolerance_px >= 0.0,
                   "CorrelationMatchOptions::shared_affine_tolerance_px must be finite and >= 0, got "
                       << shared_affine_tolerance_px);
    DIACHRON_CHECK(false_alarm_rate > 0.0 && false_alarm_rate <= 0.5,
                   "CorrelationMatchOptions::false_alarm_rate must be in (0, 0.5], got " << false_alarm_rate);
    DIACHRON_CHECK(adaptive_floor >= -1.0 && adaptive_floor <= 1.0,
                   "CorrelationMatchOptions::adaptive_floor must be in [-1, 1], got " << adaptive_floor);
    DIACHRON_CHECK(adaptive_ceiling >= adaptive_floor && adaptive_ceiling <= 1.0,
                   "CorrelationMatchOptions::adaptive_ceiling must be in [adaptive_floor = " << adaptive_floor
                                                                                           << ", 1], got "
                                                                                           << adaptive_ceiling);
    DIACHRON_CHECK(null_surfaces >= 1, "CorrelationMatchOptions::null_surfaces must be >= 1, got " << null_surfaces);
    DIACHRON_CHECK(min_null_surfaces >= 1 && min_null_surfaces <= null_surfaces,
                   "CorrelationMatchOptions::min_null_surfaces must be in [1, null_surfaces = "
                       << null_surfaces << "], got " << min_null_surfaces);
    DIACHRON_CHECK(pair_significance >= 0.0 && pair_significance < 1.0,
                   "CorrelationMatchOptions::pair_significance must be in [0, 1), got " << pair_significance);
  }

  /// The step local_affine is called with: affine_step_px, or half the window when it is 0.
  double affine_step() const { return affine_step_px > 0.0 ? affine_step_px : 0.5 * (window_px - 1); }
};

/// Why a point got its verdict.
enum class CorrelationOutcome : std::uint8_t {
  not_run,            ///< default
  matched,            ///< a high, distinct peak inside the search
  no_prediction,      ///< the Transfer (or its local affine) gives nothing at the point
  outside_master,     ///< the master window leaves the master image
  outside_secondary,  ///< the resampled search region (or already the prediction) leaves the secondary image
  flat,               ///< the master window has no variance in the measure's channels
  low_score,          ///< the best score is below min_score
  ambiguous,          ///< another peak is within min_margin of the best
  at_border,          ///< the best shift lies on the border of the search: the true peak may be outside
  chance,             ///< the peak passed, but the call's matches are no more than chance gives
                      ///< (CorrelationThreshold::rejected_as_chance)
};

/// The correlation peak of one point.
struct CorrelationPeak {
  CorrelationOutcome outcome = CorrelationOutcome::not_run;
  /// The matched secondary position b0 + A (shift), secondary px (NaN unless matched or the peak
  /// was computed but rejected).
  Eigen::Vector2d b = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// The sub-pixel shift of the peak from the prediction, master px.
  Eigen::Vector2d shift = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  double score = std::numeric_limits<double>::quiet_NaN();   ///< the peak's score
  double second = std::numeric_limits<double>::quiet_NaN();  ///< best other local maximum (-1 if none)
};

/// The score threshold one correlation_match() call applied, and the null statistics behind it.
struct CorrelationThreshold {
  /// The least peak score the call required (options.min_score unless `adaptive`).
  double min_score = std::numeric_limits<double>::quiet_NaN();
  /// True when min_score came from the null surfaces; false when adaptive_threshold is off, or on
  /// with fewer than min_null_surfaces usable null surfaces (then min_score is options.min_score).
  bool adaptive = false;
  /// The best score of each usable null surface, in the order of the samples (empty when adaptive
  /// is off).
  std::vector<double> null_maxima;
  /// Upper quantiles of null_maxima (the value at most floor(q n) of them exceed, q = 0.5, 0.1,
  /// 0.01, false_alarm_rate), and their largest; NaN without null surfaces. The adaptive threshold
  /// is null_quantile clamped to [adaptive_floor, adaptive_ceiling].
  double null_median = std::numeric_limits<double>::quiet_NaN();
  double null_q90 = std::numeric_limits<double>::quiet_NaN();
  double null_q99 = std::numeric_limits<double>::quiet_NaN();
  double null_quantile = std::numeric_limits<double>::quiet_NaN();
  double null_max = std::numeric_limits<double>::quiet_NaN();

  /// The pair test (options.pair_significance; run only when `adaptive`). The share of null
  /// surfaces whose peak would have been matched at min_score (high enough, distinct, not at the
  /// border), and its upper 99.9 % bound (Wilson), the chance rate the test uses.
  double null_match_rate = std::numeric_limits<double>::quiet_NaN();
  double null_match_rate_bound = std::numeric_limits<double>::quiet_NaN();
  /// Points judged (a surface was computed: matched, low_score, ambiguous or at_border) and of them
  /// matched, before the test.
  std::size_t judged = 0, passed = 0;
  /// P(at least `passed` of `judged` match) at the bound's rate; NaN when the test did not run.
  double chance_probability = std::numeric_limits<double>::quiet_NaN();
  /// True when the test ran and chance explains the matches: the call then returns none.
  bool rejected_as_chance = false;
};

/// What correlation_match() returns. `matches[k]` is point `point_index[k]` (score = peak score),
/// in the order of the points; `peaks` has one entry per input point.
struct CorrelationMatchResult {
  bool success = false;  ///< at least one match
  PointMatches matches;
  std::vector<std::size_t> point_index;
  std::vector<CorrelationPeak> peaks;
  std::size_t no_prediction = 0, outside_master = 0, outside_secondary = 0, flat = 0, low_score = 0,
              ambiguous = 0, at_border = 0, chance = 0;
  /// The score threshold applied (low_score is below threshold.min_score).
  CorrelationThreshold threshold;
};

/// The correlation surface of master point `a` against the secondary image around `b0` through the
/// local affine `affine` (d secondary px / d master px): entry (dy + R, dx + R) is the score of the
/// shift (dx, dy) in master px, i.e. of the secondary window centred at b0 + affine (dx, dy). NaN
/// where a secondary window is flat. Empty (0 x 0) when a window leaves an image or the master
/// window is flat.
/// @throws diachron::Error for invalid options, an image smaller than 3 x 3, non-finite a, b0 or affine.
template <class T>
Eigen::MatrixXd correlation_surface(const Raster<T>& master, const Eigen::Vector2d& a, const Raster<T>& secondary,
                                    const Eigen::Vector2d& b0, const Eigen::Matrix2d& affine,
                                    const CorrelationMatchOptions& options = {});

/// The peak of the correlation surface of one point (see correlation_surface), judged by the
/// options' thresholds and refined to sub-pixel by a parabola through the peak and its neighbours
/// on each axis.
/// @throws diachron::Error as correlation_surface.
template <class T>
CorrelationPeak correlate_point(const Raster<T>& master, const Eigen::Vector2d& a, const Raster<T>& secondary,
                                const Eigen::Vector2d& b0, const Eigen::Matrix2d& affine,
                                const CorrelationMatchOptions& options = {});

/// Correlation matching of `points` (master px, e.g. grid_interest_points) predicted through
/// `transfer`. Deterministic, parallel over points.
/// @throws diachron::Error for invalid options, an image smaller than 3 x 3, a non-finite point,
///         or a transfer that returns a non-finite position.
template <class T, class Transfer>
CorrelationMatchResult correlation_match(const Raster<T>& master, const Raster<T>& secondary,
                                         const std::vector<Eigen::Vector2d>& points, const Transfer& transfer,
                                         const CorrelationMatchOptions& options = {});

/// The same on grid_interest_points' output (their positions, in order; the strengths are not used).
template <class T, class Transfer>
CorrelationMatchResult correlation_match(const Raster<T>& master, const Raster<T>& secondary,
                                         const std::vector<InterestPoint>& points, const Transfer& transfer,
                                         const CorrelationMatchOptions& options = {});

/// The value of `values` that at most floor(share * n) of its n values exceed (its upper `share`
/// quantile, ties included), share in [0, 1]; NaN when empty. The adaptive threshold's quantile.
inline double correlation_upper_quantile(std::vector<double> values, double share);

// Implementation ---------------------------------------------------------------------------------

namespace detail {

template <class T>
void check_correlation_image(const Raster<T>& img, const char* which) {
  DIACHRON_CHECK(img.width() >= 3 && img.height() >= 3,
                 "correlation matching: the " << which << " image must be at least 3 x 3, got " << img.width()
                                              << " x " << img.height());
}

// True when c + m * o stays on or between the outer pixel centres for |o|_inf <= extent.
inline bool correlation_inside(int width, int height, const Eigen::Vector2d& c, const Eigen::Matrix2d& m,
                               double extent) {
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d p = c + m * Eigen::Vector2d((k & 1) ? extent : -extent, (k & 2) ? extent : -extent);
    if (!(p.x() >= 0.0 && p.y() >= 0.0 && p.x() <= width - 1 && p.y() <= height - 1)) return false;
  }
  return true;
}

// The reused buffers of one thread's correlations: the resampled patches, the master window's
// channels, the secondary patch's channels with their integral images, the window of a sub-pixel
// score, one row of cross products.
struct CorrelationScratch {
  AffineGridScratch grid;
  std::vector<float> master_patch, secondary_patch;
  CorrelationTemplate master;       // the point's window (correlation_template)
  CorrelationChannels channels;     // the secondary patch's
  CorrelationTemplate window;       // a sub-pixel score's secondary window (correlation_score_at)
  std::vector<double> cross;        // correlation_scores'
  int k = 1;                        // anti-aliasing sub-samples per axis
};

// One scratch per thread for the single-point functions (correlation_surface, correlate_point).
inline CorrelationScratch& correlation_thread_scratch() {
  thread_local CorrelationScratch scratch;
  return scratch;
}

template <class T>
void check_correlation_inputs(const Raster<T>& master, const Eigen::Vector2d& a, const Raster<T>& secondary,
                              const Eigen::Vector2d& b0, const Eigen::Matrix2d& affine) {
  check_correlation_image(master, "master");
  check_correlation_image(secondary, "secondary");
  DIACHRON_CHECK(a.allFinite(), "correlation matching: non-finite master point (" << a.transpose() << ")");
  DIACHRON_CHECK(b0.allFinite(), "correlation matching: non-finite predicted secondary point (" << b0.transpose()
                                                                                                << ")");
  DIACHRON_CHECK(affine.allFinite(), "correlation matching: non-finite local affine at master point ("
                                         << a.transpose() << ")");
}

// Anti-aliasing sub-samples per axis for a local affine: ceil of its largest singular value, 1 to 4.
inline int correlation_subsamples(const Eigen::Matrix2d& affine, const CorrelationMatchOptions& o) {
  if (!o.antialias) return 1;
  return std::clamp(static_cast<int>(std::ceil(affine_singular_values(affine).x() - 1e-6)), 1, 4);
}

// The half side, master px, of the secondary region a search samples (window, search, gradient
// margin), and the reach of its sub-samples beyond it.
inline double correlation_reach(const CorrelationMatchOptions& o, int k) {
  return o.window_px / 2 + o.search_radius_px + 1 + (k > 1 ? 0.5 : 0.0);
}

// The master window of point a into s.master (channels, zero-mean); outside_master, flat or not_run.
template <class T>
CorrelationOutcome correlation_master_window(const Raster<T>& master, const Eigen::Vector2d& a,
                                             const CorrelationMatchOptions& o, CorrelationScratch& s) {
  const int half = o.window_px / 2, side = o.window_px + 2;  // +1 px margin for the gradients
  if (!correlation_inside(master.width(), master.height(), a, Eigen::Matrix2d::Identity(), half + 1))
    return CorrelationOutcome::outside_master;
  s.master_patch.resize(static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  if (a.x() == std::floor(a.x()) && a.y() == std::floor(a.y())) {
    // On a pixel centre (grid points are): the pixels themselves, as the bilinear samples would be.
    const int x0 = static_cast<int>(a.x()) - (half + 1), y0 = static_cast<int>(a.y()) - (half + 1);
    for (int j = 0; j < side; ++j) {
      const T* row = master.row(y0 + j) + x0;
      float* out = s.master_patch.data() + static_cast<std::size_t>(j) * static_cast<std::size_t>(side);
      for (int i = 0; i < side; ++i) out[i] = static_cast<float>(row[i]);
    }
  } else {
    sample_affine_grid(master, a, Eigen::Matrix2d::Identity(), -(half + 1), -(half + 1), side, side, 1,
                       s.master_patch.data(), static_cast<std::size_t>(side), s.grid);
  }
  correlation_template(o.measure, s.master_patch.data(), o.window_px, static_cast<std::size_t>(side), s.master);
  return s.master.flat ? CorrelationOutcome::flat : CorrelationOutcome::not_run;
}

// The secondary patch of the offsets [first, first + cols) x [first_y, first_y + rows) at c + m o,
// with k x k sub-samples, into s.channels; false when its channels are not finite.
template <class T>
bool correlation_secondary_patch(const Raster<T>& secondary, const Eigen::Vector2d& c, const Eigen::Matrix2d& m,
                                 int first_x, int first_y, int cols, int rows, int k, const CorrelationMatchOptions& o,
                                 CorrelationScratch& s) {
  s.secondary_patch.resize(static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows));
  sample_affine_grid(secondary, c, m, first_x, first_y, cols, rows, k, s.secondary_patch.data(),
                     static_cast<std::size_t>(cols), s.grid);
  correlation_channels(o.measure, s.secondary_patch.data(), cols, rows, static_cast<std::size_t>(cols), s.channels);
  for (int ch = 0; ch < s.channels.channels; ++ch)
    if (!std::isfinite(s.channels.sum[ch].back()) || !std::isfinite(s.channels.sum2[ch].back())) return false;
  return true;
}

// The surface into `surface` ((2R+1)^2); returns the outcome (not_run when the surface is valid).
template <class T>
CorrelationOutcome correlation_surface_into(const Raster<T>& master, const Eigen::Vector2d& a,
                                            const Raster<T>& secondary, const Eigen::Vector2d& b0,
                                            const Eigen::Matrix2d& affine, const CorrelationMatchOptions& o,
                                            CorrelationScratch& s, Eigen::MatrixXd& surface) {
  const int half = o.window_px / 2, r = o.search_radius_px;
  const int half_region = half + r + 1;  // every shift's window, plus the gradients' margin
  if (!correlation_inside(master.width(), master.height(), a, Eigen::Matrix2d::Identity(), half + 1))
    return CorrelationOutcome::outside_master;
  const int k = correlation_subsamples(affine, o);
  // The sub-samples reach half a master pixel beyond the outer offsets.
  if (!correlation_inside(secondary.width(), secondary.height(), b0, affine, correlation_reach(o, k)))
    return CorrelationOutcome::outside_secondary;
  s.k = k;
  const CorrelationOutcome window = correlation_master_window(master, a, o, s);
  if (window != CorrelationOutcome::not_run) return window;
  const int side = 2 * half_region + 1;
  if (!correlation_secondary_patch(secondary, b0, affine, -half_region, -half_region, side, side, k, o, s))
    return CorrelationOutcome::flat;
  correlation_scores(s.master, s.channels, 0, 0, 2 * r + 1, 2 * r + 1, surface, s.cross);
  return CorrelationOutcome::not_run;
}

// Vertex of the parabola through (-1, l), (0, c), (1, r), clamped to [-limit, limit]; 0 when the
// three values do not bend down.
inline double correlation_vertex(double l, double c, double r, double limit) {
  const double d = l - 2.0 * c + r;
  if (!std::isfinite(d) || !(d < 0.0)) return 0.0;
  return std::clamp(0.5 * (l - r) / d, -limit, limit);
}

// Peak, second peak, sub-pixel refinement and verdict of a surface.
inline CorrelationPeak correlation_peak(const Eigen::MatrixXd& surface, const Eigen::Vector2d& b0,
                                        const Eigen::Matrix2d& affine, const CorrelationMatchOptions& o) {
  CorrelationPeak p;
  const int shifts = static_cast<int>(surface.rows()), r = o.search_radius_px;
  int bx = -1, by = -1;
  double best = -std::numeric_limits<double>::infinity();
  for (int y = 0; y < shifts; ++y)
    for (int x = 0; x < shifts; ++x)
      if (std::isfinite(surface(y, x)) && surface(y, x) > best) {
        best = surface(y, x);
        bx = x;
        by = y;
      }
  if (bx < 0) {
    p.outcome = CorrelationOutcome::flat;
    return p;
  }
  // The best other local maximum (>= its finite 8 neighbours, so a ridge's plateau counts) outside
  // the peak's exclusion zone.
  double second = -1.0;
  for (int y = 0; y < shifts; ++y)
    for (int x = 0; x < shifts; ++x) {
      const double v = surface(y, x);
      if (!std::isfinite(v) || std::max(std::abs(x - bx), std::abs(y - by)) <= o.exclusion_px || v <= second)
        continue;
      bool local_max = true;
      for (int ny = std::max(0, y - 1); ny <= std::min(shifts - 1, y + 1) && local_max; ++ny)
        for (int nx = std::max(0, x - 1); nx <= std::min(shifts - 1, x + 1); ++nx)
          if (std::isfinite(surface(ny, nx)) && surface(ny, nx) > v) {
            local_max = false;
            break;
          }
      if (local_max) second = v;
    }
  // Parabola through the peak and its two neighbours on each axis; no neighbour, no refinement.
  auto vertex = [](double l, double c, double rr) { return correlation_vertex(l, c, rr, 0.5); };
  const double fx = bx > 0 && bx < shifts - 1 ? vertex(surface(by, bx - 1), best, surface(by, bx + 1)) : 0.0;
  const double fy = by > 0 && by < shifts - 1 ? vertex(surface(by - 1, bx), best, surface(by + 1, bx)) : 0.0;
  p.shift = Eigen::Vector2d(bx - r + fx, by - r + fy);
  p.b = b0 + affine * p.shift;
  p.score = best;
  p.second = second;
  if (bx == 0 || by == 0 || bx == shifts - 1 || by == shifts - 1) p.outcome = CorrelationOutcome::at_border;
  else if (!(best >= o.min_score)) p.outcome = CorrelationOutcome::low_score;
  else if (!(best - second >= o.min_margin)) p.outcome = CorrelationOutcome::ambiguous;
  else p.outcome = CorrelationOutcome::matched;
  return p;
}

// The score of the secondary window centred at `centre` (the master channels of the last
// correlation_surface_into in `s`); NaN when it leaves the image or is flat.
template <class T>
double correlation_score_at(const Raster<T>& secondary, const Eigen::Vector2d& centre, const Eigen::Matrix2d& affine,
                            const CorrelationMatchOptions& o, CorrelationScratch& s) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const int side = o.window_px + 2;
  if (!correlation_inside(secondary.width(), secondary.height(), centre, affine,
                          o.window_px / 2 + 1 + (s.k > 1 ? 0.5 : 0.0)))
    return nan;
  s.secondary_patch.resize(static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  sample_affine_grid(secondary, centre, affine, -(side / 2), -(side / 2), side, side, s.k, s.secondary_patch.data(),
                     static_cast<std::size_t>(side), s.grid);
  correlation_template(o.measure, s.secondary_patch.data(), o.window_px, static_cast<std::size_t>(side), s.window);
  if (s.window.flat) return nan;
  // Both windows are zero-mean: the cross term is the plain sum of products.
  const std::size_t n = static_cast<std::size_t>(o.window_px) * static_cast<std::size_t>(o.window_px);
  double cross = 0.0;
  for (int c = 0; c < s.master.channels; ++c) {
    const float* m = s.master.data[c].data();
    const float* f = s.window.data[c].data();
    for (std::size_t i = 0; i < n; ++i) cross += static_cast<double>(m[i]) * f[i];
  }
  return std::clamp(cross / std::sqrt(s.master.var * s.window.var), -1.0, 1.0);
}

// Rounds of scores at halving steps around the peak (the centre and its four neighbours along the
// axes, all the two parabolas use), each recentred on the parabolas' vertex. Stops (keeping the last
// estimate) when a score cannot be computed.
template <class T>
void correlation_refine(const Raster<T>& secondary, const Eigen::Vector2d& b0, const Eigen::Matrix2d& affine,
                        const CorrelationMatchOptions& o, CorrelationScratch& s, CorrelationPeak& p) {
  Eigen::Vector2d c = p.shift;
  double h = 0.5;
  const int offsets[5][2] = {{0, 0}, {-1, 0}, {1, 0}, {0, -1}, {0, 1}};
  for (int round = 0; round < o.subpixel_rounds; ++round, h *= 0.5) {
    double v[5];
    bool ok = true;
    for (int k = 0; k < 5 && ok; ++k) {
      v[k] = correlation_score_at(
          secondary, Eigen::Vector2d(b0 + affine * (c + h * Eigen::Vector2d(offsets[k][0], offsets[k][1]))), affine, o, s);
      ok = std::isfinite(v[k]);
    }
    if (!ok) break;
    c += h * Eigen::Vector2d(correlation_vertex(v[1], v[0], v[2], 1.0), correlation_vertex(v[3], v[0], v[4], 1.0));
  }
  const double score = correlation_score_at(secondary, Eigen::Vector2d(b0 + affine * c), affine, o, s);
  if (!std::isfinite(score)) return;
  p.shift = c;
  p.b = b0 + affine * c;
  p.score = score;
}

}  // namespace detail

template <class T>
Eigen::MatrixXd correlation_surface(const Raster<T>& master, const Eigen::Vector2d& a, const Raster<T>& secondary,
                                    const Eigen::Vector2d& b0, const Eigen::Matrix2d& affine,
                                    const CorrelationMatchOptions& options) {
  static_assert(std::is_arithmetic_v<T>, "correlation_surface: the pixel type must be arithmetic");
  options.check();
  detail::check_correlation_inputs(master, a, secondary, b0, affine);
  detail::CorrelationScratch& s = detail::correlation_thread_scratch();
  Eigen::MatrixXd surface;
  if (detail::correlation_surface_into(master, a, secondary, b0, affine, options, s, surface) !=
      CorrelationOutcome::not_run)
    return Eigen::MatrixXd();
  return surface;
}

template <class T>
CorrelationPeak correlate_point(const Raster<T>& master, const Eigen::Vector2d& a, const Raster<T>& secondary,
                                const Eigen::Vector2d& b0, const Eigen::Matrix2d& affine,
                                const CorrelationMatchOptions& options) {
  static_assert(std::is_arithmetic_v<T>, "correlate_point: the pixel type must be arithmetic");
  options.check();
  detail::check_correlation_inputs(master, a, secondary, b0, affine);
  detail::CorrelationScratch& s = detail::correlation_thread_scratch();
  Eigen::MatrixXd surface;
  const CorrelationOutcome o = detail::correlation_surface_into(master, a, secondary, b0, affine, options, s, surface);
  if (o != CorrelationOutcome::not_run) {
    CorrelationPeak p;
    p.outcome = o;
    return p;
  }
  CorrelationPeak p = detail::correlation_peak(surface, b0, affine, options);
  if (p.outcome == CorrelationOutcome::matched) detail::correlation_refine(secondary, b0, affine, options, s, p);
  return p;
}

inline double correlation_upper_quantile(std::vector<double> values, double share) {
  DIACHRON_CHECK(share >= 0.0 && share <= 1.0, "correlation_upper_quantile: share must be in [0, 1], got " << share);
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = values.size();
  // At most `above` values may exceed the answer; the 1e-9 keeps 0.29 * 100 (28.999...) from flooring to 28.
  const std::size_t above =
      std::min(n - 1, static_cast<std::size_t>(std::floor(share * static_cast<double>(n) + 1e-9)));
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(n - 1 - above);
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

namespace detail {

// Null surfaces of a call with few points (capped by options.null_surfaces): enough for the
// threshold's quantile however few points are matched.
constexpr std::size_t kMinNullSurfacesPerCall = 256;

// The adaptive threshold of one call (options.adaptive_threshold): null surface j correlates the
// master window of an eligible point (spread evenly over `eligible`) around its prediction displaced
// by a random offset whose Chebyshev norm is in [2 R + window, 2 (2 R + window)) master px, through the
// point's local affine, and keeps the surface's best score. Offsets that take the search off the
// secondary image are drawn again (8 tries); a point whose tries all leave it gives no sample.
template <class T>
CorrelationThreshold correlation_null_threshold(const Raster<T>& master, const Raster<T>& secondary,
                                                const std::vector<Eigen::Vector2d>& points,
                                                const std::vector<std::optional<Eigen::Vector2d>>& predictions,
                                                const std::vector<std::optional<Eigen::Matrix2d>>& affines,
                                                const std::vector<std::size_t>& eligible,
                                                const CorrelationMatchOptions& o) {
  CorrelationThreshold t;
  const std::size_t samples =
      eligible.empty() ? 0
                       : std::min(static_cast<std::size_t>(o.null_surfaces),
                                  std::max<std::size_t>(kMinNullSurfacesPerCall, eligible.size() / 4));
  std::vector<double> maxima(samples, std::numeric_limits<double>::quiet_NaN());
  // Whether the surface's peak is distinct and inside the search: matched at any high enough threshold.
  std::vector<char> distinct(samples, 0);
  CorrelationMatchOptions any_score = o;
  any_score.min_score = -1.0;
  const double reach = 2.0 * o.search_radius_px + o.window_px;
  constexpr std::size_t kChunk = 8;
  parallel_for((samples + kChunk - 1) / kChunk, o.threads, [&](std::size_t chunk) {
    CorrelationScratch s;
    Eigen::MatrixXd surface;
    for (std::size_t j = chunk * kChunk; j < std::min(samples, (chunk + 1) * kChunk); ++j) {
      const std::size_t i = eligible[j * eligible.size() / samples];
      const std::optional<Eigen::Matrix2d>& affine = affines[i];
      if (!affine) continue;
      RandomStream rng(o.seed, j);
      for (int attempt = 0; attempt < 8; ++attempt) {
        const double angle = rng.uniform(0.0, 2.0 * kPi);
        const double norm = rng.uniform(reach, 2.0 * reach);
        const Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
        const Eigen::Vector2d offset = norm / std::max(std::abs(dir.x()), std::abs(dir.y())) * dir;
        const Eigen::Vector2d displaced = *predictions[i] + *affine * offset;
        const CorrelationOutcome outcome =
            correlation_surface_into(master, points[i], secondary, displaced, *affine, o, s, surface);
        if (outcome == CorrelationOutcome::outside_secondary) continue;
        if (outcome == CorrelationOutcome::not_run) {
          const CorrelationPeak peak = correlation_peak(surface, displaced, *affine, any_score);
          if (peak.outcome != CorrelationOutcome::flat) {
            maxima[j] = peak.score;
            distinct[j] = peak.outcome == CorrelationOutcome::matched;
          }
        }
        break;
      }
    }
  });
  std::vector<char> null_distinct;
  for (std::size_t j = 0; j < samples; ++j)
    if (std::isfinite(maxima[j])) {
      t.null_maxima.push_back(maxima[j]);
      null_distinct.push_back(distinct[j]);
    }
  if (!t.null_maxima.empty()) {
    t.null_median = correlation_upper_quantile(t.null_maxima, 0.5);
    t.null_q90 = correlation_upper_quantile(t.null_maxima, 0.1);
    t.null_q99 = correlation_upper_quantile(t.null_maxima, 0.01);
    t.null_quantile = correlation_upper_quantile(t.null_maxima, o.false_alarm_rate);
    t.null_max = *std::max_element(t.null_maxima.begin(), t.null_maxima.end());
  }
  t.adaptive = t.null_maxima.size() >= static_cast<std::size_t>(o.min_null_surfaces);
  t.min_score = t.adaptive ? std::clamp(t.null_quantile, o.adaptive_floor, o.adaptive_ceiling) : o.min_score;
  if (!t.null_maxima.empty()) {
    std::size_t matched = 0;
    for (std::size_t j = 0; j < t.null_maxima.size(); ++j)
      if (null_distinct[j] && t.null_maxima[j] >= t.min_score) ++matched;
    const double n = static_cast<double>(t.null_maxima.size());
    t.null_match_rate = static_cast<double>(matched) / n;
    t.null_match_rate_bound = wilson_upper_bound(t.null_match_rate, n, 3.09);  // one-sided 99.9 %
  }
  return t;
}

// Points whose surfaces read one secondary patch, sampled through the local affine of the first
// (`reference`) around its prediction: member m's search is centred on lattice[m] of that patch,
// i.e. on b_ref + A_ref lattice[m] (its own prediction rounded to the patch's master-pixel grid).
struct CorrelationGroup {
  std::vector<std::size_t> members;      // point indices; members[0] is the reference
  std::vector<Eigen::Vector2i> lattice;  // lattice[0] = (0, 0)
};

// The groups of correlation_match (options.shared_tile_px, shared_affine_tolerance_px): the
// candidates in order of their master tile (rows of tiles, then columns, then the point's index);
// each joins the first group of its tile whose reference has the same anti-aliasing, an affine
// within the tolerance of its own, and puts it on a lattice position within 2 tiles of the
// reference whose search stays inside the secondary image; otherwise it opens a group.
// Deterministic: the groups depend on the points, predictions and affines alone.
template <class T>
std::vector<CorrelationGroup> correlation_groups(const Raster<T>& secondary, const std::vector<Eigen::Vector2d>& points,
                                                 const std::vector<std::optional<Eigen::Vector2d>>& predictions,
                                                 const std::vector<std::optional<Eigen::Matrix2d>>& affines,
                                                 const std::vector<std::size_t>& candidates,
                                                 const CorrelationMatchOptions& o) {
  std::vector<CorrelationGroup> groups;
  groups.reserve(candidates.size());
  if (o.shared_tile_px <= 0) {
    for (std::size_t i : candidates) groups.push_back({{i}, {Eigen::Vector2i::Zero()}});
    return groups;
  }
  const double tile = o.shared_tile_px;
  struct Keyed {
    std::int64_t ty, tx;
    std::size_t i;
  };
  std::vector<Keyed> keyed;
  keyed.reserve(candidates.size());
  for (std::size_t i : candidates)
    keyed.push_back({static_cast<std::int64_t>(std::floor(points[i].y() / tile)),
                     static_cast<std::int64_t>(std::floor(points[i].x() / tile)), i});
  std::sort(keyed.begin(), keyed.end(), [](const Keyed& l, const Keyed& r) {
    return l.ty != r.ty ? l.ty < r.ty : l.tx != r.tx ? l.tx < r.tx : l.i < r.i;
  });
  const double half = o.window_px / 2;
  const int max_lattice = 2 * o.shared_tile_px;
  struct Open {
    Eigen::Matrix2d affine, inverse;
    Eigen::Vector2d centre;
    int k;
    bool shareable;
    std::size_t group;
  };
  std::vector<Open> open;  // the groups of the current tile
  for (std::size_t at = 0; at < keyed.size(); ++at) {
    if (at == 0 || keyed[at].ty != keyed[at - 1].ty || keyed[at].tx != keyed[at - 1].tx) open.clear();
    const std::size_t i = keyed[at].i;
    const Eigen::Matrix2d& a = *affines[i];
    const Eigen::Vector2d& b = *predictions[i];
    const int k = correlation_subsamples(a, o);
    bool joined = false;
    if (std::abs(a.determinant()) > 1e-9) {
      for (const Open& g : open) {
        if (!g.shareable || g.k != k) continue;
        const Eigen::Matrix2d d = (a - g.affine).cwiseAbs();
        // The largest move of a window's sample, secondary px, between the two affines.
        if (half * std::max(d(0, 0) + d(0, 1), d(1, 0) + d(1, 1)) > o.shared_affine_tolerance_px) continue;
        const Eigen::Vector2d q = g.inverse * (b - g.centre);
        if (!(q.cwiseAbs().maxCoeff() <= max_lattice)) continue;
        const Eigen::Vector2i lattice(static_cast<int>(std::lround(q.x())), static_cast<int>(std::lround(q.y())));
        if (!correlation_inside(secondary.width(), secondary.height(), g.centre + g.affine * lattice.cast<double>(),
                                g.affine, correlation_reach(o, k)))
          continue;
        groups[g.group].members.push_back(i);
        groups[g.group].lattice.push_back(lattice);
        joined = true;
        break;
      }
    }
    if (joined) continue;
    const bool shareable = std::abs(a.determinant()) > 1e-9;
    open.push_back({a, shareable ? Eigen::Matrix2d(a.inverse()) : Eigen::Matrix2d::Zero(), b, k, shareable,
                    groups.size()});
    groups.push_back({{i}, {Eigen::Vector2i::Zero()}});
  }
  return groups;
}

// The peaks of a group's members into peaks[member]: one secondary patch over all their searches,
// then each member's master window, surface, peak, and (when matched) the sub-pixel rounds through
// its own prediction and local affine.
template <class T>
void correlation_group_peaks(const Raster<T>& master, const Raster<T>& secondary,
                             const std::vector<Eigen::Vector2d>& points,
                             const std::vector<std::optional<Eigen::Vector2d>>& predictions,
                             const std::vector<std::optional<Eigen::Matrix2d>>& affines, const CorrelationGroup& group,
                             const CorrelationMatchOptions& o, CorrelationScratch& s, Eigen::MatrixXd& surface,
                             std::vector<CorrelationPeak>& peaks) {
  const std::size_t ref = group.members.front();
  const Eigen::Matrix2d& affine = *affines[ref];
  const Eigen::Vector2d& centre = *predictions[ref];
  const int r = o.search_radius_px, half_region = o.window_px / 2 + r + 1, shifts = 2 * r + 1;
  Eigen::Vector2i lo = group.lattice.front(), hi = lo;
  for (const Eigen::Vector2i& q : group.lattice) {
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  s.k = correlation_subsamples(affine, o);
  const bool finite = correlation_secondary_patch(secondary, centre, affine, lo.x() - half_region, lo.y() - half_region,
                                                  hi.x() - lo.x() + 2 * half_region + 1,
                                                  hi.y() - lo.y() + 2 * half_region + 1, s.k, o, s);
  for (std::size_t m = 0; m < group.members.size(); ++m) {
    const std::size_t i = group.members[m];
    CorrelationPeak& p = peaks[i];
    const CorrelationOutcome window = correlation_master_window(master, points[i], o, s);
    if (window != CorrelationOutcome::not_run || !finite) {
      p.outcome = window != CorrelationOutcome::not_run ? window : CorrelationOutcome::flat;
      continue;
    }
    const Eigen::Vector2i& q = group.lattice[m];
    correlation_scores(s.master, s.channels, q.x() - lo.x(), q.y() - lo.y(), shifts, shifts, surface, s.cross);
    p = correlation_peak(surface, Eigen::Vector2d(centre + affine * q.cast<double>()), affine, o);
    const Eigen::Vector2d& b0 = *predictions[i];
    const Eigen::Matrix2d& own = *affines[i];
    // The shift from the point's own prediction through its own affine (m > 0: a member's affine is
    // invertible, correlation_groups checked it).
    if (m > 0 && p.b.allFinite()) p.shift = own.inverse() * (p.b - b0);
    if (p.outcome == CorrelationOutcome::matched) correlation_refine(secondary, b0, own, o, s, p);
  }
}

// The pair test of options.pair_significance on a call's judged peaks: turns every match into
// `chance` when chance explains their number.
inline void correlation_pair_test(std::vector<CorrelationPeak>& peaks, CorrelationThreshold& t,
                                  const CorrelationMatchOptions& o) {
  if (!t.adaptive || o.pair_significance <= 0.0) return;
  for (const CorrelationPeak& p : peaks) {
    const CorrelationOutcome c = p.outcome;
    if (c == CorrelationOutcome::matched || c == CorrelationOutcome::low_score ||
        c == CorrelationOutcome::ambiguous || c == CorrelationOutcome::at_border)
      ++t.judged;
    if (c == CorrelationOutcome::matched) ++t.passed;
  }
  t.chance_probability = std::exp(log_binomial_tail(t.judged, t.null_match_rate_bound, t.passed));
  t.rejected_as_chance = t.chance_probability > o.pair_significance;
  if (!t.rejected_as_chance) return;
  for (CorrelationPeak& p : peaks)
    if (p.outcome == CorrelationOutcome::matched) p.outcome = CorrelationOutcome::chance;
}

}  // namespace detail

template <class T, class Transfer>
CorrelationMatchResult correlation_match(const Raster<T>& master, const Raster<T>& secondary,
                                         const std::vector<Eigen::Vector2d>& points, const Transfer& transfer,
                                         const CorrelationMatchOptions& options) {
  static_assert(std::is_arithmetic_v<T>, "correlation_match: the pixel type must be arithmetic");
  static_assert(check_transfer<Transfer>());
  options.check();
  detail::check_correlation_image(master, "master");
  detail::check_correlation_image(secondary, "secondary");
  for (std::size_t i = 0; i < points.size(); ++i)
    DIACHRON_CHECK(points[i].allFinite(), "correlation_match: master point " << i << " is not finite");
  CorrelationMatchResult result;
  result.peaks.assign(points.size(), CorrelationPeak{});
  constexpr std::size_t kChunk = 32;  // each task allocates its scratch once
  const std::size_t chunks = (points.size() + kChunk - 1) / kChunk;
  // The predictions first: the adaptive threshold samples among the points they put inside.
  std::vector<std::optional<Eigen::Vector2d>> predictions(points.size());
  parallel_for(chunks, options.threads, [&](std::size_t chunk) {
    for (std::size_t i = chunk * kChunk; i < std::min(points.size(), (chunk + 1) * kChunk); ++i) {
      predictions[i] = transfer(points[i]);
      DIACHRON_CHECK(!predictions[i] || predictions[i]->allFinite(),
                     "correlation_match: the transfer sends master point "
                         << i << " (" << points[i].transpose() << ") to a non-finite position");
    }
  });
  const int half = options.window_px / 2;
  auto inside_secondary = [&](const Eigen::Vector2d& b) {
    return b.x() >= 0.0 && b.y() >= 0.0 && b.x() <= secondary.width() - 1 && b.y() <= secondary.height() - 1;
  };
  auto inside_master = [&](const Eigen::Vector2d& a) {
    return detail::correlation_inside(master.width(), master.height(), a, Eigen::Matrix2d::Identity(), half + 1);
  };
  // The local affines of the points predicted onto the secondary image; a prediction off it leaves
  // it with any window around it (the window's corners surround its centre): its local affine, four
  // more transfers, is not needed to say so. The null surfaces reuse them.
  std::vector<std::optional<Eigen::Matrix2d>> affines(points.size());
  parallel_for(chunks, options.threads, [&](std::size_t chunk) {
    for (std::size_t i = chunk * kChunk; i < std::min(points.size(), (chunk + 1) * kChunk); ++i)
      if (predictions[i] && inside_secondary(*predictions[i]))
        affines[i] = local_affine(transfer, points[i], options.affine_step());
  });
  if (options.adaptive_threshold) {
    std::vector<std::size_t> eligible;
    for (std::size_t i = 0; i < points.size(); ++i)
      if (predictions[i] && inside_secondary(*predictions[i]) && inside_master(points[i])) eligible.push_back(i);
    result.threshold =
        detail::correlation_null_threshold(master, secondary, points, predictions, affines, eligible, options);
  } else {
    result.threshold.min_score = options.min_score;
  }
  CorrelationMatchOptions judged = options;
  judged.min_score = result.threshold.min_score;
  // The verdicts that need no surface; the others go into groups that share a secondary patch.
  std::vector<std::size_t> candidates;
  for (std::size_t i = 0; i < points.size(); ++i) {
    CorrelationPeak& p = result.peaks[i];
    const std::optional<Eigen::Vector2d>& b0 = predictions[i];
    if (b0 && !inside_secondary(*b0)) {
      p.outcome = inside_master(points[i]) ? CorrelationOutcome::outside_secondary : CorrelationOutcome::outside_master;
    } else if (!b0 || !affines[i]) {
      p.outcome = CorrelationOutcome::no_prediction;
    } else if (!inside_master(points[i])) {
      p.outcome = CorrelationOutcome::outside_master;
    } else if (!detail::correlation_inside(secondary.width(), secondary.height(), *b0, *affines[i],
                                           detail::correlation_reach(judged, detail::correlation_subsamples(*affines[i], judged)))) {
      p.outcome = CorrelationOutcome::outside_secondary;
    } else {
      candidates.push_back(i);
    }
  }
  const std::vector<detail::CorrelationGroup> groups =
      detail::correlation_groups(secondary, points, predictions, affines, candidates, judged);
  constexpr std::size_t kGroupChunk = 4;
  parallel_for((groups.size() + kGroupChunk - 1) / kGroupChunk, options.threads, [&](std::size_t chunk) {
    detail::CorrelationScratch s;
    Eigen::MatrixXd surface;
    for (std::size_t g = chunk * kGroupChunk; g < std::min(groups.size(), (chunk + 1) * kGroupChunk); ++g)
      detail::correlation_group_peaks(master, secondary, points, predictions, affines, groups[g], judged, s, surface,
                                      result.peaks);
  });
  detail::correlation_pair_test(result.peaks, result.threshold, options);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const CorrelationPeak& p = result.peaks[i];
    switch (p.outcome) {
      case CorrelationOutcome::matched:
        result.matches.push_back({points[i], p.b, p.score});
        result.point_index.push_back(i);
        break;
      case CorrelationOutcome::no_prediction: ++result.no_prediction; break;
      case CorrelationOutcome::outside_master: ++result.outside_master; break;
      case CorrelationOutcome::outside_secondary: ++result.outside_secondary; break;
      case CorrelationOutcome::flat: ++result.flat; break;
      case CorrelationOutcome::low_score: ++result.low_score; break;
      case CorrelationOutcome::ambiguous: ++result.ambiguous; break;
      case CorrelationOutcome::at_border: ++result.at_border; break;
      case CorrelationOutcome::chance: ++result.chance; break;
      case CorrelationOutcome::not_run: break;
    }
  }
  result.success = !result.matches.empty();
  return result;
}

template <class T, class Transfer>
CorrelationMatchResult correlation_match(const Raster<T>& master, const Raster<T>& secondary,
                                         const std::vector<InterestPoint>& points, const Transfer& transfer,
                                         const CorrelationMatchOptions& options) {
  std::vector<Eigen::Vector2d> positions;
  positions.reserve(points.size());
  for (const InterestPoint& p : points) positions.push_back(p.position);
  return correlation_match(master, secondary, positions, transfer, options);
}

}  // namespace diachron
