#pragma once
/// @file
/// The shape of a correlation match's peak, for the benchmarks that study how precise a match is:
/// the negative second derivatives of a quadratic fitted to correlation_surface's scores over +-2
/// master px around the match, and the transfer's local affine there.

#include <optional>

#include <Eigen/Core>
#include <Eigen/QR>

#include <diachron/matching/correlation_matcher.hpp>
#include <diachron/terrain/local_affine.hpp>

namespace diachron::bench {

/// A peak's curvature (per master px^2: positive definite for a sharp peak, an eigenvalue near 0
/// along an edge) and the local affine (secondary px per master px) the surface was sampled with.
struct PeakShape {
  Eigen::Matrix2d curvature;
  Eigen::Matrix2d affine;
};

/// The peak shape of the match (a, b) under `transfer` and the correlation options (their window,
/// measure and affine step; the search radius is replaced by 2). Nothing when the transfer has no
/// local affine at a or a window leaves an image.
template <class T, class Transfer>
std::optional<PeakShape> peak_shape(const Raster<T>& master, const Raster<T>& secondary, const Eigen::Vector2d& a,
                                    const Eigen::Vector2d& b, const Transfer& transfer,
                                    CorrelationMatchOptions options) {
  const std::optional<Eigen::Matrix2d> affine = local_affine(transfer, a, options.affine_step());
  if (!affine) return std::nullopt;
  options.search_radius_px = 2;
  const Eigen::MatrixXd surface = correlation_surface(master, a, secondary, b, *affine, options);
  if (surface.rows() != 5 || !surface.allFinite()) return std::nullopt;
  Eigen::Matrix<double, 25, 6> design;
  Eigen::Matrix<double, 25, 1> scores;
  int k = 0;
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx, ++k) {
      design.row(k) << 1.0, dx, dy, dx * dx, dx * dy, dy * dy;
      scores(k) = surface(dy + 2, dx + 2);
    }
  const Eigen::Matrix<double, 6, 1> q = design.colPivHouseholderQr().solve(scores);
  PeakShape out;
  out.curvature << -2.0 * q(3), -q(4), -q(4), -2.0 * q(5);
  out.affine = *affine;
  return out;
}

}  // namespace diachron::bench
