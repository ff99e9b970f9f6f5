#pragma once
/// @file
/// Rendering of synthetic aerial images: every pixel's ray is cast through the epoch's true
/// surface (first crossing with the DSM), the albedo is sampled bilinearly at the hit and shaded by
/// the sun; then the "film" look of the epoch is applied: Gaussian blur, gain / offset / contrast /
/// gamma, vignetting, film grain, scratches and dust.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/camera/ortho_frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/ray.hpp>
#include <diachron/synth/compression.hpp>
#include <diachron/synth/noise.hpp>
#include <diachron/synth/texture.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>

namespace diachron {

/// The radiometric "look" of one epoch's images (scanned film of a given age and quality).
/// Intensities are in [0, 1] before quantisation to 8 bits.
struct LookOptions {
  /// Sun azimuth (counter-clockwise from world +X) and elevation, degrees.
  double sun_azimuth_deg = 135.0;
  double sun_elevation_deg = 45.0;
  /// Strength of the Lambertian shading of the relief, in [0, 1] (0 = flat albedo).
  double shading = 0.5;
  /// Linear radiometry: out = offset + gain * in, then contrast about 0.5. gain > 0, contrast > 0.
  double gain = 1.0;
  double offset = 0.0;
  double contrast = 1.0;
  /// Gamma of the tone curve: out = in^(1/gamma). > 0.
  double gamma = 1.0;
  /// Darkening at the image corners (fraction of the intensity lost at the farthest corner). [0, 1).
  double vignetting = 0.1;
  /// Sigma of the Gaussian blur (optics, scanning), pixels. >= 0 (0 = none).
  double blur_sigma_px = 0.6;
  /// Standard deviation of the per-pixel film grain (intensity units). >= 0.
  double grain_sigma = 0.015;
  /// Number of scratches per image (long thin lines, bright or dark). >= 0.
  int scratches = 0;
  /// Dust specks per megapixel (small bright or dark blobs). >= 0.
  double dust_per_megapixel = 30.0;
  /// Intensity of pixels whose ray misses the surface (outside the scene).
  double background = 0.0;

  // Effects of decades (all off by default; SceneOptions::decades_apart() sets them).
  /// Share of the direct sunlight that cast shadows block (buildings, trees, relief), in [0, 1]:
  /// 1 is physical (only the `1 - shading` sky light is left), 0 = no cast shadows.
  double cast_shadow = 0.0;
  /// How the film or sensor renders each land-cover class (may invert a class's contrast).
  LandCoverResponse land_cover;
  /// Steepness of the film's S-shaped characteristic curve (toe and shoulder), >= 0; 0 = linear.
  double tone_curve = 0.0;
  /// Amplitude of the low-frequency uneven exposure and development, a multiplicative field of
  /// relative amplitude in [0, 0.9] (0 = none) and wavelength `unevenness_wavelength` image widths.
  double exposure_unevenness = 0.0;
  double unevenness_wavelength = 0.6;
  /// Correlation length of the film grain (Gaussian sigma of the grain clumps), pixels; 0 = white
  /// grain. Clumped grain makes blobs that a detector takes for features. >= 0.
  double grain_size_px = 0.0;
  /// Scanner lines: standard deviation of a per-row intensity offset, and the number of strong
  /// stripes (a few rows brighter or darker) per image. >= 0.
  double scan_line_sigma = 0.0;
  int scan_stripes = 0;
  /// JPEG-like lossy compression of the 8-bit image (8 x 8 DCT, the JPEG luminance table scaled by
  /// quality as libjpeg does): quality in [1, 100], 0 = none.
  int jpeg_quality = 0;

