#pragma once
/// @file
/// Dense DoD maps (difference of DSMs, paper section 4.6) as rasters: a free (e.g. historical) epoch's
/// DSM moved into the reference epoch's frame by a 3D Helmert and differenced with the reference DSM on
/// the reference DSM's grid; a mask of stable terrain around given points (e.g. ground-filter inliers);
/// and the paper's statistics (mu, sigma, |mu|, plus median and NMAD) over all cells and over the
/// stable ones. Needs Eigen and the standard library only. docs/evaluation.md, "DoD maps".

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/eval/error_statistics.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of dod_map().
struct DodMapOptions {
  /// Most iterations of the vertical-line intersection per cell, >= 1. Each iteration shrinks the
  /// horizontal miss by about sin(tilt of the Helmert) x (terrain slope): with a tilt of 0.05 rad (3 deg)
  /// on slopes up to 0.5 a miss of metres is below 0.1 mm after 3 to 4 iterations, and a Helmert
  /// without tilt (rotation about Z only) needs one. 20 lets walls converge where the rate is still
  /// well below 1 (a 40 m step between two 1 m cells under a tilt of 0.01 rad needs about 11); the
  /// iterations are only spent on such cells.
  int max_iterations = 20;
  /// A cell's intersection has converged when the moved surface point lies this close to the cell
  /// centre's vertical line (horizontal distance, reference frame units: metres for a metric frame),
  /// > 0. The dZ error is then at most slope x tolerance: 0.1 mm keeps it far below 1 cm.
  double tolerance_m = 1e-4;
  /// Worker threads over rows (0 = all cores); the result does not depend on it.
  std::size_t threads = 0;

  void check() const {
    DIACHRON_CHECK(max_iterations >= 1, "DodMapOptions::max_iterations must be >= 1, got " << max_iterations);
    DIACHRON_CHECK(std::isfinite(tolerance_m) && tolerance_m > 0.0,
                   "DodMapOptions::tolerance_m must be finite and > 0, got " << tolerance_m);
  }
};

/// What one cell of a DoD map is.
enum class DodCellStatus : std::uint8_t {
  valid,            ///< dZ is defined
  reference_hole,   ///< the reference DSM has no height at this cell
  moving_hole,      ///< the vertical line meets the moved DSM where a sample that carries weight is a hole
  outside,          ///< the vertical line misses the moved DSM (off it, or within half a cell of its edge)
  not_converged,    ///< the intersection did not converge (steep slope under a tilted Helmert, overhang)
};

/// A DoD map on the reference DSM's grid. `success == false` (with `reason`) when no cell is valid;
/// `dz` and `status` are still filled then (all NaN / no valid cell), unless the input was rejected.
struct DodMap {
  bool success = false;
  std::string reason;
  /// dZ = Z_moved_surface - Z_reference at each reference cell centre, in the reference frame's height
  /// unit (metres for a metric frame): positive where the moved epoch is higher. NaN where status is
  /// not valid. Same size, geotransform and CRS as the reference DSM, so write_geotiff_dsm writes it.
  Dsm dz;
  Raster<DodCellStatus> status;  ///< per cell, same size as `dz`
  std::size_t num_valid = 0;           ///< cells with a dZ
  std::size_t num_reference_hole = 0;  ///< cells where the reference DSM is a hole
  std::size_t num_moving_hole = 0;     ///< cells on a hole of the moved DSM
  std::size_t num_outside = 0;         ///< cells off the moved DSM
  std::size_t num_not_converged = 0;   ///< cells where the intersection did not converge
  int max_iterations_used = 0;         ///< the most iterations a valid cell needed
};

namespace detail {

// Throws unless `h` is a finite similarity with scale > 0 and a proper rotation: its inverse (R^T)
// is only the inverse for an orthonormal R.
inline void check_dod_helmert(const Helmert3& h, const char* where) {
  DIACHRON_CHECK(std::isfinite(h.scale) && h.scale > 0.0 && h.rotation.allFinite() && h.translation.allFinite(),
                 where << ": the Helmert must be finite with scale > 0 (scale " << h.scale << ")");
  const double orthonormality = (h.rotation.transpose() * h.rotation - Eigen::Matrix3d::Identity()).norm();
  DIACHRON_CHECK(orthonormality < 1e-6 && h.rotation.determinant() > 0.0,
                 where << ": the Helmert's rotation is not a proper rotation (|R^T R - I| = " << orthonormality
                       << ")");
}

}  // namespace detail

