#pragma once
/// @file
/// Rotation helpers shared by Similarity2 and Helmert3: 2D rotation matrices, axis-angle and
/// yaw-pitch-roll to 3x3 matrices (scalar-templated for Ceres Jets), angle wrapping, rotation
/// distances and deterministic random rotations for tests and scene generators.

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/core/random.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// The 2x2 rotation by `angle` radians, counter-clockwise in a right-handed x/y frame
/// (clockwise on screen when y points down, as in pixel coordinates):
/// @code
/// [ cos(a)  -sin(a) ]
/// [ sin(a)   cos(a) ]
/// @endcode
template <class T>
Eigen::Matrix<T, 2, 2> rotation2(const T& angle) {
  using std::cos;
  using std::sin;
  const T c = cos(angle);
  const T s = sin(angle);
  Eigen::Matrix<T, 2, 2> r;
  r << c, -s, s, c;
  return r;
}

/// Rodrigues' formula: the rotation by |axis_angle| radians about axis_angle / |axis_angle|
/// (right-hand rule). Below |axis_angle| ~ 1e-8 it switches to the first-order form, so the
/// derivatives stay finite for Ceres Jets at the identity (sqrt has an infinite slope at 0).
template <class T>
Eigen::Matrix<T, 3, 3> rotation_from_axis_angle(const Eigen::Matrix<T, 3, 1>& axis_angle) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  // R = I + a K + b K^2 with K the cross-product matrix of v = axis_angle, written out with
  // K^2 = v v^T - theta^2 I: element by element, no matrix product to instantiate.
  const T x = axis_angle(0), y = axis_angle(1), z = axis_angle(2);
  const T theta2 = x * x + y * y + z * z;
  T a(1), b(0);  // first-order form below 1e-8 rad
  if (theta2 > T(1e-16)) {
    const T theta = sqrt(theta2);
    a = sin(theta) / theta;
    b = (T(1) - cos(theta)) / theta2;
  }
  const T diagonal = T(1) - b * theta2;
  Eigen::Matrix<T, 3, 3> r;
  r << diagonal + b * x * x, b * x * y - a * z, b * x * z + a * y,  //
      b * x * y + a * z, diagonal + b * y * y, b * y * z - a * x,   //
      b * x * z - a * y, b * y * z + a * x, diagonal + b * z * z;
  return r;
}

/// R = Rz(yaw) * Ry(pitch) * Rx(roll), angles in radians, each a right-hand rotation about the
/// fixed axis it names: a point is first rolled about x, then pitched about y, then yawed about z.
template <class T>
Eigen::Matrix<T, 3, 3> rotation_from_yaw_pitch_roll(const T& yaw, const T& pitch, const T& roll) {
  using std::cos;
  using std::sin;
  const T cy = cos(yaw), sy = sin(yaw);
  const T cp = cos(pitch), sp = sin(pitch);
  const T cr = cos(roll), sr = sin(roll);
  Eigen::Matrix<T, 3, 3> r;
  r << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
      sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,   //
      -sp, cp * sr, cp * cr;
  return r;
}

/// `angle` wrapped into (-pi, pi] radians. Non-finite input comes back unchanged.
inline double wrap_angle(double angle) {
  if (!std::isfinite(angle)) return angle;
  double wrapped = std::remainder(angle, 2.0 * kPi);  // in [-pi, pi]
  if (wrapped <= -kPi) wrapped += 2.0 * kPi;
  return wrapped;
}

/// Rotation angle of a 3x3 rotation matrix, in [0, pi] radians. Uses atan2 of the sine and cosine
/// parts rather than acos of the trace, so it stays accurate near 0 and near pi.
inline double rotation_angle(const Eigen::Matrix3d& r) {
  const Eigen::Vector3d skew(r(2, 1) - r(1, 2), r(0, 2) - r(2, 0), r(1, 0) - r(0, 1));
  return std::atan2(0.5 * skew.norm(), 0.5 * (r.trace() - 1.0));
}

/// Angle in [0, pi] radians of the rotation that takes `a` to `b` (the geodesic distance on SO(3)).
inline double rotation_distance(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return rotation_angle(a.transpose() * b);
}

/// Axis-angle vector (axis times angle in radians, angle in [0, pi]) of a rotation matrix.
/// Goes through a quaternion, which is well conditioned also at 180 degrees.
inline Eigen::Vector3d axis_angle_from_rotation(const Eigen::Matrix3d& r) {
  // Eigen::AngleAxisd(quaternion) in closed form (it would instantiate stableNorm for 3 numbers).
  const Eigen::Quaterniond q = Eigen::Quaterniond(r).normalized();
  const double half_sine = std::hypot(q.x(), q.y(), q.z());  // sin(angle / 2)
  if (!(half_sine > 0.0)) return Eigen::Vector3d::Zero();
  // q and -q are the same rotation; the one with w >= 0 has its angle in [0, pi].
  const double angle = 2.0 * std::atan2(half_sine, std::abs(q.w()));
  return (q.w() < 0.0 ? -angle : angle) / half_sine * q.vec();
}

/// A rotation drawn uniformly from SO(3) (Haar measure): a normalised 4D Gaussian quaternion.
inline Eigen::Matrix3d random_rotation(RandomStream& random) {
  Eigen::Quaterniond q;
  double norm = 0.0;
  do {
    // One draw per statement (core/random.hpp: the order of a call's arguments is unspecified).
    const double z = random.normal(), y = random.normal(), x = random.normal(), w = random.normal();
    q = Eigen::Quaterniond(w, x, y, z);
    norm = q.norm();
  } while (norm < 1e-6);
  q.coeffs() /= norm;
  return q.toRotationMatrix();
}

/// A rotation about a uniformly random axis by an angle uniform in [0, max_angle] radians; handy
/// for the small attitude differences between epochs.
inline Eigen::Matrix3d random_rotation(RandomStream& random, double max_angle) {
  Eigen::Vector3d axis;
  do {
    const double z = random.normal(), y = random.normal(), x = random.normal();
    axis = Eigen::Vector3d(x, y, z);
  } while (axis.norm() < 1e-6);
  axis.normalize();
  return rotation_from_axis_angle<double>(axis * random.uniform(0.0, max_angle));
}

namespace detail {

/// One step of wrapping into (-pi, pi] that keeps Ceres Jet derivatives (it only adds constants).
/// Enough for sums and negations of angles already in (-pi, pi].
template <class T>
T wrap_angle_once(T angle) {
  if (angle > T(kPi)) {
    angle -= T(2.0 * kPi);
  } else if (angle <= T(-kPi)) {
    angle += T(2.0 * kPi);
  }
  return angle;
}

}  // namespace detail
}  // namespace diachron
