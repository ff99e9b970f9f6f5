#pragma once
/// @file
/// Ground sampling distance of an image at a pixel, as MicMac defines it (cGet3Dcoor::GetGSD): the
/// planimetric (X/Y) distance between the ground points of pixel px and of px + (1, 0).
///
/// MicMac intersects both rays with the horizontal plane Z = AltiSol and measures at the image
/// centre only; gsd_at_height() is that variant at any pixel, gsd_on_dsm() uses the terrain itself.
/// The 3D RANSAC of precise matching uses 10 x the GSD of the secondary image as its threshold.

#include <cmath>
#include <optional>

#include <Eigen/Core>

#include <diachron/geometry/ray.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>
#include <diachron/terrain/transfer.hpp>

namespace diachron {

namespace detail {
/// Where `ray` meets the plane Z = z in front of its origin, or nullopt (parallel, or behind).
inline std::optional<Eigen::Vector3d> ray_plane_z(const Ray3& ray, double z) {
  if (!ray.origin.allFinite() || !ray.direction.allFinite() || ray.direction.z() == 0.0) return std::nullopt;
  const double t = (z - ray.origin.z()) / ray.direction.z();
  if (!(t > 0.0) || !std::isfinite(t)) return std::nullopt;
  return ray.at(t);
}
}  // namespace detail

/// GSD (world units per pixel, planimetric) at pixel `px` of `frame` over the horizontal plane
/// Z = `ground_z` (MicMac's AltiSol). nullopt when either ray misses the plane (parallel, or the
/// plane is behind the camera) or the frame has no ray for the pixels.
/// @tparam Frame has `std::optional<Ray3> ray(const Eigen::Vector2d&) const`.
template <class Frame>
std::optional<double> gsd_at_height(const Frame& frame, double ground_z, const Eigen::Vector2d& px) {
  static_assert(has_frame_ray_v<Frame>, "gsd_at_height: Frame must have `std::optional<Ray3> ray(const Eigen::Vector2d&) const`");
  DIACHRON_CHECK(std::isfinite(ground_z), "gsd_at_height: ground height must be finite, got " << ground_z);
  const std::optional<Ray3> r0 = frame.ray(px);
  const std::optional<Ray3> r1 = frame.ray(Eigen::Vector2d(px + Eigen::Vector2d::UnitX()));
  if (!r0 || !r1) return std::nullopt;
  const std::optional<Eigen::Vector3d> p0 = detail::ray_plane_z(*r0, ground_z);
  const std::optional<Eigen::Vector3d> p1 = detail::ray_plane_z(*r1, ground_z);
  if (!p0 || !p1) return std::nullopt;
  return (p1->head<2>() - p0->head<2>()).norm();
}

/// GSD (world units per pixel, planimetric) at pixel `px` of `frame` on the DSM: both pixels' rays
/// are intersected with the terrain. nullopt when either ray has no first crossing. On steep terrain
/// or at an occlusion edge the two ground points may be far apart: this is the true footprint, not
/// an average.
/// @tparam Frame has `std::optional<Ray3> ray(const Eigen::Vector2d&) const`.
template <class Frame>
std::optional<double> gsd_on_dsm(const Frame& frame, const Dsm& dsm, const Eigen::Vector2d& px,
                                 const RayDsmOptions& options = {}) {
  static_assert(has_frame_ray_v<Frame>, "gsd_on_dsm: Frame must have `std::optional<Ray3> ray(const Eigen::Vector2d&) const`");
  const std::optional<Ray3> r0 = frame.ray(px);
  const std::optional<Ray3> r1 = frame.ray(Eigen::Vector2d(px + Eigen::Vector2d::UnitX()));
  if (!r0 || !r1) return std::nullopt;
  const std::optional<Eigen::Vector3d> p0 = ray_dsm_point(dsm, *r0, options);
  if (!p0) return std::nullopt;
  const std::optional<Eigen::Vector3d> p1 = ray_dsm_point(dsm, *r1, options);
  if (!p1) return std::nullopt;
  return (p1->head<2>() - p0->head<2>()).norm();
}

}  // namespace diachron
