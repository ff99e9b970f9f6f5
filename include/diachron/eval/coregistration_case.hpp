#pragma once
/// @file
/// Co-registration test cases made from real DEMs: two overlapping windows, the first (epoch 1,
/// "master") moved into an arbitrary frame by a known Helmert, with holes and noise; and the error
/// of an estimated Helmert measured over their overlap.
///
/// Real archives give DSMs in unrelated frames; georeferenced DEMs do not. This turns one or two
/// georeferenced DEMs of the same place into a case whose answer is known (docs/architecture.md).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// How a case is made. Ranges are sampled uniformly from the case's seed.
struct CoregistrationCaseOptions {
  double overlap_min = 0.3;          ///< smallest overlap, as a fraction of one window's area, (0, 1]
  double overlap_max = 1.0;          ///< largest overlap, same unit, [overlap_min, 1]
  double rotation_max_deg = 360.0;   ///< rotation about the vertical drawn in [0, this), degrees
  double tilt_max_deg = 2.0;         ///< tilt of the master frame's vertical, degrees (SfM frames are nearly level)
  double scale_min = 0.5;            ///< scale of the master frame relative to the world, > 0
  double scale_max = 2.0;            ///< upper bound of that scale
  double shift_max = 1.0e4;          ///< translation of the master frame, each axis in [-this, this], master units
  double cell_jitter = 0.25;         ///< master cell = scale * world cell * u, u in [1 - this, 1 + this]
  double noise_sigma_cells = 0.05;   ///< Gaussian height noise, in world cells (scaled into each frame)
  double hole_fraction = 0.05;       ///< fraction of each DSM covered by random circular holes, [0, 0.9]
  double hole_radius_px = 6.0;       ///< mean hole radius, pixels
  /// Cut two windows with the drawn overlap (true), or use each DEM whole (false: the overlap is
  /// whatever the DEMs share, e.g. a crater DEM inside a regional one).
  bool crop_windows = true;

  void check() const {
    DIACHRON_CHECK(overlap_min > 0.0 && overlap_min <= overlap_max && overlap_max <= 1.0,
                   "overlap range must satisfy 0 < min <= max <= 1, got [" << overlap_min << ", "
                                                                          << overlap_max << "]");
    DIACHRON_CHECK(scale_min > 0.0 && scale_min <= scale_max, "scale range must be positive and ordered");
    DIACHRON_CHECK(tilt_max_deg >= 0.0 && tilt_max_deg < 30.0, "tilt_max_deg must be in [0, 30)");
    DIACHRON_CHECK(cell_jitter >= 0.0 && cell_jitter < 1.0, "cell_jitter must be in [0, 1)");
    DIACHRON_CHECK(noise_sigma_cells >= 0.0, "noise_sigma_cells must be >= 0");
    DIACHRON_CHECK(hole_fraction >= 0.0 && hole_fraction <= 0.9, "hole_fraction must be in [0, 0.9]");
    DIACHRON_CHECK(hole_radius_px > 0.0, "hole_radius_px must be > 0");
  }
};

/// A made case: find `secondary_from_master` given only the two DSMs.
struct CoregistrationCase {
  Dsm master;                      ///< epoch 1, in its own arbitrary frame
  Dsm secondary;                   ///< epoch 2, the reference (a window of the world DEM, world frame)
  Helmert3 secondary_from_master;  ///< the truth: X2 = scale R X1 + T
  double overlap = 0.0;            ///< planimetric overlap of the two windows, fraction of a window
  double rotation_deg = 0.0;       ///< rotation about the vertical that was applied, degrees
  double scale = 1.0;              ///< scale of the master frame relative to the world
};

/// Error of an estimated Helmert against the truth over the overlap, in secondary (target) units.
struct HelmertError {
  bool valid = false;        ///< false when no master pixel maps into the secondary's footprint
  double rms = std::numeric_limits<double>::infinity();  ///< RMS 3D distance over the overlap
  double max = std::numeric_limits<double>::infinity();  ///< largest 3D distance over the overlap
  std::size_t samples = 0;   ///< master pixels used
};