  void check() const {
    DIACHRON_CHECK(sun_elevation_deg > 0.0 && sun_elevation_deg <= 90.0,
                   "LookOptions::sun_elevation_deg must be in (0, 90], got " << sun_elevation_deg);
    DIACHRON_CHECK(shading >= 0.0 && shading <= 1.0, "LookOptions::shading must be in [0, 1]");
    DIACHRON_CHECK(gain > 0.0 && std::isfinite(gain), "LookOptions::gain must be > 0, got " << gain);
    DIACHRON_CHECK(std::isfinite(offset), "LookOptions::offset must be finite");
    DIACHRON_CHECK(contrast > 0.0 && std::isfinite(contrast), "LookOptions::contrast must be > 0");
    DIACHRON_CHECK(gamma > 0.0 && std::isfinite(gamma), "LookOptions::gamma must be > 0, got " << gamma);
    DIACHRON_CHECK(vignetting >= 0.0 && vignetting < 1.0, "LookOptions::vignetting must be in [0, 1)");
    DIACHRON_CHECK(blur_sigma_px >= 0.0 && blur_sigma_px <= 50.0, "LookOptions::blur_sigma_px must be in [0, 50]");
    DIACHRON_CHECK(grain_sigma >= 0.0 && grain_sigma <= 1.0, "LookOptions::grain_sigma must be in [0, 1]");
    DIACHRON_CHECK(scratches >= 0 && scratches <= 1000, "LookOptions::scratches must be in [0, 1000]");
    DIACHRON_CHECK(dust_per_megapixel >= 0.0 && dust_per_megapixel <= 1e5,
                   "LookOptions::dust_per_megapixel must be in [0, 1e5]");
    DIACHRON_CHECK(cast_shadow >= 0.0 && cast_shadow <= 1.0, "LookOptions::cast_shadow must be in [0, 1]");
    land_cover.check();
    DIACHRON_CHECK(tone_curve >= 0.0 && tone_curve <= 50.0, "LookOptions::tone_curve must be in [0, 50]");
    DIACHRON_CHECK(exposure_unevenness >= 0.0 && exposure_unevenness <= 0.9,
                   "LookOptions::exposure_unevenness must be in [0, 0.9]");
    DIACHRON_CHECK(unevenness_wavelength > 0.0 && std::isfinite(unevenness_wavelength),
                   "LookOptions::unevenness_wavelength must be > 0");
    DIACHRON_CHECK(grain_size_px >= 0.0 && grain_size_px <= 20.0, "LookOptions::grain_size_px must be in [0, 20]");
    DIACHRON_CHECK(scan_line_sigma >= 0.0 && scan_line_sigma <= 1.0 && scan_stripes >= 0 && scan_stripes <= 1000,
                   "LookOptions: scan_line_sigma must be in [0, 1] and scan_stripes in [0, 1000]");
    DIACHRON_CHECK(jpeg_quality >= 0 && jpeg_quality <= 100, "LookOptions::jpeg_quality must be in [0, 100]");
  }
};

namespace detail {

/// First crossing of rays with a DSM, accelerated for rendering: a coarse grid of per-block
/// maximum heights lets a ray skip every block it passes above; inside a block that it may hit,
/// the exact crossing comes from intersect_ray_dsm(). The result is the one intersect_ray_dsm()
/// would give on the whole ray (a block's maximum bounds the bilinear surface over the block).
class SurfaceTracer {
 public:
  static constexpr int kBlock = 8;  // cells per block side

  /// Keeps a pointer to `dsm`, which must outlive the tracer (a temporary is refused).
  explicit SurfaceTracer(const Dsm&&) = delete;
  explicit SurfaceTracer(const Dsm& dsm) : dsm_(&dsm) {
    DIACHRON_CHECK(!dsm.empty(), "SurfaceTracer: empty DSM");
    const int w = dsm.width(), h = dsm.height();
    bw_ = (std::max(w - 1, 1) + kBlock - 1) / kBlock;
    bh_ = (std::max(h - 1, 1) + kBlock - 1) / kBlock;
    block_max_.resize(bw_, bh_, -std::numeric_limits<float>::infinity());
    for (int by = 0; by < bh_; ++by)
      for (int bx = 0; bx < bw_; ++bx) {
        float m = -std::numeric_limits<float>::infinity();
        // Inclusive of the shared edge samples: the bilinear surface of a cell is bounded by its
        // four corners, all of which are in the block's range.
        for (int y = by * kBlock; y <= std::min((by + 1) * kBlock, h - 1); ++y)
          for (int x = bx * kBlock; x <= std::min((bx + 1) * kBlock, w - 1); ++x) {
            const float v = dsm.heights()(x, y);
            if (!std::isnan(v)) m = std::max(m, v);
          }
        block_max_(bx, by) = m;
      }
  }

