#pragma once
/// @file
/// Full-size scans from a coarse render: a scene generated at a coarse image size is delivered at
/// `scale` times that size (12000 x 12000 px film scans in minutes rather than hours). The cameras
/// and every pixel of the truth are scaled exactly; each written image is rebuilt band by band from
/// the ground position of every coarse pixel's ray hit, interpolated to the full grid, where the
/// epoch's albedo and sun shading are sampled and a procedural detail texture of ground position
/// (the same in every epoch) adds what the albedo's texels lack; the epoch's film look is applied
/// at the full size, grain per epoch on top. Needs Eigen and the standard library only.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/synth/compression.hpp>
#include <diachron/synth/noise.hpp>
#include <diachron/synth/render.hpp>
#include <diachron/synth/scene.hpp>

namespace diachron {

/// Options of the full-size images (FullSizeEpochRenderer).
struct FullSizeScanOptions {
  /// Written pixels per rendered pixel (the factor scale_scene_images() applied), >= 1.
  double scale = 1.0;
  /// Relative amplitude of the ground detail texture that multiplies the albedo, in [0, 1].
  double detail_amplitude = 0.25;
  /// Longest wavelength of the detail texture, metres (> 0); each further octave halves it.
  double detail_wavelength_m = 1.0;
  /// Octaves of the detail texture, in [0, 8] (0 = none).
  int detail_octaves = 3;
  /// Two neighbouring coarse hits further apart than this many coarse ground sampling distances
  /// mark a depth edge (a wall, a crown): the nearest hit is used there instead of interpolating
  /// between the roof and the ground. > 1.
  double edge_jump = 3.0;
  /// Rows produced per band (a multiple of 8, so that JPEG blocks align across bands), >= 8.
  int band_rows = 256;
  /// Worker threads, 0 = all cores. Results do not depend on it.
  std::size_t threads = 0;

