#pragma once
/// @file
/// PatchWarp: a master-image rectangle's map into the secondary image, fitted from any Transfer on a
/// grid of nodes, and the bilinear resampling of the secondary image onto the rectangle's pixel grid
/// (resample_patch), so that the scale, rotation and perspective between the two images vanish in
/// the resampled patch. Used by one-to-one tiling (tiling/one_to_one.hpp); reusable wherever a
/// secondary window must be seen in master geometry (NCC validation, guided matching).
///
/// Three kinds (PatchWarpKind):
/// - homography_corners: MicMac's GetPatchPair Guided mode: a homography through the transfers of
///   the rectangle's 4 corners (exact there, unchecked between them);
/// - homography_grid: a homography fitted by least squares to an n x n grid of transferred nodes
///   (normalised DLT, then Gauss-Newton on the transfer residuals in secondary pixels);
/// - piecewise_affine: the grid's nodes joined by two affine triangles per cell (the diagonal from
///   the cell's top-left to its bottom-right node), continuous across cells and exact at every node,
///   so that it follows relief a homography cannot.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/tiling/grid_tiler.hpp>

namespace diachron {

/// How a PatchWarp maps the master rectangle into the secondary image (see the file comment).
enum class PatchWarpKind {
  homography_corners,  ///< MicMac: homography through the 4 corners' transfers
  homography_grid,     ///< least-squares homography on the grid's transferred nodes
  piecewise_affine,    ///< two affine triangles per grid cell through the nodes' transfers
};

/// Short name of a kind: "homography_corners", "homography_grid", "piecewise_affine".
inline const char* to_string(PatchWarpKind kind) {
  switch (kind) {
    case PatchWarpKind::homography_corners: return "homography_corners";
    case PatchWarpKind::homography_grid: return "homography_grid";
    case PatchWarpKind::piecewise_affine: return "piecewise_affine";
  }
  return "unknown";
}

/// Options of fit_patch_warp().
struct PatchWarpOptions {
  PatchWarpKind kind = PatchWarpKind::piecewise_affine;
  /// Grid nodes per axis (>= 2, <= 1000) for homography_grid and piecewise_affine, spread evenly
  /// from the rectangle's first to its last pixel centre (homography_corners uses the 4 corner
  /// pixel centres whatever this is). 9 by default: cells of 1920 / 8 = 240 px on a MicMac tile.
  int grid_points = 9;
  /// Fewest nodes that must transfer (>= 4) for homography_grid and piecewise_affine; fewer fail
  /// the fit (too_few_points). 6 by default: two spare equations over the homography's 8 unknowns.
  int min_points = 6;
  /// Gauss-Newton iterations refining the grid homography's DLT on the residuals in secondary px
  /// (>= 0; 0 keeps the algebraic DLT). 10 by default.
  int refine_iterations = 10;

  void check() const {
    DIACHRON_CHECK(grid_points >= 2 && grid_points <= 1000,
                   "PatchWarpOptions::grid_points must be in [2, 1000], got " << grid_points);
    DIACHRON_CHECK(min_points >= 4, "PatchWarpOptions::min_points must be >= 4, got " << min_points);
    DIACHRON_CHECK(refine_iterations >= 0 && refine_iterations <= 1000,
                   "PatchWarpOptions::refine_iterations must be in [0, 1000], got " << refine_iterations);
  }
};

/// Why fit_patch_warp() failed.
enum class PatchWarpFailure {
  none,                    ///< it did not
  too_small,               ///< the rectangle is narrower or shorter than 2 px
  corner_not_transferred,  ///< homography_corners: a corner has no transfer
  too_few_points,          ///< fewer than min_points grid nodes transferred
  degenerate_fit,          ///< the transferred points determine no (non-singular) homography
};

/// Short text for a failure.
inline const char* to_string(PatchWarpFailure failure) {
  switch (failure) {
    case PatchWarpFailure::none: return "none";
    case PatchWarpFailure::too_small: return "rectangle smaller than 2 x 2 px";
    case PatchWarpFailure::corner_not_transferred: return "a corner does not transfer";
    case PatchWarpFailure::too_few_points: return "too few grid points transfer";
    case PatchWarpFailure::degenerate_fit: return "transferred points determine no homography";
  }
  return "unknown";
}

namespace detail {
template <class Transfer>
struct PatchWarpBuilder;
}  // namespace detail

/// A fitted master-rectangle -> secondary-image map (a Transfer: master image px -> secondary
/// image px, both in full-image pixels, diachron's pixel-centre convention). Outside its rectangle
/// it extrapolates (the homography, or the border cell's triangle). A default-constructed warp maps
/// nothing. Immutable, so const calls are thread-safe.
class PatchWarp {
 public:
  PatchWarp() = default;