  const Dsm& dsm() const { return *dsm_; }

  /// The first crossing of `ray` with the surface, or nullopt (missed, or started below it).
  /// `tolerance_cells` is the bisection tolerance of intersect_ray_dsm(): the default gives truth
  /// to far below a micrometre; rendering needs far less.
  std::optional<Vec3> intersect(const Ray3& ray, double tolerance_cells = 1e-8) const {
    const Dsm& dsm = *dsm_;
    const Vec3 o = ray.origin;
    const Vec3 d = ray.direction.normalized();
    if (!o.allFinite() || !d.allFinite()) return std::nullopt;
    const DsmStatistics& stats = dsm.statistics();
    if (stats.count == 0) return std::nullopt;
    const Vec2 a = dsm.world_to_pixel(o.head<2>());
    const Vec2 b = dsm.world_to_pixel(o.head<2>() + d.head<2>()) - a;
    const double w = dsm.width(), h = dsm.height();
    double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
    clip_slab(a.x(), b.x(), 0.0, w - 1.0, t0, t1);
    clip_slab(a.y(), b.y(), 0.0, h - 1.0, t0, t1);
    const double margin = 1e-6 * (1.0 + std::abs(stats.min) + std::abs(stats.max));
    clip_slab(o.z(), d.z(), stats.min - margin, stats.max + margin, t0, t1);
    if (!(t0 <= t1) || !std::isfinite(t1)) {
      // Horizontal rays inside the height range have an unbounded slab; let the exact search
      // decide (it clips to the grid itself).
      if (!(t0 <= t1)) return std::nullopt;
      const RayDsmResult r = exact_result(o, d, std::numeric_limits<double>::infinity(), tolerance_cells);
      if (!r.success) return std::nullopt;
      return r.point;
    }
    const double inf = std::numeric_limits<double>::infinity();
    const double B = kBlock;
    const Vec2 p0 = a + b * t0;
    int bx = std::clamp(static_cast<int>(std::floor(p0.x() / B)), 0, bw_ - 1);
    int by = std::clamp(static_cast<int>(std::floor(p0.y() / B)), 0, bh_ - 1);
    const int sx = b.x() > 0.0 ? 1 : (b.x() < 0.0 ? -1 : 0);
    const int sy = b.y() > 0.0 ? 1 : (b.y() < 0.0 ? -1 : 0);
    const auto next_x = [&](int i) { return sx > 0 ? ((i + 1) * B - a.x()) / b.x() : (sx < 0 ? (i * B - a.x()) / b.x() : inf); };
    const auto next_y = [&](int j) { return sy > 0 ? ((j + 1) * B - a.y()) / b.y() : (sy < 0 ? (j * B - a.y()) / b.y() : inf); };
    double tx = next_x(bx), ty = next_y(by);
    double t = t0;
    while (t <= t1) {
      const double tn = std::min({tx, ty, t1});
      const double z_low = std::min(o.z() + d.z() * t, o.z() + d.z() * std::max(tn, t));
      const double top = block_max_(bx, by) + margin;
      if (z_low <= top) {
        // The segment may meet the surface in this block: search it exactly from where it goes
        // below the block's highest point (above that nothing can be hit), to a little beyond the
        // block's end, so that a crossing on the block edge is not lost between two searches.
        const double start = d.z() < 0.0 ? std::clamp((top - o.z()) / d.z(), t, std::max(tn, t)) : t;
        const double length = std::max(tn - start, 0.0) + 1e-6 * dsm.min_cell_size();
        const RayDsmResult r = exact_result(o + d * start, d, length, tolerance_cells);
        if (r.success) return r.point;
        if (r.outcome == RayDsmOutcome::below_surface || r.outcome == RayDsmOutcome::hidden_by_hole)
          return std::nullopt;
      }
      if (tn >= t1) break;
      if (tn == tx) {
        bx += sx;
        tx = next_x(bx);
      }
      if (tn == ty) {
        by += sy;
        ty = next_y(by);
      }
      if (bx < 0 || by < 0 || bx >= bw_ || by >= bh_) break;
      t = std::max(t, tn);
    }
    return std::nullopt;
  }

