#pragma once
/// @file
/// Dsm: a digital surface model, heights Z over a regular X/Y grid given by a GeoTransform, with
/// NaN holes; bilinear height look-up that never invents values next to holes or outside.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <utility>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/raster.hpp>

namespace diachron {

/// Statistics of the valid (non-hole) heights of a DSM, in height units (metres for a metric DSM).
/// All values are NaN when `count == 0`.
struct DsmStatistics {
  double mean = std::numeric_limits<double>::quiet_NaN();  ///< mean height
  double std = std::numeric_limits<double>::quiet_NaN();   ///< population standard deviation (divides by count)
  double min = std::numeric_limits<double>::quiet_NaN();   ///< lowest valid height
  double max = std::numeric_limits<double>::quiet_NaN();   ///< highest valid height
  std::size_t count = 0;                                   ///< number of valid pixels
};

/// Axis-aligned world X/Y box, world units.
struct WorldBounds {
  double min_x = 0.0;
  double min_y = 0.0;
  double max_x = 0.0;
  double max_y = 0.0;
};

/// A digital surface model: `heights()(x, y)` is the height Z at the centre of pixel (x, y), whose
/// world X/Y is `transform().pixel_to_world({x, y})` (diachron's pixel-centre convention).
/// Holes (no data) are NaN. The world frame is right-handed with Z up (docs/conventions.md).
///
/// A Dsm is immutable once built: its statistics are computed once at construction, which is what
/// lets ray intersection bound its search by the height range at no cost per ray.
class Dsm {
 public:
  /// An empty DSM (no pixels): every look-up is NaN, every ray misses.
  Dsm() = default;

  /// Takes `heights` (holes NaN; +-infinity are turned into holes too), the geotransform and the CRS
  /// (WKT or user text such as "EPSG:26910"; may be empty when the frame is arbitrary).
  /// Throws diachron::Error for an empty raster or a singular / non-finite geotransform.
  Dsm(Raster<float> heights, const GeoTransform& transform, std::string crs = {})
      : heights_(std::move(heights)), transform_(transform), crs_(std::move(crs)) {
    DIACHRON_CHECK(heights_.width() > 0 && heights_.height() > 0,
                   "a DSM needs at least one pixel, got " << heights_.width() << " x " << heights_.height());
    for (double v : transform_.c) DIACHRON_CHECK(std::isfinite(v), "DSM geotransform has a non-finite coefficient");
    const double det = transform_.c[1] * transform_.c[5] - transform_.c[2] * transform_.c[4];
    DIACHRON_CHECK(det != 0.0, "DSM geotransform is singular (zero pixel area)");
    for (float& v : heights_)
      if (!std::isfinite(v)) v = std::numeric_limits<float>::quiet_NaN();
    compute_statistics();
  }

  int width() const { return heights_.width(); }
  int height() const { return heights_.height(); }
  bool empty() const { return heights_.empty(); }
  const Raster<float>& heights() const { return heights_; }
  const GeoTransform& transform() const { return transform_; }
  /// CRS as given (WKT or user text); empty when unknown or arbitrary.
  const std::string& crs() const { return crs_; }

  /// True when pixel (x, y) is inside the raster and not a hole.
  bool valid(int x, int y) const { return heights_.contains(x, y) && !std::isnan(heights_(x, y)); }

  /// Ground size of one cell along the raster's x and y axes (world units, positive).
  Eigen::Vector2d cell_size() const { return transform_.cell_size(); }
  /// The smaller of the two cell sizes (world units): the resolution that step sizes refer to.
  double min_cell_size() const {
    const Eigen::Vector2d c = cell_size();
    return std::min(c.x(), c.y());
  }

  /// World X/Y of pixel `px` (pixel-centre convention) and back.
  Eigen::Vector2d pixel_to_world(const Eigen::Vector2d& px) const { return transform_.pixel_to_world(px); }
  Eigen::Vector2d world_to_pixel(const Eigen::Vector2d& xy) const { return transform_.world_to_pixel(xy); }

