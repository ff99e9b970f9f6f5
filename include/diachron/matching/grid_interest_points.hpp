#pragma once
/// @file
/// Evenly spread, well-textured interest points for correlation matching: the pixel with the
/// strongest smallest eigenvalue of the structure tensor (Shi-Tomasi / Foerstner's "weight") in
/// each cell of a regular grid. A correlation window centred there has gradients in two
/// directions, so its correlation surface has a peak rather than a ridge. Eigen and std only.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>

namespace diachron {

/// Options of grid_interest_points().
struct GridInterestOptions {
  /// Side of the square grid cells, pixels (>= 2). One point at most per cell: 32 px gives about
  /// 1900 candidates on a 1600 x 1200 image.
  int cell_px = 32;
  /// Side of the square window the structure tensor sums over, pixels (odd, >= 3). It should be
  /// about the correlation window: the point is textured where the correlation looks. 21 is
  /// CorrelationMatchOptions::window_px, so that the margin below is the correlation's too: every
  /// default grid point's correlation window lies inside the image (none is outside_master).
  int window_px = 21;
  /// Points closer than this to the image edge are not taken, pixels (>= 0). The window itself
  /// always stays inside: the margin is max(border_px, window_px / 2 + 1), the correlation
  /// window's for a correlation window of window_px.
  int border_px = 0;
  /// A point is kept when its smallest eigenvalue, per window pixel, is at least this
  /// (grey levels^2 per pixel^2 of central-difference gradients, >= 0). 4 means an isotropic
  /// gradient of about 2 grey levels per pixel: below, 8-bit film grain dominates.
  double min_strength = 4.0;

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    DIACHRON_CHECK(cell_px >= 2, "GridInterestOptions::cell_px must be >= 2, got " << cell_px);
    DIACHRON_CHECK(window_px >= 3 && window_px % 2 == 1,
                   "GridInterestOptions::window_px must be odd and >= 3, got " << window_px);
    DIACHRON_CHECK(border_px >= 0, "GridInterestOptions::border_px must be >= 0, got " << border_px);
    DIACHRON_CHECK(std::isfinite(min_strength) && min_strength >= 0.0,
                   "GridInterestOptions::min_strength must be finite and >= 0, got " << min_strength);
  }
};

/// One interest point: an integer pixel centre (docs/conventions.md) and its strength (smallest
/// structure-tensor eigenvalue per window pixel, the units of GridInterestOptions::min_strength).
struct InterestPoint {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double strength = 0.0;
};

