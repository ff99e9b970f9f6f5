#pragma once
/// @file
/// Similarity2T: the 4-parameter 2D similarity (scale, rotation angle, translation) that maps a
/// source image or DSM image into the target one. Scalar-templated for Ceres Jets.

#include <cmath>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/geometry/rotation.hpp>

namespace diachron {

/// A 2D similarity `target = scale * R(angle) * source + translation`.
///
/// - `scale`: dimensionless, > 0 for a valid transform (target units per source unit).
/// - `angle`: radians, counter-clockwise in a right-handed x/y frame (see rotation2()); estimators
///   and the operations below keep it in (-pi, pi] when their inputs are.
/// - `translation`: in target units (pixels, metres).
///
/// Name instances `<to>_from_<from>`, e.g. `secondary_from_master`. An aggregate, so
/// `Similarity2{2.0, 0.5, {10.0, 20.0}}` works. With T = ceres::Jet every member function is
/// differentiable (no value-dependent branch drops a derivative).
/// @tparam T double, float or ceres::Jet.
template <class T>
struct Similarity2T {
  using Scalar = T;
  using Vector = Eigen::Matrix<T, 2, 1>;
  using Matrix = Eigen::Matrix<T, 2, 2>;

  T scale = T(1);
  T angle = T(0);
  Vector translation = Vector::Zero();

  /// The transform that maps every point onto itself.
  static Similarity2T identity() { return Similarity2T{T(1), T(0), Vector::Zero()}; }

  /// R(angle), 2x2.
  Matrix rotation() const { return rotation2<T>(angle); }

  /// scale * R(angle): the linear part, 2x2.
  Matrix linear() const { return scale * rotation(); }

  /// Homogeneous 3x3 matrix [scale * R, translation; 0 0 1].
  Eigen::Matrix<T, 3, 3> matrix() const {
    Eigen::Matrix<T, 3, 3> m = Eigen::Matrix<T, 3, 3>::Identity();
    m.template topLeftCorner<2, 2>() = linear();
    m.template topRightCorner<2, 1>() = translation;
    return m;
  }

  /// Maps a source point into the target frame.
  Vector operator()(const Vector& source) const {
    using std::cos;
    using std::sin;
    const T a = scale * cos(angle);
    const T b = scale * sin(angle);
    return Vector(a * source(0) - b * source(1) + translation(0),
                  b * source(0) + a * source(1) + translation(1));
  }

  /// The transform from target back to source: scale 1/s, angle -a, translation -R^T t / s.
  /// Precondition: scale != 0 (throws diachron::Error otherwise).
  Similarity2T inverse() const {
    DIACHRON_CHECK(scale != T(0), "Similarity2T::inverse of a transform with zero scale");
    const T inverse_scale = T(1) / scale;
    const Matrix rt = rotation().transpose();
    return Similarity2T{inverse_scale, detail::wrap_angle_once(-angle),
                        Vector(-inverse_scale * (rt * translation))};
  }

  /// Composition: `(a * b)(x) == a(b(x))`, so `c_from_a = c_from_b * b_from_a`.
  Similarity2T operator*(const Similarity2T& b) const {
    return Similarity2T{scale * b.scale, detail::wrap_angle_once(angle + b.angle),
                        Vector(scale * (rotation() * b.translation) + translation)};
  }

  /// The same transform with scalar type U (double -> float, double -> ceres::Jet, ...).
  template <class U>
  Similarity2T<U> cast() const {
    return Similarity2T<U>{static_cast<U>(scale), static_cast<U>(angle),
                           translation.template cast<U>()};
  }
};

/// The double-precision 2D similarity used throughout the library.
using Similarity2 = Similarity2T<double>;

}  // namespace diachron
