#pragma once
/// @file
/// Multi-view triangulation of one point from oriented frames: linear DLT on the undistorted
/// normalised rays (Camera::unproject), then Gauss-Newton on the reprojection error in pixels
/// with Jacobians from Camera::project run on ceres::Jet (the one camera model). Reports failure
/// (too few views, a small triangulation angle, a point behind a camera, no convergence) instead
/// of returning a meaningless point.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <ceres/jet.h>

#include <diachron/adjustment/tracks.hpp>
#include <diachron/camera/camera.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// Options of triangulate_point.
struct TriangulationOptions {
  /// Fewest views. >= 2.
  int min_views = 2;
  /// Smallest largest angle between two rays of the point, degrees. > 0. Below it depth is
  /// unreliable (the DLT would still return a point, but along a nearly degenerate direction).
  double min_angle_deg = 1.0;
  /// Most Gauss-Newton iterations of the refinement. >= 0 (0: DLT only).
  int max_iterations = 10;
  /// Largest accepted RMS reprojection error of the refined point, px. > 0.
  double max_rms_px = 1e6;

  void check() const {
    DIACHRON_CHECK(min_views >= 2, "TriangulationOptions::min_views must be >= 2, got " << min_views);
    DIACHRON_CHECK(min_angle_deg > 0.0 && min_angle_deg < 180.0,
                   "TriangulationOptions::min_angle_deg must be in (0, 180), got " << min_angle_deg);
    DIACHRON_CHECK(max_iterations >= 0, "TriangulationOptions::max_iterations must be >= 0");
    DIACHRON_CHECK(max_rms_px > 0.0, "TriangulationOptions::max_rms_px must be > 0");
  }
};

/// Outcome of triangulate_point. Default: failure.
struct TriangulationResult {
  bool success = false;
  std::string message;                 ///< why it failed, empty on success
  Vec3 point = Vec3::Zero();           ///< world frame, valid only when success
  int views = 0;                       ///< views used
  double angle_deg = 0.0;              ///< largest angle between two rays, degrees
  double rms_px = std::numeric_limits<double>::infinity();  ///< RMS reprojection error, px
  int iterations = 0;                  ///< Gauss-Newton iterations
};

namespace detail {

// Pixel residuals of a world point in all views and their Jacobian (2n x 3) by Jets.
template <class Distortion>
bool reprojection_and_jacobian(const std::vector<const Frame<Distortion>*>& frames, const std::vector<Vec2>& pixels,
                               const Vec3& x, Eigen::VectorXd& r, Eigen::MatrixXd& j) {
  using Jet = ceres::Jet<double, 3>;
  const std::size_t n = frames.size();
  r.resize(static_cast<Eigen::Index>(2 * n));
  j.resize(static_cast<Eigen::Index>(2 * n), 3);
  const Jet point[3] = {Jet(x.x(), 0), Jet(x.y(), 1), Jet(x.z(), 2)};
  for (std::size_t v = 0; v < n; ++v) {
    const Frame<Distortion>& f = *frames[v];
    const Mat3& rot = f.pose().cam_from_world_rotation();
    const Vec3& c = f.pose().centre();
    Jet cam[3];
    for (int a = 0; a < 3; ++a)
      cam[a] = Jet(rot(a, 0)) * (point[0] - Jet(c.x())) + Jet(rot(a, 1)) * (point[1] - Jet(c.y())) +
               Jet(rot(a, 2)) * (point[2] - Jet(c.z()));
    if (!(cam[2].a > 0.0)) return false;
    const auto intrinsics = f.camera().intrinsics();
    Jet in[Camera<Distortion>::kNumIntrinsics];
    for (int k = 0; k < Camera<Distortion>::kNumIntrinsics; ++k) in[k] = Jet(intrinsics[static_cast<std::size_t>(k)]);
    Jet pixel[2];
    Camera<Distortion>::project(in, cam, pixel);
    for (int a = 0; a < 2; ++a) {
      const auto row = static_cast<Eigen::Index>(2 * v + static_cast<std::size_t>(a));
      r(row) = pixel[a].a - pixels[v][a];
      j.row(row) = pixel[a].v.transpose();
    }
  }
  return r.allFinite() && j.allFinite();
}

}  // namespace detail

