#pragma once
/// @file
/// DSM images that stay the same when the DSM's frame turns about the vertical or changes scale:
/// slope, local relief, and a multi-directional hillshade.
///
/// Epochs come in unrelated frames, so a DSM image should not depend on the frame's rotation or scale.
/// The paper's mean +- k sigma stretch does not depend on them but spends its 256 levels on the whole
/// height range: on mountains, 1000 m over 255 levels hides everything smaller than 4 m. A hillshade
/// shows that detail but its light direction turns with the frame. These three show the detail and
/// do not depend on the frame (docs/rough-coregistration.md measures them).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>  // Matrix2d::inverse()

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/dsm_image.hpp>

namespace diachron {

/// Options of slope_image().
struct SlopeImageOptions {
  /// The slope (rise over run) at this percentile of the valid pixels maps to gray 255; 0.98 by
  /// default. A percentile, not a fixed angle, so flat and mountainous DSMs both use the full range.
  double upper_percentile = 0.98;
  std::uint8_t fill = 0;  ///< gray written at holes

  void check() const {
    DIACHRON_CHECK(upper_percentile > 0.0 && upper_percentile <= 1.0,
                   "SlopeImageOptions::upper_percentile must be in (0, 1], got " << upper_percentile);
  }
};

/// Options of local_relief_image().
struct LocalReliefOptions {
  /// Half size of the box, pixels: z = (Z - box mean) / box std over (2 r + 1)^2 valid pixels. 12 by
  /// default, about the support of a SIFT descriptor at the first octaves.
  int half_window = 12;
  /// Box standard deviations below this many cells' worth of height are raised to it, so flat areas
  /// (water, fields) do not turn noise into contrast. In cell sizes; 0.05 by default.
  double min_std_cells = 0.05;
  std::uint8_t fill = 0;  ///< gray written at holes

  void check() const {
    DIACHRON_CHECK(half_window >= 1, "LocalReliefOptions::half_window must be >= 1, got " << half_window);
    DIACHRON_CHECK(min_std_cells >= 0.0, "LocalReliefOptions::min_std_cells must be >= 0");
  }
};

/// Slope magnitude |grad Z| (dimensionless: invariant to the frame's rotation about the vertical and
/// to its scale), by central differences in world units, stretched to [0, 255] with the percentile
/// in the options. Pixels next to holes use one-sided differences; holes get `fill`.
Raster<std::uint8_t> slope_image(const Dsm& dsm, const SlopeImageOptions& options = {});

/// Local relief: atan of the height's z-score within a box (computed on the float heights, so no
/// detail is lost to 8-bit quantisation first), mapped to [0, 255]. Holes are left out of the box
/// statistics and get `fill`.
Raster<std::uint8_t> local_relief_image(const Dsm& dsm, const LocalReliefOptions& options = {});

/// The mean of hillshades lit from `directions` azimuths spread evenly over 360 degrees: nearly
/// independent of the frame's rotation about the vertical, unlike a single hillshade.
Raster<std::uint8_t> multidirectional_hillshade(const Dsm& dsm, int directions = 8,
                                                const HillshadeOptions& options = {});

// Implementation --------------------------------------------------------------------------------

namespace detail {

/// d Z / d(pixel x) and d Z / d(pixel y) by central differences, one-sided next to holes and borders;
/// NaN when the pixel is a hole or has no valid neighbour along an axis.
inline Eigen::Vector2d pixel_gradient(const Dsm& dsm, int x, int y) {
  const Raster<float>& z = dsm.heights();
  auto at = [&](int u, int v) { return dsm.valid(u, v) ? static_cast<double>(z(u, v)) : std::nan(""); };
  const double c = at(x, y);
  auto diff = [&](double minus, double plus) {
    if (!std::isnan(minus) && !std::isnan(plus)) return 0.5 * (plus - minus);
    if (!std::isnan(plus)) return plus - c;
    if (!std::isnan(minus)) return c - minus;
    return std::nan("");
  };
  return {diff(at(x - 1, y), at(x + 1, y)), diff(at(x, y - 1), at(x, y + 1))};
}

}  // namespace detail

inline Raster<std::uint8_t> slope_image(const Dsm& dsm, const SlopeImageOptions& options) {
  options.check();
  const int w = dsm.width(), h = dsm.height();
  Raster<std::uint8_t> out(w, h, options.fill);
  if (dsm.empty()) return out;
  // World gradient from pixel gradient: grad_pixel = J^T grad_world, J = d(world)/d(pixel).
  const auto& c = dsm.transform().c;
  Eigen::Matrix2d jt;
  jt << c[1], c[4], c[2], c[5];
  const Eigen::Matrix2d jt_inv = jt.inverse();
  Raster<float> slope(w, h, std::numeric_limits<float>::quiet_NaN());
  std::vector<float> values;
  values.reserve(dsm.statistics().count);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!dsm.valid(x, y)) continue;
      const Eigen::Vector2d g = detail::pixel_gradient(dsm, x, y);
      if (!g.allFinite()) continue;
      const float s = static_cast<float>((jt_inv * g).norm());
      slope(x, y) = s;
      values.push_back(s);
    }
  if (values.empty()) return out;
  const std::size_t k = std::min(values.size() - 1,
                                 static_cast<std::size_t>(options.upper_percentile * static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  const double top = values[k] > 0.0f ? values[k] : 1.0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float s = slope(x, y);
      if (std::isnan(s)) continue;
      out(x, y) = static_cast<std::uint8_t>(std::lround(std::clamp(255.0 * s / top, 0.0, 255.0)));
    }
  return out;
}

