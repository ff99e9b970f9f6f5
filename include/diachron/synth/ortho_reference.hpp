#pragma once
/// @file
/// make_ortho_reference(): one epoch of a generated scene (usually the last, recent one) delivered
/// as a national mapping agency delivers its reference: a true orthophoto (every pixel rendered
/// straight down, no relief displacement) and the true surface as its DSM, both north-up in the
/// epoch's own frame, instead of images and an SfM model. Needs Eigen and the standard library only.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <diachron/camera/ortho_frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/synth/epoch.hpp>
#include <diachron/synth/render.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of make_ortho_reference().
struct OrthoReferenceOptions {
  /// Ground sampling distance of the orthophoto, metres; 0 = the epoch's (its images' GSD at the
  /// mean ground height), as an orthophoto is produced at about the GSD of its flight. >= 0.
  double gsd_m = 0.0;
  /// Cell size of the DSM delivered with it, metres; 0 = the cell of the epoch's true surface (the
  /// scene's terrain grid, so the DSM loses nothing of it). >= 0.
  double dsm_cell_m = 0.0;
  /// Worker threads: 0 = all cores. Results do not depend on it.
  std::size_t threads = 0;

  void check() const {
    DIACHRON_CHECK(gsd_m >= 0.0 && std::isfinite(gsd_m), "OrthoReferenceOptions::gsd_m must be >= 0, got " << gsd_m);
    DIACHRON_CHECK(dsm_cell_m >= 0.0 && std::isfinite(dsm_cell_m),
                   "OrthoReferenceOptions::dsm_cell_m must be >= 0, got " << dsm_cell_m);
  }
};

/// The look of an orthophoto made from an epoch's images: that epoch's look (sun, land-cover
/// response, tone, grain, compression) without vignetting, which an orthophoto producer corrects
/// and which, applied once over a whole orthophoto, would be one dark-cornered blotch.
inline LookOptions orthophoto_look(const LookOptions& epoch_look) {
  LookOptions look = epoch_look;
  look.vignetting = 0.0;
  return look;
}

/// The true surface seen along the Z axis of another frame: on the `width` x `height` grid
/// `transform` of that frame (X, Y axes of the frame), each cell holds the frame Z where the
/// frame's vertical line through the cell centre first meets `tracer`'s surface (world frame), NaN
/// where it misses. With `world_from_frame` the identity it is the surface resampled on the grid.
/// Rows in parallel; the result does not depend on `threads`. Throws diachron::Error for an empty
/// or rotated grid.
inline Dsm true_surface_in_frame(const detail::SurfaceTracer& tracer, const Helmert3& world_from_frame,
                                 const GeoTransform& transform, int width, int height, std::size_t threads = 0) {
  const OrthoFrame grid(transform, width, height);
  const Helmert3 frame_from_world = world_from_frame.inverse();
  const double top = detail::surface_top_in_frame(tracer.dsm(), world_from_frame);
  Raster<float> heights(width, height, std::numeric_limits<float>::quiet_NaN());
  parallel_for(static_cast<std::size_t>(height), threads, [&](std::size_t row) {
    for (int x = 0; x < width; ++x) {
      const std::optional<Ray3> ray =
          detail::vertical_ray_in_world(grid, world_from_frame, top, Vec2(x, static_cast<double>(row)));
      if (!ray) continue;
      if (const std::optional<Vec3> hit = tracer.intersect(*ray))
        heights(x, static_cast<int>(row)) = static_cast<float>(frame_from_world(*hit).z());
    }
  });
  return Dsm(std::move(heights), transform);
}

