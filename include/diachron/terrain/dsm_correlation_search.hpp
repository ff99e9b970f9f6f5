#pragma once
/// @file
/// Dense search of one DSM in another by the correlation of their heights: the master DSM is
/// rotated and scaled over a grid of hypotheses (rotation over 360 degrees about the vertical, a log
/// grid of scale ratios around the cell-size ratio), and for each, the zero-mean normalised cross-
/// correlation of heights over every translation is computed at once with masks (terrain/
/// masked_ncc.hpp: holes and partial overlap are exact). Coarse to fine: the whole grid on small
/// working rasters, then the best few hypotheses refined at finer rasters and finer steps. The
/// winner must stand out from the hypotheses that map the master elsewhere, or hold tile by tile
/// where no other candidate does (terrain/tile_agreement.hpp), otherwise there is no answer. For
/// DSMs with too little texture for feature matchers (a coarse DSM of 20 x 30 cells);
/// ZNCC is blind to the gain and offset of heights, hence to the frames' height scale and datum.
/// By default (CorrelationSignal::gradient) it correlates the heights' gradient (two channels), which
/// is also blind to a tilt between the frames; CorrelationSignal::heights correlates the heights.
/// The scales of the coarse grid, then the candidates, run on `threads` (the result does not depend
/// on them) and report `progress`.
///
/// Conventions: pixel coordinates are pixel centres (diachron's convention); the result maps master
/// DSM pixels to secondary DSM pixels, p_s = scale R(angle) D p_m + translation, with D = diag(1, -1)
/// when `mirrored` (the two geotransforms have determinants of opposite sign), identity otherwise.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/progress.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/masked_ncc.hpp>
#include <diachron/terrain/tile_agreement.hpp>

namespace diachron {

/// What dsm_correlation_search() correlates.
enum class CorrelationSignal {
  /// The heights themselves: the whole relief, blind to gain and offset.
  heights,
  /// The heights' gradient (two channels, central differences on the working raster, correlated as
  /// one signal by MaskedNcc): blind also to a tilt between the frames, and local, so that ground
  /// that changed between the epochs (a lava dome, a glacier) only spoils its own cells instead of
  /// moving the whole correlation, as a change of heights over a third of the overlap does.
  gradient,
};

/// How dsm_correlation_search() weighs a peak's overlap: its strength is Fisher's z of the ZNCC
/// (atanh) times the square root of a number of pixels, as the standard error of z falls with the
/// square root of the samples.
enum class CorrelationStrength {
  /// The overlap's share of the smaller raster's valid pixels (at most 1): a placement that covers
  /// the whole of a small template counts fully, whatever its size.
  share,
  /// The overlap in working pixels over coarse_size_px squared, not capped: a template shrunk by a
  /// small scale hypothesis to a few dozen pixels weighs what its few samples are worth. On DSM pairs
  /// that do not overlap, small smooth templates are where chance correlations win
  /// (docs/rough-coregistration.md, "Cases without an answer").
  samples,
};

/// Options of dsm_correlation_search(). Sizes in working-raster pixels, angles in degrees.
struct DsmCorrelationSearchOptions {
  /// The frames' unknown scale (secondary units per master unit) is searched in [1/this, this]:
  /// the pixel scale ratio (master cell in secondary cells) is the cell-size ratio of the two DSMs
  /// (in their own units) times that scale. 2.5 covers SfM frames of scale 0.5 to 2 with a margin of 10 %.
  double frame_scale_range = 2.2;
  /// Scale hypotheses per octave at the coarse level (4: steps of 19 %).
  int scales_per_octave = 4;
  /// Rotation step at the coarse level, degrees (36 rotations over 360 degrees at 10).
  double angle_step_deg = 10.0;
  /// Coarse level: the smaller footprint's shorter side has about this many working pixels (never
  /// finer than the coarser DSM's cell: there is nothing to gain from upsampling), and the larger
  /// footprint's longer side at most four times this many (bounds the FFT size).
  double coarse_size_px = 32.0;
  /// Finest level: the working cell is the coarser DSM's cell, unless the larger footprint's longer
  /// side would exceed this many pixels (bounds the FFT size, hence time and memory).
  double max_size_px = 256.0;
  /// When > 0, heights are correlated after subtracting their local mean over a box of this
  /// fraction of the smaller footprint's shorter side, and pixels whose box is not entirely valid
  /// become holes. Off (0, raw heights) by measurement (docs/rough-coregistration.md): the erosion
  /// around the evaluation's holes left a few percent of a coarse window, and on the gap-8 cases the
  /// true placement scored higher with raw heights (ZNCC 0.96-0.99) than high-passed (0.11-0.96).
  double high_pass_fraction = 0.0;
  /// Heights or their gradient (see CorrelationSignal). The gradient with `samples` by measurement
  /// (docs/rough-coregistration.md, "Weighing a peak by its samples"): on 100 resolution-gap cases it
  /// answered 80 right and none wrong, and none of 190 DSM pairs that do not overlap.
  CorrelationSignal signal = CorrelationSignal::gradient;
  /// Coarse hypotheses refined at the finer levels (the best, each from a different place).
  int candidates = 4;
  /// A shift counts only where the overlap holds at least this fraction of the smaller raster's
  /// valid pixels and at least `min_overlap_px` of them: tiny overlaps give chance correlations.
  double min_overlap_fraction = 0.25;
  int min_overlap_px = 48;
  /// Answer only when the refined ZNCC reaches this...
  double min_score = 0.5;
  /// ...and the winner's coarse strength (Fisher z of its ZNCC, times the square root of its
  /// overlap as `strength` counts it) exceeds that of the best hypothesis that maps the
  /// master elsewhere (another place, a rotation more than 30 degrees or a scale more than 1.5
  /// times off) by this much.
  double min_margin = 0.25;
  /// The alternative to the margin: a winner that falls short of it is still the answer when its
  /// placement holds piece by piece and no other refined candidate's does. At the finest cell its
  /// overlap is cut into tiles (`tiles`), each correlated on its own around the placement, and the
  /// number of tiles that agree must be one that chance gives with probability at most
  /// `max_tile_chance`, for a tile of a wrong placement agreeing with probability `tile_chance`
  /// (binomial_tail()). 0.25 is about twice the rate measured on wrong placements (0.138 over 3313
  /// tiles of the winners on 285 DSM pairs that do not overlap, 0.123 on the wrong winners of the
  /// resolution-gap cases; docs/rough-coregistration.md, "Verification by tiles"): chance
  /// agreements cluster by case. 0 switches the alternative off.
  double max_tile_chance = 1e-3;
  double tile_chance = 0.25;
  TileAgreementOptions tiles;

