#pragma once
/// @file
/// DSM -> 8-bit image for rough co-registration (paper 3.2.1): a linear stretch of mean +- k sigma,
/// a Wallis-type local contrast filter following MicMac's recipe, and a hillshade.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of dsm_to_image().
struct DsmImageOptions {
  /// Heights mean - k sigma and mean + k sigma (over valid pixels) map to 0 and 255; beyond, values
  /// are clipped. 2 by default as in the paper ("values beyond 2 sigma are ignored"); MicMac's
  /// DSM_Equalization uses 5 (STDRange).
  double k_sigma = 2.0;
  /// Gray value written at holes. 0 by default.
  std::uint8_t fill = 0;
  /// Also produce the validity mask (255 valid, 0 hole). On by default: the fill value is also a
  /// legitimate gray, so only the mask tells holes apart.
  bool make_mask = true;

  void check() const {
    DIACHRON_CHECK(k_sigma > 0.0 && std::isfinite(k_sigma), "DsmImageOptions::k_sigma must be positive, got " << k_sigma);
  }
};

/// Result of dsm_to_image().
struct DsmImage {
  Raster<std::uint8_t> image;  ///< the stretched heights, `fill` at holes
  Raster<std::uint8_t> mask;   ///< 255 where the DSM is valid, 0 at holes; empty unless make_mask
  double low = 0.0;            ///< height mapped to gray 0 (mean - k sigma), height units
  double high = 0.0;           ///< height mapped to gray 255 (mean + k sigma), height units
  std::size_t valid_count = 0; ///< number of valid pixels the statistics used
};

namespace detail {
inline DsmImage stretch_heights(const Raster<float>& heights, double mean, double sigma, std::size_t count,
                                const DsmImageOptions& options) {
  options.check();
  DsmImage out;
  out.image.resize(heights.width(), heights.height(), options.fill);
  if (options.make_mask) out.mask.resize(heights.width(), heights.height(), 0);
  out.valid_count = count;
  if (count == 0) return out;
  out.low = mean - options.k_sigma * sigma;
  out.high = mean + options.k_sigma * sigma;
  // A constant DSM has no contrast to stretch: mid-gray keeps it apart from a black fill.
  const double scale = out.high > out.low ? 255.0 / (out.high - out.low) : 0.0;
  const std::size_t n = heights.size();
  const float* src = heights.data();
  std::uint8_t* dst = out.image.data();
  std::uint8_t* mask = options.make_mask ? out.mask.data() : nullptr;
  for (std::size_t i = 0; i < n; ++i) {
    const float z = src[i];
    if (!std::isfinite(z)) continue;
    const double g = scale > 0.0 ? (z - out.low) * scale : 127.5;
    dst[i] = static_cast<std::uint8_t>(std::lround(std::clamp(g, 0.0, 255.0)));
    if (mask) mask[i] = 255;
  }
  return out;
}
}  // namespace detail

/// The 8-bit DSM image: gray = round(255 (Z - low) / (high - low)) clipped to [0, 255], with low/high
/// = mean -+ k sigma of the valid heights (holes, NaN or infinite, take no part and get `fill`).
/// A DSM without valid pixels gives an all-fill image (valid_count 0), not an error.
inline DsmImage dsm_to_image(const Raster<float>& heights, const DsmImageOptions& options = {}) {
  double sum = 0.0;
  std::size_t count = 0;
  for (float z : heights)
    if (std::isfinite(z)) {
      sum += z;
      ++count;
    }
  const double mean = count ? sum / static_cast<double>(count) : 0.0;
  double sq = 0.0;
  for (float z : heights)
    if (std::isfinite(z)) sq += (z - mean) * (z - mean);
  const double sigma = count ? std::sqrt(sq / static_cast<double>(count)) : 0.0;
  return detail::stretch_heights(heights, mean, sigma, count, options);
}

/// Same, for a Dsm (reuses its statistics).
inline DsmImage dsm_to_image(const Dsm& dsm, const DsmImageOptions& options = {}) {
  const DsmStatistics& s = dsm.statistics();
  return detail::stretch_heights(dsm.heights(), s.count ? s.mean : 0.0, s.count ? s.std : 0.0, s.count, options);
}