  /// The secondary pixel of master pixel `master_px`, or nullopt (not finite, the homography's line
  /// at infinity, an empty warp).
  std::optional<Eigen::Vector2d> operator()(const Eigen::Vector2d& master_px) const {
    if (!fitted_ || !master_px.allFinite()) return std::nullopt;
    if (kind_ != PatchWarpKind::piecewise_affine) return homography_(master_px);
    return piecewise(master_px);
  }

  bool empty() const { return !fitted_; }
  PatchWarpKind kind() const { return kind_; }
  /// The master rectangle the warp was fitted over, px.
  const PixelRect& rect() const { return rect_; }
  /// The homography (master px -> secondary px): the warp itself for the homography kinds; for
  /// piecewise_affine the grid fit that stands in for the nodes that did not transfer.
  const Homography2& homography() const { return homography_; }
  /// Nodes per axis: 2 for homography_corners, grid_points otherwise.
  int grid_points() const { return n_; }
  /// Master pixel of node (i, j) (column i, row j), px.
  Eigen::Vector2d node_master(int i, int j) const {
    return {rect_.x + step_.x() * i, rect_.y + step_.y() * j};
  }
  /// Secondary pixel of node (i, j): its transfer, or the homography's value where it had none.
  const Eigen::Vector2d& node_secondary(int i, int j) const {
    return nodes_[static_cast<std::size_t>(j) * static_cast<std::size_t>(n_) + static_cast<std::size_t>(i)];
  }

 private:
  template <class Transfer>
  friend struct detail::PatchWarpBuilder;

  std::optional<Eigen::Vector2d> piecewise(const Eigen::Vector2d& p) const {
    const double fx = (p.x() - rect_.x) / step_.x(), fy = (p.y() - rect_.y) / step_.y();
    const int i = std::clamp(static_cast<int>(std::floor(fx)), 0, n_ - 2);
    const int j = std::clamp(static_cast<int>(std::floor(fy)), 0, n_ - 2);
    const double s = fx - i, t = fy - j;
    const Eigen::Vector2d& p00 = node_secondary(i, j);
    const Eigen::Vector2d& p10 = node_secondary(i + 1, j);
    const Eigen::Vector2d& p01 = node_secondary(i, j + 1);
    const Eigen::Vector2d& p11 = node_secondary(i + 1, j + 1);
    if (s >= t) return Eigen::Vector2d(p00 + s * (p10 - p00) + t * (p11 - p10));
    return Eigen::Vector2d(p00 + s * (p11 - p01) + t * (p01 - p00));
  }