/// Makes a case from `master_world` (epoch 1's DEM) and `secondary_world` (epoch 2's DEM), both
/// georeferenced in the same world frame; they may be the same DEM. The windows are as large as the
/// drawn overlap allows inside the DEMs' common footprint. Deterministic in `seed`.
/// Throws diachron::Error when the DEMs do not overlap at all.
CoregistrationCase make_coregistration_case(const Dsm& master_world, const Dsm& secondary_world,
                                            const CoregistrationCaseOptions& options,
                                            std::uint64_t seed);

/// Distance between `estimate(X1)` and `truth(X1)` for X1 on the valid master pixels whose true
/// position falls in the secondary's footprint (at most `max_samples`, on a regular subgrid).
HelmertError helmert_error_on_overlap(const Helmert3& estimate, const CoregistrationCase& c,
                                      std::size_t max_samples = 20000);

// Implementation --------------------------------------------------------------------------------

namespace detail {

/// A world-axis-aligned window: [x0, x1] x [y0, y1] in world units.
struct WorldWindow {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double width() const { return x1 - x0; }
  double height() const { return y1 - y0; }
  bool contains(double x, double y) const { return x >= x0 && x <= x1 && y >= y0 && y <= y1; }
};

inline void punch_holes(Raster<float>& r, double fraction, double mean_radius, RandomStream& random) {
  if (fraction <= 0.0 || r.empty()) return;
  const double area = static_cast<double>(r.width()) * r.height();
  double punched = 0.0;
  // Overlapping discs make the covered fraction slightly smaller than the drawn area: fine for tests.
  while (punched < fraction * area) {
    const double radius = mean_radius * random.uniform(0.5, 1.5);
    const double cx = random.uniform(0.0, r.width()), cy = random.uniform(0.0, r.height());
    const int x0 = std::max(0, static_cast<int>(cx - radius)), x1 = std::min(r.width() - 1, static_cast<int>(cx + radius));
    const int y0 = std::max(0, static_cast<int>(cy - radius)), y1 = std::min(r.height() - 1, static_cast<int>(cy + radius));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= radius * radius)
          r(x, y) = std::numeric_limits<float>::quiet_NaN();
    punched += kPi * radius * radius;
  }
}

inline void add_noise(Raster<float>& r, double sigma, RandomStream& random) {
  if (sigma <= 0.0) return;
  for (float& v : r)
    if (!std::isnan(v)) v = static_cast<float>(v + random.normal(0.0, sigma));
}

}  // namespace detail