/// Options of wallis_filter(). Defaults reproduce MicMac's Wallis/SFS filter (CPP_Devlop.cpp).
struct WallisOptions {
  /// Half size of the local box, pixels: the box is (2 half_window + 1)^2. 50 (101 x 101) by default.
  int half_window = 50;
  /// Cap on the local term's amplitude, gray levels: amplitude = min(max_amplitude, g, 255 - g)
  /// so that the output stays in [0, 255]. 64 by default.
  double max_amplitude = 64.0;
  /// Weights of the global tone g = (w_eq HistEq + w_lin Linear + w_sqrt SqrtHistEq) / (sum of weights):
  /// histogram equalisation, linear 255 / max, equalisation of the square-rooted histogram.
  /// 1, 2, 3 by default.
  double weight_equalized = 1.0;
  double weight_linear = 2.0;
  double weight_sqrt_equalized = 3.0;
  /// Local standard deviations below this (gray levels) are raised to it. 0 by default, as MicMac;
  /// a value of ~1 stops the filter from blowing up quantisation steps in flat areas (water).
  double min_std = 0.0;
  /// Gray written where the mask marks a hole. 0 by default.
  std::uint8_t fill = 0;

  void check() const {
    DIACHRON_CHECK(half_window >= 1, "WallisOptions::half_window must be >= 1, got " << half_window);
    DIACHRON_CHECK(max_amplitude >= 0.0 && max_amplitude <= 255.0,
                   "WallisOptions::max_amplitude must be in [0, 255], got " << max_amplitude);
    DIACHRON_CHECK(weight_equalized >= 0.0 && weight_linear >= 0.0 && weight_sqrt_equalized >= 0.0 &&
                       weight_equalized + weight_linear + weight_sqrt_equalized > 0.0,
                   "WallisOptions: tone weights must be >= 0 with a positive sum");
    DIACHRON_CHECK(min_std >= 0.0 && std::isfinite(min_std), "WallisOptions::min_std must be >= 0, got " << min_std);
  }
};

