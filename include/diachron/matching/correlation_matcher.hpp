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
#include <diachron/matching/grid_interest_points.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/robust/chance_inliers.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/validation/ncc_validator.hpp>  // detail::ncc_bilinear, the shared sampler

namespace diachron {

/// The similarity the correlation surface measures. All are zero-mean normalised correlations in
/// [-1, 1] over one or two channels computed on the resampled windows (master geometry).
enum class CorrelationMeasure : std::uint8_t {
  intensity,    ///< grey values (classic NCC): invariant to gain and offset
  gradient,     ///< the gradient vector (gx, gy): also ignores slow illumination ramps
  orientation,  ///< the doubled-angle gradient |g| (cos 2t, sin 2t): invariant to contrast inversion
                ///< (g and -g give the same vector), weighted by the gradient magnitude
};

/// "intensity", "gradient" or "orientation".
inline const char* to_string(CorrelationMeasure m) {
  return m == CorrelationMeasure::intensity ? "intensity"
         : m == CorrelationMeasure::gradient ? "gradient"
                                              : "orientation";
}

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

// The products of a patch's affine with each column's and each row's sub-sample offsets
// (correlation_sample), kept between calls so that their storage is allocated once per task.
struct CorrelationOffsets {
  std::vector<double> col_x, col_y, row_x, row_y;
};

// Samples a side x side patch at c + m * o, o in [-(side/2), side/2]^2 (side odd), averaging
// k x k sub-samples spread over each master pixel when k > 1. The products of m with each column's
// and each row's offsets are taken once (into `offsets`): the positions are those of c + m * o to
// the last bit (the same products and sums), at a fraction of the work.
template <class T>
void correlation_sample(const Raster<T>& img, const Eigen::Vector2d& c, const Eigen::Matrix2d& m, int side, int k,
                        CorrelationOffsets& offsets, std::vector<double>& out) {
  out.resize(static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  const int first = -(side / 2);
  const std::size_t n = static_cast<std::size_t>(side) * static_cast<std::size_t>(k);
  std::vector<double>& col_x = offsets.col_x;
  std::vector<double>& col_y = offsets.col_y;
  std::vector<double>& row_x = offsets.row_x;
  std::vector<double>& row_y = offsets.row_y;
  col_x.resize(n);
  col_y.resize(n);
  row_x.resize(n);
  row_y.resize(n);
  for (int i = 0; i < side; ++i)
    for (int sub = 0; sub < k; ++sub) {
      const double o = first + i + (sub + 0.5) / k - 0.5;
      const std::size_t q = static_cast<std::size_t>(i * k + sub);
      col_x[q] = m(0, 0) * o;
      col_y[q] = m(1, 0) * o;
      row_x[q] = m(0, 1) * o;
      row_y[q] = m(1, 1) * o;
    }
  std::size_t idx = 0;
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i) {
      double sum = 0.0;
      for (int sy = 0; sy < k; ++sy) {
        const std::size_t qy = static_cast<std::size_t>(j * k + sy);
        for (int sx = 0; sx < k; ++sx) {
          const std::size_t qx = static_cast<std::size_t>(i * k + sx);
          sum += ncc_bilinear(img, c.x() + (col_x[qx] + row_x[qy]), c.y() + (col_y[qx] + row_y[qy]));
        }
      }
      out[idx++] = sum / (k * k);
    }
}

// The measure's channels of a patch of side `side` (1 px margin used by the gradients), on the
// inner (side - 2)^2 pixels, row-major; one or two channels.
inline int correlation_channels(CorrelationMeasure measure, const std::vector<double>& patch, int side,
                                std::vector<double>& c0, std::vector<double>& c1) {
  const int inner = side - 2;
  const std::size_t n = static_cast<std::size_t>(inner) * static_cast<std::size_t>(inner);
  c0.resize(n);
  c1.resize(n);
  auto v = [&](int x, int y) {
    return patch[static_cast<std::size_t>(y) * static_cast<std::size_t>(side) + static_cast<std::size_t>(x)];
  };
  std::size_t idx = 0;
  for (int y = 1; y <= inner; ++y)
    for (int x = 1; x <= inner; ++x, ++idx) {
      if (measure == CorrelationMeasure::intensity) {
        c0[idx] = v(x, y);
        continue;
      }
      const double gx = 0.5 * (v(x + 1, y) - v(x - 1, y)), gy = 0.5 * (v(x, y + 1) - v(x, y - 1));
      if (measure == CorrelationMeasure::gradient) {
        c0[idx] = gx;
        c1[idx] = gy;
        continue;
      }
      const double mag = std::sqrt(gx * gx + gy * gy);
      // |g| (cos 2t, sin 2t) = ((gx^2 - gy^2), 2 gx gy) / |g|: the same for g and -g.
      c0[idx] = mag > 0.0 ? (gx * gx - gy * gy) / mag : 0.0;
      c1[idx] = mag > 0.0 ? 2.0 * gx * gy / mag : 0.0;
    }
  return measure == CorrelationMeasure::intensity ? 1 : 2;
}

// Integral image (one leading row and column of zeros) of a side x side array, and of its squares.
inline void correlation_integrals(const std::vector<double>& c, int side, std::vector<double>& sum,
                                  std::vector<double>& sum2) {
  const std::size_t s1 = static_cast<std::size_t>(side) + 1;
  sum.assign(s1 * s1, 0.0);
  sum2.assign(s1 * s1, 0.0);
  for (int y = 0; y < side; ++y) {
    double r = 0.0, r2 = 0.0;
    for (int x = 0; x < side; ++x) {
      const double v = c[static_cast<std::size_t>(y) * static_cast<std::size_t>(side) + static_cast<std::size_t>(x)];
      r += v;
      r2 += v * v;
      sum[(y + 1) * s1 + (x + 1)] = sum[y * s1 + (x + 1)] + r;
      sum2[(y + 1) * s1 + (x + 1)] = sum2[y * s1 + (x + 1)] + r2;
    }
  }
}

inline double correlation_box(const std::vector<double>& integral, int side, int x, int y, int w) {
  const std::size_t s1 = static_cast<std::size_t>(side) + 1;
  return integral[(y + w) * s1 + (x + w)] - integral[y * s1 + (x + w)] - integral[(y + w) * s1 + x] +
         integral[y * s1 + x];
}

struct CorrelationScratch {
  std::vector<double> master_patch, secondary_patch, m0, m1, s0, s1, sum0, sum20, sum1, sum21, f0, f1;
  std::vector<double> cross;  // one row of shifts (correlation_surface_into)
  CorrelationOffsets offsets;  // correlation_sample's
  double master_var = 0.0;  // sum of squares of the zero-mean master channels
  int channels = 1;
  int k = 1;  // anti-aliasing sub-samples per axis
};

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

// The surface into `surface` ((2R+1)^2); returns the outcome (not_run when the surface is valid).
template <class T>
CorrelationOutcome correlation_surface_into(const Raster<T>& master, const Eigen::Vector2d& a,
                                            const Raster<T>& secondary, const Eigen::Vector2d& b0,
                                            const Eigen::Matrix2d& affine, const CorrelationMatchOptions& o,
                                            CorrelationScratch& s, Eigen::MatrixXd& surface) {
  const int half = o.window_px / 2, r = o.search_radius_px;
  const int master_side = o.window_px + 2;            // +1 px margin for the gradients
  const int secondary_side = o.window_px + 2 * r + 2;  // every shift's window, plus the margin
  const Eigen::Matrix2d identity = Eigen::Matrix2d::Identity();
  if (!correlation_inside(master.width(), master.height(), a, identity, half + 1))
    return CorrelationOutcome::outside_master;
  int k = 1;
  if (o.antialias) k = std::clamp(static_cast<int>(std::ceil(affine_singular_values(affine).x() - 1e-6)), 1, 4);
  // The sub-samples reach half a master pixel beyond the outer offsets.
  if (!correlation_inside(secondary.width(), secondary.height(), b0, affine, half + r + 1 + (k > 1 ? 0.5 : 0.0)))
    return CorrelationOutcome::outside_secondary;
  s.k = k;
  correlation_sample(master, a, identity, master_side, 1, s.offsets, s.master_patch);
  correlation_sample(secondary, b0, affine, secondary_side, k, s.offsets, s.secondary_patch);
  const int channels = correlation_channels(o.measure, s.master_patch, master_side, s.m0, s.m1);
  correlation_channels(o.measure, s.secondary_patch, secondary_side, s.s0, s.s1);
  const int w = o.window_px, side = secondary_side - 2;
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(w);
  if (!std::all_of(s.m0.begin(), s.m0.end(), [](double v) { return std::isfinite(v); }) ||
      !std::all_of(s.s0.begin(), s.s0.end(), [](double v) { return std::isfinite(v); }))
    return CorrelationOutcome::flat;
  // Zero-mean master channels: the cross term then needs no secondary mean.
  double master_var = 0.0, master_scale = 0.0;
  for (int c = 0; c < channels; ++c) {
    std::vector<double>& m = c == 0 ? s.m0 : s.m1;
    double mean = 0.0;
    for (double v : m) mean += v;
    mean /= static_cast<double>(n);
    for (double& v : m) {
      master_scale += v * v;
      v -= mean;
      master_var += v * v;
    }
  }
  // Rounding of a constant window leaves ~1e-20 relative variance: that is flat, not texture.
  if (!(master_var > 1e-12 * std::max(1.0, master_scale))) return CorrelationOutcome::flat;
  s.master_var = master_var;
  s.channels = channels;
  correlation_integrals(s.s0, side, s.sum0, s.sum20);
  if (channels == 2) correlation_integrals(s.s1, side, s.sum1, s.sum21);
  const int shifts = 2 * r + 1;
  surface.resize(shifts, shifts);
  // A row of shifts at a time: each shift's sum over a master row takes the products in the order
  // of the row's pixels, and cross[dx] the rows' sums in channel and row order, so every score is
  // the sum of the same terms in the same order as one window at a time.
  s.cross.resize(static_cast<std::size_t>(shifts));
  double* const cross = s.cross.data();
  for (int dy = 0; dy < shifts; ++dy) {
    std::fill(cross, cross + shifts, 0.0);
    for (int c = 0; c < channels; ++c) {
      const std::vector<double>& m = c == 0 ? s.m0 : s.m1;
      const std::vector<double>& sc = c == 0 ? s.s0 : s.s1;
      for (int j = 0; j < w; ++j) {
        const double* mrow = m.data() + static_cast<std::size_t>(j) * static_cast<std::size_t>(w);
        const double* srow = sc.data() + static_cast<std::size_t>(dy + j) * static_cast<std::size_t>(side);
        // Eight shifts side by side: eight independent sums keep the adder busy where one sum
        // would wait on its own previous addition at every pixel.
        int dx = 0;
        for (; dx + 8 <= shifts; dx += 8) {
          double a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0, a4 = 0.0, a5 = 0.0, a6 = 0.0, a7 = 0.0;
          const double* sp = srow + dx;
          for (int i = 0; i < w; ++i) {
            const double mi = mrow[i];
            a0 += mi * sp[i];
            a1 += mi * sp[i + 1];
            a2 += mi * sp[i + 2];
            a3 += mi * sp[i + 3];
            a4 += mi * sp[i + 4];
            a5 += mi * sp[i + 5];
            a6 += mi * sp[i + 6];
            a7 += mi * sp[i + 7];
          }
          cross[dx] += a0;
          cross[dx + 1] += a1;
          cross[dx + 2] += a2;
          cross[dx + 3] += a3;
          cross[dx + 4] += a4;
          cross[dx + 5] += a5;
          cross[dx + 6] += a6;
          cross[dx + 7] += a7;
        }
        for (; dx < shifts; ++dx) {
          double a = 0.0;
          const double* sp = srow + dx;
          for (int i = 0; i < w; ++i) a += mrow[i] * sp[i];
          cross[dx] += a;
        }
      }
    }
    for (int dx = 0; dx < shifts; ++dx) {
      double var = 0.0, scale = 0.0;
      for (int c = 0; c < channels; ++c) {
        const double sum = correlation_box(c == 0 ? s.sum0 : s.sum1, side, dx, dy, w);
        const double sum2 = correlation_box(c == 0 ? s.sum20 : s.sum21, side, dx, dy, w);
        var += sum2 - sum * sum / static_cast<double>(n);
        scale += sum2;
      }
      surface(dy, dx) = var > 1e-12 * std::max(1.0, scale)
                            ? std::clamp(cross[dx] / std::sqrt(master_var * var), -1.0, 1.0)
                            : std::numeric_limits<double>::quiet_NaN();
    }
  }
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
  correlation_sample(secondary, centre, affine, side, s.k, s.offsets, s.secondary_patch);
  correlation_channels(o.measure, s.secondary_patch, side, s.f0, s.f1);
  const double n = static_cast<double>(s.f0.size());
  double cross = 0.0, var = 0.0, scale = 0.0;
  for (int c = 0; c < s.channels; ++c) {
    const std::vector<double>& m = c == 0 ? s.m0 : s.m1;
    const std::vector<double>& f = c == 0 ? s.f0 : s.f1;
    double sum = 0.0, sum2 = 0.0;
    for (std::size_t i = 0; i < f.size(); ++i) {
      cross += m[i] * f[i];
      sum += f[i];
      sum2 += f[i] * f[i];
    }
    var += sum2 - sum * sum / n;
    scale += sum2;
  }
  if (!std::isfinite(var) || !(var > 1e-12 * std::max(1.0, scale))) return nan;
  return std::clamp(cross / std::sqrt(s.master_var * var), -1.0, 1.0);
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
  detail::CorrelationScratch s;
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
  detail::CorrelationScratch s;
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
template <class T, class Transfer>
CorrelationThreshold correlation_null_threshold(const Raster<T>& master, const Raster<T>& secondary,
                                                const std::vector<Eigen::Vector2d>& points,
                                                const std::vector<std::optional<Eigen::Vector2d>>& predictions,
                                                const std::vector<std::size_t>& eligible, const Transfer& transfer,
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
      const std::optional<Eigen::Matrix2d> affine = local_affine(transfer, points[i], o.affine_step());
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
  if (options.adaptive_threshold) {
    std::vector<std::size_t> eligible;
    for (std::size_t i = 0; i < points.size(); ++i)
      if (predictions[i] && inside_secondary(*predictions[i]) && inside_master(points[i])) eligible.push_back(i);
    result.threshold =
        detail::correlation_null_threshold(master, secondary, points, predictions, eligible, transfer, options);
  } else {
    result.threshold.min_score = options.min_score;
  }
  CorrelationMatchOptions judged = options;
  judged.min_score = result.threshold.min_score;
  parallel_for(chunks, options.threads, [&](std::size_t chunk) {
    detail::CorrelationScratch s;
    Eigen::MatrixXd surface;
    for (std::size_t i = chunk * kChunk; i < std::min(points.size(), (chunk + 1) * kChunk); ++i) {
      CorrelationPeak& p = result.peaks[i];
      const std::optional<Eigen::Vector2d>& b0 = predictions[i];
      // A prediction off the secondary image leaves it with any window around it (the window's
      // corners surround its centre): its local affine, four more transfers, is not needed to say so.
      if (b0 && !inside_secondary(*b0)) {
        p.outcome =
            inside_master(points[i]) ? CorrelationOutcome::outside_secondary : CorrelationOutcome::outside_master;
        continue;
      }
      const std::optional<Eigen::Matrix2d> affine =
          b0 ? local_affine(transfer, points[i], judged.affine_step()) : std::nullopt;
      if (!b0 || !affine) {
        p.outcome = CorrelationOutcome::no_prediction;
        continue;
      }
      const CorrelationOutcome o =
          detail::correlation_surface_into(master, points[i], secondary, *b0, *affine, judged, s, surface);
      if (o != CorrelationOutcome::not_run) {
        p.outcome = o;
        continue;
      }
      p = detail::correlation_peak(surface, *b0, *affine, judged);
      if (p.outcome == CorrelationOutcome::matched) detail::correlation_refine(secondary, *b0, *affine, judged, s, p);
    }
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