  void check() const {
    DIACHRON_CHECK(scale >= 1.0 && scale <= 100.0, "FullSizeScanOptions::scale must be in [1, 100], got " << scale);
    DIACHRON_CHECK(detail_amplitude >= 0.0 && detail_amplitude <= 1.0,
                   "FullSizeScanOptions::detail_amplitude must be in [0, 1]");
    DIACHRON_CHECK(detail_wavelength_m > 0.0 && std::isfinite(detail_wavelength_m),
                   "FullSizeScanOptions::detail_wavelength_m must be > 0");
    DIACHRON_CHECK(detail_octaves >= 0 && detail_octaves <= 8, "FullSizeScanOptions::detail_octaves must be in [0, 8]");
    DIACHRON_CHECK(edge_jump > 1.0 && std::isfinite(edge_jump), "FullSizeScanOptions::edge_jump must be > 1");
    DIACHRON_CHECK(band_rows >= 8 && band_rows % 8 == 0 && band_rows <= 65536,
                   "FullSizeScanOptions::band_rows must be a multiple of 8 in [8, 65536], got " << band_rows);
  }
};

/// `camera` seeing the same rays on a grid `k` times finer: pixel p becomes k (p + 0.5) - 0.5
/// (docs/conventions.md: pixel centres), so f, the principal point, B1, B2 and the size scale and K,
/// P (normalised coordinates) stay. Throws diachron::Error unless k > 0 and k times the size is whole.
inline Camera<FraserAffine> scale_camera(const Camera<FraserAffine>& camera, double k) {
  DIACHRON_CHECK(k > 0.0 && std::isfinite(k), "scale_camera: the factor must be > 0, got " << k);
  const double w = k * camera.width(), h = k * camera.height();
  DIACHRON_CHECK(std::abs(w - std::round(w)) < 1e-9 * w && std::abs(h - std::round(h)) < 1e-9 * h && w >= 1.0 && h >= 1.0,
                 "scale_camera: " << camera.width() << " x " << camera.height() << " px times " << k
                                  << " is not a whole number of pixels");
  Camera<FraserAffine>::Params p = camera.params();
  p[5] *= k;
  p[6] *= k;
  return Camera<FraserAffine>(k * camera.focal(), k * (camera.cx() + 0.5) - 0.5, k * (camera.cy() + 0.5) - 0.5,
                              static_cast<int>(std::lround(w)), static_cast<int>(std::lround(h)), p);
}

/// Delivers every photo epoch of `scene` (generated at its coarse size) `k` times larger: true and
/// estimated cameras (scale_camera), the GSD, the check points' pixels, and the tie points'
/// observations, whose noise stays as drawn in pixels of the written images (each observation is the
/// scaled true projection plus its coarse noise). Poses, DSMs, Helmerts and 3D positions do not
/// change: the estimated poses fit the scaled projections as they fitted the coarse ones. The
/// images' `pixels` stay the coarse render (a preview; FullSizeEpochRenderer makes the written
/// ones). Orthophoto epochs are left alone. Throws diachron::Error when a camera does not scale to
/// whole pixels (scale_camera).
inline void scale_scene_images(Scene& scene, double k) {
  DIACHRON_CHECK(k >= 1.0 && k <= 100.0, "scale_scene_images: the factor must be in [1, 100], got " << k);
  const auto scaled = [k](const Vec2& p) -> Vec2 { return k * (p + Vec2(0.5, 0.5)) - Vec2(0.5, 0.5); };
  for (std::size_t e = 0; e < scene.epochs.size(); ++e) {
    SyntheticEpoch& epoch = scene.epochs[e];
    if (epoch.orthophoto) continue;
    const Camera<FraserAffine> camera = scale_camera(epoch.camera, k);
    const Camera<FraserAffine> estimated = scale_camera(epoch.estimated_camera, k);
    for (TiePoint& tie : epoch.tie_points)
      for (ImageObservation& ob : tie.observations) {
        const std::optional<Vec2> truth = epoch.world_frame(static_cast<std::size_t>(ob.image)).project(tie.world);
        const Vec2 noise = truth ? Vec2(ob.pixel - *truth) : Vec2::Zero();
        ob.pixel = truth ? Vec2(scaled(*truth) + noise) : scaled(ob.pixel);
      }
    epoch.camera = camera;
    epoch.estimated_camera = estimated;
    epoch.gsd_m /= k;
  }
  for (CheckPoint& cp : scene.check_points)
    for (CheckPoint::Observation& ob : cp.observations)
      if (!scene.epochs.at(static_cast<std::size_t>(ob.epoch)).orthophoto) ob.pixel = scaled(ob.pixel);
}

/// Makes the full-size images of one epoch of a scene that scale_scene_images() scaled by
/// `options.scale`: per image, the ground position of each coarse pixel's ray hit (the coarse
/// camera is the scaled one shrunk back), interpolated bilinearly to each full-size pixel (nearest
/// at depth edges, `edge_jump`; background where the rays miss); there the epoch's albedo times
/// (1 + detail_amplitude * detail texture) times the sun shading; then the film look of `look` in
/// written pixels: blur, gain, offset, contrast, uneven exposure, S curve, gamma, vignetting,
/// grain (clumped as in develop_image), scanner lines and stripes, then scratches and dust, which
/// are marks on the film and so keep their count per image and grow with the scale; JPEG last.
/// Images come band by band, so one image is never held as floats.
/// Determinism: a function of the scene, the options and the seed; not of `threads` nor of
/// `band_rows`. Keeps references to `scene`, which must outlive it; const members may be called
/// from several threads.
class FullSizeEpochRenderer {
 public:
  /// Precondition: `epoch` is a photo epoch of `scene` whose cameras are `options.scale` times the
  /// rendered ones; `look` is that epoch's (EpochOptions::look). Computes the epoch's shading map
  /// (one shadow ray per surface cell with cast shadows).
  FullSizeEpochRenderer(const Scene& scene, std::size_t epoch, const LookOptions& look,
                        const FullSizeScanOptions& options)
      : scene_(&scene), epoch_index_(epoch), look_(look), options_(options) {
    options.check();
    look.check();
    DIACHRON_CHECK(epoch < scene.epochs.size() && !scene.epochs[epoch].orthophoto,
                   "FullSizeEpochRenderer: epoch " << epoch << " is not a photo epoch of the scene");
    const SyntheticEpoch& e = scene.epochs[epoch];
    DIACHRON_CHECK(!e.true_surface.empty() && !e.albedo.values.empty(),
                   "FullSizeEpochRenderer: epoch " << e.name << " has no true surface or albedo");
    coarse_camera_ = scale_camera(e.camera, 1.0 / options.scale);
    tracer_.emplace(e.true_surface);
    shading_ = shading_map(e.true_surface, look, options.threads);
    directions_ = PixelDirections::of(coarse_camera_, options.threads);
    // Tone curve, clamp and gamma as one table of the value after contrast (a smooth function).
    const double k = look.tone_curve;
    const double s_low = 1.0 / (1.0 + std::exp(0.5 * k)), s_high = 1.0 / (1.0 + std::exp(-0.5 * k));
    tone_.resize(kToneSize);
    for (std::size_t j = 0; j < kToneSize; ++j) {
      double v = kToneLow + (kToneHigh - kToneLow) * static_cast<double>(j) / (kToneSize - 1);
      if (k > 0.0) v = (1.0 / (1.0 + std::exp(-k * (v - 0.5))) - s_low) / (s_high - s_low);
      tone_[j] = static_cast<float>(std::pow(std::clamp(v, 0.0, 1.0), 1.0 / look.gamma));
    }
  }