/// Wallis-type local contrast filter on an 8-bit raster (MicMac's recipe):
///   g = global tone of I (see WallisOptions),
///   z = (I - local mean) / local std over the box around the pixel (clipped at the borders),
///   out = g + min(max_amplitude, g, 255 - g) * atan(z) / (pi / 2), rounded.
/// Equalisations use mid-rank cumulative histograms (a level's cdf is taken half way through its own
/// count), so a constant image maps to mid-gray rather than to an extreme.
/// `mask` (optional, same size, nonzero = valid) keeps holes out of the histograms and the local
/// statistics, and holes are written as `fill`. Box sums use running column sums and a 1D
/// integral image per row: O(1) per pixel whatever the window, O(width) extra memory.
inline Raster<std::uint8_t> wallis_filter(const Raster<std::uint8_t>& image, const WallisOptions& options = {},
                                          const Raster<std::uint8_t>* mask = nullptr) {
  options.check();
  const int w = image.width(), h = image.height();
  if (mask)
    DIACHRON_CHECK(mask->width() == w && mask->height() == h,
                   "wallis_filter: mask is " << mask->width() << " x " << mask->height() << ", image " << w << " x " << h);
  Raster<std::uint8_t> out(w, h, options.fill);
  if (image.empty()) return out;
  const auto valid = [&](int x, int y) { return !mask || (*mask)(x, y) != 0; };

  // Global tone, as a look-up table over the 256 gray levels.
  std::array<double, 256> hist{};
  int max_level = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (valid(x, y)) {
        hist[image(x, y)] += 1.0;
        max_level = std::max(max_level, static_cast<int>(image(x, y)));
      }
  const auto equalize = [&](bool use_sqrt) {
    std::array<double, 256> lut{};
    double total = 0.0;
    for (double c : hist) total += use_sqrt ? std::sqrt(c) : c;
    double below = 0.0;
    for (int v = 0; v < 256; ++v) {
      const double c = use_sqrt ? std::sqrt(hist[v]) : hist[v];
      lut[v] = total > 0.0 ? 255.0 * (below + 0.5 * c) / total : 0.0;
      below += c;
    }
    return lut;
  };
  const std::array<double, 256> eq = equalize(false), eq_sqrt = equalize(true);
  const double wsum = options.weight_equalized + options.weight_linear + options.weight_sqrt_equalized;
  std::array<double, 256> tone{};
  for (int v = 0; v < 256; ++v) {
    const double linear = max_level > 0 ? 255.0 * v / max_level : 0.0;
    tone[v] = (options.weight_equalized * eq[v] + options.weight_linear * linear +
               options.weight_sqrt_equalized * eq_sqrt[v]) / wsum;
  }

  // Local statistics. Integer sums are exact: n * sum(I^2) - sum(I)^2 has no cancellation error.
  const int r = options.half_window;
  std::vector<std::int64_t> col_n(w, 0), col_s(w, 0), col_s2(w, 0);
  std::vector<std::int64_t> pre_n(w + 1, 0), pre_s(w + 1, 0), pre_s2(w + 1, 0);
  const auto add_row = [&](int y, int sign) {
    for (int x = 0; x < w; ++x)
      if (valid(x, y)) {
        const std::int64_t v = image(x, y);
        col_n[x] += sign;
        col_s[x] += sign * v;
        col_s2[x] += sign * v * v;
      }
  };
  for (int y = 0; y < std::min(r, h); ++y) add_row(y, +1);
  const double half_pi = 0.5 * kPi;
  for (int y = 0; y < h; ++y) {
    if (y + r < h) add_row(y + r, +1);
    if (y - r - 1 >= 0) add_row(y - r - 1, -1);
    for (int x = 0; x < w; ++x) {
      pre_n[x + 1] = pre_n[x] + col_n[x];
      pre_s[x + 1] = pre_s[x] + col_s[x];
      pre_s2[x + 1] = pre_s2[x] + col_s2[x];
    }
    for (int x = 0; x < w; ++x) {
      if (!valid(x, y)) continue;
      const int x0 = std::max(0, x - r), x1 = std::min(w, x + r + 1);
      const std::int64_t n = pre_n[x1] - pre_n[x0];
      const std::int64_t s = pre_s[x1] - pre_s[x0];
      const std::int64_t s2 = pre_s2[x1] - pre_s2[x0];
      const int v = image(x, y);
      const double g = tone[v];
      double z = 0.0;
      if (n > 0) {
        const double nd = static_cast<double>(n);
        const double var = static_cast<double>(n * s2 - s * s) / (nd * nd);
        const double sd = std::max(std::sqrt(std::max(var, 0.0)), options.min_std);
        if (sd > 0.0) z = (v - static_cast<double>(s) / nd) / sd;
      }
      const double amplitude = std::min({options.max_amplitude, g, 255.0 - g});
      const double o = g + amplitude * std::atan(z) / half_pi;
      out(x, y) = static_cast<std::uint8_t>(std::lround(std::clamp(o, 0.0, 255.0)));
    }
  }
  return out;
}

/// Options of hillshade().
struct HillshadeOptions {
  /// Direction the light comes from, degrees clockwise from north (world +Y). 315 (north-west) by
  /// default, the cartographic convention.
  double azimuth_deg = 315.0;
  /// Height of the light above the horizon, degrees in (0, 90]. 45 by default.
  double altitude_deg = 45.0;
  /// Vertical exaggeration (heights are multiplied by it). 1 by default.
  double z_factor = 1.0;
  /// Gray written at holes. 0 by default.
  std::uint8_t fill = 0;

  void check() const {
    DIACHRON_CHECK(std::isfinite(azimuth_deg), "HillshadeOptions::azimuth_deg must be finite");
    DIACHRON_CHECK(altitude_deg > 0.0 && altitude_deg <= 90.0,
                   "HillshadeOptions::altitude_deg must be in (0, 90], got " << altitude_deg);
    DIACHRON_CHECK(z_factor > 0.0 && std::isfinite(z_factor), "HillshadeOptions::z_factor must be positive");
  }
};

