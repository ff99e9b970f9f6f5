#pragma once
/// @file
/// Ceres cost functors of the reprojection error of a frame camera, templated on the Distortion
/// policy; the projection is Camera<Distortion>'s own scalar-templated `project`, so values and
/// derivatives (ceres::Jet) come from the one model. Usable in any Ceres problem: they need no
/// diachron track or problem builder.
///
/// Parameter-block layouts (doubles, in this order):
///   intrinsics  [f (px), cx (px), cy (px), params[0 .. kNumParams - 1]]  (Camera::intrinsics())
///   camera      [f, cx, cy, K1, K2, K3, P1, P2]  (FraserAffine without B1, B2; shared per camera)
///   affine      [B1 (px), B2 (px)]                 (per image: film and scanner deformation)
///   pose        [w0, w1, w2, Cx, Cy, Cz]: w the angle-axis vector (radians) of the rotation
///               R = cam_from_world, C the projection centre (world units); X_cam = R (X - C).
///   point       [X, Y, Z] world units.
/// Residual: (projected - observed) / sigma_px, two values, dimensionless (pixels when sigma = 1).
///
/// Why angle-axis + centre: six numbers with no manifold to attach (a user's problem needs none),
/// the rotation stays well defined at the half-turn of nadir cameras (angle pi), and the centre is
/// the quantity photogrammetry fixes, weights and compares (GPS, FrozenPoses, the Helmert moves
/// it), unlike the translation t = -R C, which mixes rotation into position.

#include <array>
#include <cmath>

#include <Eigen/Core>
#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// Size of a pose block [angle-axis (3), centre (3)].
inline constexpr int kPoseBlockSize = 6;
/// Size of a FraserAffine camera block without the affine part [f, cx, cy, K1, K2, K3, P1, P2].
inline constexpr int kFraserCameraBlockSize = 8;
/// Size of a per-image affine block [B1, B2].
inline constexpr int kAffineBlockSize = 2;

/// The pose block [angle-axis of R, C] of a Pose.
inline std::array<double, kPoseBlockSize> pose_block(const Pose& pose) {
  const Mat3& r = pose.cam_from_world_rotation();
  std::array<double, kPoseBlockSize> out{};
  // Eigen stores column-major; Ceres' adapter reads it so, and is exact near angle pi.
  ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(r.data()), out.data());
  out[3] = pose.centre().x();
  out[4] = pose.centre().y();
  out[5] = pose.centre().z();
  return out;
}

/// The Pose of a pose block [angle-axis of R, C]. Precondition: finite values.
inline Pose pose_from_block(const double* block) {
  Mat3 r;
  ceres::AngleAxisToRotationMatrix(block, ceres::ColumnMajorAdapter3x3(r.data()));
  return Pose(r, Vec3(block[3], block[4], block[5]));
}

/// Camera-frame coordinates of a world point from a pose block: X_cam = R (X - C).
template <class T>
void cam_from_world_block(const T* pose, const T* point, T* point_cam) {
  const T shifted[3] = {point[0] - pose[3], point[1] - pose[4], point[2] - pose[5]};
  ceres::AngleAxisRotatePoint(pose, shifted, point_cam);
}

/// Reprojection error with one intrinsics block per camera (every Distortion policy).
/// Blocks: intrinsics (Camera<Distortion>::kNumIntrinsics), pose (6), point (3); 2 residuals.
/// Evaluation fails (returns false, Ceres then shortens the step) when the point is not in front
/// of the camera.
template <class Distortion>
struct ReprojectionError {
  static_assert(check_distortion<Distortion>());
  static constexpr int kIntrinsicsSize = Camera<Distortion>::kNumIntrinsics;

  /// @param observed pixel, px (diachron convention). @param sigma_px its standard deviation, > 0.
  ReprojectionError(const Vec2& observed, double sigma_px)
      : u_(observed.x()), v_(observed.y()), inverse_sigma_(1.0 / sigma_px) {}

  template <class T>
  bool operator()(const T* const intrinsics, const T* const pose, const T* const point,
                  T* residuals) const {
    T point_cam[3];
    cam_from_world_block(pose, point, point_cam);
    if (!(point_cam[2] > T(0))) return false;
    T pixel[2];
    Camera<Distortion>::project(intrinsics, point_cam, pixel);
    residuals[0] = (pixel[0] - T(u_)) * T(inverse_sigma_);
    residuals[1] = (pixel[1] - T(v_)) * T(inverse_sigma_);
    return true;
  }