inline Raster<std::uint8_t> local_relief_image(const Dsm& dsm, const LocalReliefOptions& options) {
  options.check();
  const int w = dsm.width(), h = dsm.height();
  Raster<std::uint8_t> out(w, h, options.fill);
  if (dsm.empty() || dsm.statistics().count == 0) return out;
  // Summed-area tables of count, Z and Z^2 over valid pixels (heights centred on the mean, so the
  // sums of squares keep their digits far above sea level).
  const double mean = dsm.statistics().mean;
  const std::size_t stride = static_cast<std::size_t>(w) + 1;
  std::vector<double> s0((static_cast<std::size_t>(h) + 1) * stride, 0.0), s1(s0.size(), 0.0), s2(s0.size(), 0.0);
  for (int y = 0; y < h; ++y) {
    double r0 = 0, r1 = 0, r2 = 0;
    for (int x = 0; x < w; ++x) {
      if (dsm.valid(x, y)) {
        const double z = dsm.heights()(x, y) - mean;
        r0 += 1.0;
        r1 += z;
        r2 += z * z;
      }
      const std::size_t i = (static_cast<std::size_t>(y) + 1) * stride + static_cast<std::size_t>(x) + 1;
      s0[i] = s0[i - stride] + r0;
      s1[i] = s1[i - stride] + r1;
      s2[i] = s2[i - stride] + r2;
    }
  }
  auto box = [&](const std::vector<double>& s, int x0, int y0, int x1, int y1) {
    const std::size_t a = static_cast<std::size_t>(y0) * stride + static_cast<std::size_t>(x0);
    const std::size_t b = static_cast<std::size_t>(y0) * stride + static_cast<std::size_t>(x1);
    const std::size_t c = static_cast<std::size_t>(y1) * stride + static_cast<std::size_t>(x0);
    const std::size_t d = static_cast<std::size_t>(y1) * stride + static_cast<std::size_t>(x1);
    return s[d] - s[b] - s[c] + s[a];
  };
  const int r = options.half_window;
  const double min_std = options.min_std_cells * dsm.min_cell_size();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!dsm.valid(x, y)) continue;
      const int x0 = std::max(0, x - r), y0 = std::max(0, y - r);
      const int x1 = std::min(w, x + r + 1), y1 = std::min(h, y + r + 1);
      const double n = box(s0, x0, y0, x1, y1);
      const double m = box(s1, x0, y0, x1, y1) / n;
      const double var = std::max(0.0, box(s2, x0, y0, x1, y1) / n - m * m);
      const double sd = std::max(std::sqrt(var), std::max(min_std, 1e-12));
      const double z = (dsm.heights()(x, y) - mean - m) / sd;
      const double g = 127.5 + 127.5 * std::atan(z) / (0.5 * kPi);
      out(x, y) = static_cast<std::uint8_t>(std::lround(std::clamp(g, 0.0, 255.0)));
    }
  return out;
}

inline Raster<std::uint8_t> multidirectional_hillshade(const Dsm& dsm, int directions,
                                                       const HillshadeOptions& options) {
  DIACHRON_CHECK(directions >= 1, "multidirectional_hillshade needs at least one direction, got " << directions);
  const int w = dsm.width(), h = dsm.height();
  Raster<float> sum(w, h, 0.0f);
  for (int d = 0; d < directions; ++d) {
    HillshadeOptions o = options;
    o.azimuth_deg = options.azimuth_deg + 360.0 * d / directions;
    const Raster<std::uint8_t> one = hillshade(dsm, o);
    for (std::size_t i = 0; i < one.size(); ++i) sum.data()[i] += one.data()[i];
  }
  Raster<std::uint8_t> out(w, h, options.fill);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (dsm.valid(x, y))
        out(x, y) = static_cast<std::uint8_t>(std::lround(std::clamp(sum(x, y) / directions, 0.0f, 255.0f)));
  return out;
}

}  // namespace diachron