 private:
  static void clip_slab(double a, double b, double lo, double hi, double& t0, double& t1) {
    if (b == 0.0) {
      if (a < lo || a > hi) {
        t0 = std::numeric_limits<double>::infinity();
        t1 = -std::numeric_limits<double>::infinity();
      }
      return;
    }
    double ta = (lo - a) / b, tb = (hi - a) / b;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }

  RayDsmResult exact_result(const Vec3& origin, const Vec3& d, double max_distance, double tolerance_cells) const {
    RayDsmOptions options;
    options.max_distance = max_distance;
    options.tolerance_cells = tolerance_cells;
    // Cell edges split the march anyway and each cell is tested exactly, so longer steps lose
    // nothing and save evaluations.
    options.step_cells = 2.0;
    return intersect_ray_dsm(*dsm_, Ray3{origin, d}, options);
  }

  const Dsm* dsm_;
  int bw_ = 0, bh_ = 0;
  Raster<float> block_max_;
};

/// Unit vector towards the sun in the world frame.
inline Vec3 sun_direction(const LookOptions& look) {
  const double az = deg_to_rad(look.sun_azimuth_deg), el = deg_to_rad(look.sun_elevation_deg);
  return {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
}

/// Separable Gaussian blur with clamped edges.
inline Raster<float> blur_radiance(const Raster<float>& in, double sigma, std::size_t threads) {
  if (sigma <= 0.0 || in.empty()) return in;
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
  std::vector<double> kernel(static_cast<std::size_t>(2 * radius + 1));
  double sum = 0.0;
  for (int k = -radius; k <= radius; ++k) sum += kernel[static_cast<std::size_t>(k + radius)] = std::exp(-0.5 * k * k / (sigma * sigma));
  for (double& k : kernel) k /= sum;
  const int w = in.width(), h = in.height();
  Raster<float> tmp(w, h), out(w, h);
  parallel_for(static_cast<std::size_t>(h), threads, [&](std::size_t row) {
    const int y = static_cast<int>(row);
    for (int x = 0; x < w; ++x) {
      double acc = 0.0;
      for (int k = -radius; k <= radius; ++k)
        acc += kernel[static_cast<std::size_t>(k + radius)] * in(std::clamp(x + k, 0, w - 1), y);
      tmp(x, y) = static_cast<float>(acc);
    }
  });
  parallel_for(static_cast<std::size_t>(h), threads, [&](std::size_t row) {
    const int y = static_cast<int>(row);
    for (int x = 0; x < w; ++x) {
      double acc = 0.0;
      for (int k = -radius; k <= radius; ++k)
        acc += kernel[static_cast<std::size_t>(k + radius)] * tmp(x, std::clamp(y + k, 0, h - 1));
      out(x, y) = static_cast<float>(acc);
    }
  });
  return out;
}

}  // namespace detail

/// Bisection tolerance of rendering rays, in DSM cells: a micrometre-level hit is pointless for a
/// pixel's colour, and each factor of 2 costs one evaluation per ray. The hit is then refined
/// by linear interpolation, so 5e-2 cells still places it far below a hundredth of a pixel.
inline constexpr double kRenderToleranceCells = 5e-2;

/// The sun shading factor of every DSM cell (Lambertian, normalised to 1 on flat ground), on the
/// DSM's grid: computed once per epoch instead of four height look-ups per pixel. With
/// `look.cast_shadow` > 0, a ray from each cell towards the sun decides whether the cell lies in a
/// cast shadow (of a building, a tree or the relief), which removes that share of the direct light:
/// one shadow ray per DSM cell rather than per pixel, and bilinear sampling of the map gives the
/// penumbra of about a cell.
inline AlbedoMap shading_map(const Dsm& surface, const LookOptions& look, std::size_t threads = 0) {
  look.check();
  AlbedoMap out;
  out.transform = surface.transform();
  const int w = surface.width(), h = surface.height();
  out.values.resize(w, h, 1.0f);
  if (look.shading <= 0.0) return out;
  const Vec3 sun = detail::sun_direction(look);
  std::optional<detail::SurfaceTracer> shadow_tracer;
  if (look.cast_shadow > 0.0) shadow_tracer.emplace(surface);
  // The ray starts a little above the cell so that it does not meet the surface it leaves.
  const double lift = 0.02 * surface.min_cell_size();
  const GeoTransform& t = surface.transform();
  // Central differences on the grid, mapped to world X/Y through the geotransform's linear part.
  Eigen::Matrix2d pixel_from_world_linear;
  pixel_from_world_linear << t.c[1], t.c[2], t.c[4], t.c[5];
  pixel_from_world_linear = pixel_from_world_linear.inverse().eval();
  const Raster<float>& z = surface.heights();
  parallel_for(static_cast<std::size_t>(h), threads, [&](std::size_t row) {
    const int y = static_cast<int>(row);
    const int y0 = std::max(y - 1, 0), y1 = std::min(y + 1, h - 1);
    for (int x = 0; x < w; ++x) {
      const int x0 = std::max(x - 1, 0), x1 = std::min(x + 1, w - 1);
      const double dzdc = x1 > x0 ? (z(x1, y) - z(x0, y)) / (x1 - x0) : 0.0;
      const double dzdr = y1 > y0 ? (z(x, y1) - z(x, y0)) / (y1 - y0) : 0.0;
      // dz/dX = dz/dcol dcol/dX + dz/drow drow/dX.
      const Vec2 gradient = pixel_from_world_linear.transpose() * Vec2(dzdc, dzdr);
      if (!gradient.allFinite()) continue;
      const Vec3 n = Vec3(-gradient.x(), -gradient.y(), 1.0).normalized();
      double direct = std::max(0.0, n.dot(sun)) / sun.z();
      if (shadow_tracer && direct > 0.0) {
        const Vec2 xy = t.pixel_to_world(Vec2(x, y));
        const Ray3 ray{Vec3(xy.x(), xy.y(), static_cast<double>(z(x, y)) + lift), sun};
        if (shadow_tracer->intersect(ray, kRenderToleranceCells)) direct *= 1.0 - look.cast_shadow;
      }
      out.values(x, y) = static_cast<float>((1.0 - look.shading) + look.shading * direct);
    }
  });
  return out;
}

/// The unit ray direction (camera frame) of every pixel of a camera: images that share a camera
/// share these, so the iterative unprojection runs once per pixel and camera, not per image.
struct PixelDirections {
  int width = 0;
  int height = 0;
  std::vector<Vec3> directions;  ///< row-major; NaN where the pixel cannot be unprojected

