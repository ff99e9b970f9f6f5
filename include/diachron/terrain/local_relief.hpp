#pragma once
/// @file
/// local_relief(): how far a DSM departs from a plane around a ground point.
///
/// A correlation window on ground that is locally a plane sees one parallax field, which the
/// transfer's local affine models, and no cast shadows. A window over trees, buildings or banks sees
/// several parallaxes at once and shadows that move with the sun, so its correlation peak is a
/// compromise between them (docs/correlation-matching.md, "Where the error comes from"). The plane
/// fit lets a tilted slope pass; only what sticks out of it counts.

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include <diachron/core/error.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Departure of a DSM from its least-squares plane over a disc. Default: nothing measured.
struct LocalRelief {
  bool valid = false;  ///< false when fewer than the required valid cells lie in the disc
  double rms = std::numeric_limits<double>::infinity();      ///< RMS of the plane residuals, DSM height units
  double max_abs = std::numeric_limits<double>::infinity();  ///< largest |residual|, DSM height units
  int cells = 0;       ///< valid cells used
};

/// The plane residuals of `dsm`'s valid cells whose centres lie within `radius` (world units, > 0)
/// of world (X, Y) = `xy`. Invalid when fewer than `min_cells` (>= 3) cells are valid there or
/// their centres are collinear: a disc that is mostly hole says nothing about the surface.
inline LocalRelief local_relief(const Dsm& dsm, const Eigen::Vector2d& xy, double radius, int min_cells = 6) {
  DIACHRON_CHECK(std::isfinite(radius) && radius > 0.0, "local_relief: radius must be finite and > 0, got " << radius);
  DIACHRON_CHECK(min_cells >= 3, "local_relief: min_cells must be >= 3, got " << min_cells);
  LocalRelief out;
  if (dsm.empty() || !xy.allFinite()) return out;
  const Eigen::Vector2d centre = dsm.world_to_pixel(xy);
  const Eigen::Vector2d cell = dsm.cell_size();
  // The geotransform may rotate the grid: a square of the disc's radius in the smaller cell size
  // holds the disc whatever the rotation.
  const int reach = static_cast<int>(std::ceil(radius / std::min(cell.x(), cell.y()))) + 1;
  const int x0 = std::max(0, static_cast<int>(std::floor(centre.x())) - reach);
  const int x1 = std::min(dsm.width() - 1, static_cast<int>(std::ceil(centre.x())) + reach);
  const int y0 = std::max(0, static_cast<int>(std::floor(centre.y())) - reach);
  const int y1 = std::min(dsm.height() - 1, static_cast<int>(std::ceil(centre.y())) + reach);
  if (x0 > x1 || y0 > y1) return out;

  // Normal equations of z = a + b dx + c dy, with dx, dy relative to the disc's centre so that
  // large world coordinates do not spoil the conditioning.
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  const double r2 = radius * radius;
  int n = 0;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      if (!dsm.valid(x, y)) continue;
      const Eigen::Vector2d d = dsm.pixel_to_world(Eigen::Vector2d(x, y)) - xy;
      if (d.squaredNorm() > r2) continue;
      const Eigen::Vector3d row(1.0, d.x(), d.y());
      normal.noalias() += row * row.transpose();
      rhs += row * static_cast<double>(dsm.heights()(x, y));
      ++n;
    }
  out.cells = n;
  if (n < min_cells) return out;
  const Eigen::LDLT<Eigen::Matrix3d> solve(normal);
  // Collinear centres (a one-cell-wide strip of data) leave the plane's tilt across it free.
  if (solve.info() != Eigen::Success || !(std::abs(solve.vectorD().minCoeff()) > 1e-9 * normal.trace())) return out;
  const Eigen::Vector3d plane = solve.solve(rhs);
  double sum = 0.0, worst = 0.0;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      if (!dsm.valid(x, y)) continue;
      const Eigen::Vector2d d = dsm.pixel_to_world(Eigen::Vector2d(x, y)) - xy;
      if (d.squaredNorm() > r2) continue;
      const double e = dsm.heights()(x, y) - (plane(0) + plane(1) * d.x() + plane(2) * d.y());
      sum += e * e;
      worst = std::max(worst, std::abs(e));
    }
  out.valid = true;
  out.rms = std::sqrt(sum / n);
  out.max_abs = worst;
  return out;
}

}  // namespace diachron
