#pragma once
/// @file
/// reintersect_dsm(): an epoch's DSM carried to its adjusted orientation, for the DoD after the
/// adjustment (paper section 4.6). A DSM cell is a ground point its SfM intersected from the
/// pixels it sees in the epoch's images; reintersecting the rays of those same pixels with the
/// adjusted orientation gives the point the adjusted block would have measured, which is what a
/// DSM computed again from the adjusted orientation holds (same image correspondences, new
/// geometry). A wrong camera bends a DSM (the "dome" of a film epoch's radial distortion); the
/// adjusted camera takes the bend out, and a similarity could not. Returns the similarity that
/// best maps the DSM's points onto their reintersected positions (the epoch's rigid placement in
/// the reference) and the DSM with the non-rigid rest applied, on its own grid, so that
/// dod_map(reference, result.dsm, result.reference_from_epoch) is the adjusted DoD.
/// Needs Eigen and diachron's adjustment layer (triangulation) only.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <diachron/adjustment/triangulation.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/procrustes.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of reintersect_dsm.
struct DsmReintersectionOptions {
  /// Fewest images a cell must project into (inside the image) to be reintersected. >= 2.
  int min_images = 2;
  /// Triangulation of each cell's rays (its min_views is min_images).
  TriangulationOptions triangulation = [] {
    TriangulationOptions o;
    o.max_iterations = 3;  // the pixels are exact projections: the DLT is already close
    return o;
  }();
  /// Worker threads, 0 = all cores; results do not depend on it.
  std::size_t threads = 0;

  void check() const {
    DIACHRON_CHECK(min_images >= 2, "DsmReintersectionOptions::min_images must be >= 2, got " << min_images);
    triangulation.check();
  }
};

/// Outcome of reintersect_dsm. Default: failure.
struct DsmReintersection {
  bool success = false;
  std::string reason;  ///< why not, when !success
  /// The DSM, in the epoch's own frame and grid, with each reintersected cell's height corrected by
  /// the non-rigid part of its move; NaN where the input is a hole or the cell was not reintersected.
  Dsm dsm;
  /// The similarity that best maps the DSM's points onto their reintersected points (least
  /// squares over every reintersected cell): the epoch's DSM into the reference frame.
  Helmert3 reference_from_epoch = Helmert3::identity();
  std::size_t cells = 0;           ///< cells with a height
  std::size_t reintersected = 0;   ///< of those, reintersected
  /// RMS distance of the reintersected points from the similarity's image of the DSM's points,
  /// reference units: the size of the bend the adjustment took out.
  double rms_nonrigid = std::numeric_limits<double>::quiet_NaN();
  /// Largest |height correction| applied, epoch units.
  double max_height_correction = std::numeric_limits<double>::quiet_NaN();
};

