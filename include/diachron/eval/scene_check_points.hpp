#pragma once
/// @file
/// The check points of a synthetic scene (synth/scene.hpp) as evaluate_check_points() takes them:
/// the true position in the reference epoch's frame and the true pixels in the images of the epoch
/// being evaluated. Needs Eigen and the standard library only.

#include <cstddef>
#include <optional>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/synth/scene.hpp>

namespace diachron {

/// Every check point of `scene`, in order: `truth` = its world position moved into the frame of
/// epoch `reference` (the true epoch_from_world), `observations` = its true pixels in the images of
/// epoch `observed` (image = index in that epoch's images). Pixels carry no noise; add it to test
/// a triangulator under noise. A check point that epoch `observed` does not see keeps no
/// observation (evaluate_check_points() then counts it as failed when the triangulator says so).
/// Precondition: both epoch indices exist, else throws diachron::Error.
inline std::vector<ObservedCheckPoint> scene_check_points(const Scene& scene, std::size_t observed,
                                                          std::size_t reference) {
  DIACHRON_CHECK(observed < scene.epochs.size() && reference < scene.epochs.size(),
                 "scene_check_points: epochs " << observed << " and " << reference << " of a scene with "
                                               << scene.epochs.size());
  const Helmert3 reference_from_world = scene.epochs[reference].epoch_from_world();
  std::vector<ObservedCheckPoint> out;
  out.reserve(scene.check_points.size());
  for (const CheckPoint& cp : scene.check_points) {
    ObservedCheckPoint p;
    p.truth = reference_from_world(cp.world);
    for (const CheckPoint::Observation& o : cp.observations)
      if (o.epoch == static_cast<int>(observed)) p.observations.push_back({static_cast<std::size_t>(o.image), o.pixel});
    out.push_back(std::move(p));
  }
  return out;
}

/// Every check point of `scene`, triangulated from its true pixels in epoch `observed` and judged in
/// the world frame: `triangulate` (std::vector<CheckPointObservation> -> std::optional<Vec3>, e.g. a
/// FrameTriangulator over epoch `observed`'s frames moved into epoch `reference`'s frame) answers in
/// epoch `reference`'s frame, and its answer is moved to the world by that epoch's true
/// world_from_epoch. Errors are thus in metres whatever the scale of the SfM frames, and in epoch
/// `observed`'s GSD. Precondition: both epoch indices exist, else throws diachron::Error.
template <class Triangulate>
CheckPointReport evaluate_scene_check_points(const Scene& scene, std::size_t observed, std::size_t reference,
                                             Triangulate&& triangulate) {
  std::vector<ObservedCheckPoint> points = scene_check_points(scene, observed, reference);
  for (std::size_t k = 0; k < points.size(); ++k) points[k].truth = scene.check_points[k].world;
  const Helmert3& world_from_reference = scene.epochs[reference].world_from_epoch;
  return evaluate_check_points(
      points,
      [&](const std::vector<CheckPointObservation>& observations) -> std::optional<Vec3> {
        const std::optional<Vec3> p = triangulate(observations);
        return p ? std::optional<Vec3>(world_from_reference(*p)) : std::nullopt;
      },
      scene.epochs[observed].gsd_m);
}

}  // namespace diachron
