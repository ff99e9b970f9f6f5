#pragma once
/// @file
/// The NCC validator of precise matching (paper 3.2.2, MicMac's CrossCorrelation): zero-mean
/// normalised cross-correlation between a window of the master image at each match and the
/// secondary window resampled through the local affine of a Transfer, with an optional
/// least-squares sub-pixel refinement of the secondary position (beyond MicMac, which only filters).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/validation/match_filter.hpp>

namespace diachron {

/// How the secondary position is refined (NccOptions::refine).
enum class NccRefineMethod : std::uint8_t {
  lsm,       ///< least-squares matching: Gauss-Newton on an affine warp plus gain and offset
  ncc_peak,  ///< the peak of a quadratic fitted to the NCC on a 3 x 3 grid of 1 px shifts
};

/// Options of the sub-pixel refinement.
struct NccRefineOptions {
  /// The first method tried.
  NccRefineMethod method = NccRefineMethod::lsm;
  /// When least-squares matching does not converge, try the NCC peak before giving up.
  bool fallback_to_ncc_peak = true;
  /// Largest move of the secondary position, secondary pixels (finite, > 0). A refinement that
  /// moves further is rejected and the original position kept: the match was then wrong, or the
  /// window ambiguous, and a filter must not turn it into a different match.
  double max_move_px = 2.0;
  /// Gauss-Newton iterations at most (>= 1).
  int max_iterations = 20;
  /// Converged when a step moves every window sample by less than this, secondary pixels (> 0).
  double convergence_px = 1e-3;

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    DIACHRON_CHECK(std::isfinite(max_move_px) && max_move_px > 0.0,
                   "NccRefineOptions::max_move_px must be finite and > 0, got " << max_move_px);
    DIACHRON_CHECK(max_iterations >= 1, "NccRefineOptions::max_iterations must be >= 1, got " << max_iterations);
    DIACHRON_CHECK(std::isfinite(convergence_px) && convergence_px > 0.0,
                   "NccRefineOptions::convergence_px must be finite and > 0, got " << convergence_px);
  }
};

/// Options of ncc_validate(). Defaults are MicMac's today (SzW = 32, CCTh = 0.6; the paper used 0.5).
struct NccOptions {
  /// Side of the square window, pixels of the master image, in [4, 512]. The window covers the
  /// integer offsets [-w/2, w - w/2) around the match on each axis (32: [x - 16, x + 16), MicMac's).
  int window_px = 32;
  /// A match is kept when its NCC is at least this, in [-1, 1].
  double min_ncc = 0.6;
  /// Step of the central differences that give the local affine of the Transfer, master pixels (> 0).
  double affine_step_px = 1.0;
  /// Threads over matches (0 = all cores). The result does not depend on it.
  std::size_t threads = 1;
  /// Refine the secondary position of every kept match (see NccRefinement).
  bool refine = false;
  NccRefineOptions refinement;

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    DIACHRON_CHECK(window_px >= 4 && window_px <= 512, "NccOptions::window_px must be in [4, 512], got " << window_px);
    DIACHRON_CHECK(min_ncc >= -1.0 && min_ncc <= 1.0, "NccOptions::min_ncc must be in [-1, 1], got " << min_ncc);
    DIACHRON_CHECK(std::isfinite(affine_step_px) && affine_step_px > 0.0,
                   "NccOptions::affine_step_px must be finite and > 0, got " << affine_step_px);
    refinement.check();
  }
};

/// Why a match got its verdict.
enum class NccOutcome : std::uint8_t {
  not_run,            ///< default: never validated
  kept,               ///< NCC >= min_ncc
  below_threshold,    ///< NCC < min_ncc
  no_affine,          ///< the Transfer gives no local affine at match.a
  outside_master,     ///< the master window leaves the master image
  outside_secondary,  ///< the resampled secondary window leaves the secondary image
  flat,               ///< a window has zero variance (up to rounding): the NCC is undefined
  not_finite,         ///< a window holds a non-finite pixel (NaN holes of a float image)
};