  /// Width and height of the written images, pixels.
  int width() const { return scene_->epochs[epoch_index_].camera.width(); }
  int height() const { return scene_->epochs[epoch_index_].camera.height(); }

  /// Renders image `image` of the epoch band by band, top to bottom: `sink(first_row, band)` gets
  /// each band (width() wide, at most band_rows rows) as a `const Raster<std::uint8_t>&`.
  template <class Sink>
  void render(std::size_t image, Sink&& sink) const;

  /// The whole image at once (tests and small scales).
  Raster<std::uint8_t> render(std::size_t image) const {
    Raster<std::uint8_t> out(width(), height());
    render(image, [&](int first_row, const Raster<std::uint8_t>& band) {
      for (int y = 0; y < band.height(); ++y)
        for (int x = 0; x < band.width(); ++x) out(x, first_row + y) = band(x, y);
    });
    return out;
  }

  /// The ground positions (world X, Y) that full-size pixels `pixels` of image `image` show, as the
  /// renderer interpolates them; nullopt where it draws the background. For tests: what a check
  /// point's pixel shows.
  std::vector<std::optional<Vec2>> ground_positions(std::size_t image, const std::vector<Vec2>& pixels) const {
    const GroundGrid grid = ground_grid(image);
    std::vector<std::optional<Vec2>> out;
    out.reserve(pixels.size());
    for (const Vec2& p : pixels) out.push_back(interpolate(grid, p));
    return out;
  }

 private:
  static constexpr std::size_t kToneSize = 1 << 14;
  static constexpr double kToneLow = -2.0, kToneHigh = 3.0;

  // Ray hits of every coarse pixel (world X, Y; NaN where the ray misses).
  struct GroundGrid {
    int width = 0, height = 0;
    std::vector<Vec2> xy;
    const Vec2& at(int x, int y) const { return xy[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)]; }
  };

  GroundGrid ground_grid(std::size_t image) const {
    const SyntheticEpoch& e = scene_->epochs[epoch_index_];
    const Pose& pose = e.images.at(image).pose_world;
    GroundGrid grid;
    grid.width = coarse_camera_.width();
    grid.height = coarse_camera_.height();
    grid.xy.assign(static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height),
                   Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
    parallel_for(static_cast<std::size_t>(grid.height), options_.threads, [&](std::size_t row) {
      for (int x = 0; x < grid.width; ++x) {
        const std::size_t at = row * static_cast<std::size_t>(grid.width) + static_cast<std::size_t>(x);
        const Vec3& d = directions_.directions[at];
        if (!d.allFinite()) continue;
        if (const std::optional<Vec3> hit =
                tracer_->intersect(Ray3{pose.centre(), pose.world_direction_from_cam(d)}, kRenderToleranceCells))
          grid.xy[at] = hit->head<2>();
      }
    });
    return grid;
  }