inline CoregistrationCase make_coregistration_case(const Dsm& master_world, const Dsm& secondary_world,
                                                   const CoregistrationCaseOptions& options,
                                                   std::uint64_t seed) {
  options.check();
  DIACHRON_CHECK(!master_world.empty() && !secondary_world.empty(), "case DEMs must not be empty");
  RandomStream random(seed, 0x636f726567ULL);

  // The common footprint of both DEMs, in world X/Y.
  const WorldBounds bm = master_world.bounds(), bs = secondary_world.bounds();
  CoregistrationCase out;
  detail::WorldWindow common{std::max(bm.min_x, bs.min_x), std::max(bm.min_y, bs.min_y),
                             std::min(bm.max_x, bs.max_x), std::min(bm.max_y, bs.max_y)};
  DIACHRON_CHECK(common.width() > 0 && common.height() > 0, "the two DEMs do not overlap");

  // Two equal windows whose intersection is `overlap` of a window: offsets (1-a) w and (1-b) h with
  // a b = overlap; each window as large as fits in the common footprint.
  const double overlap = random.uniform(options.overlap_min, options.overlap_max);
  out.overlap = overlap;
  const double a = random.uniform(overlap, 1.0);
  const double b = overlap / a;
  const double w = common.width() / (2.0 - a) * 0.999, h = common.height() / (2.0 - b) * 0.999;
  const double dx = (1.0 - a) * w, dy = (1.0 - b) * h;
  const double slack_x = common.width() - w - dx, slack_y = common.height() - h - dy;
  const double ox = common.x0 + random.uniform(0.0, std::max(slack_x, 0.0));
  const double oy = common.y0 + random.uniform(0.0, std::max(slack_y, 0.0));
  const bool master_left = random.uniform01() < 0.5, master_low = random.uniform01() < 0.5;
  if (!options.crop_windows) {
    // Whole DEMs: the windows are their footprints, the overlap what they share.
    out.overlap = common.width() * common.height() / ((bm.max_x - bm.min_x) * (bm.max_y - bm.min_y));
  }
  detail::WorldWindow win_m{ox + (master_left ? 0.0 : dx), oy + (master_low ? 0.0 : dy), 0, 0};
  detail::WorldWindow win_s{ox + (master_left ? dx : 0.0), oy + (master_low ? dy : 0.0), 0, 0};
  win_m.x1 = win_m.x0 + w;
  win_m.y1 = win_m.y0 + h;
  win_s.x1 = win_s.x0 + w;
  win_s.y1 = win_s.y0 + h;
  if (!options.crop_windows) {
    win_m = {bm.min_x, bm.min_y, bm.max_x, bm.max_y};
    win_s = {bs.min_x, bs.min_y, bs.max_x, bs.max_y};
  }
  const double world_cell = secondary_world.min_cell_size();

  // Secondary: the window cut from its DEM on its own grid, in the world frame.
  {
    const Eigen::Vector2d p0 = secondary_world.world_to_pixel({win_s.x0, win_s.y1});
    const Eigen::Vector2d p1 = secondary_world.world_to_pixel({win_s.x1, win_s.y0});
    const int c0 = std::max(0, static_cast<int>(std::ceil(std::min(p0.x(), p1.x()))));
    const int r0 = std::max(0, static_cast<int>(std::ceil(std::min(p0.y(), p1.y()))));
    const int c1 = std::min(secondary_world.width() - 1, static_cast<int>(std::floor(std::max(p0.x(), p1.x()))));
    const int r1 = std::min(secondary_world.height() - 1, static_cast<int>(std::floor(std::max(p0.y(), p1.y()))));
    DIACHRON_CHECK(c1 > c0 && r1 > r0, "secondary window is empty");
    Raster<float> heights(c1 - c0 + 1, r1 - r0 + 1);
    for (int y = r0; y <= r1; ++y)
      for (int x = c0; x <= c1; ++x) heights(x - c0, y - r0) = secondary_world.heights()(x, y);
    GeoTransform gt = secondary_world.transform();
    const Eigen::Vector2d corner = gt.pixel_to_world({c0 - 0.5, r0 - 0.5});
    gt.c[0] = corner.x();
    gt.c[3] = corner.y();
    detail::add_noise(heights, options.noise_sigma_cells * world_cell, random);
    detail::punch_holes(heights, options.hole_fraction, options.hole_radius_px, random);
    out.secondary = Dsm(std::move(heights), gt, secondary_world.crs());
  }

  // Master frame: X1 = F(X_world), F = s Rz(theta) Rtilt X + t; the truth is its inverse.
  const double theta = deg_to_rad(random.uniform(0.0, options.rotation_max_deg));
  const double scale = random.uniform(options.scale_min, options.scale_max);
  // One draw per statement, y before x (core/random.hpp, "Order of draws").
  const double tilt_y = random.uniform(-1, 1), tilt_x = random.uniform(-1, 1);
  Eigen::Vector3d tilt_axis(tilt_x, tilt_y, 0.0);
  if (tilt_axis.norm() < 1e-9) tilt_axis = Eigen::Vector3d::UnitX();
  tilt_axis.normalize();
  const double tilt = deg_to_rad(random.uniform(0.0, options.tilt_max_deg));
  const Eigen::Matrix3d rz = rotation_from_axis_angle<double>(Eigen::Vector3d(0, 0, theta));
  const Eigen::Matrix3d rt = rotation_from_axis_angle<double>(tilt_axis * tilt);
  // Centre the frame change on the window so the shift is what the option says, not a lever arm.
  const double mean_z = master_world.statistics().mean;
  const Eigen::Vector3d centre(0.5 * (win_m.x0 + win_m.x1), 0.5 * (win_m.y0 + win_m.y1),
                               std::isfinite(mean_z) ? mean_z : 0.0);
  const double shift_z = random.uniform(-0.1 * options.shift_max, 0.1 * options.shift_max);
  const double shift_y = random.uniform(-options.shift_max, options.shift_max);
  const double shift_x = random.uniform(-options.shift_max, options.shift_max);
  const Eigen::Vector3d shift(shift_x, shift_y, shift_z);
  Helmert3 master_from_world;
  master_from_world.scale = scale;
  master_from_world.rotation = rz * rt;
  master_from_world.translation = shift - scale * (rz * rt) * centre;
  const Helmert3 world_from_master = master_from_world.inverse();
  out.secondary_from_master = world_from_master;
  out.rotation_deg = rad_to_deg(theta);
  out.scale = scale;

  // Master grid: axis-aligned in the master frame, covering the moved window's footprint.
  const double cell = scale * master_world.min_cell_size() *
                      random.uniform(1.0 - options.cell_jitter, 1.0 + options.cell_jitter);
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x;
  double max_x = -min_x, max_y = -min_x;
  for (double cx : {win_m.x0, win_m.x1})
    for (double cy : {win_m.y0, win_m.y1}) {
      const Eigen::Vector3d p = master_from_world(Eigen::Vector3d(cx, cy, centre.z()));
      min_x = std::min(min_x, p.x());
      max_x = std::max(max_x, p.x());
      min_y = std::min(min_y, p.y());
      max_y = std::max(max_y, p.y());
    }
  const int width = std::max(2, static_cast<int>(std::ceil((max_x - min_x) / cell)));
  const int height = std::max(2, static_cast<int>(std::ceil((max_y - min_y) / cell)));
  const GeoTransform gt = GeoTransform::north_up(min_x, max_y, cell);
  Raster<float> heights(width, height, std::numeric_limits<float>::quiet_NaN());
  const double tolerance = 1e-4 * cell;
  const double start_z = master_from_world(centre).z();
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector2d xy = gt.pixel_to_world({double(x), double(y)});
      // The surface point on this master-frame vertical: a fixed point in z, contracting because
      // the tilt is small (each step scales the error by about tan(tilt) times the slope).
      double z = start_z;
      bool ok = false;
      for (int it = 0; it < 20; ++it) {
        const Eigen::Vector3d pw = world_from_master(Eigen::Vector3d(xy.x(), xy.y(), z));
        if (!win_m.contains(pw.x(), pw.y())) break;
        const double zw = master_world.height_at(pw.x(), pw.y());
        if (std::isnan(zw)) break;
        const double z_new = master_from_world(Eigen::Vector3d(pw.x(), pw.y(), zw)).z();
        if (std::abs(z_new - z) < tolerance) {
          z = z_new;
          ok = true;
          break;
        }
        z = z_new;
      }
      if (ok) heights(x, y) = static_cast<float>(z);
    }
  detail::add_noise(heights, options.noise_sigma_cells * world_cell * scale, random);
  detail::punch_holes(heights, options.hole_fraction, options.hole_radius_px, random);
  out.master = Dsm(std::move(heights), gt, std::string());
  return out;
}