/// The DoD map of `moving` (a free epoch's DSM, in its own frame) against `reference`, on the
/// reference's grid: dZ = Z_moved - Z_reference at each reference cell centre (X, Y), where Z_moved is
/// the height at which the vertical line through (X, Y) meets the moving DSM's surface (bilinear
/// between its pixel centres) moved by `reference_from_moving` (X_ref = scale R X_moving + t).
///
/// A rotation with tilt does not keep verticals vertical, so the intersection is iterated: map
/// (X, Y, z) (first z = the reference height) into the moving frame by the inverse Helmert, read the
/// moving DSM's height there, map that surface point back, and take away its horizontal miss of
/// (X, Y): the next query is (X, Y, z of that point); stop when the miss is below options.tolerance_m. Each
/// step shrinks the miss by about sin(tilt) x slope, so ordinary terrain converges in a few steps. Where
/// that product nears 1 (walls and cliffs under a tilted Helmert) or the moved surface overhangs (the
/// vertical line meets it more than once), the iteration may oscillate: such cells are `not_converged`
/// and NaN, never a guessed height; where it converges on an overhang it finds one of the crossings.
/// A Helmert without tilt needs one step and has no such cells.
///
/// Edges and holes: a guess that falls off the moving DSM reads its border and goes on, so a crossing
/// near the edge is found; two such reads in a row (or no convergence after one) make the cell
/// `outside`. A guess that meets a hole stops at once (`moving_hole`): with a tilt, cells within about
/// tilt x |dZ| of a hole may be lost although their own crossing has data.
///
/// Throws diachron::Error for an empty DSM, a non-finite Helmert, a scale <= 0, a rotation that is not
/// a proper rotation (|R^T R - I| >= 1e-6) and bad options.
inline DodMap dod_map(const Dsm& reference, const Dsm& moving, const Helmert3& reference_from_moving,
                      const DodMapOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!reference.empty(), "dod_map: empty reference DSM");
  DIACHRON_CHECK(!moving.empty(), "dod_map: empty moving DSM");
  detail::check_dod_helmert(reference_from_moving, "dod_map");
  const Helmert3& to_reference = reference_from_moving;
  const Helmert3 to_moving = reference_from_moving.inverse();
  const int w = reference.width(), h = reference.height();
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  Raster<float> dz(w, h, nan);
  Raster<DodCellStatus> status(w, h, DodCellStatus::valid);
  std::vector<int> row_iterations(static_cast<std::size_t>(h), 0);
  const double tolerance_squared = options.tolerance_m * options.tolerance_m;

  parallel_for(static_cast<std::size_t>(h), options.threads, [&](std::size_t row) {
    const int y = static_cast<int>(row);
    int most = 0;
    for (int x = 0; x < w; ++x) {
      const float z_reference = reference.heights()(x, y);
      if (std::isnan(z_reference)) {
        status(x, y) = DodCellStatus::reference_hole;
        continue;
      }
      const Eigen::Vector2d centre = reference.pixel_to_world({x, y});
      Eigen::Vector3d p(centre.x(), centre.y(), z_reference);
      DodCellStatus s = DodCellStatus::not_converged;
      bool was_clamped = false;
      for (int k = 1; k <= options.max_iterations; ++k) {
        const Eigen::Vector3d q = to_moving(p);
        // A guess off the moving DSM reads its border instead: the first guess uses the reference
        // height, which a tilt turns into a horizontal error, and a crossing just inside the edge is
        // still found. Two border reads in a row mean the line misses the DSM.
        const Eigen::Vector2d px = moving.world_to_pixel(q.head<2>());
        const Eigen::Vector2d clamped_px(std::clamp(px.x(), 0.0, static_cast<double>(moving.width() - 1)),
                                         std::clamp(px.y(), 0.0, static_cast<double>(moving.height() - 1)));
        const bool clamped = clamped_px != px;
        const double z_moving = moving.height_at_pixel(clamped_px);
        if (std::isnan(z_moving)) {
          s = clamped ? DodCellStatus::outside : DodCellStatus::moving_hole;
          break;
        }
        if (clamped && was_clamped) {
          s = DodCellStatus::outside;
          break;
        }
        was_clamped = clamped;
        const Eigen::Vector2d uv = clamped ? moving.pixel_to_world(clamped_px) : Eigen::Vector2d(q.head<2>());
        const Eigen::Vector3d surface = to_reference(Eigen::Vector3d(uv.x(), uv.y(), z_moving));
        const Eigen::Vector2d miss = surface.head<2>() - centre;
        if (miss.squaredNorm() <= tolerance_squared) {
          // Also after a border read: that border point is on the surface and on the line.
          s = DodCellStatus::valid;
          dz(x, y) = static_cast<float>(surface.z() - static_cast<double>(z_reference));
          most = std::max(most, k);
          break;
        }
        // Back onto the vertical line at the surface point's height: a fixed point in z whose rate is
        // about sin(tilt) x slope. (Moving the query by the miss instead, from where it was, adds the
        // tilt's lever on the height change and oscillates at walls that this converges on.)
        p.z() = surface.z();
      }
      if (s == DodCellStatus::not_converged && was_clamped) s = DodCellStatus::outside;
      status(x, y) = s;
    }
    row_iterations[row] = most;
  });

  DodMap m;
  for (const DodCellStatus s : status) {
    switch (s) {
      case DodCellStatus::valid: ++m.num_valid; break;
      case DodCellStatus::reference_hole: ++m.num_reference_hole; break;
      case DodCellStatus::moving_hole: ++m.num_moving_hole; break;
      case DodCellStatus::outside: ++m.num_outside; break;
      case DodCellStatus::not_converged: ++m.num_not_converged; break;
    }
  }
  m.max_iterations_used = *std::max_element(row_iterations.begin(), row_iterations.end());
  m.dz = Dsm(std::move(dz), reference.transform(), reference.crs());
  m.status = std::move(status);
  if (m.num_valid == 0) {
    m.reason = "no cell has both heights (" + std::to_string(m.num_reference_hole) + " reference holes, " +
               std::to_string(m.num_moving_hole) + " moving holes, " + std::to_string(m.num_outside) +
               " outside, " + std::to_string(m.num_not_converged) + " not converged)";
    return m;
  }
  m.success = true;
  return m;
}

