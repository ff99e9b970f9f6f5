#pragma once
/// @file
/// distortion_difference(): how far apart two cameras' distortions are over the image, in pixels,
/// apart from their focal lengths and principal points (the "distortion recovered within 0.5 px"
/// of a self-calibration).
///
/// A camera moves the pixel of a ray with ideal normalised coordinates x by its distortion:
///   d(p) = p - c - f x(p),   x(p) = the ray of pixel p (Camera::normalized_from_pixel),
/// with c the principal point and f the focal length. Comparing d of two cameras at the same pixels
/// compares what each distortion (radial, decentring and affine part together) does there, whatever
/// the focal lengths and principal points: those are reported apart.

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <diachron/camera/camera.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// Options of distortion_difference().
struct DistortionDifferenceOptions {
  /// Sample pixels per image side: a grid of samples x samples pixels from corner to corner. >= 2.
  int samples = 17;
};

/// The distortion difference of two cameras over the image. Default: nothing measured.
struct DistortionDifference {
  bool valid = false;     ///< false when no pixel could be unprojected by both cameras
  double max_px = std::numeric_limits<double>::infinity();   ///< largest |d_a(p) - d_b(p)|, px
  double rms_px = std::numeric_limits<double>::infinity();   ///< RMS over the samples, px
  int samples = 0;        ///< pixels both cameras unprojected
  int failed = 0;         ///< pixels one of them could not unproject (beyond a fold)
};

/// Compares the distortions of `a` and `b` at the given pixels of their images, e.g. where an
/// adjustment had observations: what the data determined, without the extrapolation to image corners
/// no observation reached. Precondition: both cameras of the same image size, else throws
/// diachron::Error. No pixels: nothing measured (valid == false).
template <class DistortionA, class DistortionB>
DistortionDifference distortion_difference_at(const Camera<DistortionA>& a, const Camera<DistortionB>& b,
                                              const std::vector<Vec2>& pixels) {
  DIACHRON_CHECK(a.width() == b.width() && a.height() == b.height(),
                 "distortion_difference: image sizes differ, " << a.width() << " x " << a.height() << " and "
                                                               << b.width() << " x " << b.height());
  DistortionDifference out;
  double sum = 0.0, worst = 0.0;
  for (const Vec2& pixel : pixels) {
    DIACHRON_CHECK(pixel.allFinite(), "distortion_difference_at: a pixel is not finite");
    const std::optional<Vec2> xa = a.normalized_from_pixel(pixel), xb = b.normalized_from_pixel(pixel);
    if (!xa || !xb) {
      ++out.failed;
      continue;
    }
    const Vec2 da = pixel - a.principal_point() - a.focal() * *xa;
    const Vec2 db = pixel - b.principal_point() - b.focal() * *xb;
    const double e = (da - db).norm();
    worst = std::max(worst, e);
    sum += e * e;
    ++out.samples;
  }
  if (out.samples == 0) return out;
  out.valid = true;
  out.max_px = worst;
  out.rms_px = std::sqrt(sum / out.samples);
  return out;
}

/// Compares the distortions of `a` and `b` on a grid over `a`'s image (corners included).
/// Precondition: both cameras of the same image size, else throws diachron::Error.
template <class DistortionA, class DistortionB>
DistortionDifference distortion_difference(const Camera<DistortionA>& a, const Camera<DistortionB>& b,
                                           const DistortionDifferenceOptions& options = {}) {
  DIACHRON_CHECK(options.samples >= 2, "DistortionDifferenceOptions::samples must be >= 2, got " << options.samples);
  std::vector<Vec2> grid;
  const int n = options.samples;
  grid.reserve(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      // Pixel centres of the corner pixels and an even grid between them.
      grid.emplace_back((a.width() - 1) * static_cast<double>(i) / (n - 1), (a.height() - 1) * static_cast<double>(j) / (n - 1));
  return distortion_difference_at(a, b, grid);
}

}  // namespace diachron