  // The ground position of full-size pixel `p`: bilinear (extrapolated linearly at the border) in
  // the coarse grid, the nearest hit across a depth edge or next to a miss.
  std::optional<Vec2> interpolate(const GroundGrid& grid, const Vec2& p) const {
    const double k = options_.scale;
    const double cx = (p.x() + 0.5) / k - 0.5, cy = (p.y() + 0.5) / k - 0.5;
    const int x0 = std::clamp(static_cast<int>(std::floor(cx)), 0, std::max(grid.width - 2, 0));
    const int y0 = std::clamp(static_cast<int>(std::floor(cy)), 0, std::max(grid.height - 2, 0));
    const int x1 = std::min(x0 + 1, grid.width - 1), y1 = std::min(y0 + 1, grid.height - 1);
    const double tx = cx - x0, ty = cy - y0;
    const Vec2& a = grid.at(x0, y0);
    const Vec2& b = grid.at(x1, y0);
    const Vec2& c = grid.at(x0, y1);
    const Vec2& d = grid.at(x1, y1);
    const double limit = options_.edge_jump * coarse_gsd(), limit2 = limit * limit;
    const bool valid = a.allFinite() && b.allFinite() && c.allFinite() && d.allFinite();
    if (valid && (a - b).squaredNorm() <= limit2 && (a - c).squaredNorm() <= limit2 && (b - d).squaredNorm() <= limit2 &&
        (c - d).squaredNorm() <= limit2) {
      const Vec2 top = a + tx * (b - a), bottom = c + tx * (d - c);
      return top + ty * (bottom - top);
    }
    const Vec2& nearest = grid.at(std::clamp(static_cast<int>(std::lround(cx)), 0, grid.width - 1),
                                  std::clamp(static_cast<int>(std::lround(cy)), 0, grid.height - 1));
    if (!nearest.allFinite()) return std::nullopt;
    return nearest;
  }

  double coarse_gsd() const { return scene_->epochs[epoch_index_].gsd_m * options_.scale; }

  std::uint64_t stream(std::size_t image) const {
    return detail::mix64(detail::stream_id(detail::SynthStream::full_size, epoch_index_, image));
  }

  // Separable Gaussian kernel of `sigma` (normalised to sum 1); empty for sigma <= 0.
  static std::vector<float> gaussian(double sigma) {
    if (sigma <= 0.0) return {};
    const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
    std::vector<float> kernel(static_cast<std::size_t>(2 * radius + 1));
    double sum = 0.0;
    for (int j = -radius; j <= radius; ++j) sum += std::exp(-0.5 * j * j / (sigma * sigma));
    for (int j = -radius; j <= radius; ++j)
      kernel[static_cast<std::size_t>(j + radius)] = static_cast<float>(std::exp(-0.5 * j * j / (sigma * sigma)) / sum);
    return kernel;
  }

  // Rows [row0, row0 + rows.height()) of a w-wide image, blurred along x in place (clamped edges).
  static void blur_rows(Raster<float>& rows, const std::vector<float>& kernel, std::size_t threads) {
    if (kernel.empty()) return;
    const int radius = static_cast<int>(kernel.size() / 2), w = rows.width();
    parallel_for(static_cast<std::size_t>(rows.height()), threads, [&](std::size_t r) {
      const int y = static_cast<int>(r);
      std::vector<float> line(static_cast<std::size_t>(w));
      for (int x = 0; x < w; ++x) {
        float acc = 0.0f;
        for (int j = -radius; j <= radius; ++j) acc += kernel[static_cast<std::size_t>(j + radius)] * rows(std::clamp(x + j, 0, w - 1), y);
        line[static_cast<std::size_t>(x)] = acc;
      }
      for (int x = 0; x < w; ++x) rows(x, y) = line[static_cast<std::size_t>(x)];
    });
  }

  // Value at band row y (image row y0 + y) of the vertical blur of `rows`, which hold image rows
  // [first, first + rows.height()) (all the kernel needs, clamped at the image's edges).
  static float blur_column(const Raster<float>& rows, int first, int image_height, const std::vector<float>& kernel,
                           int x, int y) {
    if (kernel.empty()) return rows(x, y - first);
    const int radius = static_cast<int>(kernel.size() / 2);
    float acc = 0.0f;
    for (int j = -radius; j <= radius; ++j)
      acc += kernel[static_cast<std::size_t>(j + radius)] * rows(x, std::clamp(y + j, 0, image_height - 1) - first);
    return acc;
  }