/// What the refinement of one match did.
enum class NccRefineStatus : std::uint8_t {
  not_run,        ///< not asked for, or the match was not kept
  lsm,            ///< least-squares matching converged within max_move_px: `b` is its position
  ncc_peak,       ///< the NCC-peak fit gave `b` (first method, or the fallback)
  rejected_move,  ///< a method converged but moved further than max_move_px: original `b` kept
  failed,         ///< no method converged (window left the image, singular system, no peak)
};

/// The refinement of one match's secondary position. `b` is the position to use: the refined one
/// when `status` is lsm or ncc_peak, the input's otherwise (NaN only in a default-constructed one).
struct NccRefinement {
  Eigen::Vector2d b = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Distance from the original to the refined candidate, secondary pixels, also when the candidate
  /// was rejected (NaN when there is none).
  double moved_px = std::numeric_limits<double>::quiet_NaN();
  /// NCC of the windows at `b` (with the refined affine after LSM); NaN when not run.
  double ncc = std::numeric_limits<double>::quiet_NaN();
  /// Gauss-Newton iterations run (0 for the NCC peak alone).
  int iterations = 0;
  /// Least-squares matching converged (whether or not its move was accepted).
  bool converged = false;
  NccRefineStatus status = NccRefineStatus::not_run;

  /// True when `b` differs from the input because a refinement was accepted.
  bool applied() const { return status == NccRefineStatus::lsm || status == NccRefineStatus::ncc_peak; }
};

/// What ncc_validate() returns. Index-aligned with the input (MatchFilterResult): `score[i]` is
/// match i's NCC in [-1, 1] at its input position, NaN when it could not be computed; `keep[i]` is 1
/// when it is at least min_ncc. The verdict never depends on the refinement.
struct NccResult : MatchFilterResult {
  /// The reason for each verdict.
  std::vector<NccOutcome> outcome;
  /// Matches per reason (kept() counts the kept ones).
  std::size_t below_threshold = 0;
  std::size_t no_affine = 0;
  std::size_t outside_master = 0;
  std::size_t outside_secondary = 0;
  std::size_t flat = 0;
  std::size_t not_finite = 0;

  /// One per match when NccOptions::refine (status not_run for the matches not kept), else empty.
  std::vector<NccRefinement> refinement;
  /// Refinements per status.
  std::size_t refined_lsm = 0;
  std::size_t refined_ncc_peak = 0;
  std::size_t refine_rejected_move = 0;
  std::size_t refine_failed = 0;
};

/// The NCC of one pair of windows, with its outcome (kept/below_threshold are not decided here:
/// `outcome` is kept whenever `ncc` is finite).
struct NccWindowScore {
  double ncc = std::numeric_limits<double>::quiet_NaN();
  NccOutcome outcome = NccOutcome::not_run;
};

/// Zero-mean NCC between the master window centred at `a` and the secondary window whose sample at
/// master offset o is at `b + affine * o`, both bilinear at sub-pixel positions, over the offsets of
/// NccOptions::window_px. A window is inside an image when all its sample positions lie within
/// [0, width - 1] x [0, height - 1] (the pixel centres, docs/conventions.md).
/// @throws diachron::Error for an image smaller than 2 x 2, or a window_px outside [4, 512].
template <class T>
NccWindowScore ncc_window(const Raster<T>& master, const Eigen::Vector2d& a, const Raster<T>& secondary,
                          const Eigen::Vector2d& b, const Eigen::Matrix2d& affine, int window_px = 32);

