#pragma once
// COLMAP's own projection, written from COLMAP's documentation of its camera models (not from
// diachron's code), so that tests can compare diachron's cameras and poses with what COLMAP computes:
// X_cam = R(q) X + t, then the model's distortion, then pixels with the centre of the top-left pixel
// at (0.5, 0.5).

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace diachron::test {

inline Eigen::Vector2d colmap_projection(const std::string& model, const std::vector<double>& p,
                                         const Eigen::Vector4d& qvec, const Eigen::Vector3d& tvec,
                                         const Eigen::Vector3d& world) {
  const Eigen::Quaterniond q(qvec[0], qvec[1], qvec[2], qvec[3]);
  const Eigen::Vector3d c = q.normalized().toRotationMatrix() * world + tvec;
  const double u = c.x() / c.z(), v = c.y() / c.z();
  double fx = 0, fy = 0, cx = 0, cy = 0, k1 = 0, k2 = 0, k3 = 0, k4 = 0, k5 = 0, k6 = 0, p1 = 0, p2 = 0;
  if (model == "SIMPLE_PINHOLE" || model == "SIMPLE_RADIAL" || model == "RADIAL") {
    fx = fy = p[0];
    cx = p[1];
    cy = p[2];
    if (model != "SIMPLE_PINHOLE") k1 = p[3];
    if (model == "RADIAL") k2 = p[4];
  } else {
    fx = p[0];
    fy = p[1];
    cx = p[2];
    cy = p[3];
    if (model == "OPENCV" || model == "FULL_OPENCV") {
      k1 = p[4];
      k2 = p[5];
      p1 = p[6];
      p2 = p[7];
    }
    if (model == "FULL_OPENCV") {
      k3 = p[8];
      k4 = p[9];
      k5 = p[10];
      k6 = p[11];
    }
  }
  const double u2 = u * u, v2 = v * v, uv = u * v, r2 = u2 + v2;
  const double radial = (1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2) / (1 + k4 * r2 + k5 * r2 * r2 + k6 * r2 * r2 * r2);
  const double du = u * (radial - 1) + 2 * p1 * uv + p2 * (r2 + 2 * u2);
  const double dv = v * (radial - 1) + 2 * p2 * uv + p1 * (r2 + 2 * v2);
  return {fx * (u + du) + cx, fy * (v + dv) + cy};
}

}  // namespace diachron::test