/// A mask on `grid`'s cells: 1 where the cell centre lies within `radius_m` (horizontal distance in
/// X, Y, `grid`'s world units) of at least one of `points`, else 0. Meant for stable terrain: with the
/// 3D positions of the ground filter's inliers (tie points on ground that did not change between the
/// epochs), the DoD over the mask measures the co-registration rather than real change. Z is ignored,
/// as are points whose circle misses the grid. The cells need not be square nor north-up.
/// Throws diachron::Error for an empty grid, a non-finite point (naming its index) or a radius that is
/// not finite and > 0.
inline Raster<std::uint8_t> stable_mask_near_points(const Dsm& grid, const std::vector<Eigen::Vector3d>& points,
                                                    double radius_m) {
  DIACHRON_CHECK(!grid.empty(), "stable_mask_near_points: empty grid");
  DIACHRON_CHECK(std::isfinite(radius_m) && radius_m > 0.0,
                 "stable_mask_near_points: radius_m must be finite and > 0, got " << radius_m);
  const int w = grid.width(), h = grid.height();
  Raster<std::uint8_t> mask(w, h, 0);
  const double r2 = radius_m * radius_m;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& p = points[i];
    DIACHRON_CHECK(p.allFinite(), "stable_mask_near_points: point " << i << " is not finite");
    // The pixel box of the circle's world box (its four corners: the grid may be rotated), one pixel
    // wider against rounding; the exact test is on the cell centre below.
    double lo_x = std::numeric_limits<double>::infinity(), lo_y = lo_x, hi_x = -lo_x, hi_y = -lo_x;
    for (const double sx : {-1.0, 1.0})
      for (const double sy : {-1.0, 1.0}) {
        const Eigen::Vector2d px = grid.world_to_pixel({p.x() + sx * radius_m, p.y() + sy * radius_m});
        lo_x = std::min(lo_x, px.x());
        hi_x = std::max(hi_x, px.x());
        lo_y = std::min(lo_y, px.y());
        hi_y = std::max(hi_y, px.y());
      }
    if (hi_x < -1.0 || hi_y < -1.0 || lo_x > w || lo_y > h) continue;
    const int x0 = std::max(0, static_cast<int>(std::floor(lo_x)) - 1);
    const int x1 = std::min(w - 1, static_cast<int>(std::ceil(hi_x)) + 1);
    const int y0 = std::max(0, static_cast<int>(std::floor(lo_y)) - 1);
    const int y1 = std::min(h - 1, static_cast<int>(std::ceil(hi_y)) + 1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        if (mask(x, y) != 0) continue;
        if ((grid.pixel_to_world({x, y}) - p.head<2>()).squaredNorm() <= r2) mask(x, y) = 1;
      }
  }
  return mask;
}