/// Validates `matches` by NCC (MicMac's CrossCorrelation, without its patch files): for each match,
/// the Transfer's local affine A at match.a (local_affine(), central differences of
/// options.affine_step_px) resamples the secondary image around match.b onto the master window's
/// grid, so rotation, scale and shear between the images drop out; the match is kept when the
/// zero-mean NCC is at least options.min_ncc. With options.refine, each kept match's secondary
/// position is also refined to sub-pixel accuracy (NccRefinement). Deterministic, parallel over
/// matches.
///
/// @tparam T pixel type (std::uint8_t, std::uint16_t, float, ...); both images share it.
/// @tparam Transfer a Transfer (terrain/transfer.hpp): a DsmTransfer, or a MapTransfer of a
///         Similarity2 or a homography. Only its Jacobian matters: it need not map a onto b.
/// @throws diachron::Error for invalid options, an image smaller than 2 x 2, a non-finite keypoint.
template <class T, class Transfer>
NccResult ncc_validate(const Raster<T>& master, const Raster<T>& secondary, const PointMatches& matches,
                       const Transfer& transfer, const NccOptions& options = {});

// Implementation ---------------------------------------------------------------------------------

namespace detail {

// The first window offset on each axis: [-w/2, w - w/2).
inline int ncc_first_offset(int window_px) { return -(window_px / 2); }

// True when every sample of the window lies on or between the outer pixel centres; the window is
// the affine image of a square, so its four corners decide.
inline bool ncc_window_inside(int width, int height, const Eigen::Vector2d& c, const Eigen::Matrix2d& m,
                              int window_px) {
  const double lo = ncc_first_offset(window_px), hi = lo + window_px - 1;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d p = c + m * Eigen::Vector2d((k & 1) ? hi : lo, (k & 2) ? hi : lo);
    if (!(p.x() >= 0.0 && p.y() >= 0.0 && p.x() <= width - 1 && p.y() <= height - 1)) return false;
  }
  return true;
}

// Bilinear value at (x, y) of an image of at least 2 x 2. The cell is clamped inside, so the last
// row and column (x == width - 1) interpolate with weight 1 on their own value, and positions a
// rounding error outside stay in memory.
template <class T>
inline double ncc_bilinear(const Raster<T>& img, double x, double y) {
  const int x0 = std::clamp(static_cast<int>(x), 0, img.width() - 2);
  const int y0 = std::clamp(static_cast<int>(y), 0, img.height() - 2);
  const double fx = x - x0, fy = y - y0;
  const T* r0 = img.row(y0) + x0;
  const T* r1 = r0 + img.width();
  const double top = static_cast<double>(r0[0]) + fx * (static_cast<double>(r0[1]) - static_cast<double>(r0[0]));
  const double bottom = static_cast<double>(r1[0]) + fx * (static_cast<double>(r1[1]) - static_cast<double>(r1[0]));
  return top + fy * (bottom - top);
}

// Bilinear value and its gradient (the exact derivative of the bilinear surface in the cell).
template <class T>
inline double ncc_bilinear_gradient(const Raster<T>& img, double x, double y, double& gx, double& gy) {
  const int x0 = std::clamp(static_cast<int>(x), 0, img.width() - 2);
  const int y0 = std::clamp(static_cast<int>(y), 0, img.height() - 2);
  const double fx = x - x0, fy = y - y0;
  const T* r0 = img.row(y0) + x0;
  const T* r1 = r0 + img.width();
  const double v00 = r0[0], v10 = r0[1], v01 = r1[0], v11 = r1[1];
  const double top = v00 + fx * (v10 - v00), bottom = v01 + fx * (v11 - v01);
  gx = (1.0 - fy) * (v10 - v00) + fy * (v11 - v01);
  gy = bottom - top;
  return top + fy * (bottom - top);
}

// Samples the window at c + m * o, row by row (offset y outer, x inner) into out[window_px^2].
// Precondition: ncc_window_inside.
template <class T>
inline void ncc_sample(const Raster<T>& img, const Eigen::Vector2d& c, const Eigen::Matrix2d& m, int window_px,
                       double* out) {
  const int first = ncc_first_offset(window_px);
  const double sx = m(0, 0), sy = m(1, 0);
  for (int j = 0; j < window_px; ++j) {
    const Eigen::Vector2d row = c + m * Eigen::Vector2d(first, first + j);
    for (int i = 0; i < window_px; ++i) *out++ = ncc_bilinear(img, row.x() + i * sx, row.y() + i * sy);
  }
}

