#pragma once
/// @file
/// Features: keypoints with scale and orientation plus one descriptor per keypoint, as
/// FeatureExtractors return them and descriptor matchers consume them.

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace diachron {

/// A detected keypoint. `position` in pixels (docs/conventions.md); `scale` in pixels (the
/// detector's characteristic size, e.g. OpenCV's KeyPoint::size; 0 when the detector has none);
/// `angle` in radians, measured from the +x axis towards +y (clockwise as seen on screen, since y
/// points down), in [0, 2 pi); negative when the detector gives no orientation. `response` is the
/// detector strength (higher is stronger).
struct Keypoint {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double scale = 0.0;
  double angle = -1.0;
  double response = 0.0;
};

/// Row-major float descriptors, one row per keypoint.
using DescriptorMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Keypoints and their descriptors: descriptors.rows() == keypoints.size().
struct Features {
  std::vector<Keypoint> keypoints;
  DescriptorMatrix descriptors;

  std::size_t size() const { return keypoints.size(); }
  bool empty() const { return keypoints.empty(); }
};

}  // namespace diachron