  const Scene* scene_;
  std::size_t epoch_index_;
  LookOptions look_;
  FullSizeScanOptions options_;
  Camera<FraserAffine> coarse_camera_{1.0, 0.0, 0.0, 1, 1};
  std::optional<detail::SurfaceTracer> tracer_;
  AlbedoMap shading_;
  PixelDirections directions_;
  std::vector<float> tone_;
};

// Implementation

template <class Sink>
void FullSizeEpochRenderer::render(std::size_t image, Sink&& sink) const {
  const SyntheticEpoch& e = scene_->epochs[epoch_index_];
  DIACHRON_CHECK(image < e.images.size(), "FullSizeEpochRenderer: epoch " << e.name << " has no image " << image);
  const LookOptions& look = look_;
  const std::size_t threads = options_.threads;
  const int w = width(), h = height();
  const double k = options_.scale;
  const std::uint64_t seed = scene_->seed;
  const std::uint64_t s = stream(image);
  const GroundGrid grid = ground_grid(image);
  const std::uint64_t detail_seed = detail::mix64(seed ^ 0x44455441494cULL);  // one texture for every epoch

  // The film's blur and grain clumps, in written pixels; clumped grain normalised analytically to
  // unit standard deviation (blurred white noise: the sum of the squared 2D kernel).
  const std::vector<float> blur = gaussian(look.blur_sigma_px);
  const bool clumped = look.grain_sigma > 0.0 && look.grain_size_px > 0.0;
  const std::vector<float> clump = clumped ? gaussian(look.grain_size_px) : std::vector<float>{};
  double clump_norm = 1.0;
  if (clumped) {
    double sum2 = 0.0;
    for (float v : clump) sum2 += static_cast<double>(v) * v;
    clump_norm = 1.0 / sum2;  // 1 / sqrt(sum2^2): separable, the 2D sum of squares is sum2^2
  }
  const int blur_radius = static_cast<int>(blur.size() / 2), clump_radius = static_cast<int>(clump.size() / 2);

  // Uneven exposure on a grid every 16 px (its wavelength is thousands of pixels), bilinear.
  constexpr int kStep = 16;
  const int gw = w / kStep + 2, gh = h / kStep + 2;
  std::vector<float> uneven;
  if (look.exposure_unevenness > 0.0) {
    uneven.resize(static_cast<std::size_t>(gw) * static_cast<std::size_t>(gh));
    const std::uint64_t uneven_seed = detail::mix64(s ^ 0x554e4556454eULL);
    const double wavelength = look.unevenness_wavelength * std::max(w, 1);
    parallel_for(static_cast<std::size_t>(gh), threads, [&](std::size_t gy) {
      for (int gx = 0; gx < gw; ++gx)
        uneven[gy * static_cast<std::size_t>(gw) + static_cast<std::size_t>(gx)] = static_cast<float>(
            1.0 + look.exposure_unevenness * detail::fbm(uneven_seed, gx * kStep, static_cast<double>(gy) * kStep, wavelength, 2));
    });
  }

  // Marks on the film, drawn once per image in a fixed order: row offsets, stripes, scratches, dust.
  std::vector<float> row_offset(static_cast<std::size_t>(h), 0.0f);
  if (look.scan_line_sigma > 0.0 || look.scan_stripes > 0) {
    RandomStream random(seed, s ^ 0x5343414eULL);
    for (float& o : row_offset) o = static_cast<float>(look.scan_line_sigma * random.normal());
    for (int st = 0; st < look.scan_stripes; ++st) {
      const auto first = static_cast<int>(random.uniform_index(static_cast<std::size_t>(h)));
      const int rows = 1 + static_cast<int>(random.uniform_index(static_cast<std::size_t>(std::max(1.0, 3.0 * k))));
      const double sign = random.uniform01() < 0.5 ? 1.0 : -1.0;
      const double strength = sign * random.uniform(0.04, 0.12);
      for (int y = first; y < std::min(h, first + rows); ++y) row_offset[static_cast<std::size_t>(y)] += static_cast<float>(strength);
    }
  }
  struct Scratch {
    Vec2 p, n;
    double strength, half_width;
  };
  struct Speck {
    Vec2 c;
    double radius, strength;
  };
  std::vector<Scratch> scratches;
  std::vector<Speck> specks;
  {
    RandomStream random(seed, s ^ 0x5343524154ULL);
    for (int st = 0; st < look.scratches; ++st) {
      const double py = random.uniform(0.0, h), px = random.uniform(0.0, w);  // y first ("Order of draws")
      const double angle = 0.5 * kPi + random.normal(0.0, 0.08);
      const double sign = random.uniform01() < 0.7 ? 1.0 : -1.0;
      const double strength = sign * random.uniform(0.15, 0.45);
      const double half_width = k * random.uniform(0.4, 1.2);
      scratches.push_back({Vec2(px, py), Vec2(-std::sin(angle), std::cos(angle)), strength, half_width});
    }
    // As many specks per image as the coarse render had: dust sits on the film, not per pixel.
    const auto count = static_cast<int>(std::llround(look.dust_per_megapixel * w * h * 1e-6 / (k * k)));
    for (int st = 0; st < count; ++st) {
      const double cy = random.uniform(0.0, h), cx = random.uniform(0.0, w);
      const double radius = k * random.uniform(0.6, 2.5);
      const double sign = random.uniform01() < 0.5 ? 1.0 : -1.0;
      const double strength = sign * random.uniform(0.2, 0.5);
      specks.push_back({Vec2(cx, cy), radius, strength});
    }
  }

  const double half_diagonal = std::max(0.5 * std::hypot(w - 1.0, h - 1.0), 1.0);
  const SyntheticEpoch& ep = e;
  const auto radiance = [&](const Vec2& pixel) -> float {
    const std::optional<Vec2> xy = interpolate(grid, pixel);
    if (!xy) return static_cast<float>(look.background);
    double albedo = ep.albedo.sample(*xy);
    if (options_.detail_octaves > 0 && options_.detail_amplitude > 0.0)
      albedo *= 1.0 + options_.detail_amplitude *
                          detail::fbm(detail_seed, xy->x(), xy->y(), options_.detail_wavelength_m, options_.detail_octaves, 0.7);
    return static_cast<float>(albedo * shading_.sample(*xy));
  };

  Raster<float> rad, noise, tone_rows;
  Raster<std::uint8_t> band;
  for (int y0 = 0; y0 < h; y0 += options_.band_rows) {
    const int y1 = std::min(h, y0 + options_.band_rows), rows = y1 - y0;
    // Radiance of the band and the blur's halo, blurred along x.
    const int r0 = std::max(0, y0 - blur_radius), r1 = std::min(h, y1 + blur_radius);
    rad.resize(w, r1 - r0);
    parallel_for(static_cast<std::size_t>(r1 - r0), threads, [&](std::size_t r) {
      const int y = r0 + static_cast<int>(r);
      for (int x = 0; x < w; ++x) rad(x, static_cast<int>(r)) = radiance(Vec2(x, y));
    });
    blur_rows(rad, blur, threads);
    // Clumped grain: white noise per image row (its own stream), blurred; same for any banding.
    const int n0 = std::max(0, y0 - clump_radius), n1 = std::min(h, y1 + clump_radius);
    if (clumped) {
      noise.resize(w, n1 - n0);
      parallel_for(static_cast<std::size_t>(n1 - n0), threads, [&](std::size_t r) {
        const auto y = static_cast<std::uint64_t>(n0) + r;
        RandomStream random(seed, s ^ (0x434c554dULL + (y << 20)));
        for (int x = 0; x < w; ++x) noise(x, static_cast<int>(r)) = static_cast<float>(random.normal());
      });
      blur_rows(noise, clump, threads);
    }
    // Film response, vignetting, grain and scanner lines, per pixel.
    tone_rows.resize(w, rows);
    parallel_for(static_cast<std::size_t>(rows), threads, [&](std::size_t r) {
      const int y = y0 + static_cast<int>(r);
      RandomStream grain(seed, s ^ (0x4752414eULL + static_cast<std::uint64_t>(y)));
      const double gy = static_cast<double>(y) / kStep;
      const int gy0 = std::min(static_cast<int>(gy), gh - 2);
      const double ty = gy - gy0;
      for (int x = 0; x < w; ++x) {
        double v = look.offset + look.gain * blur_column(rad, r0, h, blur, x, y);
        if (!uneven.empty()) {
          const double gx = static_cast<double>(x) / kStep;
          const int gx0 = std::min(static_cast<int>(gx), gw - 2);
          const double tx = gx - gx0;
          const float* u0 = &uneven[static_cast<std::size_t>(gy0) * static_cast<std::size_t>(gw) + static_cast<std::size_t>(gx0)];
          const float* u1 = u0 + gw;
          v *= (1.0 - ty) * ((1.0 - tx) * u0[0] + tx * u0[1]) + ty * ((1.0 - tx) * u1[0] + tx * u1[1]);
        }
        v = 0.5 + look.contrast * (v - 0.5);
        const double at = std::clamp((v - kToneLow) / (kToneHigh - kToneLow) * (kToneSize - 1), 0.0, kToneSize - 1.0);
        const auto j = std::min(static_cast<std::size_t>(at), kToneSize - 2);
        const double f = at - static_cast<double>(j);
        v = tone_[j] + f * (tone_[j + 1] - tone_[j]);
        const double dx = x - 0.5 * (w - 1), dy = y - 0.5 * (h - 1);
        v *= 1.0 - look.vignetting * (dx * dx + dy * dy) / (half_diagonal * half_diagonal);
        if (look.grain_sigma > 0.0)
          v += look.grain_sigma * (clumped ? clump_norm * blur_column(noise, n0, h, clump, x, y) : grain.normal());
        tone_rows(x, static_cast<int>(r)) = static_cast<float>(v + row_offset[static_cast<std::size_t>(y)]);
      }
    });
    // Scratches (nearly along y: the pixels within reach of the line on each row) and dust.
    for (const Scratch& sc : scratches) {
      const double reach = sc.half_width + 1.0;
      for (int y = y0; y < y1; ++y) {
        int xa = 0, xb = w - 1;
        if (std::abs(sc.n.x()) > 1e-3) {
          const double xc = sc.p.x() - (y - sc.p.y()) * sc.n.y() / sc.n.x();
          const double dx = reach / std::abs(sc.n.x());
          xa = std::max(0, static_cast<int>(std::floor(xc - dx)));
          xb = std::min(w - 1, static_cast<int>(std::ceil(xc + dx)));
        }
        for (int x = xa; x <= xb; ++x) {
          const double dist = std::abs((Vec2(x, y) - sc.p).dot(sc.n));
          if (dist < reach) tone_rows(x, y - y0) += static_cast<float>(sc.strength * (1.0 - dist / reach));
        }
      }
    }
    for (const Speck& sp : specks) {
      const int ya = std::max(y0, static_cast<int>(sp.c.y() - sp.radius - 1));
      const int yb = std::min(y1 - 1, static_cast<int>(sp.c.y() + sp.radius + 1));
      for (int y = ya; y <= yb; ++y)
        for (int x = std::max(0, static_cast<int>(sp.c.x() - sp.radius - 1)); x <= std::min(w - 1, static_cast<int>(sp.c.x() + sp.radius + 1)); ++x)
          if ((Vec2(x, y) - sp.c).norm() <= sp.radius) tone_rows(x, y - y0) += static_cast<float>(sp.strength);
    }
    band.resize(w, rows);
    parallel_for(static_cast<std::size_t>(rows), threads, [&](std::size_t r) {
      const int y = static_cast<int>(r);
      for (int x = 0; x < w; ++x)
        band(x, y) = static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(static_cast<double>(tone_rows(x, y)), 0.0, 1.0)));
    });
    if (look.jpeg_quality > 0) band = jpeg_like_compress(band, look.jpeg_quality, threads);
    sink(y0, static_cast<const Raster<std::uint8_t>&>(band));
  }
}

}  // namespace diachron