  bool fitted_ = false;
  PatchWarpKind kind_ = PatchWarpKind::piecewise_affine;
  PixelRect rect_;
  Homography2 homography_;
  int n_ = 0;
  Eigen::Vector2d step_ = Eigen::Vector2d::Ones();  // master px between nodes
  std::vector<Eigen::Vector2d> nodes_;               // row-major, secondary px
};

/// Result of fit_patch_warp(): the warp when `success`, else the failure and a message.
struct PatchWarpFit {
  bool success = false;
  PatchWarpFailure failure = PatchWarpFailure::too_small;
  std::string message;
  PatchWarp warp;
  std::size_t points = 0;       ///< nodes whose transfer was asked (4 for the corners)
  std::size_t transferred = 0;  ///< of those, nodes that transferred
  /// RMS of |homography(node) - transfer(node)| over the transferred nodes, secondary px (NaN when
  /// the fit failed). For piecewise_affine it describes the stand-in homography; the warp itself
  /// is exact at the nodes.
  double homography_rms_px = std::numeric_limits<double>::quiet_NaN();
};

namespace detail {

// Gauss-Newton on sum |H(x_i) - y_i|^2, in Hartley-normalised coordinates with h22 fixed to 1 (the
// DLT's answer there is near the identity's scale, so h22 is far from 0). Keeps the DLT when a step
// does not lower the cost.
inline Homography2 refine_homography(const Homography2& initial, const std::vector<PointPair2>& pairs, int iterations) {
  if (iterations <= 0 || pairs.size() < 5) return initial;
  const auto norm_of = [&](bool source) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const PointPair2& p : pairs) mean += source ? p.source : p.target;
    mean /= static_cast<double>(pairs.size());
    double spread = 0.0;
    for (const PointPair2& p : pairs) spread += ((source ? p.source : p.target) - mean).norm();
    spread /= static_cast<double>(pairs.size());
    Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
    if (!(spread > 0.0)) return t;
    t(0, 0) = t(1, 1) = 1.0 / spread;
    t(0, 2) = -mean.x() / spread;
    t(1, 2) = -mean.y() / spread;
    return t;
  };
  const Eigen::Matrix3d ts = norm_of(true), tt = norm_of(false);
  Eigen::Matrix3d h = tt * initial.matrix * ts.inverse();
  if (!(std::abs(h(2, 2)) > 1e-8 * h.norm())) return initial;
  h /= h(2, 2);
  std::vector<Eigen::Vector3d> xs;
  std::vector<Eigen::Vector2d> ys;
  for (const PointPair2& p : pairs) {
    xs.push_back(ts * p.source.homogeneous());
    ys.push_back((tt * p.target.homogeneous()).head<2>());
  }
  const auto cost = [&](const Eigen::Matrix3d& m) {
    double c = 0.0;
    for (std::size_t i = 0; i < xs.size(); ++i) {
      const Eigen::Vector3d q = m * xs[i];
      if (!(std::abs(q.z()) > 1e-12)) return std::numeric_limits<double>::infinity();
      c += (q.head<2>() / q.z() - ys[i]).squaredNorm();
    }
    return c;
  };
  double current = cost(h);
  for (int it = 0; it < iterations && current > 0.0; ++it) {
    Eigen::Matrix<double, 8, 8> jtj = Eigen::Matrix<double, 8, 8>::Zero();
    Eigen::Matrix<double, 8, 1> jtr = Eigen::Matrix<double, 8, 1>::Zero();
    for (std::size_t i = 0; i < xs.size(); ++i) {
      const Eigen::Vector3d& x = xs[i];
      const Eigen::Vector3d q = h * x;
      const double w = q.z();
      const Eigen::Vector2d u = q.head<2>() / w;
      const Eigen::Vector2d r = u - ys[i];
      // Parameters h00 h01 h02 h10 h11 h12 h20 h21 (h22 = 1).
      Eigen::Matrix<double, 2, 8> j = Eigen::Matrix<double, 2, 8>::Zero();
      j.block<1, 3>(0, 0) = x.transpose() / w;
      j.block<1, 3>(1, 3) = x.transpose() / w;
      j.block<1, 2>(0, 6) = -u.x() * x.head<2>().transpose() / w;
      j.block<1, 2>(1, 6) = -u.y() * x.head<2>().transpose() / w;
      jtj += j.transpose() * j;
      jtr += j.transpose() * r;
    }
    const Eigen::Matrix<double, 8, 1> delta = jtj.ldlt().solve(-jtr);
    if (!delta.allFinite()) break;
    Eigen::Matrix3d next = h;
    for (int k = 0; k < 8; ++k) next(k / 3, k % 3) += delta(k);
    const double c = cost(next);
    if (!(c < current)) break;
    const bool converged = current - c <= 1e-12 * current;
    h = next;
    current = c;
    if (converged) break;
  }
  Eigen::Matrix3d out = tt.inverse() * h * ts;
  const double n = out.norm();
  if (!(n > 0.0) || !out.allFinite()) return initial;
  return Homography2{out / n};
}

}  // namespace detail