inline HelmertError helmert_error_on_overlap(const Helmert3& estimate, const CoregistrationCase& c,
                                             std::size_t max_samples) {
  HelmertError e;
  const Dsm& m = c.master;
  const std::size_t total = static_cast<std::size_t>(m.width()) * m.height();
  const int stride = std::max<int>(1, static_cast<int>(std::sqrt(double(total) / std::max<std::size_t>(max_samples, 1))));
  double sum2 = 0.0, worst = 0.0;
  for (int y = 0; y < m.height(); y += stride)
    for (int x = 0; x < m.width(); x += stride) {
      if (!m.valid(x, y)) continue;
      const Eigen::Vector2d xy = m.pixel_to_world({double(x), double(y)});
      const Eigen::Vector3d x1(xy.x(), xy.y(), m.heights()(x, y));
      const Eigen::Vector3d truth = c.secondary_from_master(x1);
      if (!c.secondary.contains(truth.x(), truth.y())) continue;
      const double d = (estimate(x1) - truth).norm();
      sum2 += d * d;
      worst = std::max(worst, d);
      ++e.samples;
    }
  if (e.samples == 0) return e;
  e.valid = true;
  e.rms = std::sqrt(sum2 / static_cast<double>(e.samples));
  e.max = worst;
  return e;
}

}  // namespace diachron
