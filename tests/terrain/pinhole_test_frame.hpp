#pragma once
// A minimal pinhole frame for the terrain tests: the Frame signatures the library's templates
// expect (project / ray), without depending on camera/.
#include <cmath>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/geometry/ray.hpp>

namespace diachron::test {

/// x_cam = R (X - C); u = f x/z + cx, v = f y/z + cy (camera x right, y down, z forward).
struct PinholeFrame {
  double f = 1000.0, cx = 500.0, cy = 500.0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d C = Eigen::Vector3d::Zero();

  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& world) const {
    const Eigen::Vector3d x = R * (world - C);
    if (!(x.z() > 0.0)) return std::nullopt;
    return Eigen::Vector2d(f * x.x() / x.z() + cx, f * x.y() / x.z() + cy);
  }
  std::optional<Ray3> ray(const Eigen::Vector2d& px) const {
    if (!px.allFinite()) return std::nullopt;
    const Eigen::Vector3d d = R.transpose() * Eigen::Vector3d((px.x() - cx) / f, (px.y() - cy) / f, 1.0);
    return Ray3{C, d.normalized()};
  }
};

/// Camera looking straight down, image x = world +X, image y = world -Y (north up).
inline Eigen::Matrix3d nadir_rotation() {
  Eigen::Matrix3d r;
  r << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  return r;
}

/// A nadir frame at `centre`, then turned by `roll` about its optical axis and tilted by `tilt`
/// about its x axis (radians).
inline PinholeFrame make_frame(const Eigen::Vector3d& centre, double f = 1000.0, double roll = 0.0,
                               double tilt = 0.0) {
  PinholeFrame frame;
  frame.f = f;
  frame.C = centre;
  frame.R = Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()).toRotationMatrix() *
            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix() * nadir_rotation();
  return frame;
}

}  // namespace diachron::test