// Zero-mean NCC of two sample arrays (two passes: means first, so no cancellation).
inline NccWindowScore ncc_of_samples(const double* a, const double* b, std::size_t n) {
  NccWindowScore out;
  double mean_a = 0.0, mean_b = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    mean_a += a[k];
    mean_b += b[k];
  }
  if (!std::isfinite(mean_a) || !std::isfinite(mean_b)) {
    out.outcome = NccOutcome::not_finite;
    return out;
  }
  mean_a /= static_cast<double>(n);
  mean_b /= static_cast<double>(n);
  double saa = 0.0, sbb = 0.0, sab = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double da = a[k] - mean_a, db = b[k] - mean_b;
    saa += da * da;
    sbb += db * db;
    sab += da * db;
  }
  // Bilinear weights of a constant image can leave variances of 1e-28 relative to the values;
  // such a window is flat, not a correlation of rounding noise.
  const double n_d = static_cast<double>(n);
  const double tiny_a = n_d * 1e-20 * std::max(1.0, mean_a * mean_a);
  const double tiny_b = n_d * 1e-20 * std::max(1.0, mean_b * mean_b);
  if (!(saa > tiny_a) || !(sbb > tiny_b)) {
    out.outcome = NccOutcome::flat;
    return out;
  }
  out.ncc = std::clamp(sab / std::sqrt(saa * sbb), -1.0, 1.0);
  out.outcome = NccOutcome::kept;
  return out;
}

template <class T>
void check_ncc_image(const Raster<T>& img, const char* which) {
  DIACHRON_CHECK(img.width() >= 2 && img.height() >= 2,
                 "ncc_validate: the " << which << " image must be at least 2 x 2, got " << img.width() << " x "
                                      << img.height());
}

// The master window's samples and statistics, computed once per match and shared by the NCC and
// the refinement.
struct NccScratch {
  std::vector<double> master, secondary;
};

template <class T>
NccWindowScore ncc_secondary(const Raster<T>& secondary, const Eigen::Vector2d& b, const Eigen::Matrix2d& m,
                             int window_px, NccScratch& s) {
  if (!ncc_window_inside(secondary.width(), secondary.height(), b, m, window_px))
    return {std::numeric_limits<double>::quiet_NaN(), NccOutcome::outside_secondary};
  ncc_sample(secondary, b, m, window_px, s.secondary.data());
  return ncc_of_samples(s.master.data(), s.secondary.data(), s.master.size());
}