  /// The frames of a 3D similarity share one scale for X/Y and Z: the regression gain of the
  /// secondary's heights on the master's at the winner must be the horizontal scale it implies,
  /// within this factor (1.5: -33 % to +50 %). ZNCC alone is blind to the gain, and a wrong placement
  /// on terrain of another relief passes it. Infinity switches the test off (heights in other units
  /// than X/Y, e.g. feet over metres).
  double max_gain_factor = 1.5;
  /// How a peak's overlap weighs its ZNCC (see CorrelationStrength, and `signal` for the measurement).
  CorrelationStrength strength = CorrelationStrength::samples;
  /// Worker threads over the coarse level's scales and over the candidates (0 = all cores). The
  /// result does not depend on it. rough_coregistration() sets it to its own `threads`.
  std::size_t threads = 0;
  /// Progress: stage "correlation search: coarse scales" (one unit per scale, each of about 36
  /// rotations), then "correlation search: candidates" (one unit per candidate refined). May be
  /// empty. rough_coregistration() sets it to its own `progress`.
  ProgressCallback progress;

  void check() const {
    DIACHRON_CHECK(max_gain_factor > 1.0, "max_gain_factor must be > 1, got " << max_gain_factor);
    DIACHRON_CHECK(frame_scale_range >= 1.0 && std::isfinite(frame_scale_range),
                   "frame_scale_range must be >= 1, got " << frame_scale_range);
    DIACHRON_CHECK(scales_per_octave >= 1 && scales_per_octave <= 32, "scales_per_octave must be in [1, 32]");
    DIACHRON_CHECK(angle_step_deg > 0.0 && angle_step_deg <= 90.0, "angle_step_deg must be in (0, 90]");
    DIACHRON_CHECK(coarse_size_px >= 8.0 && coarse_size_px <= 1024.0, "coarse_size_px must be in [8, 1024]");
    DIACHRON_CHECK(max_size_px >= coarse_size_px && max_size_px <= 4096.0,
                   "max_size_px must be in [coarse_size_px, 4096]");
    DIACHRON_CHECK(high_pass_fraction >= 0.0 && high_pass_fraction <= 1.0, "high_pass_fraction must be in [0, 1]");
    DIACHRON_CHECK(candidates >= 1 && candidates <= 64, "candidates must be in [1, 64]");
    DIACHRON_CHECK(min_overlap_fraction > 0.0 && min_overlap_fraction <= 1.0, "min_overlap_fraction must be in (0, 1]");
    DIACHRON_CHECK(min_overlap_px >= 4, "min_overlap_px must be >= 4");
    DIACHRON_CHECK(min_score > -1.0 && min_score < 1.0, "min_score must be in (-1, 1)");
    DIACHRON_CHECK(min_margin >= 0.0 && min_margin < 2.0, "min_margin must be in [0, 2)");
    DIACHRON_CHECK(max_tile_chance >= 0.0 && max_tile_chance < 1.0, "max_tile_chance must be in [0, 1)");
    DIACHRON_CHECK(tile_chance > 0.0 && tile_chance < 1.0, "tile_chance must be in (0, 1)");
    tiles.check();
  }
};

/// Wall-clock seconds per stage of dsm_correlation_search().
struct DsmCorrelationTimings {
  double coarse = 0.0;  ///< the whole hypothesis grid at the coarse level
  double refine = 0.0;  ///< the candidates at the finer levels
  double tiles = 0.0;   ///< the candidates' tiles (see DsmCorrelationSearchOptions::max_tile_chance)
  double total = 0.0;
};

/// What dsm_correlation_search() found. Defaults mean no answer.
struct DsmCorrelationResult {
  bool success = false;
  std::string message = "not run";  ///< why not, or a one-line summary
  /// Master pixel -> secondary pixel: p_s = scale R(angle) D p_m + translation (see the file doc).
  double scale = 1.0;
  double angle = 0.0;  ///< radians, counter-clockwise in pixel coordinates
  bool mirrored = false;
  Eigen::Vector2d translation = Eigen::Vector2d::Zero();
  double score = std::numeric_limits<double>::quiet_NaN();         ///< refined ZNCC of the winner
  double coarse_score = std::numeric_limits<double>::quiet_NaN();  ///< its ZNCC at the coarse level
  double runner_up = std::numeric_limits<double>::quiet_NaN();     ///< best coarse ZNCC mapping elsewhere
  /// Coarse strengths (Fisher z of the ZNCC weighted by the overlap, see CorrelationStrength and
  /// detail::correlation_strength) of the winner and of the runner-up; the margin test compares them.
  double strength = std::numeric_limits<double>::quiet_NaN();
  double runner_up_strength = std::numeric_limits<double>::quiet_NaN();
  double runner_up_scale = std::numeric_limits<double>::quiet_NaN();  ///< the runner-up's scale ratio
  double runner_up_angle = std::numeric_limits<double>::quiet_NaN();  ///< and angle, radians
  /// Regression gain of the secondary's heights on the master's at the winner, and the gain the
  /// winner's horizontal scale implies (see DsmCorrelationSearchOptions::max_gain_factor).
  double height_gain = std::numeric_limits<double>::quiet_NaN();
  double expected_gain = std::numeric_limits<double>::quiet_NaN();
  /// The winner's tiles at its finest cell (see DsmCorrelationSearchOptions::max_tile_chance), and the
  /// chance of as many agreeing on a wrong placement.
  TileAgreement tiles;
  double tile_chance = std::numeric_limits<double>::quiet_NaN();
  /// The smallest such chance among the other refined candidates, refined further as the winner (1
  /// when there is none; NaN unless the winner fell short of the margin and its tiles held): an
  /// answer by tiles needs it above max_tile_chance, or the master would fit two places.
  double competitor_tile_chance = std::numeric_limits<double>::quiet_NaN();
  /// The answer (success) was below the margin and passed by its tiles.
  bool by_tiles = false;
  std::size_t hypotheses = 0;  ///< rotation x scale hypotheses correlated, all levels
  int levels = 0;              ///< working resolutions used
  DsmCorrelationTimings seconds;

