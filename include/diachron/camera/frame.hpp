#pragma once
/// @file
/// Frame<Distortion>: one oriented image (interior Camera + exterior Pose) that projects world
/// points to pixels and casts pixel rays into the world; what the DSM transfer is written against.

#include <optional>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/ray.hpp>

namespace diachron {

/// An oriented image: camera (px) and pose (world units). A value type; all const members are
/// thread-safe.
/// @tparam Distortion a model of the Distortion concept (diachron/camera/distortion.hpp).
template <class Distortion>
class Frame {
  static_assert(check_distortion<Distortion>());

 public:
  using CameraType = Camera<Distortion>;

  Frame(const CameraType& camera, const Pose& pose) : camera_(camera), pose_(pose) {}

  const CameraType& camera() const { return camera_; }
  const Pose& pose() const { return pose_; }
  void set_camera(const CameraType& camera) { camera_ = camera; }
  void set_pose(const Pose& pose) { pose_ = pose; }

  /// Pixel (px) of a world point; nullopt when the point is behind the camera or on its centre
  /// plane, is not finite, or lies beyond the fold of the distortion (Camera::project). The pixel
  /// may fall outside the image: test it with in_image().
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& world) const {
    if (!world.allFinite()) return std::nullopt;
    return camera_.project(pose_.cam_from_world(world));
  }

  /// The world ray through a pixel: origin the projection centre, unit direction in the world
  /// frame; nullopt when the pixel cannot be unprojected (non-finite, or the distortion has no
  /// preimage there). Pixels outside the image are allowed.
  /// Unprojection uses the default UnprojectOptions (1e-10 px).
  std::optional<Ray3> ray(const Eigen::Vector2d& pixel) const {
    const std::optional<Vec3> direction = camera_.unproject(pixel);
    if (!direction) return std::nullopt;
    Ray3 out;
    out.origin = pose_.centre();
    out.direction = pose_.world_direction_from_cam(*direction).normalized();
    return out;
  }

  /// True when `pixel` lies on the image (edges included), see Camera::in_image.
  bool in_image(const Eigen::Vector2d& pixel) const { return camera_.in_image(pixel); }

  /// This frame moved into another world frame by X' = scale * rotation * X + translation; see
  /// Pose::transformed. Projections are unchanged: project(X) == moved.project(s R X + t).
  Frame transformed(double scale, const Mat3& rotation, const Vec3& translation) const {
    return Frame(camera_, pose_.transformed(scale, rotation, translation));
  }

  /// The same with the similarity as a Helmert3 (e.g. epoch2_from_epoch1 of a co-registration).
  Frame transformed(const Helmert3& helmert) const { return Frame(camera_, pose_.transformed(helmert)); }

 private:
  CameraType camera_;
  Pose pose_;
};

/// Every frame of `frames` moved by `helmert` (Frame::transformed), in order: e.g. epoch 1 put into
/// epoch 2's frame by the co-registration.
template <class Distortion>
std::vector<Frame<Distortion>> transformed_frames(const std::vector<Frame<Distortion>>& frames, const Helmert3& helmert) {
  std::vector<Frame<Distortion>> out;
  out.reserve(frames.size());
  for (const Frame<Distortion>& f : frames) out.push_back(f.transformed(helmert));
  return out;
}

}  // namespace diachron