// Least-squares matching (Gruen 1985): Gauss-Newton on the 8 parameters of
//   master(a + o) ~ gain * secondary(b + A o) + offset,   o over the window,
// seeded with the Transfer's local affine. Returns the converged (b, A), or nullopt.
template <class T>
std::optional<std::pair<Eigen::Vector2d, Eigen::Matrix2d>> ncc_lsm(const Raster<T>& secondary, Eigen::Vector2d b,
                                                                    Eigen::Matrix2d m, int window_px,
                                                                    const NccRefineOptions& options,
                                                                    const Eigen::Vector2d& original, NccScratch& s,
                                                                    NccRefinement& report) {
  using Vector8 = Eigen::Matrix<double, 8, 1>;
  using Matrix8 = Eigen::Matrix<double, 8, 8>;
  const int first = ncc_first_offset(window_px);
  const std::size_t n = s.master.size();
  const double det0 = m.determinant();
  // Radiometry first, from the window statistics: the geometric steps then start from a fit
  // whose residuals are geometric.
  ncc_sample(secondary, b, m, window_px, s.secondary.data());
  double mean_m = 0.0, mean_s = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    mean_m += s.master[k];
    mean_s += s.secondary[k];
  }
  mean_m /= static_cast<double>(n);
  mean_s /= static_cast<double>(n);
  double var_m = 0.0, var_s = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    var_m += (s.master[k] - mean_m) * (s.master[k] - mean_m);
    var_s += (s.secondary[k] - mean_s) * (s.secondary[k] - mean_s);
  }
  if (!(var_s > 0.0) || !(var_m > 0.0)) return std::nullopt;
  double gain = std::sqrt(var_m / var_s), offset = mean_m - gain * mean_s;
  const double half_extent = window_px / 2.0;

  for (int it = 1; it <= options.max_iterations; ++it) {
    report.iterations = it;
    if (!ncc_window_inside(secondary.width(), secondary.height(), b, m, window_px)) return std::nullopt;
    Matrix8 normal = Matrix8::Zero();
    Vector8 rhs = Vector8::Zero();
    std::size_t k = 0;
    for (int j = 0; j < window_px; ++j) {
      const double oy = first + j;
      for (int i = 0; i < window_px; ++i, ++k) {
        const double ox = first + i;
        const Eigen::Vector2d p = b + m * Eigen::Vector2d(ox, oy);
        double gx = 0.0, gy = 0.0;
        const double v = ncc_bilinear_gradient(secondary, p.x(), p.y(), gx, gy);
        gx *= gain;
        gy *= gain;
        Vector8 jrow;
        jrow << gx, gy, gx * ox, gx * oy, gy * ox, gy * oy, v, 1.0;
        const double e = s.master[k] - (gain * v + offset);
        normal.selfadjointView<Eigen::Lower>().rankUpdate(jrow);
        rhs += jrow * e;
      }
    }
    const Eigen::LDLT<Matrix8> ldlt(normal.selfadjointView<Eigen::Lower>());
    if (ldlt.info() != Eigen::Success) return std::nullopt;
    const Vector8 step = ldlt.solve(rhs);
    if (!step.allFinite()) return std::nullopt;
    b += step.head<2>();
    Eigen::Matrix2d dm;
    dm << step(2), step(3), step(4), step(5);
    m += dm;
    gain += step(6);
    offset += step(7);
    // A step far beyond the allowed move, a collapsing or flipping warp, or a negative gain is a
    // divergence, not a path to a better match.
    const double det = m.determinant();
    if (!(gain > 0.0) || !(det / det0 > 0.25 && det / det0 < 4.0) ||
        (b - original).norm() > 4.0 * options.max_move_px)
      return std::nullopt;
    const double largest_move = step.head<2>().norm() + dm.cwiseAbs().sum() * half_extent;
    if (largest_move < options.convergence_px) return std::make_pair(b, m);
  }
  return std::nullopt;
}

// The peak of a quadratic fitted by least squares to the NCC at b + (dx, dy), dx, dy in {-1, 0, 1},
// after walking to the best integer shift (within max_move_px). nullopt when there is no peak.
template <class T>
std::optional<Eigen::Vector2d> ncc_peak(const Raster<T>& secondary, const Eigen::Vector2d& b,
                                        const Eigen::Matrix2d& m, int window_px, const NccRefineOptions& options,
                                        NccScratch& s) {
  Eigen::Vector2d centre = b;
  double values[3][3];
  const int max_walk = static_cast<int>(std::ceil(options.max_move_px)) + 1;
  for (int walk = 0; walk <= max_walk; ++walk) {
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const NccWindowScore sc = ncc_secondary(secondary, Eigen::Vector2d(centre + Eigen::Vector2d(dx, dy)), m,
                                                window_px, s);
        if (!std::isfinite(sc.ncc)) return std::nullopt;
        values[dy + 1][dx + 1] = sc.ncc;
      }
    int best_x = 1, best_y = 1;
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 3; ++x)
        if (values[y][x] > values[best_y][best_x]) {
          best_x = x;
          best_y = y;
        }
    if (best_x == 1 && best_y == 1) {
      // f = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 on the 9 samples
      Eigen::Matrix<double, 9, 6> design;
      Eigen::Matrix<double, 9, 1> f;
      for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 3; ++x) {
          const double u = x - 1, v = y - 1;
          design.row(3 * y + x) << 1.0, u, v, u * u, u * v, v * v;
          f(3 * y + x) = values[y][x];
        }
      const Eigen::Matrix<double, 6, 1> c = (design.transpose() * design).ldlt().solve(design.transpose() * f);
      Eigen::Matrix2d hessian;
      hessian << 2.0 * c(3), c(4), c(4), 2.0 * c(5);
      if (!(hessian(0, 0) < 0.0) || !(hessian.determinant() > 0.0)) return std::nullopt;
      const Eigen::Vector2d peak = -hessian.inverse() * Eigen::Vector2d(c(1), c(2));
      if (!(peak.cwiseAbs().maxCoeff() <= 1.0)) return std::nullopt;
      return Eigen::Vector2d(centre + peak);
    }
    centre += Eigen::Vector2d(best_x - 1, best_y - 1);
  }
  return std::nullopt;
}

