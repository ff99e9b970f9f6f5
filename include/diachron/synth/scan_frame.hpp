#pragma once
/// @file
/// What a scanned archive photograph holds besides the ground: the film's frame. A dark band along
/// the image's edges with bright fiducial marks (a cross in a ring at the corners and the middle of
/// each side) and, on one side, a data strip of bright glyphs (the clock, the altimeter, the frame
/// number). Drawn over a synthetic image, it gives the strongest edges of the image to things that
/// are not on the ground, as a scan that was not cropped does; the mask it returns is what a user
/// hands over with such scans (matching/image_mask.hpp: 0 on the frame). Std only.

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>

namespace diachron {

/// Options of draw_scan_frame().
struct ScanFrameOptions {
  /// Width of the frame's band along every edge, pixels (>= 0; 0: no frame).
  int band_px = 0;
  /// Grey level of the band (the unexposed film's base, dark on a positive scan).
  std::uint8_t band_grey = 18;
  /// Grey level of the fiducial marks and the data strip's glyphs.
  std::uint8_t mark_grey = 235;
  /// Seed of the data strip's glyphs.
  std::uint64_t seed = 0;

  /// Throws diachron::Error naming the first invalid field.
  void check() const { DIACHRON_CHECK(band_px >= 0, "ScanFrameOptions::band_px must be >= 0, got " << band_px); }
};

/// Draws the frame into `image` (in place) and returns its mask: 0 on the band, 255 inside. A band
/// wider than a third of the image's smaller side is an error: nothing of the ground would be left.
inline Raster<std::uint8_t> draw_scan_frame(Raster<std::uint8_t>& image, const ScanFrameOptions& options) {
  options.check();
  const int w = image.width(), h = image.height(), b = options.band_px;
  DIACHRON_CHECK(3 * b <= std::min(w, h), "draw_scan_frame: a band of " << b << " px leaves nothing of a " << w
                                                                          << " x " << h << " px image");
  Raster<std::uint8_t> mask(w, h, 255);
  if (b == 0) return mask;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (x < b || y < b || x >= w - b || y >= h - b) {
        image(x, y) = options.band_grey;
        mask(x, y) = 0;
      }
  const auto dot = [&](int x, int y) {
    if (image.contains(x, y) && mask(x, y) == 0) image(x, y) = options.mark_grey;
  };
  // Fiducial marks: a cross in a ring, centred in the band, at the corners and the sides' middles.
  const int c = b / 2, r = std::max(2, b / 3);
  for (const int fx : {c, w / 2, w - 1 - c})
    for (const int fy : {c, h / 2, h - 1 - c}) {
      if (fx == w / 2 && fy == h / 2) continue;
      for (int d = -r; d <= r; ++d) {
        dot(fx + d, fy);
        dot(fx, fy + d);
      }
      for (int k = 0; k < 8 * r; ++k) {
        const double a = 2.0 * 3.14159265358979323846 * k / (8.0 * r);
        dot(fx + static_cast<int>(std::lround(r * std::cos(a))), fy + static_cast<int>(std::lround(r * std::sin(a))));
      }
    }
  // The data strip along the bottom band, between the marks: glyphs of 3 x 5 random strokes.
  RandomStream random(options.seed, 0);
  const int glyph_h = std::max(5, b / 3), glyph_w = std::max(3, glyph_h * 3 / 5);
  const int top = h - b + (b - glyph_h) / 2;
  for (int x0 = c + 2 * r + 2; x0 + glyph_w < w / 2 - 2 * r; x0 += glyph_w + 2)
    for (int gy = 0; gy < 5; ++gy)
      for (int gx = 0; gx < 3; ++gx) {
        if (random.uniform01() < 0.5) continue;
        for (int y = top + gy * glyph_h / 5; y < top + (gy + 1) * glyph_h / 5; ++y)
          for (int x = x0 + gx * glyph_w / 3; x < x0 + (gx + 1) * glyph_w / 3; ++x) dot(x, y);
      }
  return mask;
}

}  // namespace diachron