/// The DSM `dsm` of an epoch (its own frame), computed with the orientation `before` (the epoch's
/// images in that frame), carried to `after` (the same images adjusted, in the reference frame):
/// see the file comment. Occlusion is not modelled: a cell takes every image it projects into,
/// which on near-nadir blocks is the images that see it, and on steep terrain may add one that
/// does not (its ray then still points at the cell's pixel, as a dense matcher would have used it).
/// Throws diachron::Error when `before` and `after` differ in size or options are bad.
template <class Distortion>
DsmReintersection reintersect_dsm(const Dsm& dsm, const std::vector<Frame<Distortion>>& before,
                                  const std::vector<Frame<Distortion>>& after,
                                  const DsmReintersectionOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(before.size() == after.size(), "reintersect_dsm: " << before.size() << " frames before, "
                                                                    << after.size() << " after");
  DsmReintersection out;
  if (dsm.empty()) {
    out.reason = "the DSM is empty";
    return out;
  }
  TriangulationOptions triangulation = options.triangulation;
  triangulation.min_views = options.min_images;
  const int w = dsm.width(), h = dsm.height();
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  DIACHRON_CHECK(n < (std::size_t{1} << 32), "reintersect_dsm: " << w << " x " << h << " cells are too many");
  // A cell's point; its reintersected point is kept as the move from it in single precision (the
  // moves are metres at most, far within float's 7 digits), 12 bytes a cell instead of 48: a DSM of
  // tens of millions of cells stays within memory.
  const auto point_of = [&dsm](std::size_t k, int width) {
    const int x = static_cast<int>(k % static_cast<std::size_t>(width)), y = static_cast<int>(k / static_cast<std::size_t>(width));
    const Eigen::Vector2d xy = dsm.pixel_to_world({x, y});
    return Vec3(xy.x(), xy.y(), dsm.heights()(x, y));
  };
  std::vector<Eigen::Vector3f> move(n, Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  parallel_for(static_cast<std::size_t>(h), options.threads, [&](std::size_t row) {
    const int y = static_cast<int>(row);
    for (int x = 0; x < w; ++x) {
      if (!dsm.valid(x, y)) continue;
      const std::size_t k = row * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
      const Vec3 point = point_of(k, w);
      Track track;
      for (std::size_t i = 0; i < before.size(); ++i) {
        const std::optional<Vec2> px = before[i].project(point);
        if (px && before[i].in_image(*px))
          track.observations.push_back({static_cast<int>(i), *px, ObservationKind::intra_epoch});
      }
      if (static_cast<int>(track.observations.size()) < options.min_images) continue;
      const TriangulationResult r = triangulate_track(after, track, triangulation);
      if (r.success) move[k] = (r.point - point).cast<float>();
    }
  });
  // The reintersected cells as Procrustes pairs, computed when read.
  std::vector<std::uint32_t> cells;
  for (std::size_t k = 0; k < n; ++k) {
    if (move[k].allFinite()) cells.push_back(static_cast<std::uint32_t>(k));
    if (!std::isnan(dsm.heights().data()[k])) ++out.cells;
  }
  struct Pairs {
    const std::vector<std::uint32_t>& cells;
    const std::vector<Eigen::Vector3f>& move;
    decltype(point_of)& point;
    int width;
    std::size_t size() const { return cells.size(); }
    PointPair3 operator[](std::size_t i) const {
      const Vec3 p = point(cells[i], width);
      return {p, p + move[cells[i]].cast<double>()};
    }
  };
  const Pairs pairs{cells, move, point_of, w};
  out.reintersected = pairs.size();
  const std::optional<Helmert3> fit = pairs.size() >= 3 ? fit_helmert3(pairs) : std::nullopt;
  if (!fit) {
    out.reason = "too few cells reintersected (" + std::to_string(pairs.size()) + " of " + std::to_string(out.cells) +
                 "): the DSM and the images do not overlap";
    return out;
  }
  out.reference_from_epoch = *fit;
  const Helmert3 epoch_from_reference = fit->inverse();
  // The non-rigid rest, brought back into the epoch's frame: the reintersected point lands at
  // (x', y', z'); the surface there rose by z' - z(x', y'), and that rise, varying slowly, is
  // applied at the cell itself.
  Raster<float> heights(w, h, std::numeric_limits<float>::quiet_NaN());
  double sum2 = 0.0, largest = 0.0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const PointPair3 pair = pairs[i];
    sum2 += (pair.target - (*fit)(pair.source)).squaredNorm();
    const Vec3 moved = epoch_from_reference(pair.target);
    // Clamped to the grid of cell centres: a border cell's point may come back a hair outside.
    const Eigen::Vector2d px = dsm.world_to_pixel(moved.head<2>());
    const double there =
        dsm.height_at_pixel(Eigen::Vector2d(std::clamp(px.x(), 0.0, w - 1.0), std::clamp(px.y(), 0.0, h - 1.0)));
    if (std::isnan(there)) continue;
    const double correction = moved.z() - there;
    largest = std::max(largest, std::abs(correction));
    const std::size_t k = cells[i];
    heights(static_cast<int>(k % static_cast<std::size_t>(w)), static_cast<int>(k / static_cast<std::size_t>(w))) =
        static_cast<float>(pair.source.z() + correction);
  }
  out.rms_nonrigid = std::sqrt(sum2 / static_cast<double>(pairs.size()));
  out.max_height_correction = largest;
  out.dsm = Dsm(std::move(heights), dsm.transform(), dsm.crs());
  out.success = true;
  return out;
}

}  // namespace diachron
