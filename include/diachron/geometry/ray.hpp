#pragma once
/// @file
/// Ray3: a half-line in a world or epoch frame, as cameras emit and DSMs intersect.

#include <Eigen/Core>

namespace diachron {

/// Points origin + t * direction for t >= 0. `direction` is unit length (producers normalise it);
/// `origin` is the camera centre for rays from a Frame. Units of the frame (metres for a DSM).
struct Ray3 {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();

  Eigen::Vector3d at(double t) const { return origin + t * direction; }
};

}  // namespace diachron