/// Replaces epoch `index` of `scene` (made by generate_scene(`options`)) by a true orthophoto and
/// its DSM, as a national orthophoto with its DEM is the usual modern reference:
///  - the orthophoto renders the epoch's true surface straight down along the epoch frame's
///    vertical, with the epoch's albedo, sun and look (orthophoto_look()), at `ortho.gsd_m`
///    (default the epoch's GSD), north-up in the epoch frame: its grid axes are the epoch frame's
///    X and Y, so the rough co-registration still has the frame's rotation, scale and shift to find;
///  - it covers the box, in the epoch frame, of the footprints of the epoch's images (corners cast
///    on the lowest ground), where that epoch's SfM DSM would lie; pixels beyond the scene's
///    surface get `look.background`;
///  - `dsm` becomes the true surface in the epoch frame on the same box (true_surface_in_frame),
///    at `ortho.dsm_cell_m` (default the true surface's cell), not an SfM's noisy one.
/// The epoch's images and tie points are dropped, and so are the check points' observations in
/// them (the check points keep their world position; the other epochs are untouched, so a scene
/// with and without the orthophoto has the same older epochs). `world_from_epoch` stays the truth.
/// Throws diachron::Error for invalid options, an index out of range, options that do not match
/// the scene's epochs, or an epoch that is already an orthophoto or has no images or no truth.
inline void make_ortho_reference(Scene& scene, const SceneOptions& options, std::size_t index,
                                 const OrthoReferenceOptions& ortho = {}) {
  options.check();
  ortho.check();
  DIACHRON_CHECK(index < scene.epochs.size(),
                 "make_ortho_reference: epoch " << index << " of a scene with " << scene.epochs.size() << " epoch(s)");
  DIACHRON_CHECK(options.epochs.size() == scene.epochs.size() && options.epochs[index].name == scene.epochs[index].name,
                 "make_ortho_reference: the options are not those the scene was generated with (epoch "
                     << scene.epochs[index].name << ")");
  SyntheticEpoch& epoch = scene.epochs[index];
  DIACHRON_CHECK(!epoch.orthophoto, "make_ortho_reference: epoch " << epoch.name << " is already an orthophoto");
  DIACHRON_CHECK(!epoch.images.empty() && !epoch.true_surface.empty() && !epoch.albedo.values.empty(),
                 "make_ortho_reference: epoch " << epoch.name << " needs its images, true surface and albedo");
  const Helmert3 epoch_from_world = epoch.epoch_from_world();
  const double s = epoch_from_world.scale;

  // The box of the images' footprints in the epoch frame.
  const double lowest = epoch.true_surface.statistics().min;
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x, max_x = -min_x, max_y = -min_x;
  for (std::size_t i = 0; i < epoch.images.size(); ++i)
    for (const Vec3& p : detail::corner_footprint(epoch.world_frame(i), lowest)) {
      const Vec3 q = epoch_from_world(p);
      min_x = std::min(min_x, q.x());
      max_x = std::max(max_x, q.x());
      min_y = std::min(min_y, q.y());
      max_y = std::max(max_y, q.y());
    }
  const auto grid_of = [&](double cell_m, const char* what) {
    const double cell = cell_m * s;
    const double w = std::ceil((max_x - min_x) / cell), h = std::ceil((max_y - min_y) / cell);
    DIACHRON_CHECK(w >= 1.0 && h >= 1.0 && w * h <= 4e8,
                   "make_ortho_reference: the " << what << " would have " << w << " x " << h << " cells");
    return OrthoFrame(GeoTransform::north_up(min_x, max_y, cell), static_cast<int>(w), static_cast<int>(h));
  };
  const double gsd = ortho.gsd_m > 0.0 ? ortho.gsd_m : epoch.gsd_m;
  const OrthoFrame frame = grid_of(gsd, "orthophoto");
  const OrthoFrame dsm_grid =
      grid_of(ortho.dsm_cell_m > 0.0 ? ortho.dsm_cell_m : epoch.true_surface.min_cell_size(), "DSM");

  const LookOptions look = orthophoto_look(options.epochs[index].look);
  const detail::SurfaceTracer tracer(epoch.true_surface);
  const AlbedoMap shading = shading_map(epoch.true_surface, look, ortho.threads);
  const Raster<float> radiance =
      render_radiance(frame, epoch.world_from_epoch, tracer, epoch.albedo, shading, look, ortho.threads);
  SyntheticOrthophoto out;
  out.pixels = develop_image(radiance, look, scene.seed,
                             detail::stream_id(detail::SynthStream::orthophoto, static_cast<std::uint64_t>(index)),
                             ortho.threads);
  out.frame = frame;
  epoch.dsm = true_surface_in_frame(tracer, epoch.world_from_epoch, dsm_grid.geo_transform(), dsm_grid.width(),
                                    dsm_grid.height(), ortho.threads);
  epoch.orthophoto = std::move(out);
  epoch.gsd_m = gsd;
  epoch.images.clear();
  epoch.tie_points.clear();
  const auto in_epoch = [&](const CheckPoint::Observation& o) { return o.epoch == static_cast<int>(index); };
  for (CheckPoint& cp : scene.check_points)
    cp.observations.erase(std::remove_if(cp.observations.begin(), cp.observations.end(), in_epoch),
                          cp.observations.end());
}

}  // namespace diachron