  /// Maps a master pixel into the secondary's pixels.
  Eigen::Vector2d operator()(const Eigen::Vector2d& p) const {
    return scale * linear_unit() * p + translation;
  }
  /// R(angle) D.
  Eigen::Matrix2d linear_unit() const {
    Eigen::Matrix2d r;
    r << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
    if (mirrored) r.col(1) = -r.col(1);
    return r;
  }
};

namespace detail {

/// Box means of a raster with holes, in constant time per sample (integral images of the valid
/// values and of the valid count): the prefilter that keeps a downsampled height raster from aliasing.
/// Keeps a pointer to the raster: it must outlive the sampler.
class BoxMeanSampler {
 public:
  explicit BoxMeanSampler(const Raster<float>& r) : raster_(&r), w_(r.width()), h_(r.height()) {
    sum_.assign(static_cast<std::size_t>(w_ + 1) * (h_ + 1), 0.0);
    count_.assign(sum_.size(), 0.0);
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) {
        const float v = r(x, y);
        const bool ok = !std::isnan(v);
        const std::size_t i = idx(x + 1, y + 1);
        sum_[i] = (ok ? v : 0.0) + sum_[idx(x, y + 1)] + sum_[idx(x + 1, y)] - sum_[idx(x, y)];
        count_[i] = (ok ? 1.0 : 0.0) + count_[idx(x, y + 1)] + count_[idx(x + 1, y)] - count_[idx(x, y)];
      }
  }
  /// Mean of the cells in the box (centres within `half` of (x, y)); NaN unless every one of them
  /// is inside the raster and valid.
  float mean_full(double x, double y, double half) const {
    const int x0 = static_cast<int>(std::ceil(x - half)), x1 = static_cast<int>(std::floor(x + half));
    const int y0 = static_cast<int>(std::ceil(y - half)), y1 = static_cast<int>(std::floor(y + half));
    if (x0 < 0 || y0 < 0 || x1 >= w_ || y1 >= h_ || x0 > x1 || y0 > y1) return std::numeric_limits<float>::quiet_NaN();
    const auto box = [&](const std::vector<double>& t) {
      return t[idx(x1 + 1, y1 + 1)] - t[idx(x0, y1 + 1)] - t[idx(x1 + 1, y0)] + t[idx(x0, y0)];
    };
    const double area = static_cast<double>(x1 - x0 + 1) * (y1 - y0 + 1);
    if (box(count_) < area - 0.5) return std::numeric_limits<float>::quiet_NaN();
    return static_cast<float>(box(sum_) / area);
  }
  /// Mean of the valid cells whose centres lie within `half` (>= 0.5) of (x, y) along each axis;
  /// NaN when fewer than half of the box's cells are valid (outside the raster counts as a hole).
  float mean(double x, double y, double half) const {
    // A box of one or two cells would smooth by a different amount at every position (the box
    // holds one or two cell centres): below two cells, interpolate bilinearly instead.
    if (half < 1.0) return bilinear(x, y);
    const int x0 = static_cast<int>(std::ceil(x - half)), x1 = static_cast<int>(std::floor(x + half));
    const int y0 = static_cast<int>(std::ceil(y - half)), y1 = static_cast<int>(std::floor(y + half));
    const double area = static_cast<double>(std::max(0, x1 - x0 + 1)) * std::max(0, y1 - y0 + 1);
    const int cx0 = std::max(x0, 0), cx1 = std::min(x1, w_ - 1), cy0 = std::max(y0, 0), cy1 = std::min(y1, h_ - 1);
    if (area <= 0.0 || cx0 > cx1 || cy0 > cy1) return std::numeric_limits<float>::quiet_NaN();
    const auto box = [&](const std::vector<double>& t) {
      return t[idx(cx1 + 1, cy1 + 1)] - t[idx(cx0, cy1 + 1)] - t[idx(cx1 + 1, cy0)] + t[idx(cx0, cy0)];
    };
    const double n = box(count_);
    if (n < 0.5 * area || n < 0.5) return std::numeric_limits<float>::quiet_NaN();
    return static_cast<float>(box(sum_) / n);
  }

 private:
  float bilinear(double x, double y) const {
    constexpr float nan = std::numeric_limits<float>::quiet_NaN();
    if (!(x >= 0.0 && y >= 0.0 && x <= w_ - 1 && y <= h_ - 1)) return nan;
    const int x0 = std::min(static_cast<int>(x), std::max(w_ - 2, 0)), y0 = std::min(static_cast<int>(y), std::max(h_ - 2, 0));
    const int x1 = std::min(x0 + 1, w_ - 1), y1 = std::min(y0 + 1, h_ - 1);
    const double fx = x - x0, fy = y - y0;
    const Raster<float>& r = *raster_;
    const double v = (1 - fx) * (1 - fy) * r(x0, y0) + fx * (1 - fy) * r(x1, y0) + (1 - fx) * fy * r(x0, y1) + fx * fy * r(x1, y1);
    return static_cast<float>(v);  // NaN when any neighbour is a hole
  }
  std::size_t idx(int x, int y) const { return static_cast<std::size_t>(y) * (w_ + 1) + x; }
  const Raster<float>* raster_;
  int w_, h_;
  std::vector<double> sum_, count_;
};

/// One hypothesis of the search: pixel scale ratio, angle, and (once correlated) its best shift.
struct CorrelationHypothesis {
  double ratio = 1.0;   ///< master cell in secondary cells
  double angle = 0.0;   ///< radians
  double score = -std::numeric_limits<double>::infinity();     ///< ZNCC at the peak
  double strength = -std::numeric_limits<double>::infinity();  ///< see correlation_strength()
  Eigen::Vector2d translation = Eigen::Vector2d::Zero();  ///< master px -> secondary px, as in the result
  int scale_index = 0, angle_index = 0;  ///< coarse grid position
};

/// The master raster rotated and scaled into working pixels of cell `g` (secondary pixels per working
/// pixel): template pixel q shows master point (R D)^-1 (g / ratio) (q + origin).
inline Raster<float> make_template(const BoxMeanSampler& master, int mw, int mh, double ratio, double angle,
                                   bool mirrored, double g, Eigen::Vector2d& origin) {
  Eigen::Matrix2d rd;
  rd << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  if (mirrored) rd.col(1) = -rd.col(1);
  const double k = ratio / g;  // working pixels per master pixel
  Eigen::Vector2d lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (int c = 0; c < 4; ++c) {
    const Eigen::Vector2d corner((c & 1) ? mw - 0.5 : -0.5, (c & 2) ? mh - 0.5 : -0.5);
    const Eigen::Vector2d u = k * rd * corner;
    lo = lo.cwiseMin(u);
    hi = hi.cwiseMax(u);
  }
  origin = Eigen::Vector2d(std::floor(lo.x()), std::floor(lo.y()));
  const int w = std::max(1, static_cast<int>(std::ceil(hi.x() - origin.x()))),
            h = std::max(1, static_cast<int>(std::ceil(hi.y() - origin.y())));
  Raster<float> out(w, h, std::numeric_limits<float>::quiet_NaN());
  const Eigen::Matrix2d back = rd.inverse() / k;
  const double half = 0.5 / k;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector2d p = back * (Eigen::Vector2d(x, y) + origin);
      out(x, y) = master.mean(p.x(), p.y(), half);
    }
  return out;
}