namespace detail {

// A struct, so that the fit can fill PatchWarp's private state as its friend.
template <class Transfer>
struct PatchWarpBuilder {
  static PatchWarpFit fit(const Transfer& transfer, const PixelRect& rect, const PatchWarpOptions& options) {
    PatchWarpFit out;
    if (rect.width < 2 || rect.height < 2) {
      out.failure = PatchWarpFailure::too_small;
      out.message = to_string(out.failure);
      return out;
    }
    const bool corners = options.kind == PatchWarpKind::homography_corners;
    const int n = corners ? 2 : options.grid_points;
    PatchWarp w;
    w.kind_ = options.kind;
    w.rect_ = rect;
    w.n_ = n;
    w.step_ = Eigen::Vector2d((rect.width - 1.0) / (n - 1), (rect.height - 1.0) / (n - 1));
    std::vector<std::optional<Eigen::Vector2d>> node(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
    std::vector<PointPair2> pairs;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector2d m = w.node_master(i, j);
        std::optional<Eigen::Vector2d> s = transfer(m);
        if (s && !s->allFinite()) s.reset();
        ++out.points;
        if (!s) continue;
        ++out.transferred;
        node[static_cast<std::size_t>(j * n + i)] = s;
        pairs.push_back(PointPair2{m, *s});
      }
    const std::size_t needed = corners ? 4 : static_cast<std::size_t>(options.min_points);
    if (out.transferred < needed) {
      out.failure = corners ? PatchWarpFailure::corner_not_transferred : PatchWarpFailure::too_few_points;
      std::ostringstream why;
      why << to_string(out.failure) << ": " << out.transferred << " of " << out.points << " transferred, " << needed
          << " needed";
      out.message = why.str();
      return out;
    }
    std::optional<Homography2> h = estimate_homography(pairs);
    if (!h) {
      out.failure = PatchWarpFailure::degenerate_fit;
      out.message = to_string(out.failure);
      return out;
    }
    if (!corners) h = detail::refine_homography(*h, pairs, options.refine_iterations);
    double sum2 = 0.0;
    for (const PointPair2& p : pairs) {
      const std::optional<Eigen::Vector2d> q = (*h)(p.source);
      if (!q) {
        // A node the homography sends to infinity: the transfer is far from projective here.
        out.failure = PatchWarpFailure::degenerate_fit;
        out.message = to_string(out.failure);
        return out;
      }
      sum2 += (*q - p.target).squaredNorm();
    }
    out.homography_rms_px = std::sqrt(sum2 / static_cast<double>(pairs.size()));
    w.homography_ = *h;
    w.nodes_.resize(node.size());
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const std::size_t k = static_cast<std::size_t>(j * n + i);
        if (node[k]) {
          w.nodes_[k] = *node[k];
          continue;
        }
        const std::optional<Eigen::Vector2d> q = (*h)(w.node_master(i, j));
        if (!q) {
          out.failure = PatchWarpFailure::degenerate_fit;
          out.message = to_string(out.failure);
          return out;
        }
        w.nodes_[k] = *q;
      }
    w.fitted_ = true;
    out.warp = std::move(w);
    out.success = true;
    out.failure = PatchWarpFailure::none;
    return out;
  }
};

}  // namespace detail