/// Hillshade of a DSM: 255 max(0, n . l) with n the surface normal (Horn's 3x3 gradient, in world
/// units through the geotransform, so rotated grids and non-square cells are right) and l the
/// direction to the light. Next to borders and holes the differences become one-sided, so those
/// pixels are shaded like their surroundings; holes themselves get `fill`.
inline Raster<std::uint8_t> hillshade(const Dsm& dsm, const HillshadeOptions& options = {}) {
  options.check();
  const int w = dsm.width(), h = dsm.height();
  Raster<std::uint8_t> out(w, h, options.fill);
  if (dsm.empty()) return out;
  const auto& c = dsm.transform().c;
  // grad_pixel = J^T grad_world with J = d(X, Y) / d(col, row).
  const double det = c[1] * c[5] - c[2] * c[4];  // non-zero: checked by Dsm
  Eigen::Matrix2d to_world;  // (J^T)^-1
  to_world << c[5] / det, -c[4] / det, -c[2] / det, c[1] / det;
  const double az = deg_to_rad(options.azimuth_deg), alt = deg_to_rad(options.altitude_deg);
  const Eigen::Vector3d light(std::sin(az) * std::cos(alt), std::cos(az) * std::cos(alt), std::sin(alt));
  const Raster<float>& z = dsm.heights();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float centre = z(x, y);
      if (std::isnan(centre)) continue;
      const auto sample = [&](int xx, int yy, double& v) {
        if (!z.contains(xx, yy) || std::isnan(z(xx, yy))) return false;
        v = z(xx, yy);
        return true;
      };
      // Horn's gradient: the 1-2-1 weighted mean of three central differences. A difference whose
      // far sample is missing (border, hole) becomes one-sided and a line without any pair is left
      // out, so the gradient stays exact on planes right up to borders and hole edges.
      const auto derivative = [&](bool along_rows) {
        double sum = 0.0, weights = 0.0;
        for (int k = -1; k <= 1; ++k) {
          double zm = 0.0, z0 = 0.0, zp = 0.0;
          const bool hm = along_rows ? sample(x + k, y - 1, zm) : sample(x - 1, y + k, zm);
          const bool h0 = along_rows ? sample(x + k, y, z0) : sample(x, y + k, z0);
          const bool hp = along_rows ? sample(x + k, y + 1, zp) : sample(x + 1, y + k, zp);
          double d;
          if (hm && hp) d = 0.5 * (zp - zm);
          else if (h0 && hp) d = zp - z0;
          else if (h0 && hm) d = z0 - zm;
          else continue;
          const double wk = k == 0 ? 2.0 : 1.0;
          sum += wk * d;
          weights += wk;
        }
        return weights > 0.0 ? sum / weights : 0.0;
      };
      double dzdc, dzdr;
      if (x > 0 && y > 0 && x + 1 < w && y + 1 < h) {
        // Interior: plain Horn when the whole 3x3 block is valid (NaN propagates otherwise).
        const float* a = z.row(y - 1) + x;
        const float* b = z.row(y) + x;
        const float* c3 = z.row(y + 1) + x;
        dzdc = ((a[1] + 2.0 * b[1] + c3[1]) - (a[-1] + 2.0 * b[-1] + c3[-1])) / 8.0;
        dzdr = ((c3[-1] + 2.0 * c3[0] + c3[1]) - (a[-1] + 2.0 * a[0] + a[1])) / 8.0;
        if (std::isnan(dzdc) || std::isnan(dzdr)) {
          dzdc = derivative(false);
          dzdr = derivative(true);
        }
      } else {
        dzdc = derivative(false);
        dzdr = derivative(true);
      }
      const Eigen::Vector2d g = options.z_factor * (to_world * Eigen::Vector2d(dzdc, dzdr));
      const Eigen::Vector3d n = Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
      const double shade = std::max(0.0, n.dot(light));
      out(x, y) = static_cast<std::uint8_t>(std::lround(255.0 * shade));
    }
  return out;
}

}  // namespace diachron
