#pragma once
/// @file
/// distortion_difference(): how far apart two cameras' distortions are over the image, in pixels,
/// apart from their focal lengths and principal points (the "distortion recovered within 0.5 px"
/// of a self-calibration).
///
/// A camera moves the pixel of a ray with ideal normalised coordinates x by its distortion:
///   d(p) = p - c - f x(p),   x(p) = the ray of pixel p (Camera::normalized_from_pixel),
/// with c the principal point and f the focal length. Comparing d of two cameras at the same pixels
/// compares what each distortion (radial, decentring and affine part together) does there, whatever
/// the focal lengths and principal points: those are reported apart.
///
/// A near-nadir block over flat ground cannot tell every such difference from a change of pose: a
/// focal length that is too long with a flying height that is too high images the ground the same,
/// and a radial polynomial can take part of that trade. Two more comparisons therefore take the
/// cameras' whole ray-to-pixel mappings, m_b(x) - m_a(x) at the rays x of a's pixels, and remove a
/// least-squares fit first:
/// - `refit_*`: of what changing b's focal length and principal point does (dm_b/df, and a shift):
///   the "balanced" comparison of calibration reports, where the share of the focal length a radial
///   polynomial takes does not count;
/// - `beyond_pose_*`: of what a small change of b's pose does to its image of a plane at right
///   angles to the optical axis, to first order: the ray x = (x, y) moves by
///     dx = t_x - theta y + s x + w_y x^2 - w_x x y,   dy = t_y + theta x + s y + w_y x y - w_x y^2
///   (t: shift across the view and tilt, theta: turn about the axis, s: height, w_x, w_y: tilt), and
///   the pixel by J_b(x) (dx, dy), J_b = dm_b/dx. What is left is the part of the difference that
///   no pose can absorb over flat ground; relief is what separates the rest, and a block with little
///   of it determines the rest poorly.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

#include <diachron/camera/camera.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

#include <Eigen/Dense>

namespace diachron {

/// Options of distortion_difference().
struct DistortionDifferenceOptions {
  /// Sample pixels per image side: a grid of samples x samples pixels from corner to corner. >= 2.
  int samples = 17;
};

/// The distortion difference of two cameras over the image. Default: nothing measured.
struct DistortionDifference {
  bool valid = false;     ///< false when no pixel could be unprojected by both cameras
  double max_px = std::numeric_limits<double>::infinity();   ///< largest |d_a(p) - d_b(p)|, px
  double rms_px = std::numeric_limits<double>::infinity();   ///< RMS over the samples, px
  int samples = 0;        ///< pixels both cameras unprojected
  int failed = 0;         ///< pixels one of them could not unproject (beyond a fold)
  /// Largest and RMS difference of the whole ray-to-pixel mappings left after the least-squares
  /// fit of a change of b's pose over flat ground (see the file comment), px. Infinite when fewer
  /// than 4 samples leave the fit undetermined.
  double beyond_pose_max_px = std::numeric_limits<double>::infinity();
  double beyond_pose_rms_px = std::numeric_limits<double>::infinity();
  /// The same after the least-squares change of b's focal length and principal point instead (see
  /// the file comment), px. Infinite when fewer than 4 samples.
  double refit_max_px = std::numeric_limits<double>::infinity();
  double refit_rms_px = std::numeric_limits<double>::infinity();
};

namespace detail {

/// d(p) = p - c - f x of `camera` at `pixel`, whose ray has ideal normalised coordinates `ray` (the
/// file comment's definition, shared with eval/distortion_precision.hpp), px.
template <class Distortion>
Vec2 distortion_at(const Camera<Distortion>& camera, const Vec2& pixel, const Vec2& ray) {
  return pixel - camera.principal_point() - camera.focal() * ray;
}

/// A samples x samples grid of pixels from the centre of one corner pixel of a width x height image to
/// the opposite one, evenly spaced, row by row. samples >= 2.
inline std::vector<Vec2> corner_to_corner_grid(int width, int height, int samples) {
  std::vector<Vec2> grid;
  grid.reserve(static_cast<std::size_t>(samples) * static_cast<std::size_t>(samples));
  for (int j = 0; j < samples; ++j)
    for (int i = 0; i < samples; ++i)
      grid.emplace_back((width - 1) * static_cast<double>(i) / (samples - 1), (height - 1) * static_cast<double>(j) / (samples - 1));
  return grid;
}

/// Largest and RMS residual of `observed` (2n values, px) after its least-squares fit by the
/// columns of `design`; {inf, inf} when they are not independent.
inline std::pair<double, double> residual_after_fit(const Eigen::MatrixXd& design, const Eigen::VectorXd& observed) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(design);
  if (qr.rank() < design.cols()) return {inf, inf};
  const Eigen::VectorXd residual = observed - design * qr.solve(observed);
  double worst = 0.0, sum = 0.0;
  const Eigen::Index n = residual.size() / 2;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double e = std::hypot(residual(2 * i), residual(2 * i + 1));
    worst = std::max(worst, e);
    sum += e * e;
  }
  return {worst, std::sqrt(sum / static_cast<double>(n))};
}