/// Statistics of a DoD map. `success == false` (with `reason`) when no cell of the map is valid, or
/// when a stable mask was given and no valid cell is stable (`all` is still filled then).
struct DodMapStatistics {
  bool success = false;
  std::string reason;
  std::size_t num_cells = 0;         ///< cells of the map
  /// Over every valid (non-NaN) cell, in dZ's unit (metres): mean = the paper's mu, sigma, mean_abs =
  /// its |mu|, median, nmad; `all.count` is the number of valid cells.
  ErrorStatistics all;
  bool has_stable_mask = false;      ///< a stable mask was given
  std::size_t num_stable_cells = 0;  ///< cells the mask marks stable, valid or not
  /// Over the valid cells the mask marks stable (`stable.count` of them); count 0 and NaN without a mask.
  ErrorStatistics stable;
};

/// The statistics of the DoD map `dz` (e.g. DodMap::dz), over all valid cells and, when `stable` is
/// given (non-zero = stable, same size as `dz`, e.g. from stable_mask_near_points), over the stable
/// ones. Real changes (buildings, forest, landslides) drag mu and sigma; on stable terrain they are the
/// co-registration's error. Throws diachron::Error for an empty map or a mask of another size.
inline DodMapStatistics dod_map_statistics(const Dsm& dz, const Raster<std::uint8_t>* stable = nullptr) {
  DIACHRON_CHECK(!dz.empty(), "dod_map_statistics: empty DoD map");
  if (stable != nullptr)
    DIACHRON_CHECK(stable->width() == dz.width() && stable->height() == dz.height(),
                   "dod_map_statistics: the stable mask is " << stable->width() << " x " << stable->height()
                                                             << ", the map " << dz.width() << " x " << dz.height());
  DodMapStatistics r;
  r.num_cells = dz.heights().size();
  r.has_stable_mask = stable != nullptr;
  std::vector<double> all, on_stable;
  all.reserve(static_cast<std::size_t>(dz.statistics().count));
  for (int y = 0; y < dz.height(); ++y)
    for (int x = 0; x < dz.width(); ++x) {
      const bool is_stable = stable != nullptr && (*stable)(x, y) != 0;
      r.num_stable_cells += is_stable ? 1 : 0;
      const float v = dz.heights()(x, y);
      if (std::isnan(v)) continue;
      all.push_back(v);
      if (is_stable) on_stable.push_back(v);
    }
  r.all = error_statistics(all);
  r.stable = error_statistics(on_stable);
  if (all.empty()) {
    r.reason = "no valid cell in the DoD map";
    return r;
  }
  if (stable != nullptr && on_stable.empty()) {
    r.reason = "no valid cell is stable (" + std::to_string(r.num_stable_cells) + " stable cells, " +
               std::to_string(all.size()) + " valid cells)";
    return r;
  }
  r.success = true;
  return r;
}

}  // namespace diachron