template <class T>
NccRefinement ncc_refine(const Raster<T>& secondary, const Eigen::Vector2d& b, const Eigen::Matrix2d& m,
                         int window_px, const NccRefineOptions& options, NccScratch& s) {
  NccRefinement r;
  r.b = b;
  std::optional<Eigen::Vector2d> candidate;
  Eigen::Matrix2d affine = m;
  NccRefineStatus method = NccRefineStatus::failed;
  if (options.method == NccRefineMethod::lsm) {
    if (const auto lsm = ncc_lsm(secondary, b, m, window_px, options, b, s, r)) {
      r.converged = true;
      candidate = lsm->first;
      affine = lsm->second;
      method = NccRefineStatus::lsm;
    }
  }
  if (!candidate && (options.method == NccRefineMethod::ncc_peak || options.fallback_to_ncc_peak)) {
    candidate = ncc_peak(secondary, b, m, window_px, options, s);
    if (candidate) method = NccRefineStatus::ncc_peak;
  }
  if (!candidate) {
    r.status = NccRefineStatus::failed;
    return r;
  }
  r.moved_px = (*candidate - b).norm();
  if (!(r.moved_px <= options.max_move_px)) {
    r.status = NccRefineStatus::rejected_move;
    return r;
  }
  const NccWindowScore after = ncc_secondary(secondary, *candidate, affine, window_px, s);
  if (!std::isfinite(after.ncc)) {
    r.status = NccRefineStatus::failed;
    return r;
  }
  r.b = *candidate;
  r.ncc = after.ncc;
  r.status = method;
  return r;
}

}  // namespace detail

template <class T>
NccWindowScore ncc_window(const Raster<T>& master, const Eigen::Vector2d& a, const Raster<T>& secondary,
                          const Eigen::Vector2d& b, const Eigen::Matrix2d& affine, int window_px) {
  DIACHRON_CHECK(window_px >= 4 && window_px <= 512, "ncc_window: window_px must be in [4, 512], got " << window_px);
  detail::check_ncc_image(master, "master");
  detail::check_ncc_image(secondary, "secondary");
  const Eigen::Matrix2d identity = Eigen::Matrix2d::Identity();
  if (!a.allFinite() || !detail::ncc_window_inside(master.width(), master.height(), a, identity, window_px))
    return {std::numeric_limits<double>::quiet_NaN(), NccOutcome::outside_master};
  if (!affine.allFinite()) return {std::numeric_limits<double>::quiet_NaN(), NccOutcome::no_affine};
  if (!b.allFinite()) return {std::numeric_limits<double>::quiet_NaN(), NccOutcome::outside_secondary};
  const std::size_t n = static_cast<std::size_t>(window_px) * static_cast<std::size_t>(window_px);
  detail::NccScratch s{std::vector<double>(n), std::vector<double>(n)};
  detail::ncc_sample(master, a, identity, window_px, s.master.data());
  return detail::ncc_secondary(secondary, b, affine, window_px, s);
}