  /// An autodiff cost function (caller or ceres::Problem owns it).
  /// Precondition: observed finite, sigma_px finite and > 0 (throws diachron::Error).
  static ceres::CostFunction* create(const Vec2& observed, double sigma_px = 1.0) {
    DIACHRON_CHECK(observed.allFinite() && std::isfinite(sigma_px) && sigma_px > 0.0,
                   "ReprojectionError: the pixel must be finite and sigma_px > 0, got " << sigma_px);
    return new ceres::AutoDiffCostFunction<ReprojectionError, 2, kIntrinsicsSize, kPoseBlockSize, 3>(
        new ReprojectionError(observed, sigma_px));
  }

 private:
  double u_, v_, inverse_sigma_;
};

/// Reprojection error of a FraserAffine camera whose affine part is per image: the camera block
/// [f, cx, cy, K1, K2, K3, P1, P2] is shared by the images of one camera, the affine block
/// [B1, B2] belongs to one image (each scan of a film deforms on its own).
/// Blocks: camera (8), affine (2), pose (6), point (3); 2 residuals.
struct SplitAffineReprojectionError {
  /// @param observed pixel, px. @param sigma_px its standard deviation, > 0.
  /// @param weight the square root of the observation's information relative to sigma_px: the
  ///        residual is weight (projected - observed) / sigma_px. Identity: isotropic sigma_px.
  SplitAffineReprojectionError(const Vec2& observed, double sigma_px,
                               const Eigen::Matrix2d& weight = Eigen::Matrix2d::Identity())
      : u_(observed.x()),
        v_(observed.y()),
        w_{weight(0, 0) / sigma_px, weight(0, 1) / sigma_px, weight(1, 0) / sigma_px, weight(1, 1) / sigma_px} {}

  template <class T>
  bool operator()(const T* const camera, const T* const affine, const T* const pose,
                  const T* const point, T* residuals) const {
    T point_cam[3];
    cam_from_world_block(pose, point, point_cam);
    if (!(point_cam[2] > T(0))) return false;
    // FraserAffine's parameter order: K1, K2, K3, P1, P2, B1, B2.
    const T params[FraserAffine::kNumParams] = {camera[3], camera[4], camera[5], camera[6],
                                                camera[7], affine[0], affine[1]};
    T pixel[2];
    Camera<FraserAffine>::project(camera, params, point_cam, pixel);
    const T du = pixel[0] - T(u_), dv = pixel[1] - T(v_);
    residuals[0] = T(w_[0]) * du + T(w_[1]) * dv;
    residuals[1] = T(w_[2]) * du + T(w_[3]) * dv;
    return true;
  }

  /// An autodiff cost function (caller or ceres::Problem owns it).
  /// Precondition: observed finite, sigma_px finite and > 0, weight finite and invertible (throws
  /// diachron::Error).
  static ceres::CostFunction* create(const Vec2& observed, double sigma_px = 1.0,
                                     const Eigen::Matrix2d& weight = Eigen::Matrix2d::Identity()) {
    DIACHRON_CHECK(observed.allFinite() && std::isfinite(sigma_px) && sigma_px > 0.0,
                   "SplitAffineReprojectionError: the pixel must be finite and sigma_px > 0, got "
                       << sigma_px);
    DIACHRON_CHECK(weight.allFinite() && std::abs(weight.determinant()) > 1e-12,
                   "SplitAffineReprojectionError: the weight must be finite and invertible");
    return new ceres::AutoDiffCostFunction<SplitAffineReprojectionError, 2, kFraserCameraBlockSize,
                                           kAffineBlockSize, kPoseBlockSize, 3>(
        new SplitAffineReprojectionError(observed, sigma_px, weight));
  }

 private:
  double u_, v_;
  double w_[4];  // weight / sigma_px, row-major
};

/// The camera block [f, cx, cy, K1, K2, K3, P1, P2] of a FraserAffine camera.
inline std::array<double, kFraserCameraBlockSize> fraser_camera_block(const Camera<FraserAffine>& camera) {
  const Camera<FraserAffine>::Intrinsics all = camera.intrinsics();
  std::array<double, kFraserCameraBlockSize> out{};
  for (int i = 0; i < kFraserCameraBlockSize; ++i) out[static_cast<std::size_t>(i)] = all[static_cast<std::size_t>(i)];
  return out;
}

/// The affine block [B1, B2] of a FraserAffine camera.
inline std::array<double, kAffineBlockSize> affine_block(const Camera<FraserAffine>& camera) {
  return {camera.params()[5], camera.params()[6]};
}

/// The FraserAffine camera of a camera block and an affine block (image size from `like`).
/// Precondition: a valid camera (Camera's checks, throws diachron::Error otherwise).
inline Camera<FraserAffine> camera_from_blocks(const double* camera, const double* affine, int width_px,
                                               int height_px) {
  const Camera<FraserAffine>::Params params = {camera[3], camera[4], camera[5], camera[6],
                                               camera[7], affine[0], affine[1]};
  return Camera<FraserAffine>(camera[0], camera[1], camera[2], width_px, height_px, params);
}

}  // namespace diachron