  /// True when world (X, Y) lies in the DSM's footprint: inside the outer edges of its cells.
  /// Note that height_at() is only defined between pixel *centres*, half a cell less on each side.
  bool contains(double X, double Y) const {
    if (empty() || !std::isfinite(X) || !std::isfinite(Y)) return false;
    const Eigen::Vector2d p = world_to_pixel({X, Y});
    return p.x() >= -0.5 && p.y() >= -0.5 && p.x() <= width() - 0.5 && p.y() <= height() - 0.5;
  }

  /// Bilinear height at world (X, Y). NaN when the point is not between four pixel centres of the
  /// grid (so within half a cell of the border) or when any of the surrounding samples that carry
  /// weight is a hole: the surface is never extrapolated nor blended with missing data.
  double height_at(double X, double Y) const {
    if (empty() || !std::isfinite(X) || !std::isfinite(Y)) return std::numeric_limits<double>::quiet_NaN();
    return height_at_pixel(world_to_pixel({X, Y}));
  }
  double height_at(const Eigen::Vector2d& xy) const { return height_at(xy.x(), xy.y()); }

  /// Bilinear height at pixel `px` (pixel-centre convention); same rules as height_at().
  double height_at_pixel(const Eigen::Vector2d& px) const {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    const double x = px.x(), y = px.y();
    const int w = width(), h = height();
    // Written so that NaN coordinates fail the test too.
    if (!(x >= 0.0 && y >= 0.0 && x <= w - 1 && y <= h - 1)) return nan;
    // The last row / column is reached from the cell before it, so that x == w - 1 is inside.
    const int x0 = std::min(static_cast<int>(x), std::max(w - 2, 0));
    const int y0 = std::min(static_cast<int>(y), std::max(h - 2, 0));
    const double fx = x - x0, fy = y - y0;
    const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
    const double weights[4] = {(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy};
    const float values[4] = {heights_(x0, y0), heights_(x1, y0), heights_(x0, y1), heights_(x1, y1)};
    double z = 0.0;
    for (int i = 0; i < 4; ++i) {
      // A sample with zero weight does not matter, even a hole: pixel centres next to holes keep
      // their exact value and the surface stays continuous along the edge of a hole.
      if (weights[i] == 0.0) continue;
      if (std::isnan(values[i])) return nan;
      z += weights[i] * static_cast<double>(values[i]);
    }
    return z;
  }

  /// Statistics of the valid heights (computed at construction).
  const DsmStatistics& statistics() const { return stats_; }

  /// World X/Y box of the footprint (outer cell edges), world units. All zero for an empty DSM.
  WorldBounds bounds() const {
    if (empty()) return {};
    const double w = width() - 0.5, h = height() - 0.5;
    const Eigen::Vector2d corners[4] = {pixel_to_world({-0.5, -0.5}), pixel_to_world({w, -0.5}),
                                        pixel_to_world({-0.5, h}), pixel_to_world({w, h})};
    WorldBounds b{corners[0].x(), corners[0].y(), corners[0].x(), corners[0].y()};
    for (const auto& c : corners) {
      b.min_x = std::min(b.min_x, c.x());
      b.min_y = std::min(b.min_y, c.y());
      b.max_x = std::max(b.max_x, c.x());
      b.max_y = std::max(b.max_y, c.y());
    }
    return b;
  }

 private:
  void compute_statistics() {
    double sum = 0.0;
    DsmStatistics s;
    s.min = std::numeric_limits<double>::infinity();
    s.max = -std::numeric_limits<double>::infinity();
    for (float v : heights_) {
      if (std::isnan(v)) continue;
      sum += v;
      ++s.count;
      s.min = std::min(s.min, static_cast<double>(v));
      s.max = std::max(s.max, static_cast<double>(v));
    }
    if (s.count == 0) {
      stats_ = DsmStatistics{};
      return;
    }
    s.mean = sum / static_cast<double>(s.count);
    // Two passes: a one-pass sum of squares loses digits on DSMs far above zero (heights ~ 1e3 m).
    double sq = 0.0;
    for (float v : heights_) {
      if (std::isnan(v)) continue;
      const double d = v - s.mean;
      sq += d * d;
    }
    s.std = std::sqrt(sq / static_cast<double>(s.count));
    stats_ = s;
  }

  Raster<float> heights_;
  GeoTransform transform_;
  std::string crs_;
  DsmStatistics stats_;
};

}  // namespace diachron
