#pragma once
/// @file
/// read_image_grey8(): any photo GDAL opens, as the 8-bit grey image the matchers take. Part of
/// diachron::io: include it only from code that links GDAL.
///
/// Why: archive scans come as 8- or 16-bit grey TIFFs, the modern epoch's photos as RGB JPEGs, and
/// read_image_u8() (io/geotiff.hpp) takes only 8-bit single-band files. Here:
/// - bands: 1 (grey) or 2 (grey + alpha) use the first; 3 (RGB) or 4 (RGBA) become grey with the
///   Rec. 601 luma weights 0.299 R + 0.587 G + 0.114 B (OpenCV's cvtColor and most photo tools), the
///   alpha band ignored; a palette band is expanded through its colour table first;
/// - samples: 8-bit as they are; wider or float samples are stretched linearly from a low to a high
///   percentile of the image (0.1 % and 99.9 % by default) onto 0-255, because a 16-bit scan often
///   fills only part of its range (a 12-bit scanner, a dark film) and dividing by 257 would leave it
///   a few grey levels. Matching (SIFT, NCC) is invariant to such a gain and offset.
/// No georeferencing is needed; non-finite float samples become 0. Memory: the image plus 1 (grey)
/// to 3 (RGB) bytes per pixel for 8-bit photos, 8 to 16 bytes per pixel for wider samples.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include <gdal_priv.h>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/io/geotiff.hpp>

namespace diachron {

/// Options of read_image_grey8().
struct GreyImageReadOptions {
  /// Samples wider than 8 bits: the percentiles (in percent) mapped to 0 and 255. 0.1 and 99.9 by
  /// default, so that a few saturated or dead pixels do not set the range.
  double stretch_low_percent = 0.1;
  double stretch_high_percent = 99.9;
  /// A window of the image to read instead of the whole: top-left pixel (window_x, window_y) and
  /// size window_width x window_height px (a width of 0: the whole image). It must lie inside the
  /// image. The stretch of wider samples is then that of the window. For tiles of large rasters
  /// (orthophotos) without reading all of them.
  int window_x = 0, window_y = 0, window_width = 0, window_height = 0;

  void check() const {
    DIACHRON_CHECK(window_x >= 0 && window_y >= 0 && window_width >= 0 && window_height >= 0 &&
                       (window_width == 0) == (window_height == 0),
                   "GreyImageReadOptions: the window must have a non-negative origin and both sizes 0 or > 0, got ("
                       << window_x << ", " << window_y << ") " << window_width << " x " << window_height);
    DIACHRON_CHECK(stretch_low_percent >= 0.0 && stretch_high_percent <= 100.0 &&
                       stretch_low_percent < stretch_high_percent,
                   "GreyImageReadOptions: need 0 <= stretch_low_percent < stretch_high_percent <= 100, got "
                       << stretch_low_percent << " and " << stretch_high_percent);
  }
};

/// Reads the photo at `path` as 8-bit grey (see the file comment for bands and sample types).
/// Throws diachron::Error naming the file when it is missing, cannot be opened, is empty, has 5 or
/// more bands, complex samples, or cannot be read.
inline Raster<std::uint8_t> read_image_grey8(const std::string& path, const GreyImageReadOptions& options = {}) {
  options.check();
  const detail::QuietGdalErrors quiet;
  const detail::GdalDatasetPtr ds = detail::open_raster(path, "image");
  const int bands = ds->GetRasterCount();
  DIACHRON_CHECK(bands >= 1 && bands <= 4,
                 "cannot read image '" << path << "': it has " << bands << " bands (grey, grey + alpha, RGB or RGBA expected)");
  const int full_w = ds->GetRasterXSize(), full_h = ds->GetRasterYSize();
  DIACHRON_CHECK(full_w > 0 && full_h > 0, "cannot read image '" << path << "': empty raster " << full_w << " x " << full_h);
  const bool windowed = options.window_width > 0;
  const int x0 = windowed ? options.window_x : 0, y0 = windowed ? options.window_y : 0;
  const int w = windowed ? options.window_width : full_w, h = windowed ? options.window_height : full_h;
  DIACHRON_CHECK(!windowed || (static_cast<long long>(x0) + w <= full_w && static_cast<long long>(y0) + h <= full_h),
                 "cannot read image '" << path << "': the window (" << x0 << ", " << y0 << ") " << w << " x " << h
                                       << " leaves the " << full_w << " x " << full_h << " image");
  const GDALDataType type = ds->GetRasterBand(1)->GetRasterDataType();
  DIACHRON_CHECK(!GDALDataTypeIsComplex(type), "cannot read image '" << path << "': complex samples");
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);

