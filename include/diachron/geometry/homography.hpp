#pragma once
/// @file
/// Homography2: a plane projective transform with checked application, and the normalised DLT
/// (Hartley) that estimates one from 4 or more point pairs. Used as a Transfer and for 4-point
/// patch resampling.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>

#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// A 2D homography `[x_t, y_t, 1]^T ~ matrix * [x_s, y_s, 1]^T` (equality up to scale).
///
/// `matrix` is defined up to scale; estimate_homography() returns it with unit Frobenius norm.
/// Applying it is a Transfer (docs/architecture.md): `std::optional<Vec2> operator()(const Vec2&)`,
/// empty where the point maps to (or near) the line at infinity. Name instances
/// `<to>_from_<from>`, e.g. `secondary_from_master`.
struct Homography2 {
  Eigen::Matrix3d matrix = Eigen::Matrix3d::Identity();

  /// Relative size of the homogeneous w below which a point is taken to map to infinity:
  /// |w| <= kMinRelativeW * (|h20 x| + |h21 y| + |h22|).
  static constexpr double kMinRelativeW = 1e-12;

  /// The identity homography.
  static Homography2 identity() { return Homography2{}; }

  /// The target point of `source`, or nullopt when it maps to (near) infinity or is not finite.
  std::optional<Vec2> operator()(const Vec2& source) const {
    const Eigen::Vector3d h = matrix * source.homogeneous();
    const double w_scale = std::abs(matrix(2, 0) * source.x()) +
                           std::abs(matrix(2, 1) * source.y()) + std::abs(matrix(2, 2));
    if (!(std::abs(h.z()) > kMinRelativeW * w_scale)) return std::nullopt;
    const Vec2 target = h.head<2>() / h.z();
    if (!target.allFinite()) return std::nullopt;
    return target;
  }

  /// The homography from target back to source, normalised to unit Frobenius norm; nullopt when
  /// `matrix` is singular (|det| below 1e-12 of |matrix|^3 in Frobenius norm) or not finite.
  std::optional<Homography2> inverse() const {
    const double norm = matrix.norm();
    if (!(norm > 0.0) || !std::isfinite(norm)) return std::nullopt;
    const Eigen::Matrix3d m = matrix / norm;
    const double det = m.determinant();
    if (!(std::abs(det) > 1e-12)) return std::nullopt;
    Eigen::Matrix3d inv = m.inverse();
    inv /= inv.norm();
    return Homography2{inv};
  }

  /// Composition: `(a * b)(x) == a(b(x))` wherever both sides are defined.
  Homography2 operator*(const Homography2& b) const { return Homography2{matrix * b.matrix}; }
};

/// Normalised direct linear transform (Hartley and Zisserman, Multiple View Geometry, Alg. 4.2).
///
/// Each point set is translated to its centroid and scaled to a mean distance of sqrt(2); the
/// 2n x 9 DLT system is solved by SVD and denormalised. Exact (to rounding) on 4 pairs in general
/// position, least squares of the algebraic error on more.
/// @tparam Pairs anything with `size()` and `operator[](i)` giving an object with `.source` and
///               `.target` (Eigen 2-vectors): std::vector<PointPair2>, Subset<PointPair2>, ...
/// @return the homography `target ~ H source` with unit Frobenius norm, or nullopt when fewer than
///         4 pairs, coordinates not finite, or the data do not determine a non-singular homography
///         (collinear sets, three collinear points among four, coincident points).
template <class Pairs>
std::optional<Homography2> estimate_homography(const Pairs& pairs);

// Implementation ---------------------------------------------------------------------------------

namespace detail {

/// Hartley's similarity normalisation of a point set: centroid to the origin, mean distance
/// sqrt(2). Returns nullopt when all points coincide.
template <class Pairs, class Get>
std::optional<Eigen::Matrix3d> hartley_normalisation(const Pairs& pairs, Get get) {
  const std::size_t n = pairs.size();
  // Mean relative to the first point keeps precision for large (UTM) coordinates.
  const Vec2 ref = get(pairs[0]);
  Vec2 mean = Vec2::Zero();
  for (std::size_t i = 0; i < n; ++i) mean += get(pairs[i]) - ref;
  mean /= static_cast<double>(n);
  double mean_distance = 0.0;
  for (std::size_t i = 0; i < n; ++i) mean_distance += ((get(pairs[i]) - ref) - mean).norm();
  mean_distance /= static_cast<double>(n);
  if (!(mean_distance > 0.0) || !std::isfinite(mean_distance)) return std::nullopt;
  const double s = std::sqrt(2.0) / mean_distance;
  const Vec2 centre = ref + mean;
  Eigen::Matrix3d t;
  t << s, 0.0, -s * centre.x(),  //
      0.0, s, -s * centre.y(),   //
      0.0, 0.0, 1.0;
  return t;
}

}  // namespace detail

template <class Pairs>
std::optional<Homography2> estimate_homography(const Pairs& pairs) {
  const std::size_t n = pairs.size();
  if (n < 4) return std::nullopt;
  for (std::size_t i = 0; i < n; ++i) {
    if (!pairs[i].source.allFinite() || !pairs[i].target.allFinite()) return std::nullopt;
  }
  const auto get_source = [](const auto& pair) -> Vec2 { return pair.source; };
  const auto get_target = [](const auto& pair) -> Vec2 { return pair.target; };
  const std::optional<Eigen::Matrix3d> ns = detail::hartley_normalisation(pairs, get_source);
  const std::optional<Eigen::Matrix3d> nt = detail::hartley_normalisation(pairs, get_target);
  if (!ns || !nt) return std::nullopt;

  // Rows for x' ~ H x:  [0^T, -x^T, y' x^T] and [x^T, 0^T, -x' x^T], with h row-major.
  // With 4 pairs a zero row pads the system to 9 x 9 so the SVD yields the full right basis.
  const Eigen::Index rows = static_cast<Eigen::Index>(std::max<std::size_t>(2 * n, 9));
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, 9);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d x = *ns * pairs[i].source.homogeneous();
    const Eigen::Vector3d y = *nt * pairs[i].target.homogeneous();
    const Eigen::Index r = static_cast<Eigen::Index>(2 * i);
    a.block<1, 3>(r, 3) = -y.z() * x.transpose();
    a.block<1, 3>(r, 6) = y.y() * x.transpose();
    a.block<1, 3>(r + 1, 0) = y.z() * x.transpose();
    a.block<1, 3>(r + 1, 6) = -y.x() * x.transpose();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd singular = svd.singularValues();
  // A second (near-)null direction means the data do not pin down one homography.
  if (!(singular(7) > 1e-10 * singular(0))) return std::nullopt;
  const Eigen::Matrix<double, 9, 1> h = svd.matrixV().col(8);
  Eigen::Matrix3d hn;
  hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);

  Eigen::Matrix3d result = nt->inverse() * hn * *ns;
  const double norm = result.norm();
  if (!(norm > 0.0) || !std::isfinite(norm)) return std::nullopt;
  result /= norm;
  // Singular: a degenerate configuration (e.g. three of four points collinear) fitted exactly.
  if (!(std::abs((hn / hn.norm()).determinant()) > 1e-10)) return std::nullopt;
  return Homography2{result};
}

}  // namespace diachron
