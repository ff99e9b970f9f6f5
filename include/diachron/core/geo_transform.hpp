#pragma once
/// @file
/// GeoTransform: GDAL's six affine coefficients mapping raster pixels to world X/Y.

#include <array>
#include <cmath>

#include <Eigen/Core>

#include <diachron/core/error.hpp>

namespace diachron {

/// GDAL's geotransform: for the pixel *corner* (col, row) (GDAL convention: (0, 0) is the top-left
/// corner of the top-left pixel),
///   X = c[0] + col * c[1] + row * c[2],   Y = c[3] + col * c[4] + row * c[5].
/// diachron's pixel convention puts (0, 0) at the *centre* of the top-left pixel (docs/conventions.md),
/// so pixel_to_world / world_to_pixel add and remove the half-pixel: pixel (0, 0) maps to the
/// centre of the first cell. For a north-up raster c[2] = c[4] = 0 and c[5] < 0.
struct GeoTransform {
  std::array<double, 6> c{0.0, 1.0, 0.0, 0.0, 0.0, 1.0};  ///< GDAL coefficients, world units

  /// A north-up transform: top-left *corner* (x0, y0), cell size `cell` (> 0); Y decreases downwards.
  static GeoTransform north_up(double x0, double y0, double cell) {
    DIACHRON_CHECK(cell > 0 && std::isfinite(cell), "cell size must be positive, got " << cell);
    return GeoTransform{{x0, cell, 0.0, y0, 0.0, -cell}};
  }

  /// World X/Y of the centre of pixel (x, y) in diachron's convention.
  Eigen::Vector2d pixel_to_world(const Eigen::Vector2d& px) const {
    const double col = px.x() + 0.5, row = px.y() + 0.5;
    return {c[0] + col * c[1] + row * c[2], c[3] + col * c[4] + row * c[5]};
  }

  /// Pixel (diachron convention) of world X/Y. Throws diachron::Error when the transform is singular.
  Eigen::Vector2d world_to_pixel(const Eigen::Vector2d& xy) const {
    const double det = c[1] * c[5] - c[2] * c[4];
    DIACHRON_CHECK(det != 0.0 && std::isfinite(det), "singular geotransform");
    const double dx = xy.x() - c[0], dy = xy.y() - c[3];
    const double col = (c[5] * dx - c[2] * dy) / det;
    const double row = (-c[4] * dx + c[1] * dy) / det;
    return {col - 0.5, row - 0.5};
  }

  /// Ground size of one pixel step along x and along y (world units, positive).
  Eigen::Vector2d cell_size() const {
    return {std::hypot(c[1], c[4]), std::hypot(c[2], c[5])};
  }
};

}  // namespace diachron