  template <class Distortion>
  static PixelDirections of(const Camera<Distortion>& camera, std::size_t threads = 0) {
    PixelDirections out;
    out.width = camera.width();
    out.height = camera.height();
    out.directions.assign(static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height),
                          Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
    parallel_for(static_cast<std::size_t>(out.height), threads, [&](std::size_t row) {
      for (int x = 0; x < out.width; ++x)
        if (const std::optional<Vec3> d = camera.unproject(Vec2(x, static_cast<double>(row))))
          out.directions[row * static_cast<std::size_t>(out.width) + static_cast<std::size_t>(x)] = *d;
    });
    return out;
  }
};

namespace detail {

/// The radiance loop every kind of frame shares: pixel (x, y) of a `width` x `height` image gets
/// the albedo times the shading at the first crossing of `ray_of(x, y)` (a std::optional<Ray3> in
/// the tracer's world frame; nullopt where the pixel has no ray) with the surface, and
/// `look.background` where it has none or misses. Rows in parallel; the result does not depend on
/// `threads`.
template <class RayOf>
Raster<float> render_rays(int width, int height, const RayOf& ray_of, const SurfaceTracer& tracer,
                          const AlbedoMap& albedo, const AlbedoMap& shading, const LookOptions& look,
                          std::size_t threads) {
  Raster<float> out(width, height);
  parallel_for(static_cast<std::size_t>(height), threads, [&](std::size_t row) {
    const int y = static_cast<int>(row);
    for (int x = 0; x < width; ++x) {
      double value = look.background;
      if (const std::optional<Ray3> ray = ray_of(x, y))
        if (const std::optional<Vec3> hit = tracer.intersect(*ray, kRenderToleranceCells)) {
          const Vec2 xy = hit->template head<2>();
          value = albedo.sample(xy) * shading.sample(xy);
        }
      out(x, y) = static_cast<float>(value);
    }
  });
  return out;
}

/// An upper bound (plus a unit) of `surface` (world frame) along the Z axis of the frame that
/// `world_from_frame` maps into the world: the highest frame Z over the corners of the surface's
/// box, as Z is linear in world coordinates. NaN when the surface has no valid height.
inline double surface_top_in_frame(const Dsm& surface, const Helmert3& world_from_frame) {
  const Helmert3 frame_from_world = world_from_frame.inverse();
  const WorldBounds box = surface.bounds();
  const DsmStatistics& stats = surface.statistics();
  if (stats.count == 0) return std::numeric_limits<double>::quiet_NaN();
  double top = -std::numeric_limits<double>::infinity();
  for (double x : {box.min_x, box.max_x})
    for (double y : {box.min_y, box.max_y})
      for (double z : {stats.min, stats.max}) top = std::max(top, frame_from_world(Vec3(x, y, z)).z());
  return top + 1.0 + 1e-6 * std::abs(top);
}

/// OrthoFrame::ray of `pixel`, its origin moved down its line to frame height `top` (when lower than
/// the ray's), carried into the world by `world_from_frame`; nullopt without a ray or a finite top.
inline std::optional<Ray3> vertical_ray_in_world(const OrthoFrame& frame, const Helmert3& world_from_frame,
                                                 double top, const Vec2& pixel) {
  std::optional<Ray3> ray = frame.ray(pixel);
  if (!ray || !std::isfinite(top)) return std::nullopt;
  ray->origin.z() = std::min(ray->origin.z(), top);
  return Ray3{world_from_frame(ray->origin), world_from_frame.rotation * ray->direction};
}

}  // namespace detail

/// Scene radiance seen by `frame` (intensity in [0, 1] before the film look): albedo at the first
/// crossing of each pixel's ray with the surface, times the sun shading (`shading`, from
/// shading_map() of the same surface); `look.background` where the ray misses. `directions`
/// must come from the frame's camera. Rows in parallel; the result does not depend on `threads`.
template <class Distortion>
Raster<float> render_radiance(const Frame<Distortion>& frame, const PixelDirections& directions,
                              const detail::SurfaceTracer& tracer, const AlbedoMap& albedo,
                              const AlbedoMap& shading, const LookOptions& look, std::size_t threads = 0) {
  look.check();
  const int w = frame.camera().width(), h = frame.camera().height();
  DIACHRON_CHECK(directions.width == w && directions.height == h,
                 "render_radiance: pixel directions of a " << directions.width << " x " << directions.height
                                                           << " camera for a " << w << " x " << h << " image");
  const auto ray_of = [&](int x, int y) -> std::optional<Ray3> {
    const Vec3& d = directions.directions[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) +
                                          static_cast<std::size_t>(x)];
    if (!d.allFinite()) return std::nullopt;
    return Ray3{frame.pose().centre(), frame.pose().world_direction_from_cam(d)};
  };
  return detail::render_rays(w, h, ray_of, tracer, albedo, shading, look, threads);
}

/// Scene radiance of a true orthophoto (no relief displacement): each pixel's ray is `frame`'s
/// vertical ray (OrthoFrame::ray) in the frame of its geotransform, moved into the tracer's world
/// frame by `world_from_frame` (identity when the orthophoto is georeferenced in the world; an
/// epoch's world_from_epoch when it is delivered in that epoch's frame, whose vertical may be
/// tilted). The hit is shaded as in the images, so the sun's shading and cast shadows stay, as in
/// a real orthophoto. The ray's origin is first moved down its line to just above the surface's
/// bounding box: the same ray, but a start 1e7 frame units up, carried through a tilted Helmert,
/// would cost the hit about a millimetre. Throws diachron::Error when `world_from_frame` is not
/// finite with a positive scale.
inline Raster<float> render_radiance(const OrthoFrame& frame, const Helmert3& world_from_frame,
                                     const detail::SurfaceTracer& tracer, const AlbedoMap& albedo,
                                     const AlbedoMap& shading, const LookOptions& look, std::size_t threads = 0) {
  look.check();
  DIACHRON_CHECK(world_from_frame.scale > 0.0 && std::isfinite(world_from_frame.scale) &&
                     world_from_frame.rotation.allFinite() && world_from_frame.translation.allFinite(),
                 "render_radiance: world_from_frame must be finite with a positive scale");
  const double top = detail::surface_top_in_frame(tracer.dsm(), world_from_frame);
  const auto ray_of = [&](int x, int y) {
    return detail::vertical_ray_in_world(frame, world_from_frame, top, Vec2(x, y));
  };
  return detail::render_rays(frame.width(), frame.height(), ray_of, tracer, albedo, shading, look, threads);
}

/// As above, computing the pixel directions and the shading of the tracer's surface first.
template <class Distortion>
Raster<float> render_radiance(const Frame<Distortion>& frame, const detail::SurfaceTracer& tracer,
                              const AlbedoMap& albedo, const LookOptions& look, std::size_t threads = 0) {
  return render_radiance(frame, PixelDirections::of(frame.camera(), threads), tracer, albedo,
                         shading_map(tracer.dsm(), look, threads), look, threads);
}

/// Applies the film look to a radiance image and quantises it to 8 bits: blur, tone curve,
/// vignetting, grain, scratches, dust. Deterministic from (seed, stream).
inline Raster<std::uint8_t> develop_image(const Raster<float>& radiance, const LookOptions& look,
                                          std::uint64_t seed, std::uint64_t stream, std::size_t threads = 0) {
  look.check();
  const int w = radiance.width(), h = radiance.height();
  Raster<float> img = detail::blur_radiance(radiance, look.blur_sigma_px, threads);
  const double half_diagonal = 0.5 * std::hypot(w - 1.0, h - 1.0);
  // Clumped grain: white noise blurred to the grain size, rescaled to unit standard deviation.
  Raster<float> clumps;
  if (look.grain_sigma > 0.0 && look.grain_size_px > 0.0) {
    clumps.resize(w, h);
    parallel_for(static_cast<std::size_t>(h), threads, [&](std::size_t row) {
      RandomStream noise(seed, detail::mix64(stream) ^ (0x434c554dULL + (row << 20)));
      for (int x = 0; x < w; ++x) clumps(x, static_cast<int>(row)) = static_cast<float>(noise.normal());
    });
    clumps = detail::blur_radiance(clumps, look.grain_size_px, threads);
    double sum2 = 0.0;
    for (float v : clumps) sum2 += static_cast<double>(v) * v;
    const auto norm = static_cast<float>(1.0 / std::sqrt(std::max(sum2 / (static_cast<double>(w) * h), 1e-30)));
    for (float& v : clumps) v *= norm;
  }
  const std::uint64_t uneven_seed = detail::mix64(stream ^ 0x554e4556454eULL);
  const double uneven_wavelength = look.unevenness_wavelength * std::max(w, 1);
  // The S curve is a logistic of the exposure, rescaled to map 0 and 1 onto themselves.
  const double k = look.tone_curve;
  const double s_low = 1.0 / (1.0 + std::exp(0.5 * k)), s_high = 1.0 / (1.0 + std::exp(-0.5 * k));
  parallel_for(static_cast<std::size_t>(h), threads, [&](std::size_t row) {
    const int y = static_cast<int>(row);
    RandomStream grain(seed, detail::mix64(stream) ^ (0x4752414eULL + row));
    for (int x = 0; x < w; ++x) {
      double v = look.offset + look.gain * img(x, y);
      if (look.exposure_unevenness > 0.0)
        v *= 1.0 + look.exposure_unevenness * detail::fbm(uneven_seed, x, y, uneven_wavelength, 2);
      v = 0.5 + look.contrast * (v - 0.5);
      if (k > 0.0) v = (1.0 / (1.0 + std::exp(-k * (v - 0.5))) - s_low) / (s_high - s_low);
      v = std::pow(std::clamp(v, 0.0, 1.0), 1.0 / look.gamma);
      const double r = std::hypot(x - 0.5 * (w - 1), y - 0.5 * (h - 1)) / std::max(half_diagonal, 1.0);
      v *= 1.0 - look.vignetting * r * r;
      if (look.grain_sigma > 0.0) v += look.grain_sigma * (clumps.empty() ? grain.normal() : static_cast<double>(clumps(x, y)));
      img(x, y) = static_cast<float>(v);
    }
  });

  if (look.scan_line_sigma > 0.0 || look.scan_stripes > 0) {
    // A line scanner reads the film row by row: each row gets its own offset, a few rows a strong one.
    RandomStream random(seed, detail::mix64(stream) ^ 0x5343414eULL);
    std::vector<double> row_offset(static_cast<std::size_t>(h));
    for (double& o : row_offset) o = look.scan_line_sigma * random.normal();
    for (int s = 0; s < look.scan_stripes; ++s) {
      const auto first = static_cast<int>(random.uniform_index(static_cast<std::size_t>(h)));
      const int rows = 1 + static_cast<int>(random.uniform_index(3));
      // One draw per statement (core/random.hpp, "Order of draws").
      const double sign = random.uniform01() < 0.5 ? 1.0 : -1.0;
      const double strength = sign * random.uniform(0.04, 0.12);
      for (int y = first; y < std::min(h, first + rows); ++y) row_offset[static_cast<std::size_t>(y)] += strength;
    }
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) img(x, y) += static_cast<float>(row_offset[static_cast<std::size_t>(y)]);
  }

