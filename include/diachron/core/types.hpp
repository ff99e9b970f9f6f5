#pragma once
/// @file
/// Value types shared by every module: point pairs, vector aliases and constants.

#include <Eigen/Core>

namespace diachron {

/// pi, so that no code depends on the non-standard M_PI.
inline constexpr double kPi = 3.14159265358979323846;

/// MicMac pixel coordinate minus diachron pixel coordinate, px. Both put integer coordinates at
/// pixel centres (MicMac images are indexed from the top-left pixel's centre), for images
/// (camera/micmac_conversion.hpp) and tie points (io/homol.hpp) alike; pass another value to those
/// functions if your MicMac data use the corner convention.
inline constexpr double kMicmacPixelShift = 0.0;

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;

/// A 2D correspondence: `source` in the frame being moved, `target` in the reference frame
/// (pixels or map units; the estimator does not care, residuals come out in target units).
struct PointPair2 {
  Eigen::Vector2d source;
  Eigen::Vector2d target;
};

/// A 3D correspondence: `source` in epoch 1's frame, `target` in epoch 2's frame.
struct PointPair3 {
  Eigen::Vector3d source;
  Eigen::Vector3d target;
};

/// One pixel of one image: an observation of a point. `image` indexes the caller's list of images
/// (an epoch's, or one list over several epochs).
struct ImagePixel {
  int image = 0;                                    ///< image index, >= 0
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  ///< px, diachron pixel convention
};

/// Degrees to radians and back; the API speaks radians, option names ending in `_deg` degrees.
inline constexpr double deg_to_rad(double deg) { return deg * kPi / 180.0; }
inline constexpr double rad_to_deg(double rad) { return rad * 180.0 / kPi; }

}  // namespace diachron