/// The strongest point of each grid cell (cells in row-major order, empty cells skipped), so the
/// result is deterministic and spread over the image. Non-finite pixels make their windows weak
/// (they are skipped). An image too small for one window gives an empty list. `allowed_centres`,
/// when given, is a raster of the image's size where 0 forbids a point there (an ImageMask eroded
/// by the window that will be correlated, matching/image_mask.hpp): each cell then gets its
/// strongest allowed point, not none because its strongest pixel is masked.
/// @throws diachron::Error for invalid options or an allowed_centres raster of another size.
template <class T>
std::vector<InterestPoint> grid_interest_points(const Raster<T>& image, const GridInterestOptions& options = {},
                                                const Raster<std::uint8_t>* allowed_centres = nullptr) {
  static_assert(std::is_arithmetic_v<T>, "grid_interest_points: the pixel type must be arithmetic");
  options.check();
  DIACHRON_CHECK(allowed_centres == nullptr ||
                     (allowed_centres->width() == image.width() && allowed_centres->height() == image.height()),
                 "grid_interest_points: allowed_centres is " << allowed_centres->width() << " x "
                                                             << allowed_centres->height() << ", the image "
                                                             << image.width() << " x " << image.height());
  const int w = image.width(), h = image.height();
  const int half = options.window_px / 2;
  const int margin = std::max(options.border_px, half + 1);
  std::vector<InterestPoint> out;
  if (w < 2 * margin + 1 || h < 2 * margin + 1) return out;

  // Structure tensor products of central-difference gradients, as integral images (one row and
  // column of zeros in front) so every window sum costs four look-ups. One band of image rows per
  // row of cells (the cells' rows and half a window around them), not the whole image: three
  // integral images of doubles cost 24 bytes per pixel, 3.5 GB for a 12000 x 12000 archive scan,
  // while a band costs 24 bytes per pixel of (cell + window) rows. For 8-bit images every sum is
  // a multiple of 1/4 far below 2^53, so the band sums equal the whole-image ones exactly.
  const int iw = w + 1;
  const int band_rows = options.cell_px + 2 * half;
  std::vector<double> sxx(static_cast<std::size_t>(iw) * static_cast<std::size_t>(band_rows + 1), 0.0),
      syy(sxx.size(), 0.0), sxy(sxx.size(), 0.0);
  int band_top = 0;  // image row of the band's first row
  auto at = [iw](std::vector<double>& v, int x, int row) -> double& {
    return v[static_cast<std::size_t>(row) * static_cast<std::size_t>(iw) + static_cast<std::size_t>(x)];
  };
  auto fill_band = [&](int top, int rows) {
    band_top = top;
    for (int r = 0; r < rows; ++r) {
      const int y = top + r;
      double rxx = 0.0, ryy = 0.0, rxy = 0.0;
      for (int x = 0; x < w; ++x) {
        double gx = 0.0, gy = 0.0;
        if (x > 0 && x < w - 1 && y > 0 && y < h - 1) {
          gx = 0.5 * (static_cast<double>(image(x + 1, y)) - static_cast<double>(image(x - 1, y)));
          gy = 0.5 * (static_cast<double>(image(x, y + 1)) - static_cast<double>(image(x, y - 1)));
          if (!std::isfinite(gx) || !std::isfinite(gy)) gx = gy = 0.0;
        }
        rxx += gx * gx;
        ryy += gy * gy;
        rxy += gx * gy;
        at(sxx, x + 1, r + 1) = at(sxx, x + 1, r) + rxx;
        at(syy, x + 1, r + 1) = at(syy, x + 1, r) + ryy;
        at(sxy, x + 1, r + 1) = at(sxy, x + 1, r) + rxy;
      }
    }
  };
  auto box = [&](std::vector<double>& v, int x, int y) {
    const int r = y - band_top;
    return at(v, x + half + 1, r + half + 1) - at(v, x - half, r + half + 1) - at(v, x + half + 1, r - half) +
           at(v, x - half, r - half);
  };
  const double area = static_cast<double>(options.window_px) * options.window_px;
  for (int cy = 0; cy * options.cell_px < h; ++cy) {
    const int y_begin = std::max(margin, cy * options.cell_px);
    const int y_end = std::min(h - margin, (cy + 1) * options.cell_px);
    if (y_begin >= y_end) continue;
    // Rows y_begin - half .. y_end - 1 + half, inside the image since margin > half.
    fill_band(y_begin - half, y_end - y_begin + 2 * half);
    for (int cx = 0; cx * options.cell_px < w; ++cx) {
      InterestPoint best;
      best.strength = -1.0;
      const int x_end = std::min(w - margin, (cx + 1) * options.cell_px);
      for (int y = y_begin; y < y_end; ++y) {
        for (int x = std::max(margin, cx * options.cell_px); x < x_end; ++x) {
          if (allowed_centres && (*allowed_centres)(x, y) == 0) continue;
          const double a = box(sxx, x, y) / area, c = box(syy, x, y) / area, b = box(sxy, x, y) / area;
          const double lambda_min = 0.5 * (a + c) - std::sqrt(0.25 * (a - c) * (a - c) + b * b);
          if (lambda_min > best.strength) {
            best.strength = lambda_min;
            best.position = Eigen::Vector2d(x, y);
          }
        }
      }
      if (best.strength >= options.min_strength) out.push_back(best);
    }
  }
  return out;
}

}  // namespace diachron