  GDALRasterBand* first = ds->GetRasterBand(1);
  const GDALColorTable* palette =
      first->GetColorInterpretation() == GCI_PaletteIndex ? first->GetColorTable() : nullptr;
  Raster<std::uint8_t> out(w, h);
  std::uint8_t* px = out.data();
  // Reads band `index` as samples of type V (GDAL converts), `n` of them.
  auto read_band = [&](int index, auto tag) {
    using V = decltype(tag);
    std::vector<V> values(n);
    const GDALDataType as = std::is_same_v<V, std::uint8_t> ? GDT_Byte : GDT_Float32;
    const CPLErr err = ds->GetRasterBand(index)->RasterIO(GF_Read, x0, y0, w, h, values.data(), w, h, as, 0, 0, nullptr);
    DIACHRON_CHECK(err == CE_None,
                   "cannot read image '" << path << "': read failed" << detail::QuietGdalErrors::last_message());
    return values;
  };
  auto luma = [](double r, double g, double b) { return 0.299 * r + 0.587 * g + 0.114 * b; };

  // 8-bit photos, the common case, at 1 to 3 bytes per pixel of memory.
  if (type == GDT_Byte && !palette) {
    if (bands <= 2) {
      // In strips, dropping GDAL's cached blocks after each: read at once, a 12000 x 12000 px scan
      // passed through 180 MB of block cache besides its own 144 MB.
      constexpr int kStripRows = 512;
      for (int y = 0; y < h; y += kStripRows) {
        const int rows = std::min(kStripRows, h - y);
        const CPLErr err = first->RasterIO(GF_Read, x0, y0 + y, w, rows, px + static_cast<std::size_t>(y) * w, w, rows,
                                           GDT_Byte, 0, 0, nullptr);
        DIACHRON_CHECK(err == CE_None,
                       "cannot read image '" << path << "': read failed" << detail::QuietGdalErrors::last_message());
        first->FlushCache(false);
      }
    } else {
      const std::vector<std::uint8_t> r = read_band(1, std::uint8_t{}), g = read_band(2, std::uint8_t{}),
                                      b = read_band(3, std::uint8_t{});
      for (std::size_t i = 0; i < n; ++i) px[i] = static_cast<std::uint8_t>(std::lround(luma(r[i], g[i], b[i])));
    }
    return out;
  }

  // Palette images through their colours (8-bit components), then luma.
  if (palette) {
    std::vector<double> table(static_cast<std::size_t>(std::max(palette->GetColorEntryCount(), 1)), 0.0);
    for (int i = 0; i < palette->GetColorEntryCount(); ++i) {
      const GDALColorEntry* c = palette->GetColorEntry(i);
      table[static_cast<std::size_t>(i)] = luma(c->c1, c->c2, c->c3);
    }
    const std::vector<float> index = read_band(1, float{});
    for (std::size_t i = 0; i < n; ++i) {
      const long k = std::isfinite(index[i]) ? std::lround(index[i]) : -1;
      px[i] = (k >= 0 && static_cast<std::size_t>(k) < table.size())
                  ? static_cast<std::uint8_t>(std::lround(table[static_cast<std::size_t>(k)]))
                  : 0;
    }
    return out;
  }

  // Wider or float samples: grey (luma for RGB) as float, then the linear stretch between the
  // percentiles, found by selection on a copy (exact).
  std::vector<float> grey = read_band(1, float{});
  if (bands >= 3) {
    const std::vector<float> g = read_band(2, float{}), b = read_band(3, float{});
    for (std::size_t i = 0; i < n; ++i) grey[i] = static_cast<float>(luma(grey[i], g[i], b[i]));
  }
  for (float& v : grey)
    if (!std::isfinite(v)) v = 0.0f;
  std::vector<float> sorted = grey;
  auto percentile = [&](double percent) {
    const std::size_t k =
        std::min(n - 1, static_cast<std::size_t>(std::floor(percent / 100.0 * static_cast<double>(n - 1))));
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(k), sorted.end());
    return static_cast<double>(sorted[k]);
  };
  const double lo = percentile(options.stretch_low_percent), hi = percentile(options.stretch_high_percent);
  const double gain = hi > lo ? 255.0 / (hi - lo) : 0.0;  // a constant image stays one grey (0)
  for (std::size_t i = 0; i < n; ++i)
    px[i] = static_cast<std::uint8_t>(std::clamp(std::lround((grey[i] - lo) * gain), 0L, 255L));
  return out;
}

}  // namespace diachron