/// Triangulates one point seen in `frames[k]` at `pixels[k]`.
/// @param frames oriented images (world frame of the result); pointers must be non-null.
/// @param pixels one pixel per frame, px.
/// Data failures give success == false with a message; mismatched sizes or null frames throw
/// diachron::Error.
template <class Distortion>
TriangulationResult triangulate_point(const std::vector<const Frame<Distortion>*>& frames,
                                      const std::vector<Vec2>& pixels, const TriangulationOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(frames.size() == pixels.size(),
                 "triangulate_point: " << frames.size() << " frames but " << pixels.size() << " pixels");
  for (const auto* f : frames) DIACHRON_CHECK(f != nullptr, "triangulate_point: null frame");
  TriangulationResult out;
  out.views = static_cast<int>(frames.size());
  if (out.views < options.min_views) {
    out.message = "too few views (" + std::to_string(out.views) + ")";
    return out;
  }
  // Unit world rays; the centroid of the centres and their spread condition the DLT.
  std::vector<Vec3> rays(frames.size());
  Vec3 centroid = Vec3::Zero();
  for (std::size_t v = 0; v < frames.size(); ++v) {
    const std::optional<Vec3> d = frames[v]->camera().unproject(pixels[v]);
    if (!d) {
      out.message = "a pixel cannot be unprojected";
      return out;
    }
    rays[v] = frames[v]->pose().world_direction_from_cam(*d);
    centroid += frames[v]->pose().centre();
  }
  centroid /= static_cast<double>(frames.size());
  double largest = 0.0;
  for (std::size_t a = 0; a < rays.size(); ++a)
    for (std::size_t b = a + 1; b < rays.size(); ++b)
      largest = std::max(largest, std::acos(std::clamp(rays[a].dot(rays[b]), -1.0, 1.0)));
  out.angle_deg = largest * 180.0 / kPi;
  if (out.angle_deg < options.min_angle_deg) {
    out.message = "triangulation angle " + std::to_string(out.angle_deg) + " deg below the minimum";
    return out;
  }
  double spread = 0.0;
  for (const auto* f : frames) spread += (f->pose().centre() - centroid).norm();
  spread = std::max(spread / static_cast<double>(frames.size()), 1e-9);

  // DLT in the conditioned frame Y = (X - centroid) / spread: for each view with normalised ray
  // (x, y), rows x P3 - P1 and y P3 - P2 of P = [R | R (centroid - C) / spread], each row scaled
  // to unit norm so that every view weighs alike.
  Eigen::MatrixXd a(static_cast<Eigen::Index>(2 * frames.size()), 4);
  for (std::size_t v = 0; v < frames.size(); ++v) {
    const Vec3 cam_ray = frames[v]->pose().cam_from_world_rotation() * rays[v];
    const double x = cam_ray.x() / cam_ray.z(), y = cam_ray.y() / cam_ray.z();
    Eigen::Matrix<double, 3, 4> p;
    p.leftCols<3>() = frames[v]->pose().cam_from_world_rotation();
    p.col(3) = frames[v]->pose().cam_from_world_rotation() * (centroid - frames[v]->pose().centre()) / spread;
    Eigen::Matrix<double, 1, 4> r0 = x * p.row(2) - p.row(0), r1 = y * p.row(2) - p.row(1);
    a.row(static_cast<Eigen::Index>(2 * v)) = r0 / std::max(r0.norm(), 1e-300);
    a.row(static_cast<Eigen::Index>(2 * v + 1)) = r1 / std::max(r1.norm(), 1e-300);
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  if (!(std::abs(h(3)) > 1e-12 * h.head<3>().norm())) {
    out.message = "the rays meet at infinity";
    return out;
  }
  Vec3 x = centroid + spread * h.head<3>() / h(3);
  for (const auto* f : frames)
    if (!(f->pose().cam_from_world(x).z() > 0.0)) {
      out.message = "the point is behind a camera";
      return out;
    }

  // Gauss-Newton on the pixel residuals, keeping a step only when it lowers the cost.
  Eigen::VectorXd r;
  Eigen::MatrixXd j;
  if (!detail::reprojection_and_jacobian(frames, pixels, x, r, j)) {
    out.message = "the DLT point does not project";
    return out;
  }
  double cost = r.squaredNorm();
  for (int it = 0; it < options.max_iterations; ++it) {
    const Mat3 normal = j.transpose() * j;
    const Vec3 step = normal.ldlt().solve(-j.transpose() * r);
    if (!step.allFinite()) break;
    Eigen::VectorXd r_new;
    Eigen::MatrixXd j_new;
    const Vec3 candidate = x + step;
    out.iterations = it + 1;
    if (!detail::reprojection_and_jacobian(frames, pixels, candidate, r_new, j_new) ||
        !(r_new.squaredNorm() < cost))
      break;
    const double gain = cost - r_new.squaredNorm();
    x = candidate;
    r = r_new;
    j = j_new;
    cost = r.squaredNorm();
    if (gain < 1e-12 * (1.0 + cost)) break;
  }
  out.rms_px = std::sqrt(cost / static_cast<double>(frames.size()));
  if (!(out.rms_px <= options.max_rms_px)) {
    out.message = "RMS reprojection error " + std::to_string(out.rms_px) + " px above the maximum";
    return out;
  }
  out.point = x;
  out.success = true;
  return out;
}

/// Triangulates a track with frames indexed by its observations' image indices.
/// Precondition: every image index in [0, frames.size()) (throws diachron::Error).
template <class Distortion>
TriangulationResult triangulate_track(const std::vector<Frame<Distortion>>& frames, const Track& track,
                                      const TriangulationOptions& options = {}) {
  std::vector<const Frame<Distortion>*> views;
  std::vector<Vec2> pixels;
  for (const TrackObservation& o : track.observations) {
    DIACHRON_CHECK(o.image >= 0 && static_cast<std::size_t>(o.image) < frames.size(),
                   "triangulate_track: image index " << o.image << " outside [0, " << frames.size() << ")");
    views.push_back(&frames[static_cast<std::size_t>(o.image)]);
    pixels.push_back(o.pixel);
  }
  return triangulate_point(views, pixels, options);
}

/// A triangulator over a fixed list of oriented images, for check points and tie points given as
/// observation lists (e.g. evaluate_check_points in eval/check_points.hpp): called with a vector of
/// observations that have `.image` (an index into `frames`) and `.pixel` (px), it returns the
/// triangulated point (frames' world frame), or nullopt when there are fewer than
/// options.min_views observations or triangulation fails. Keeps a reference to `frames`, which
/// must outlive it. An observation's image outside `frames` throws diachron::Error.
template <class Distortion>
class FrameTriangulator {
 public:
  explicit FrameTriangulator(const std::vector<Frame<Distortion>>& frames, const TriangulationOptions& options = {})
      : frames_(frames), options_(options) {
    options_.check();
  }

  template <class Observations>
  std::optional<Vec3> operator()(const Observations& observations) const {
    std::vector<const Frame<Distortion>*> views;
    std::vector<Vec2> pixels;
    for (const auto& o : observations) {
      const auto image = static_cast<std::size_t>(o.image);
      DIACHRON_CHECK(image < frames_.size(),
                     "FrameTriangulator: image " << o.image << " outside [0, " << frames_.size() << ")");
      views.push_back(&frames_[image]);
      pixels.push_back(o.pixel);
    }
    if (views.size() < static_cast<std::size_t>(options_.min_views)) return std::nullopt;
    const TriangulationResult r = triangulate_point(views, pixels, options_);
    if (!r.success) return std::nullopt;
    return r.point;
  }

 private:
  const std::vector<Frame<Distortion>>& frames_;
  TriangulationOptions options_;
};

}  // namespace diachron