/// The secondary raster in working pixels of cell g: working pixel w shows secondary pixel g w + (g - 1) / 2.
inline Raster<float> make_fixed(const BoxMeanSampler& secondary, int sw, int sh, double g) {
  const int w = std::max(1, static_cast<int>(std::ceil(sw / g))), h = std::max(1, static_cast<int>(std::ceil(sh / g)));
  Raster<float> out(w, h);
  const double c = 0.5 * (g - 1.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) out(x, y) = secondary.mean(g * x + c, g * y + c, 0.5 * g);
  return out;
}

/// Subtracts from each pixel the mean of the pixels within `half` pixels (a box), and makes a hole
/// of every pixel whose box is not entirely valid: near a raster's edge or a hole the box would
/// hold other ground on each side (the master's footprint ends where the secondary's terrain goes
/// on), and the two local means would differ where the heights agree.
inline void subtract_local_mean(Raster<float>& r, double half) {
  if (half < 1.0) return;
  const BoxMeanSampler sampler(r);
  Raster<float> out(r.width(), r.height(), std::numeric_limits<float>::quiet_NaN());
  for (int y = 0; y < r.height(); ++y)
    for (int x = 0; x < r.width(); ++x) {
      if (std::isnan(r(x, y))) continue;
      const float m = sampler.mean_full(x, y, half);
      if (!std::isnan(m)) out(x, y) = r(x, y) - m;
    }
  r = std::move(out);
}

/// The two components of the gradient of a working raster (central differences, raster units per
/// pixel); a pixel is a hole in both unless it and its four neighbours are valid.
inline std::vector<Raster<float>> gradient_channels(const Raster<float>& r) {
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Raster<float>> out{Raster<float>(r.width(), r.height(), nan), Raster<float>(r.width(), r.height(), nan)};
  for (int y = 1; y + 1 < r.height(); ++y)
    for (int x = 1; x + 1 < r.width(); ++x) {
      const float gx = 0.5f * (r(x + 1, y) - r(x - 1, y)), gy = 0.5f * (r(x, y + 1) - r(x, y - 1));
      if (std::isnan(r(x, y)) || std::isnan(gx) || std::isnan(gy)) continue;
      out[0](x, y) = gx;
      out[1](x, y) = gy;
    }
  return out;
}

inline std::size_t count_valid(const Raster<float>& r) {
  std::size_t n = 0;
  for (float v : r) n += !std::isnan(v);
  return n;
}

/// How strongly a peak speaks for a placement: Fisher's z of the ZNCC (atanh, which spreads the
/// scores near 1 where true peaks lie) times the square root of overlap / reference. The standard
/// error of z falls as one over the square root of the independent samples, so a high ZNCC over a
/// sliver of overlap (chance on smooth terrain) ranks below a slightly lower one over the whole
/// footprint. `capped` (CorrelationStrength::share): the reference is the smaller raster's valid
/// pixels and the factor at most 1. Not capped (CorrelationStrength::samples): a fixed number of
/// pixels, and more overlapping pixels always weigh more.
inline double correlation_strength(double zncc, double overlap, double reference, bool capped = true) {
  const double r = std::clamp(zncc, -0.9999, 0.9999);
  const double share = overlap / std::max(reference, 1.0);
  return std::atanh(r) * std::sqrt(capped ? std::min(1.0, share) : share);
}

/// Least-squares gain of `fixed` on `moving` over their overlap at shift (dx, dy): cov / var(moving),
/// summed over the channels of a signal, each centred on its own mean. NaN without overlap or variance.
inline double regression_gain(const std::vector<Raster<float>>& fixed, const std::vector<Raster<float>>& moving, int dx,
                              int dy) {
  double cov = 0.0, var = 0.0;
  for (std::size_t c = 0; c < fixed.size() && c < moving.size(); ++c) {
    const OverlapMoments m = overlap_moments(fixed[c], moving[c], dx, dy);
    if (m.n < 2.0) return std::numeric_limits<double>::quiet_NaN();
    cov += m.cov();
    var += m.var_moving();
  }
  return var > 0.0 ? cov / var : std::numeric_limits<double>::quiet_NaN();
}

/// A probability in 3 significant digits ("2.7e-05", "0.0123", "nan").
inline std::string short_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

/// Sub-pixel offset of a peak from three samples (parabola through them), within [-0.5, 0.5].
inline double parabola_offset(double left, double centre, double right) {
  if (std::isnan(left) || std::isnan(right)) return 0.0;
  const double d = left - 2.0 * centre + right;
  if (!(d < 0.0)) return 0.0;
  return std::clamp(0.5 * (left - right) / d, -0.5, 0.5);
}

}  // namespace detail