/// Fits a PatchWarp of `options.kind` over the master rectangle `rect` from `transfer`: the
/// transfers of the 4 corner pixel centres (homography_corners) or of an options.grid_points^2
/// grid of nodes from the first to the last pixel centre (the other kinds). Nodes that do not
/// transfer are skipped; for piecewise_affine they take the grid homography's value. A failure is
/// a result (success == false with the reason), not an exception; invalid options throw
/// diachron::Error.
template <class Transfer>
PatchWarpFit fit_patch_warp(const Transfer& transfer, const PixelRect& rect, const PatchWarpOptions& options = {}) {
  static_assert(check_transfer<Transfer>());
  options.check();
  return detail::PatchWarpBuilder<Transfer>::fit(transfer, rect, options);
}

/// A secondary image resampled onto a master rectangle's pixel grid.
template <class T>
struct ResampledPatch {
  /// rect.width x rect.height; pixel (u, v) is the secondary image at warp(rect.x + u, rect.y + v),
  /// bilinear; 0 (T{}) where not valid.
  Raster<T> pixels;
  /// Same size: 255 where the warped point lies on the secondary image ([-0.5, w - 0.5] x
  /// [-0.5, h - 0.5], the border half-pixel clamped to the edge pixels), 0 elsewhere.
  Raster<std::uint8_t> mask;
  std::size_t valid_pixels = 0;  ///< pixels with mask 255
};

/// Resamples `secondary` onto the pixel grid of `warp.rect()` (see ResampledPatch), bilinear;
/// integer pixel types are rounded to nearest. A point p of the patch is the master pixel
/// p + (rect.x, rect.y), and corresponds to warp(p + (rect.x, rect.y)) in the secondary image.
/// Throws diachron::Error for an empty warp or an empty image.
template <class T>
ResampledPatch<T> resample_patch(const Raster<T>& secondary, const PatchWarp& warp) {
  DIACHRON_CHECK(!warp.empty(), "resample_patch: the warp is empty (fit_patch_warp failed?)");
  DIACHRON_CHECK(!secondary.empty(), "resample_patch: the secondary image is empty");
  const PixelRect& r = warp.rect();
  ResampledPatch<T> out;
  out.pixels = Raster<T>(r.width, r.height, T{});
  out.mask = Raster<std::uint8_t>(r.width, r.height, 0);
  const int w = secondary.width(), h = secondary.height();
  for (int v = 0; v < r.height; ++v)
    for (int u = 0; u < r.width; ++u) {
      const std::optional<Eigen::Vector2d> q = warp(Eigen::Vector2d(r.x + u, r.y + v));
      if (!q || !(q->x() >= -0.5 && q->x() <= w - 0.5 && q->y() >= -0.5 && q->y() <= h - 0.5)) continue;
      const double x = std::clamp(q->x(), 0.0, w - 1.0), y = std::clamp(q->y(), 0.0, h - 1.0);
      const int x0 = std::min(static_cast<int>(x), std::max(w - 2, 0));
      const int y0 = std::min(static_cast<int>(y), std::max(h - 2, 0));
      const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
      const double fx = x - x0, fy = y - y0;
      const double value = (1.0 - fy) * ((1.0 - fx) * static_cast<double>(secondary(x0, y0)) +
                                         fx * static_cast<double>(secondary(x1, y0))) +
                           fy * ((1.0 - fx) * static_cast<double>(secondary(x0, y1)) +
                                 fx * static_cast<double>(secondary(x1, y1)));
      if constexpr (std::is_integral_v<T>) {
        const double lo = static_cast<double>(std::numeric_limits<T>::lowest());
        const double hi = static_cast<double>(std::numeric_limits<T>::max());
        out.pixels(u, v) = static_cast<T>(std::clamp(std::round(value), lo, hi));
      } else {
        out.pixels(u, v) = static_cast<T>(value);
      }
      out.mask(u, v) = 255;
      ++out.valid_pixels;
    }
  return out;
}

}  // namespace diachron
