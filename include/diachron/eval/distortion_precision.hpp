#pragma once
/// @file
/// distortion_precision(): how well an adjustment determined a camera's distortion over the image,
/// from the covariance of its intrinsics (e.g. BundleReport's CameraReport::covariance): the 1-sigma
/// of the distortion d(p) = p - c - f x(p) of eval/distortion_difference.hpp at each pixel of a grid,
/// propagated to first order. It answers, without a truth, whether a block can recover the distortion
/// to a given tolerance: a block whose corners are determined to +-0.6 px cannot meet 0.5 px there,
/// whatever its matches.
///
/// Conventions: the covariance is over the first n entries of Camera::intrinsics(), [f, cx, cy,
/// params...] (px and the parameters' own units), row-major n x n; the entries beyond n are taken as
/// exact (e.g. the bundle's camera block [f, cx, cy, K1, K2, K3, P1, P2] leaves FraserAffine's B1, B2
/// to the per-image affine blocks). The sigma of a pixel is the square root of the largest
/// eigenvalue of d's 2 x 2 covariance there: the standard deviation along its worst direction.

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <diachron/camera/camera.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/eval/distortion_difference.hpp>  // d(p) and the grid, shared

#include <Eigen/Dense>

namespace diachron {

/// Options of distortion_precision().
struct DistortionPrecisionOptions {
  /// Sample pixels per image side: a grid of samples x samples pixels from corner to corner. >= 2.
  int samples = 17;
};

/// The first-order precision of a camera's distortion over the image. Default: nothing measured.
struct DistortionPrecision {
  bool valid = false;  ///< false when no grid pixel could be unprojected
  double max_sigma_px = std::numeric_limits<double>::infinity();  ///< largest 1-sigma over the grid, px
  double rms_sigma_px = std::numeric_limits<double>::infinity();  ///< RMS of the per-pixel 1-sigma, px
  Vec2 worst_pixel = Vec2::Constant(std::numeric_limits<double>::quiet_NaN());  ///< where the largest is, px
  int samples = 0;  ///< grid pixels the camera unprojected
};

/// The 1-sigma of `camera`'s distortion over a grid of its image, from `covariance` (n x n,
/// row-major, over the first n intrinsics; see the file comment). Precondition: n in [1,
/// kNumIntrinsics], the matrix finite and symmetric to 1e-9 relative, else throws diachron::Error.
template <class Distortion>
DistortionPrecision distortion_precision(const Camera<Distortion>& camera, const std::vector<double>& covariance,
                                         const DistortionPrecisionOptions& options = {}) {
  using C = Camera<Distortion>;
  DIACHRON_CHECK(options.samples >= 2, "DistortionPrecisionOptions::samples must be >= 2, got " << options.samples);
  const int n = static_cast<int>(std::lround(std::sqrt(static_cast<double>(covariance.size()))));
  DIACHRON_CHECK(n >= 1 && n <= C::kNumIntrinsics && static_cast<std::size_t>(n * n) == covariance.size(),
                 "distortion_precision: the covariance must be n x n with n in [1, " << C::kNumIntrinsics << "], got "
                                                                                      << covariance.size() << " values");
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> cov(covariance.data(), n, n);
  DIACHRON_CHECK(cov.allFinite(), "distortion_precision: the covariance is not finite");
  DIACHRON_CHECK((cov - cov.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * std::max(1.0, cov.cwiseAbs().maxCoeff()),
                 "distortion_precision: the covariance is not symmetric");

  const typename C::Intrinsics base = camera.intrinsics();
  // Central-difference steps per intrinsic: d is nearly linear in each, so the steps only need to
  // move d far above the unprojection's 1e-10 px tolerance (1e-5 of K1 moves it ~1e-3 px at r = 0.5).
  std::vector<double> steps(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k)
    steps[static_cast<std::size_t>(k)] =
        k == 0 ? 1e-4 * base[0] : (k < 3 ? 1e-2 : 1e-5 * std::max(1.0, std::abs(base[static_cast<std::size_t>(k)])));
  const auto distortion_at = [](const C& c, const Vec2& pixel) -> std::optional<Vec2> {
    const std::optional<Vec2> x = c.normalized_from_pixel(pixel);
    if (!x) return std::nullopt;
    return detail::distortion_at(c, pixel, *x);
  };
  std::vector<C> plus, minus;
  for (int k = 0; k < n; ++k) {
    typename C::Intrinsics up = base, down = base;
    up[static_cast<std::size_t>(k)] += steps[static_cast<std::size_t>(k)];
    down[static_cast<std::size_t>(k)] -= steps[static_cast<std::size_t>(k)];
    plus.push_back(C::from_intrinsics(up, camera.width(), camera.height()));
    minus.push_back(C::from_intrinsics(down, camera.width(), camera.height()));
  }

  DistortionPrecision out;
  double worst = 0.0, sum = 0.0;
  for (const Vec2& pixel : detail::corner_to_corner_grid(camera.width(), camera.height(), options.samples)) {
    Eigen::Matrix<double, 2, Eigen::Dynamic> jacobian(2, n);
    bool ok = true;
    for (int k = 0; k < n && ok; ++k) {
      const std::optional<Vec2> a = distortion_at(plus[static_cast<std::size_t>(k)], pixel);
      const std::optional<Vec2> b = distortion_at(minus[static_cast<std::size_t>(k)], pixel);
      ok = a && b;
      if (ok) jacobian.col(k) = (*a - *b) / (2.0 * steps[static_cast<std::size_t>(k)]);
    }
    if (!ok) continue;
    const Mat2 pixel_cov = jacobian * cov * jacobian.transpose();
    const double sigma = std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Mat2>(pixel_cov).eigenvalues().maxCoeff()));
    if (sigma >= worst) {
      worst = sigma;
      out.worst_pixel = pixel;
    }
    sum += sigma * sigma;
    ++out.samples;
  }
  if (out.samples == 0) return out;
  out.valid = true;
  out.max_sigma_px = worst;
  out.rms_sigma_px = std::sqrt(sum / out.samples);
  return out;
}

}  // namespace diachron