/// Fills the refit_* and beyond_pose_* figures of `out` from m_b(x) - m_a(x) (`differences`, px) at
/// a's normalised `rays` (see the file comment). Leaves them infinite below 4 rays.
template <class Distortion>
void fit_mapping_differences(const Camera<Distortion>& b, const std::vector<Vec2>& rays,
                             const std::vector<Vec2>& differences, DistortionDifference& out) {
  const Eigen::Index n = static_cast<Eigen::Index>(rays.size());
  if (n < 4) return;
  Camera<Distortion> longer = b;
  const double df = 1e-3 * b.focal();  // the pixel is linear in f: any step gives dm/df exactly
  longer.set_focal(b.focal() + df);
  Eigen::MatrixXd intrinsics(2 * n, 3), pose(2 * n, 6);
  Eigen::VectorXd observed(2 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec2& r = rays[static_cast<std::size_t>(i)];
    const double x = r.x(), y = r.y(), h = 1e-6;  // h: normalised units, central differences
    Mat2 jacobian;
    jacobian.col(0) = (b.pixel_from_normalized(r + Vec2(h, 0.0)) - b.pixel_from_normalized(r - Vec2(h, 0.0))) / (2 * h);
    jacobian.col(1) = (b.pixel_from_normalized(r + Vec2(0.0, h)) - b.pixel_from_normalized(r - Vec2(0.0, h))) / (2 * h);
    const Vec2 dm_df = (longer.pixel_from_normalized(r) - b.pixel_from_normalized(r)) / df;
    intrinsics.block<2, 3>(2 * i, 0) << 1.0, 0.0, dm_df.x(), 0.0, 1.0, dm_df.y();
    // Ray motions of t_x, t_y, s, theta, w_x, w_y, then through b's Jacobian.
    Eigen::Matrix<double, 2, 6> motion;
    motion << 1.0, 0.0, x, -y, -x * y, x * x,
              0.0, 1.0, y, x, -y * y, x * y;
    pose.block<2, 6>(2 * i, 0) = jacobian * motion;
    observed.segment<2>(2 * i) = differences[static_cast<std::size_t>(i)];
  }
  std::tie(out.refit_max_px, out.refit_rms_px) = residual_after_fit(intrinsics, observed);
  std::tie(out.beyond_pose_max_px, out.beyond_pose_rms_px) = residual_after_fit(pose, observed);
}

}  // namespace detail

/// Compares the distortions of `a` and `b` at the given pixels of their images, e.g. where an
/// adjustment had observations: what the data determined, without the extrapolation to image corners
/// no observation reached. Precondition: both cameras of the same image size, else throws
/// diachron::Error. No pixels: nothing measured (valid == false).
template <class DistortionA, class DistortionB>
DistortionDifference distortion_difference_at(const Camera<DistortionA>& a, const Camera<DistortionB>& b,
                                              const std::vector<Vec2>& pixels) {
  DIACHRON_CHECK(a.width() == b.width() && a.height() == b.height(),
                 "distortion_difference: image sizes differ, " << a.width() << " x " << a.height() << " and "
                                                               << b.width() << " x " << b.height());
  DistortionDifference out;
  double sum = 0.0, worst = 0.0;
  std::vector<Vec2> rays, mapping_differences;  // a's ideal rays and m_b - m_a there, for the pose fit
  for (const Vec2& pixel : pixels) {
    DIACHRON_CHECK(pixel.allFinite(), "distortion_difference_at: a pixel is not finite");
    const std::optional<Vec2> xa = a.normalized_from_pixel(pixel), xb = b.normalized_from_pixel(pixel);
    if (!xa || !xb) {
      ++out.failed;
      continue;
    }
    const double e = (detail::distortion_at(a, pixel, *xa) - detail::distortion_at(b, pixel, *xb)).norm();
    worst = std::max(worst, e);
    sum += e * e;
    ++out.samples;
    // b's pixel of a's ray exists wherever b unprojects near it; past b's fold it would not be b's
    // image of that ray, so such rays stay out of the fit.
    if (b.distortion_valid_at(*xa)) {
      rays.push_back(*xa);
      mapping_differences.push_back(b.pixel_from_normalized(*xa) - pixel);
    }
  }
  if (out.samples == 0) return out;
  out.valid = true;
  out.max_px = worst;
  out.rms_px = std::sqrt(sum / out.samples);
  detail::fit_mapping_differences(b, rays, mapping_differences, out);
  return out;
}

/// Compares the distortions of `a` and `b` on a grid over `a`'s image (corners included).
/// Precondition: both cameras of the same image size, else throws diachron::Error.
template <class DistortionA, class DistortionB>
DistortionDifference distortion_difference(const Camera<DistortionA>& a, const Camera<DistortionB>& b,
                                           const DistortionDifferenceOptions& options = {}) {
  DIACHRON_CHECK(options.samples >= 2, "DistortionDifferenceOptions::samples must be >= 2, got " << options.samples);
  return distortion_difference_at(a, b, detail::corner_to_corner_grid(a.width(), a.height(), options.samples));
}

}  // namespace diachron
