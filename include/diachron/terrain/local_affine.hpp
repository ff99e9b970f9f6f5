#pragma once
/// @file
/// The local affine approximation (2x2 Jacobian) of a Transfer at a master pixel, and what it says
/// about the two images there: the predicted scale ratio and rotation that gate guided matching.

#include <cmath>
#include <optional>

#include <Eigen/Core>
#include <Eigen/LU>  // Matrix2d::determinant()

#include <diachron/core/error.hpp>
#include <diachron/terrain/transfer.hpp>

namespace diachron {

/// The Jacobian d(secondary px) / d(master px) of `transfer` at `px`, by central differences with
/// step `step_px` (master pixels, > 0). Near the edge of the transfer's domain (a DSM border, a
/// hole) a column falls back to a one-sided difference from `px`; nullopt when `px` itself does
/// not transfer or neither side of an axis does. Throws diachron::Error for a non-positive step.
///
/// Column 0 is the image of the master x axis, column 1 of the y axis. Over terrain, a step of one
/// or a few master pixels smooths DSM-cell facets little; a larger step averages relief.
template <class Transfer>
std::optional<Eigen::Matrix2d> local_affine(const Transfer& transfer, const Eigen::Vector2d& px,
                                            double step_px = 1.0) {
  static_assert(check_transfer<Transfer>());
  DIACHRON_CHECK(step_px > 0.0 && std::isfinite(step_px), "local_affine: step_px must be positive, got " << step_px);
  Eigen::Matrix2d jacobian;
  for (int axis = 0; axis < 2; ++axis) {
    const Eigen::Vector2d h = Eigen::Vector2d::Unit(axis) * step_px;
    const std::optional<Eigen::Vector2d> plus = transfer(Eigen::Vector2d(px + h));
    const std::optional<Eigen::Vector2d> minus = transfer(Eigen::Vector2d(px - h));
    if (plus && minus) {
      jacobian.col(axis) = (*plus - *minus) / (2.0 * step_px);
      continue;
    }
    if (!plus && !minus) return std::nullopt;
    // One side fails: a one-sided difference from px, evaluated only here (rarely twice: at a corner
    // of the domain, where both axes fail on one side).
    const std::optional<Eigen::Vector2d> centre = transfer(px);
    if (!centre) return std::nullopt;
    jacobian.col(axis) = plus ? Eigen::Vector2d((*plus - *centre) / step_px) : Eigen::Vector2d((*centre - *minus) / step_px);
  }
  if (!jacobian.allFinite()) return std::nullopt;
  return jacobian;
}

/// What a local affine map says about the images at one point.
struct AffineDecomposition {
  double scale = 1.0;         ///< sqrt|det A|: secondary pixels per master pixel, averaged over directions
  double sigma_max = 1.0;     ///< largest singular value (largest stretch, secondary px per master px)
  double sigma_min = 1.0;     ///< smallest singular value (smallest stretch); the ratio is the anisotropy
  double rotation = 0.0;      ///< radians in (-pi, pi]: rotation of the nearest similarity (see affine_rotation)
  bool reflection = false;    ///< det A < 0: the map mirrors (never the case between two frame images of
                              ///< the same ground seen from above)
};

/// Predicted scale ratio sqrt|det A| (secondary pixels per master pixel).
inline double affine_scale(const Eigen::Matrix2d& a) { return std::sqrt(std::abs(a.determinant())); }

/// The two singular values of A, largest first (closed form for 2x2).
inline Eigen::Vector2d affine_singular_values(const Eigen::Matrix2d& a) {
  // A = [[p, q], [r, s]]: sigma = (|conformal part| +- |anticonformal part|), which stays accurate
  // for nearly singular maps where the eigenvalues of A^T A lose half their digits.
  const double e = 0.5 * (a(0, 0) + a(1, 1)), f = 0.5 * (a(0, 0) - a(1, 1));
  const double g = 0.5 * (a(1, 0) + a(0, 1)), h = 0.5 * (a(1, 0) - a(0, 1));
  const double conformal = std::hypot(e, h), anticonformal = std::hypot(f, g);
  return {conformal + anticonformal, std::abs(conformal - anticonformal)};
}

/// Rotation angle (radians, in (-pi, pi]) between the images at a point: the angle of the rotation
/// of the similarity nearest to A in the Frobenius sense, equal to the rotation of A's polar
/// decomposition when det A > 0. Angles are in pixel coordinates (x right, y down): a positive
/// angle turns +x towards +y, i.e. clockwise on screen, as a keypoint's orientation in an image
/// whose y axis points down. For a reflection (det A < 0) it is the angle of A diag(1, -1).
inline double affine_rotation(const Eigen::Matrix2d& a) {
  if (a.determinant() >= 0.0) return std::atan2(a(1, 0) - a(0, 1), a(0, 0) + a(1, 1));
  // Mirror the master y axis first so that the remaining part is a proper rotation.
  return std::atan2(a(1, 0) + a(0, 1), a(0, 0) - a(1, 1));
}

/// All of the above at once.
inline AffineDecomposition decompose_affine(const Eigen::Matrix2d& a) {
  AffineDecomposition d;
  d.scale = affine_scale(a);
  const Eigen::Vector2d sv = affine_singular_values(a);
  d.sigma_max = sv.x();
  d.sigma_min = sv.y();
  d.rotation = affine_rotation(a);
  d.reflection = a.determinant() < 0.0;
  return d;
}

}  // namespace diachron