/// Finds the similarity that maps the master DSM's pixels onto the secondary's by the correlation of
/// their heights (see the file doc). Throws diachron::Error for empty DSMs or invalid options; a DSM
/// pair without a clear answer gives `success == false` and the reason. Deterministic.
inline DsmCorrelationResult dsm_correlation_search(const Dsm& master, const Dsm& secondary,
                                                   const DsmCorrelationSearchOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!master.empty() && !secondary.empty(), "DSM correlation search needs two non-empty DSMs");
  const auto start = std::chrono::steady_clock::now();
  const auto since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  DsmCorrelationResult result;
  if (master.statistics().count < 4 || secondary.statistics().count < 4) {
    result.message = "a DSM has fewer than 4 valid heights";
    return result;
  }
  const auto det = [](const GeoTransform& t) { return t.c[1] * t.c[5] - t.c[2] * t.c[4]; };
  result.mirrored = (det(master.transform()) > 0.0) != (det(secondary.transform()) > 0.0);
  const int mw = master.width(), mh = master.height(), sw = secondary.width(), sh = secondary.height();
  const detail::BoxMeanSampler master_sampler(master.heights()), secondary_sampler(secondary.heights());

  // Working cell g (secondary pixels per working pixel) of a ratio at a level: coarse makes the
  // smaller footprint's shorter side about coarse_size_px; the finest is the coarser DSM's cell,
  // unless the larger footprint's longer side would exceed max_size_px.
  const auto cells = [&](double ratio, double& coarse, double& finest) {
    const double m_short = std::min(mw, mh) * ratio, m_long = std::max(mw, mh) * ratio;
    const double s_short = std::min(sw, sh), s_long = std::max(sw, sh);
    finest = std::max({1.0, ratio, std::max(m_long, s_long) / options.max_size_px});
    // ...and the larger footprint's longer side at most 4 x coarse_size_px: a tiny coarse DSM
    // against a large fine one would otherwise put FFTs of 512 x 512 under every hypothesis.
    coarse = std::max({finest, std::min(m_short, s_short) / options.coarse_size_px,
                       std::max(m_long, s_long) / (4.0 * options.coarse_size_px)});
  };

  // Half-side of the high-pass box in working pixels at cell g (see high_pass_fraction).
  const auto high_pass_half = [&](double ratio, double g) {
    const double m_short = std::min(mw, mh) * ratio, s_short = std::min(sw, sh);
    return 0.5 * options.high_pass_fraction * std::min(m_short, s_short) / g;
  };
  // A working raster as the signal correlated (see CorrelationSignal).
  const auto signal_of = [&](Raster<float> r) {
    if (options.signal == CorrelationSignal::gradient) return detail::gradient_channels(r);
    return std::vector<Raster<float>>{std::move(r)};
  };
  const auto working_fixed = [&](double ratio, double g) {
    Raster<float> fixed = detail::make_fixed(secondary_sampler, sw, sh, g);
    if (options.high_pass_fraction > 0.0) detail::subtract_local_mean(fixed, high_pass_half(ratio, g));
    return signal_of(std::move(fixed));
  };

  // Correlates one hypothesis at cell g: over every shift by FFT (`ncc`), or, with `predicted`,
  // directly at the shifts within `radius` working pixels of it (refinement: a few dozen shifts
  // cost less than the FFTs, and the peak cannot jump to another place).
  std::atomic<std::size_t> hypotheses{0};
  const auto correlate = [&](MaskedNcc* ncc, const std::vector<Raster<float>>& fixed, std::size_t fixed_valid,
                             detail::CorrelationHypothesis& h, double g, const Eigen::Vector2d* predicted,
                             int radius) {
    ++hypotheses;
    Eigen::Vector2d origin;
    Raster<float> heights = detail::make_template(master_sampler, mw, mh, h.ratio, h.angle, result.mirrored, g, origin);
    if (options.high_pass_fraction > 0.0) detail::subtract_local_mean(heights, high_pass_half(h.ratio, g));
    const std::vector<Raster<float>> t = signal_of(std::move(heights));
    const std::size_t t_valid = detail::count_valid(t[0]);
    const int min_overlap = std::max(options.min_overlap_px,
                                     static_cast<int>(std::ceil(options.min_overlap_fraction *
                                                                static_cast<double>(std::min(t_valid, fixed_valid)))));
    h.score = h.strength = -std::numeric_limits<double>::infinity();
    if (t_valid < 4) return;
    MaskedNccMap map;
    if (predicted) {
      const int cx = static_cast<int>(std::lround(predicted->x())), cy = static_cast<int>(std::lround(predicted->y()));
      map.min_dx = cx - radius - 1;
      map.min_dy = cy - radius - 1;
      map.score = Raster<float>(2 * radius + 3, 2 * radius + 3);
      map.overlap = Raster<int>(2 * radius + 3, 2 * radius + 3, 0);
      for (int y = 0; y < map.score.height(); ++y)
        for (int x = 0; x < map.score.width(); ++x)
          map.score(x, y) = static_cast<float>(
              masked_ncc_at(fixed, t, x + map.min_dx, y + map.min_dy, min_overlap, 1e-12, &map.overlap(x, y)));
    } else {
      map = ncc->correlate(t, min_overlap, 1e-12);
    }
    // What a peak's overlap is counted against (see CorrelationStrength).
    const bool by_samples = options.strength == CorrelationStrength::samples;
    const double reference = by_samples ? options.coarse_size_px * options.coarse_size_px
                                        : static_cast<double>(std::min(t_valid, fixed_valid));
    int bx = 0, by = 0;
    double best = -std::numeric_limits<double>::infinity();
    bool found = false;
    for (int y = 0; y < map.score.height(); ++y)
      for (int x = 0; x < map.score.width(); ++x) {
        const double z = map.score(x, y);
        if (std::isnan(z)) continue;
        const double s = detail::correlation_strength(z, map.overlap(x, y), reference, !by_samples);
        if (!(s > best)) continue;
        // The window's rim only serves the sub-pixel fit.
        if (predicted && (x == 0 || y == 0 || x == map.score.width() - 1 || y == map.score.height() - 1)) continue;
        best = s;
        bx = x;
        by = y;
        found = true;
      }
    if (!found) return;
    const auto at = [&](int x, int y) -> double {
      return map.score.contains(x, y) ? map.score(x, y) : std::numeric_limits<double>::quiet_NaN();
    };
    const double peak = map.score(bx, by);
    const Eigen::Vector2d d(bx + map.min_dx + detail::parabola_offset(at(bx - 1, by), peak, at(bx + 1, by)),
                            by + map.min_dy + detail::parabola_offset(at(bx, by - 1), peak, at(bx, by + 1)));
    h.score = peak;
    h.strength = best;
    // p_s = g (q + d) + (g - 1) / 2 with q = u - origin, u = (ratio / g) R D p_m.
    h.translation = g * (d - origin) + Eigen::Vector2d::Constant(0.5 * (g - 1.0));
  };
  // The shift (working px) at which hypothesis h puts the master's template at cell g.
  const auto predicted_shift = [&](const detail::CorrelationHypothesis& from, const detail::CorrelationHypothesis& to,
                                   double g) {
    // Keep the master's centre where `from` put it; solve for `to`'s translation, then its shift.
    const Eigen::Vector2d centre(0.5 * (mw - 1), 0.5 * (mh - 1));
    DsmCorrelationResult a;
    a.scale = from.ratio;
    a.angle = from.angle;
    a.mirrored = result.mirrored;
    a.translation = from.translation;
    DsmCorrelationResult b = a;
    b.scale = to.ratio;
    b.angle = to.angle;
    b.translation = Eigen::Vector2d::Zero();
    const Eigen::Vector2d t = a(centre) - b(centre);
    Eigen::Vector2d origin;
    // The origin depends only on the template's geometry: recompute it cheaply from the corners.
    Eigen::Matrix2d rd = b.linear_unit();
    const double k = to.ratio / g;
    Eigen::Vector2d lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
    for (int c = 0; c < 4; ++c) {
      const Eigen::Vector2d corner((c & 1) ? mw - 0.5 : -0.5, (c & 2) ? mh - 0.5 : -0.5);
      lo = lo.cwiseMin(k * rd * corner);
    }
    origin = Eigen::Vector2d(std::floor(lo.x()), std::floor(lo.y()));
    return Eigen::Vector2d((t - Eigen::Vector2d::Constant(0.5 * (g - 1.0))) / g + origin);
  };

  // Coarse level: every scale x rotation.
  const double r0 = master.min_cell_size() / secondary.min_cell_size();
  const double step = std::pow(2.0, 1.0 / options.scales_per_octave);
  const int half_scales = static_cast<int>(std::ceil(std::log(options.frame_scale_range) / std::log(step) - 1e-9));
  const int angles = std::max(1, static_cast<int>(std::lround(360.0 / options.angle_step_deg)));
  const double angle_step = 2.0 * kPi / angles;
  // Each scale has its own working raster and FFTs: the scales run in parallel, each into its own
  // slot, gathered in scale order so that the result does not depend on the threads.
  std::vector<std::vector<detail::CorrelationHypothesis>> per_scale(static_cast<std::size_t>(2 * half_scales + 1));
  auto t0 = std::chrono::steady_clock::now();
  const auto correlate_scale = [&](std::size_t slot) {
    const int si = static_cast<int>(slot) - half_scales;
    const double ratio = r0 * std::pow(step, si);
    double g = 0.0, finest = 0.0;
    cells(ratio, g, finest);
    const std::vector<Raster<float>> fixed = working_fixed(ratio, g);
    const std::size_t fixed_valid = detail::count_valid(fixed[0]);
    if (fixed_valid < 4) return;
    // Any rotation of the template fits in a square of the master's diagonal.
    const int diag = static_cast<int>(std::ceil(std::hypot(mw, mh) * ratio / g)) + 3;
    MaskedNcc ncc(fixed, diag, diag);
    for (int ai = 0; ai < angles; ++ai) {
      detail::CorrelationHypothesis h;
      h.ratio = ratio;
      h.angle = ai * angle_step;
      h.scale_index = si;
      h.angle_index = ai;
      correlate(&ncc, fixed, fixed_valid, h, g, nullptr, 0);
      if (std::isfinite(h.score)) per_scale[slot].push_back(h);
    }
  };
  ProgressReporter scale_progress(options.progress, "correlation search: coarse scales", per_scale.size());
  parallel_for(per_scale.size(), options.threads, [&](std::size_t slot) {
    correlate_scale(slot);
    scale_progress.advance();
  });
  std::vector<detail::CorrelationHypothesis> coarse;
  for (const auto& hs : per_scale) coarse.insert(coarse.end(), hs.begin(), hs.end());
  result.seconds.coarse = since(t0);
  if (coarse.empty()) {
    result.hypotheses = hypotheses.load();
    result.message = "no hypothesis gave an overlap large enough to correlate";
    result.seconds.total = since(start);
    return result;
  }
  // The same placement: the master's centre mapped within a quarter of the smaller footprint's
  // shorter side, rotations within 30 degrees and scales within a factor 1.5 (the basin of one
  // correlation peak on smooth terrain is that wide); anything else is a competing answer.
  const Eigen::Vector2d centre(0.5 * (mw - 1), 0.5 * (mh - 1));
  const auto map_centre = [&](const detail::CorrelationHypothesis& h) {
    DsmCorrelationResult a;
    a.scale = h.ratio;
    a.angle = h.angle;
    a.mirrored = result.mirrored;
    a.translation = h.translation;
    return a(centre);
  };
  const auto same_place = [&](const detail::CorrelationHypothesis& a, const detail::CorrelationHypothesis& b) {
    const double ratio = std::max(a.ratio, b.ratio);
    const double near = 0.25 * std::min(std::min(mw, mh) * ratio, static_cast<double>(std::min(sw, sh)));
    const double da = std::abs(std::remainder(a.angle - b.angle, 2.0 * kPi));
    return da <= deg_to_rad(30.0) && std::abs(std::log(a.ratio / b.ratio)) <= std::log(1.5) &&
           (map_centre(a) - map_centre(b)).norm() <= near;
  };
  std::vector<std::size_t> order(coarse.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return coarse[a].strength > coarse[b].strength; });
  std::vector<std::size_t> picked;
  for (std::size_t i : order) {
    if (static_cast<int>(picked.size()) >= options.candidates) break;
    bool distinct = true;
    for (std::size_t j : picked) distinct = distinct && !same_place(coarse[i], coarse[j]);
    if (distinct) picked.push_back(i);
  }

  // Finer levels: each candidate's rotation, then scale, refined around it (three hypotheses per
  // parameter, steps halved per level), the peak kept within a few working pixels of where the
  // candidate put the master. Every candidate goes down to the finest cell; the best then goes on
  // halving its steps there until a step moves the template's rim by at most a pixel.
  t0 = std::chrono::steady_clock::now();
  struct Track {
    detail::CorrelationHypothesis h;
    double a_step, s_step, g_coarse, finest, g;
    int level = 1;
    bool stuck = false;
  };
  const auto refine_level = [&](Track& tr) {
    tr.g = std::max(tr.finest, tr.g / 2.0);
    tr.a_step /= 2.0;
    tr.s_step /= 2.0;
    ++tr.level;
    const double g = tr.g;
    detail::CorrelationHypothesis& h = tr.h;
    const std::vector<Raster<float>> fixed = working_fixed(h.ratio, g);
    const std::size_t fixed_valid = detail::count_valid(fixed[0]);
    const int radius = 3;
    for (int param = 0; param < 2; ++param) {
      detail::CorrelationHypothesis best = h;
      best.score = best.strength = -std::numeric_limits<double>::infinity();
      double scores[3] = {-1.0, -1.0, -1.0};
      for (int k = -1; k <= 1; ++k) {
        detail::CorrelationHypothesis trial = h;
        if (param == 0) trial.angle = h.angle + k * tr.a_step;
        else trial.ratio = h.ratio * std::exp(k * tr.s_step);
        const Eigen::Vector2d predicted = predicted_shift(h, trial, g);
        correlate(nullptr, fixed, fixed_valid, trial, g, &predicted, radius);
        scores[k + 1] = trial.strength;
        if (trial.strength > best.strength) best = trial;
      }
      if (!std::isfinite(best.strength)) {  // nothing in the window at this cell: keep the last answer
        tr.stuck = true;
        return;
      }
      // The parabola through the three scores places the parameter between the samples; the
      // translation keeps the master's centre where the best sample put it.
      if (std::isfinite(scores[0]) && std::isfinite(scores[2]) && best.strength == scores[1]) {
        const double off = detail::parabola_offset(scores[0], scores[1], scores[2]);
        const Eigen::Vector2d keep = map_centre(best);
        if (param == 0) best.angle += off * tr.a_step;
        else best.ratio *= std::exp(off * tr.s_step);
        DsmCorrelationResult m;
        m.scale = best.ratio;
        m.angle = best.angle;
        m.mirrored = result.mirrored;
        best.translation = keep - m(centre);
      }
      best.scale_index = h.scale_index;
      best.angle_index = h.angle_index;
      h = best;
    }
  };
  std::vector<Track> tracks(picked.size());
  ProgressReporter candidate_progress(options.progress, "correlation search: candidates", picked.size());
  parallel_for(picked.size(), options.threads, [&](std::size_t i) {
    Track& tr = tracks[i];
    tr.h = coarse[picked[i]];
    tr.a_step = angle_step;
    tr.s_step = std::log(step);
    cells(tr.h.ratio, tr.g_coarse, tr.finest);
    tr.g = tr.g_coarse;
    while (tr.g > tr.finest * (1.0 + 1e-9) && !tr.stuck) refine_level(tr);
    candidate_progress.advance();
  });
  std::size_t win = 0;
  for (std::size_t i = 1; i < tracks.size(); ++i)
    if (tracks[i].h.strength > tracks[win].h.strength) win = i;
  const auto refine_to_end = [&](Track& tr) {
    const auto rim = [&] { return 0.5 * std::hypot(mw, mh) * tr.h.ratio / tr.g; };  // working px
    while (!tr.stuck && tr.a_step * rim() > 1.0 && tr.level < 12) refine_level(tr);
  };
  refine_to_end(tracks[win]);
  result.levels = tracks[win].level;
  result.seconds.refine = since(t0);
  const detail::CorrelationHypothesis& w = tracks[win].h;
  const detail::CorrelationHypothesis& w_coarse = coarse[picked[win]];
  double runner = -1.0, runner_strength = -std::numeric_limits<double>::infinity();
  for (const auto& h : coarse)
    if (!same_place(h, w_coarse) && h.strength > runner_strength) {
      runner = h.score;
      runner_strength = h.strength;
      result.runner_up_scale = h.ratio;
      result.runner_up_angle = h.angle;
    }
  result.scale = w.ratio;
  result.angle = std::remainder(w.angle, 2.0 * kPi);
  result.translation = w.translation;
  result.score = w.score;
  result.coarse_score = w_coarse.score;
  result.strength = w_coarse.strength;
  result.runner_up_strength = runner_strength;
  result.runner_up = runner;
  // A candidate's signals at its finest cell, without the high-pass, and the integer shift of its
  // placement there.
  const auto placed = [&](const Track& tr, std::vector<Raster<float>>& fixed, std::vector<Raster<float>>& t) {
    Eigen::Vector2d origin;
    t = signal_of(detail::make_template(master_sampler, mw, mh, tr.h.ratio, tr.h.angle, result.mirrored, tr.g, origin));
    fixed = signal_of(detail::make_fixed(secondary_sampler, sw, sh, tr.g));
    const Eigen::Vector2d d = (tr.h.translation - Eigen::Vector2d::Constant(0.5 * (tr.g - 1.0))) / tr.g + origin;
    return Eigen::Vector2i(static_cast<int>(std::lround(d.x())), static_cast<int>(std::lround(d.y())));
  };
  // The tiles of a candidate's placement (see DsmCorrelationSearchOptions::max_tile_chance), on its
  // signals at its finest cell, and the chance of as many agreeing on a wrong placement.
  const auto tile_chance_of = [&](const std::vector<Raster<float>>& fixed, const std::vector<Raster<float>>& t,
                                  const Eigen::Vector2i& d, TileAgreement* out) {
    const TileAgreement a = tile_agreement(fixed, t, d.x(), d.y(), options.tiles);
    if (out) *out = a;
    return binomial_tail(a.agree, a.tiles, options.tile_chance);
  };
  // At the winner, from one set of its signals: the height gain, cov(f, g) / var(g) over the overlap
  // (raw heights: the gain of the whole relief; through the gradient when that is the signal, so that
  // a tilt between the frames does not enter the gain either), and its tiles.
  {
    std::vector<Raster<float>> fixed, t;
    const Eigen::Vector2i d = placed(tracks[win], fixed, t);
    result.height_gain = detail::regression_gain(fixed, t, d.x(), d.y());
    result.expected_gain = w.ratio * secondary.min_cell_size() / master.min_cell_size();
    t0 = std::chrono::steady_clock::now();
    if (options.max_tile_chance > 0.0) result.tile_chance = tile_chance_of(fixed, t, d, &result.tiles);
  }
  // A winner short of the margin whose tiles hold is the answer only if it is the only placement that
  // holds: the other candidates, refined as far as the winner (at the finest cell until a rotation
  // step moves the rim by a pixel), must not hold beyond chance.
  const bool short_of_margin = !(w_coarse.strength - runner_strength >= options.min_margin);
  if (w.score >= options.min_score && short_of_margin && result.tile_chance <= options.max_tile_chance) {
    std::vector<Track> others;
    for (std::size_t i = 0; i < tracks.size(); ++i)
      if (i != win && !same_place(tracks[i].h, w)) others.push_back(tracks[i]);
    std::vector<double> chances(others.size(), 1.0);
    parallel_for(others.size(), options.threads, [&](std::size_t i) {
      refine_to_end(others[i]);
      std::vector<Raster<float>> fixed, t;
      const Eigen::Vector2i d = placed(others[i], fixed, t);
      chances[i] = tile_chance_of(fixed, t, d, nullptr);
    });
    result.competitor_tile_chance = 1.0;
    for (double c : chances) result.competitor_tile_chance = std::min(result.competitor_tile_chance, c);
  }
  result.seconds.tiles = since(t0);
  result.hypotheses = hypotheses.load();
  result.seconds.total = since(start);
  const std::string summary =
      "ZNCC " + std::to_string(w.score).substr(0, 5) + " (coarse " + std::to_string(w_coarse.score).substr(0, 5) +
      ", strength " + std::to_string(w_coarse.strength).substr(0, 5) + " vs " +
      std::to_string(runner_strength).substr(0, 5) +
      ", runner-up elsewhere " + std::to_string(runner).substr(0, 5) + " at scale " +
      std::to_string(result.runner_up_scale).substr(0, 5) + ", rotation " +
      std::to_string(rad_to_deg(result.runner_up_angle)).substr(0, 6) + " deg), scale " + std::to_string(w.ratio).substr(0, 6) +
      ", rotation " + std::to_string(rad_to_deg(result.angle)).substr(0, 6) + " deg, " + std::to_string(result.hypotheses) +
      " hypotheses";
  if (!(w.score >= options.min_score)) {
    result.message = summary + ": below min_score " + std::to_string(options.min_score).substr(0, 4);
    return result;
  }
  const auto tile_summary = [&] {
    std::string t = std::to_string(result.tiles.agree) + " of " + std::to_string(result.tiles.tiles) +
                    " tiles agree (chance " + detail::short_number(result.tile_chance);
    if (std::isfinite(result.competitor_tile_chance))
      t += ", other candidates " + detail::short_number(result.competitor_tile_chance);
    return t + ")";
  };
  const bool held_by_tiles = short_of_margin && result.tile_chance <= options.max_tile_chance &&
                             result.competitor_tile_chance > options.max_tile_chance;
  if (short_of_margin && !held_by_tiles) {
    result.message = summary + ": not distinct from the runner-up (margin below " +
                     std::to_string(options.min_margin).substr(0, 4) + ")" +
                     (options.max_tile_chance > 0.0 ? " and " + tile_summary() : std::string());
    return result;
  }
  if (!(std::abs(std::log(result.height_gain / result.expected_gain)) <= std::log(options.max_gain_factor))) {
    result.message = summary + ": the heights' gain " + std::to_string(result.height_gain).substr(0, 6) +
                     " is not the horizontal scale " + std::to_string(result.expected_gain).substr(0, 6) +
                     " (max_gain_factor)";
    return result;
  }
  result.success = true;
  result.by_tiles = held_by_tiles;
  result.message = summary + (held_by_tiles ? ", below the margin but " + tile_summary() : "");
  return result;
}

