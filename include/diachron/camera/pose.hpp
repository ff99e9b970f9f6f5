#pragma once
/// @file
/// Pose: the exterior orientation of a frame camera, X_cam = R (X_world - C), with helpers for
/// aerial (nadir) cameras and the move of a pose into another frame by a 3D similarity.

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>

#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>

namespace diachron {

namespace detail {

// Accepts matrices that are rotations up to the rounding of stored orientations (1e-6 per
// entry of R^T R - I) and returns the nearest exact rotation, so a pose never carries a scale or
// a reflection that would bend projections.
inline Mat3 checked_rotation(const Mat3& r, const char* what) {
  DIACHRON_CHECK(r.allFinite(), what << " must be finite");
  const double error = (r.transpose() * r - Mat3::Identity()).cwiseAbs().maxCoeff();
  DIACHRON_CHECK(error <= 1e-6 && r.determinant() > 0.0,
                 what << " must be a proper rotation (orthonormal, det +1); |R^T R - I|max = "
                      << error << ", det = " << r.determinant());
  const Eigen::JacobiSVD<Mat3> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

}  // namespace detail

/// Exterior orientation: the rotation R = cam_from_world (world -> camera frame, proper, 3x3) and
/// the projection centre C (world units, metres for aerial work), X_cam = R (X_world - C).
/// Camera frame: x right, y down, z forward (docs/conventions.md). A value type; thread-safe.
class Pose {
 public:
  /// Identity rotation at the origin.
  Pose() = default;

  /// @param cam_from_world_rotation R, a proper rotation up to 1e-6 per entry (it is
  ///        re-orthonormalised); @param centre C, finite.
  /// Precondition: as above, else throws diachron::Error.
  Pose(const Mat3& cam_from_world_rotation, const Vec3& centre)
      : rotation_(detail::checked_rotation(cam_from_world_rotation, "Pose rotation")),
        centre_(centre) {
    DIACHRON_CHECK(centre.allFinite(), "Pose centre must be finite");
  }

  /// From the (R, t) form X_cam = R X_world + t of COLMAP and OpenCV: C = -R^T t.
  static Pose from_cam_from_world(const Mat3& rotation, const Vec3& translation) {
    const Mat3 r = detail::checked_rotation(rotation, "Pose rotation");
    DIACHRON_CHECK(translation.allFinite(), "Pose translation must be finite");
    return Pose(r, -r.transpose() * translation);
  }

  /// A camera at `centre` looking at `target`, rolled so that the world direction `up` appears
  /// towards the top of the image (-y of the camera). For a nadir aerial camera with up = +Y
  /// (north), image right is +X (east) and image top is north, like a map.
  /// Precondition: target != centre and `up` not parallel to the viewing direction.
  static Pose look_at(const Vec3& centre, const Vec3& target, const Vec3& up = Vec3::UnitY()) {
    DIACHRON_CHECK(centre.allFinite() && target.allFinite() && up.allFinite(),
                   "look_at: centre, target and up must be finite");
    const Vec3 view = target - centre;
    DIACHRON_CHECK(view.norm() > 0.0, "look_at: target equals the centre");
    const Vec3 z = view.normalized();
    const Vec3 up_perpendicular = up - up.dot(z) * z;
    DIACHRON_CHECK(up_perpendicular.norm() > 1e-9 * up.norm() && up.norm() > 0.0,
                   "look_at: `up` is zero or parallel to the viewing direction");
    const Vec3 y = -up_perpendicular.normalized();
    const Vec3 x = y.cross(z);
    Mat3 r;
    r.row(0) = x.transpose();
    r.row(1) = y.transpose();
    r.row(2) = z.transpose();
    return Pose(r, centre);
  }

  /// An aerial camera from yaw, pitch and roll (radians) about its nadir attitude:
  ///   world_from_cam = Rz(yaw) * N * Rx(pitch) * Ry(roll),  N = diag(1, -1, -1),
  /// N being the nadir camera with image right to +X and image top to +Y.
  /// yaw turns the image axes counter-clockwise about world Z (seen from above); pitch > 0 tilts
  /// the view towards the image top; roll > 0 tilts it towards the image right.
  /// Precondition: finite angles and centre.
  static Pose from_yaw_pitch_roll(const Vec3& centre, double yaw, double pitch, double roll) {
    DIACHRON_CHECK(std::isfinite(yaw) && std::isfinite(pitch) && std::isfinite(roll),
                   "from_yaw_pitch_roll: angles must be finite");
    const Mat3 nadir = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
    const Mat3 world_from_cam = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix() * nadir *
                                Eigen::AngleAxisd(pitch, Vec3::UnitX()).toRotationMatrix() *
                                Eigen::AngleAxisd(roll, Vec3::UnitY()).toRotationMatrix();
    return Pose(world_from_cam.transpose(), centre);
  }

  /// R: world -> camera rotation.
  const Mat3& cam_from_world_rotation() const { return rotation_; }
  /// t = -R C of the form X_cam = R X_world + t.
  Vec3 cam_from_world_translation() const { return -(rotation_ * centre_); }
  /// C: projection centre, world units.
  const Vec3& centre() const { return centre_; }
  /// Viewing direction (camera +z) in the world frame, unit.
  Vec3 viewing_direction() const { return rotation_.row(2).transpose(); }

  /// X_cam = R (X_world - C).
  Vec3 cam_from_world(const Vec3& world) const { return rotation_ * (world - centre_); }
  /// X_world = R^T X_cam + C.
  Vec3 world_from_cam(const Vec3& cam) const { return rotation_.transpose() * cam + centre_; }
  /// A direction (not a point) from the camera frame to the world frame: R^T d.
  Vec3 world_direction_from_cam(const Vec3& direction) const {
    return rotation_.transpose() * direction;
  }

  /// This pose moved into another frame by the similarity X' = scale * rotation * X + translation
  /// (e.g. epoch 1 into epoch 2 by a Helmert): C' = s R_s C + t and R' = R R_s^T, so that
  /// R' (X' - C') = s R (X - C) and every projection is unchanged.
  /// Precondition: scale finite and > 0, rotation proper, translation finite.
  Pose transformed(double scale, const Mat3& rotation, const Vec3& translation) const {
    DIACHRON_CHECK(std::isfinite(scale) && scale > 0.0,
                   "similarity scale must be finite and > 0, got " << scale);
    DIACHRON_CHECK(translation.allFinite(), "similarity translation must be finite");
    const Mat3 r = detail::checked_rotation(rotation, "similarity rotation");
    return Pose(rotation_ * r.transpose(), scale * (r * centre_) + translation);
  }

  /// The same with the similarity as a Helmert3, e.g. `pose.transformed(report.epoch2_from_epoch1)`
  /// moves an epoch-1 pose into epoch 2.
  Pose transformed(const Helmert3& helmert) const {
    return transformed(helmert.scale, helmert.rotation, helmert.translation);
  }

 private:
  Mat3 rotation_ = Mat3::Identity();
  Vec3 centre_ = Vec3::Zero();
};

}  // namespace diachron