  RandomStream random(seed, detail::mix64(stream) ^ 0x5343524154ULL);
  for (int s = 0; s < look.scratches; ++s) {
    // Film scratches run mostly along the film transport direction (image y).
    // One draw per statement, y before x (core/random.hpp, "Order of draws").
    const double py = random.uniform(0.0, h), px = random.uniform(0.0, w);
    const Vec2 p(px, py);
    const double angle = 0.5 * kPi + random.normal(0.0, 0.08);
    const Vec2 n(-std::sin(angle), std::cos(angle));
    const double sign = random.uniform01() < 0.7 ? 1.0 : -1.0;
    const double strength = sign * random.uniform(0.15, 0.45);
    const double half_width = random.uniform(0.4, 1.2);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const double dist = std::abs((Vec2(x, y) - p).dot(n));
        if (dist < half_width + 1.0) img(x, y) += static_cast<float>(strength * std::max(0.0, 1.0 - dist / (half_width + 1.0)));
      }
  }
  const auto specks = static_cast<int>(std::llround(look.dust_per_megapixel * w * h * 1e-6));
  for (int s = 0; s < specks; ++s) {
    const double cy = random.uniform(0.0, h), cx = random.uniform(0.0, w);
    const Vec2 c(cx, cy);
    const double radius = random.uniform(0.6, 2.5);
    const double sign = random.uniform01() < 0.5 ? 1.0 : -1.0;
    const double strength = sign * random.uniform(0.2, 0.5);
    for (int y = std::max(0, static_cast<int>(c.y() - radius - 1)); y <= std::min(h - 1, static_cast<int>(c.y() + radius + 1)); ++y)
      for (int x = std::max(0, static_cast<int>(c.x() - radius - 1)); x <= std::min(w - 1, static_cast<int>(c.x() + radius + 1)); ++x)
        if ((Vec2(x, y) - c).norm() <= radius) img(x, y) += static_cast<float>(strength);
  }

  Raster<std::uint8_t> out(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      out(x, y) = static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(static_cast<double>(img(x, y)), 0.0, 1.0)));
  if (look.jpeg_quality > 0) out = jpeg_like_compress(out, look.jpeg_quality, threads);
  return out;
}

}  // namespace diachron