/// 3D correspondences from a search result: master cells on a regular grid (at most about
/// `max_points` of them), each mapped into the secondary by the result, lifted through both DSMs
/// (world X/Y from each geotransform, the height of each DSM; bilinear in the secondary). Cells
/// without a height on either side are skipped. Throws diachron::Error for empty DSMs or max_points < 1.
inline std::vector<PointPair3> dsm_correlation_correspondences(const Dsm& master, const Dsm& secondary,
                                                              const DsmCorrelationResult& result,
                                                              std::size_t max_points = 2000) {
  DIACHRON_CHECK(!master.empty() && !secondary.empty(), "correspondences need two non-empty DSMs");
  DIACHRON_CHECK(max_points >= 1, "max_points must be >= 1");
  const double cells = static_cast<double>(master.width()) * master.height();
  const int stride = std::max(1, static_cast<int>(std::floor(std::sqrt(cells / static_cast<double>(max_points)))));
  std::vector<PointPair3> out;
  for (int y = stride / 2; y < master.height(); y += stride)
    for (int x = stride / 2; x < master.width(); x += stride) {
      if (!master.valid(x, y)) continue;
      const Eigen::Vector2d pm(x, y);
      const Eigen::Vector2d ps = result(pm);
      const double z2 = secondary.height_at_pixel(ps);
      if (std::isnan(z2)) continue;
      const Eigen::Vector2d w1 = master.pixel_to_world(pm), w2 = secondary.pixel_to_world(ps);
      out.push_back(PointPair3{Eigen::Vector3d(w1.x(), w1.y(), master.heights()(x, y)), Eigen::Vector3d(w2.x(), w2.y(), z2)});
    }
  return out;
}

}  // namespace diachron
