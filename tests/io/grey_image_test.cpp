#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gdal_priv.h>

#include <diachron/core/error.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/io/grey_image.hpp>

#include "support/temp_folder.hpp"

namespace {

// Writes `bands` (each w x h, row-major) to `path` as a GeoTIFF of `type`, optionally with a palette.
void write_bands(const std::string& path, int w, int h, const std::vector<std::vector<double>>& bands,
                 GDALDataType type, const GDALColorTable* palette = nullptr) {
  diachron::detail::gdal_register_once();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  REQUIRE(driver);
  GDALDataset* ds = driver->Create(path.c_str(), w, h, static_cast<int>(bands.size()), type, nullptr);
  REQUIRE(ds);
  for (std::size_t b = 0; b < bands.size(); ++b) {
    std::vector<double> v = bands[b];
    REQUIRE(ds->GetRasterBand(static_cast<int>(b) + 1)->RasterIO(GF_Write, 0, 0, w, h, v.data(), w, h, GDT_Float64, 0,
                                                                 0, nullptr) == CE_None);
  }
  if (palette) {
    ds->GetRasterBand(1)->SetColorInterpretation(GCI_PaletteIndex);
    ds->GetRasterBand(1)->SetColorTable(const_cast<GDALColorTable*>(palette));  // GDAL 3.6 takes it non-const
  }
  GDALClose(GDALDataset::ToHandle(ds));
}

bool same(const diachron::Raster<std::uint8_t>& a, const diachron::Raster<std::uint8_t>& b) {
  return a.width() == b.width() && a.height() == b.height() && std::equal(a.begin(), a.end(), b.begin());
}

}  // namespace

TEST_CASE("read_image_grey8: grey, RGB and RGBA 8-bit photos", "[io][image]") {
  const std::string dir = diachron::test::fresh_temp_folder("grey_image_8bit");
  const int w = 4, h = 2;
  const std::vector<double> r{255, 0, 0, 10, 200, 0, 255, 128}, g{0, 255, 0, 20, 100, 0, 255, 128},
      b{0, 0, 255, 30, 50, 0, 255, 128}, alpha(8, 77.0);
  write_bands(dir + "/grey.tif", w, h, {r}, GDT_Byte);
  write_bands(dir + "/grey_alpha.tif", w, h, {r, alpha}, GDT_Byte);
  write_bands(dir + "/rgb.tif", w, h, {r, g, b}, GDT_Byte);
  write_bands(dir + "/rgba.tif", w, h, {r, g, b, alpha}, GDT_Byte);

  const auto grey = diachron::read_image_grey8(dir + "/grey.tif");
  const auto grey_alpha = diachron::read_image_grey8(dir + "/grey_alpha.tif");
  CHECK(same(grey, diachron::read_image_u8(dir + "/grey.tif")));  // the strict reader's answer
  CHECK(same(grey_alpha, grey));
  const auto rgb = diachron::read_image_grey8(dir + "/rgb.tif");
  CHECK(same(diachron::read_image_grey8(dir + "/rgba.tif"), rgb));  // alpha ignored
  // Rec. 601 luma, rounded: pure red 76, green 150, blue 29; (10, 20, 30) 18; white and grey kept.
  const std::vector<int> expected{76, 150, 29, 18, 124, 0, 255, 128};
  for (int i = 0; i < w * h; ++i) CHECK(static_cast<int>(rgb(i % w, i / w)) == expected[static_cast<std::size_t>(i)]);
  // The strict reader refuses what this one converts.
  CHECK_THROWS_WITH(diachron::read_image_u8(dir + "/rgb.tif"), Catch::Contains("3 bands"));
}

TEST_CASE("read_image_grey8: a 16-bit scan is stretched between its percentiles", "[io][image]") {
  const std::string dir = diachron::test::fresh_temp_folder("grey_image_16bit");
  // A 12-bit ramp 1000..3047 over 64 x 32 pixels, with one hot and one dead pixel.
  const int w = 64, h = 32;
  std::vector<double> ramp(static_cast<std::size_t>(w * h));
  for (int i = 0; i < w * h; ++i) ramp[static_cast<std::size_t>(i)] = 1000.0 + i;
  ramp[5] = 65535.0;
  ramp[6] = 0.0;
  write_bands(dir + "/scan.tif", w, h, {ramp}, GDT_UInt16);
  CHECK_THROWS_WITH(diachron::read_image_u8(dir + "/scan.tif"), Catch::Contains("UInt16"));

  diachron::GreyImageReadOptions options;
  options.stretch_low_percent = 1.0;
  options.stretch_high_percent = 99.0;
  const auto image = diachron::read_image_grey8(dir + "/scan.tif", options);
  // Oracle: the percentiles by sorting, then the linear map, clamped and rounded.
  std::vector<double> sorted = ramp;
  std::sort(sorted.begin(), sorted.end());
  const double lo = sorted[static_cast<std::size_t>(0.01 * (w * h - 1))];
  const double hi = sorted[static_cast<std::size_t>(0.99 * (w * h - 1))];
  int mismatches = 0;
  for (int i = 0; i < w * h; ++i) {
    const long want = std::clamp(std::lround((ramp[static_cast<std::size_t>(i)] - lo) * 255.0 / (hi - lo)), 0L, 255L);
    mismatches += static_cast<long>(image(i % w, i / w)) != want;
  }
  CHECK(mismatches == 0);
  CHECK(image(5, 0) == 255);  // the hot pixel saturates instead of setting the range
  CHECK(image(6, 0) == 0);
  CHECK(image(w - 1, h - 1) == 255);

  // Float samples the same way, a constant image becomes one grey.
  write_bands(dir + "/flat.tif", 8, 8, {std::vector<double>(64, 0.25)}, GDT_Float32);
  const auto flat = diachron::read_image_grey8(dir + "/flat.tif");
  CHECK(std::all_of(flat.begin(), flat.end(), [](std::uint8_t v) { return v == 0; }));
}

TEST_CASE("read_image_grey8: a palette image through its colours; bad files throw", "[io][image]") {
  const std::string dir = diachron::test::fresh_temp_folder("grey_image_bad");
  GDALColorTable palette;
  const GDALColorEntry red{255, 0, 0, 255}, white{255, 255, 255, 255};
  palette.SetColorEntry(0, &red);
  palette.SetColorEntry(1, &white);
  write_bands(dir + "/palette.tif", 2, 1, {{0, 1}}, GDT_Byte, &palette);
  const auto image = diachron::read_image_grey8(dir + "/palette.tif");
  CHECK(image(0, 0) == 76);
  CHECK(image(1, 0) == 255);

  write_bands(dir + "/five.tif", 2, 2, std::vector<std::vector<double>>(5, std::vector<double>(4, 1.0)), GDT_Byte);
  CHECK_THROWS_WITH(diachron::read_image_grey8(dir + "/five.tif"), Catch::Contains("5 bands"));
  CHECK_THROWS_WITH(diachron::read_image_grey8(dir + "/missing.tif"), Catch::Contains("no such file"));
  diachron::GreyImageReadOptions bad;
  bad.stretch_low_percent = 60.0;
  bad.stretch_high_percent = 40.0;
  CHECK_THROWS_AS(diachron::read_image_grey8(dir + "/palette.tif", bad), diachron::Error);
}