template <class T, class Transfer>
NccResult ncc_validate(const Raster<T>& master, const Raster<T>& secondary, const PointMatches& matches,
                       const Transfer& transfer, const NccOptions& options) {
  static_assert(std::is_arithmetic_v<T>, "ncc_validate: the pixel type must be arithmetic (std::uint8_t, float, ...)");
  static_assert(check_transfer<Transfer>());
  options.check();
  detail::check_ncc_image(master, "master");
  detail::check_ncc_image(secondary, "secondary");
  for (std::size_t i = 0; i < matches.size(); ++i)
    DIACHRON_CHECK(matches[i].a.allFinite() && matches[i].b.allFinite(),
                   "ncc_validate: match " << i << " has a non-finite keypoint");

  const std::size_t count = matches.size();
  NccResult result;
  result.keep.assign(count, 0);
  result.score.assign(count, std::numeric_limits<double>::quiet_NaN());
  result.outcome.assign(count, NccOutcome::not_run);
  if (options.refine) {
    result.refinement.assign(count, NccRefinement{});
    for (std::size_t i = 0; i < count; ++i) result.refinement[i].b = matches[i].b;
  }

  const int w = options.window_px;
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(w);
  const Eigen::Matrix2d identity = Eigen::Matrix2d::Identity();
  // Chunks of matches, so each task allocates its scratch once; every match writes only its slots.
  constexpr std::size_t kChunk = 64;
  const std::size_t chunks = (count + kChunk - 1) / kChunk;
  parallel_for(chunks, options.threads, [&](std::size_t chunk) {
    detail::NccScratch s{std::vector<double>(n), std::vector<double>(n)};
    const std::size_t end = std::min(count, (chunk + 1) * kChunk);
    for (std::size_t i = chunk * kChunk; i < end; ++i) {
      const PointMatch& match = matches[i];
      if (!detail::ncc_window_inside(master.width(), master.height(), match.a, identity, w)) {
        result.outcome[i] = NccOutcome::outside_master;
        continue;
      }
      const std::optional<Eigen::Matrix2d> affine = local_affine(transfer, match.a, options.affine_step_px);
      if (!affine) {
        result.outcome[i] = NccOutcome::no_affine;
        continue;
      }
      detail::ncc_sample(master, match.a, identity, w, s.master.data());
      const NccWindowScore sc = detail::ncc_secondary(secondary, match.b, *affine, w, s);
      result.score[i] = sc.ncc;
      if (sc.outcome != NccOutcome::kept) {
        result.outcome[i] = sc.outcome;
        continue;
      }
      if (!(sc.ncc >= options.min_ncc)) {
        result.outcome[i] = NccOutcome::below_threshold;
        continue;
      }
      result.outcome[i] = NccOutcome::kept;
      result.keep[i] = 1;
      if (options.refine)
        result.refinement[i] = detail::ncc_refine(secondary, match.b, *affine, w, options.refinement, s);
    }
  });

  for (std::size_t i = 0; i < count; ++i) {
    switch (result.outcome[i]) {
      case NccOutcome::below_threshold: ++result.below_threshold; break;
      case NccOutcome::no_affine: ++result.no_affine; break;
      case NccOutcome::outside_master: ++result.outside_master; break;
      case NccOutcome::outside_secondary: ++result.outside_secondary; break;
      case NccOutcome::flat: ++result.flat; break;
      case NccOutcome::not_finite: ++result.not_finite; break;
      case NccOutcome::kept:
      case NccOutcome::not_run: break;
    }
    if (!options.refine) continue;
    switch (result.refinement[i].status) {
      case NccRefineStatus::lsm: ++result.refined_lsm; break;
      case NccRefineStatus::ncc_peak: ++result.refined_ncc_peak; break;
      case NccRefineStatus::rejected_move: ++result.refine_rejected_move; break;
      case NccRefineStatus::failed: ++result.refine_failed; break;
      case NccRefineStatus::not_run: break;
    }
  }
  return result;
}

}  // namespace diachron
