#pragma once
/// @file
/// Helmert3T: the 7-parameter spatial similarity X2 = scale * R * X1 + T that moves epoch 1 into
/// epoch 2's frame. Scalar-templated so Ceres Jets can run through it.

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/geometry/rotation.hpp>

namespace diachron {

/// A 3D Helmert (spatial similarity) `X2 = scale * rotation * X1 + translation`.
///
/// - `scale`: dimensionless, > 0 for a valid transform (epoch-2 units per epoch-1 unit).
/// - `rotation`: a proper rotation (orthonormal, det +1), 3x3; not re-orthonormalised here.
/// - `translation`: in the target (epoch 2) frame's units, usually metres.
///
/// By convention (docs/conventions.md) a Helmert maps epoch 1 into epoch 2; name instances
/// `epoch2_from_epoch1`. An aggregate:
/// @code
/// const Helmert3 epoch2_from_epoch1 =
///     Helmert3::from_yaw_pitch_roll(1.02, 0.1, 0.0, 0.0, {5.0, 0.0, 1.0});
/// const Eigen::Vector3d x2 = epoch2_from_epoch1(x1);
/// @endcode
/// @tparam T double, float or ceres::Jet.
template <class T>
struct Helmert3T {
  using Scalar = T;
  using Vector = Eigen::Matrix<T, 3, 1>;
  using Matrix = Eigen::Matrix<T, 3, 3>;

  T scale = T(1);
  Matrix rotation = Matrix::Identity();
  Vector translation = Vector::Zero();

  /// The transform that maps every point onto itself.
  static Helmert3T identity() { return Helmert3T{T(1), Matrix::Identity(), Vector::Zero()}; }

  /// From an axis-angle rotation vector (axis times angle in radians, see
  /// rotation_from_axis_angle()).
  static Helmert3T from_axis_angle(const T& scale, const Vector& axis_angle,
                                   const Vector& translation) {
    return Helmert3T{scale, rotation_from_axis_angle<T>(axis_angle), translation};
  }

  /// From yaw, pitch and roll in radians, R = Rz(yaw) Ry(pitch) Rx(roll) (see
  /// rotation_from_yaw_pitch_roll()).
  static Helmert3T from_yaw_pitch_roll(const T& scale, const T& yaw, const T& pitch, const T& roll,
                                       const Vector& translation) {
    return Helmert3T{scale, rotation_from_yaw_pitch_roll<T>(yaw, pitch, roll), translation};
  }

  /// Homogeneous 4x4 matrix [scale * R, translation; 0 0 0 1].
  Eigen::Matrix<T, 4, 4> matrix() const {
    Eigen::Matrix<T, 4, 4> m = Eigen::Matrix<T, 4, 4>::Identity();
    m.template topLeftCorner<3, 3>() = scale * rotation;
    m.template topRightCorner<3, 1>() = translation;
    return m;
  }

  /// Maps an epoch-1 point into epoch 2.
  Vector operator()(const Vector& x1) const { return scale * (rotation * x1) + translation; }

  /// The transform from epoch 2 back to epoch 1: scale 1/s, R^T, translation -R^T t / s.
  /// Precondition: scale != 0 (throws diachron::Error otherwise).
  Helmert3T inverse() const {
    DIACHRON_CHECK(scale != T(0), "Helmert3T::inverse of a transform with zero scale");
    const T inverse_scale = T(1) / scale;
    const Matrix rt = rotation.transpose();
    return Helmert3T{inverse_scale, rt, Vector(-inverse_scale * (rt * translation))};
  }

  /// Composition: `(a * b)(x) == a(b(x))`, so `epoch3_from_epoch1 = epoch3_from_epoch2 *
  /// epoch2_from_epoch1`.
  Helmert3T operator*(const Helmert3T& b) const {
    return Helmert3T{scale * b.scale, Matrix(rotation * b.rotation),
                     Vector(scale * (rotation * b.translation) + translation)};
  }

  /// The same transform with scalar type U (double -> float, double -> ceres::Jet, ...).
  template <class U>
  Helmert3T<U> cast() const {
    return Helmert3T<U>{static_cast<U>(scale), rotation.template cast<U>(),
                        translation.template cast<U>()};
  }
};

/// The double-precision 3D Helmert used throughout the library.
using Helmert3 = Helmert3T<double>;

}  // namespace diachron
