#pragma once
/// @file
/// Lossy compression of synthetic 8-bit images as a JPEG encoder would leave them: 8 x 8 blocks,
/// orthonormal DCT, quantisation with the JPEG luminance table scaled by a quality factor, then
/// the inverse transform. Only the loss is modelled (no entropy coding, no file): recent aerial
/// images are often delivered as JPEG, and its block artefacts and lost fine texture are part of
/// what a matcher meets. Needs the standard library only.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/raster.hpp>

namespace diachron {

namespace detail {

/// The luminance quantisation table of the JPEG standard (ITU-T T.81, annex K), row-major by
/// vertical then horizontal frequency: the values a quality-50 JPEG divides DCT coefficients by.
inline constexpr std::array<int, 64> kJpegLuminanceTable = {
    16, 11, 10, 16, 24,  40,  51,  61,  12, 12, 14, 19, 26,  58,  60,  55,  14, 13, 16, 24, 40,  57,
    69, 56, 14, 17, 22,  29,  51,  87,  80, 62, 18, 22, 37,  56,  68,  109, 103, 77, 24, 35, 55, 64,
    81, 104, 113, 92, 49, 64, 78,  87,  103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99};

/// Orthonormal 8-point DCT-II basis: basis[u][x] = a(u) cos((2x + 1) u pi / 16).
inline std::array<std::array<double, 8>, 8> dct8_basis() {
  std::array<std::array<double, 8>, 8> c{};
  for (int u = 0; u < 8; ++u)
    for (int x = 0; x < 8; ++x)
      c[static_cast<std::size_t>(u)][static_cast<std::size_t>(x)] =
          (u == 0 ? std::sqrt(0.125) : 0.5) * std::cos((2.0 * x + 1.0) * u * 3.14159265358979323846 / 16.0);
  return c;
}

}  // namespace detail

/// The quantisation step of each of the 64 DCT coefficients at JPEG `quality` in [1, 100], scaled
/// from the standard table as the IJG library does (quality 50 is the table itself; 100 gives 1).
inline std::array<int, 64> jpeg_quantisation_table(int quality) {
  DIACHRON_CHECK(quality >= 1 && quality <= 100, "jpeg_quantisation_table: quality must be in [1, 100], got " << quality);
  const int scale = quality < 50 ? 5000 / quality : 200 - 2 * quality;
  std::array<int, 64> q{};
  for (std::size_t k = 0; k < 64; ++k) q[k] = std::clamp((detail::kJpegLuminanceTable[k] * scale + 50) / 100, 1, 255);
  return q;
}

/// The image after a JPEG round trip at `quality` in [1, 100] (luminance only). Blocks that cross
/// the right or bottom border are padded by repeating the edge, as encoders do. Rows of blocks
/// are processed in parallel; the result does not depend on `threads`.
inline Raster<std::uint8_t> jpeg_like_compress(const Raster<std::uint8_t>& image, int quality, std::size_t threads = 0) {
  const std::array<int, 64> q = jpeg_quantisation_table(quality);
  const auto c = detail::dct8_basis();
  const int w = image.width(), h = image.height();
  Raster<std::uint8_t> out(w, h);
  if (image.empty()) return out;
  const int block_rows = (h + 7) / 8, block_cols = (w + 7) / 8;
  parallel_for(static_cast<std::size_t>(block_rows), threads, [&](std::size_t block_row) {
    std::array<double, 64> f{}, tmp{}, coef{};
    for (int bc = 0; bc < block_cols; ++bc) {
      const int x0 = bc * 8, y0 = static_cast<int>(block_row) * 8;
      for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x)
          f[static_cast<std::size_t>(8 * y + x)] = image(std::min(x0 + x, w - 1), std::min(y0 + y, h - 1)) - 128.0;
      // Separable forward transform: rows then columns.
      for (int y = 0; y < 8; ++y)
        for (int u = 0; u < 8; ++u) {
          double acc = 0.0;
          for (int x = 0; x < 8; ++x) acc += c[static_cast<std::size_t>(u)][static_cast<std::size_t>(x)] * f[static_cast<std::size_t>(8 * y + x)];
          tmp[static_cast<std::size_t>(8 * y + u)] = acc;
        }
      for (int v = 0; v < 8; ++v)
        for (int u = 0; u < 8; ++u) {
          double acc = 0.0;
          for (int y = 0; y < 8; ++y) acc += c[static_cast<std::size_t>(v)][static_cast<std::size_t>(y)] * tmp[static_cast<std::size_t>(8 * y + u)];
          const auto k = static_cast<std::size_t>(8 * v + u);
          coef[k] = std::round(acc / q[k]) * q[k];
        }
      // Inverse: columns then rows.
      for (int y = 0; y < 8; ++y)
        for (int u = 0; u < 8; ++u) {
          double acc = 0.0;
          for (int v = 0; v < 8; ++v) acc += c[static_cast<std::size_t>(v)][static_cast<std::size_t>(y)] * coef[static_cast<std::size_t>(8 * v + u)];
          tmp[static_cast<std::size_t>(8 * y + u)] = acc;
        }
      for (int y = 0; y < 8 && y0 + y < h; ++y)
        for (int x = 0; x < 8 && x0 + x < w; ++x) {
          double acc = 0.0;
          for (int u = 0; u < 8; ++u) acc += c[static_cast<std::size_t>(u)][static_cast<std::size_t>(x)] * tmp[static_cast<std::size_t>(8 * y + u)];
          out(x0 + x, y0 + y) = static_cast<std::uint8_t>(std::clamp(std::lround(acc + 128.0), 0L, 255L));
        }
    }
  });
  return out;
}

}  // namespace diachron
