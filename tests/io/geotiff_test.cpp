// Tests of the GeoTIFF DSM reader/writer: round trips (values, holes, transform, CRS), integer and
// multi-band files, the untagged-sentinel option, errors that name the file, the real DEMs, and the
// 8-bit image writer.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <diachron/io/geotiff.hpp>

#include "support/temp_folder.hpp"
#include "support/test_paths.hpp"

using diachron::Dsm;
using diachron::GeoTransform;
using diachron::Raster;
namespace fs = std::filesystem;

namespace {

/// A fresh temporary folder for one test case, removed afterwards.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) : path(diachron::test::fresh_temp_folder("geotiff_" + name)) {}
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string file(const std::string& name) const { return (path / name).string(); }
};

Dsm sample_dsm(const GeoTransform& gt, const std::string& crs) {
  Raster<float> z(37, 23);
  for (int y = 0; y < z.height(); ++y)
    for (int x = 0; x < z.width(); ++x) z(x, y) = 1234.5f + 0.37f * x - 1.9f * y + 0.001f * x * y;
  z(3, 4) = std::numeric_limits<float>::quiet_NaN();
  z(36, 22) = std::numeric_limits<float>::quiet_NaN();
  return Dsm(std::move(z), gt, crs);
}

// Writes a raw GTiff with GDAL directly (for cases our writer never produces).
void write_raw(const std::string& path, int bands, GDALDataType type, const std::vector<double>& values, int w, int h,
               const double* nodata, bool georef) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  GDALDataset* ds = driver->Create(path.c_str(), w, h, bands, type, nullptr);
  REQUIRE(ds);
  if (georef) {
    double gt[6] = {500000, 10, 0, 5000000, 0, -10};
    ds->SetGeoTransform(gt);
  }
  for (int b = 1; b <= bands; ++b) {
    std::vector<double> v(values);
    for (double& x : v) x += 100.0 * (b - 1);
    GDALRasterBand* band = ds->GetRasterBand(b);
    if (nodata) band->SetNoDataValue(*nodata);
    REQUIRE(band->RasterIO(GF_Write, 0, 0, w, h, v.data(), w, h, GDT_Float64, 0, 0, nullptr) == CE_None);
  }
  GDALClose(GDALDataset::ToHandle(ds));
}

bool same_bits(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

}  // namespace

TEST_CASE("GeoTiff: write then read gives the same DSM", "[io]") {
  const TempDir dir("roundtrip");
  const double c = std::cos(0.3), s = std::sin(0.3);
  for (const GeoTransform& gt : {GeoTransform::north_up(500123.5, 8700456.25, 2.5),
                                 GeoTransform{{1000.0, 3 * c, -3 * s, 2000.0, 3 * s, 3 * c}}}) {
    const Dsm dsm = sample_dsm(gt, "EPSG:32633");
    const std::string path = dir.file("dsm.tif");
    diachron::write_geotiff_dsm(dsm, path);
    const Dsm back = diachron::read_geotiff_dsm(path);
    REQUIRE(back.width() == dsm.width());
    REQUIRE(back.height() == dsm.height());
    bool identical = true;
    for (int y = 0; y < dsm.height(); ++y)
      for (int x = 0; x < dsm.width(); ++x) identical = identical && same_bits(back.heights()(x, y), dsm.heights()(x, y));
    CHECK(identical);
    CHECK(std::isnan(back.heights()(3, 4)));
    CHECK(back.statistics().count == dsm.statistics().count);
    for (int i = 0; i < 6; ++i) CHECK(back.transform().c[i] == Approx(gt.c[i]).epsilon(1e-12));
    // The CRS comes back as WKT of the same system, and is stable from then on.
    OGRSpatialReference read_srs, expected;
    REQUIRE(read_srs.SetFromUserInput(back.crs().c_str()) == OGRERR_NONE);
    expected.importFromEPSG(32633);
    CHECK(read_srs.IsSame(&expected));
    diachron::write_geotiff_dsm(back, dir.file("again.tif"));
    const Dsm again = diachron::read_geotiff_dsm(dir.file("again.tif"));
    CHECK(again.crs() == back.crs());
  }
  // No CRS, another nodata value, no compression.
  const Dsm plain = sample_dsm(GeoTransform::north_up(0, 0, 1), "");
  diachron::GeoTiffWriteOptions options;
  options.nodata = -32767.0;
  options.compression = "NONE";
  diachron::write_geotiff_dsm(plain, dir.file("plain.tif"), options);
  const Dsm plain_back = diachron::read_geotiff_dsm(dir.file("plain.tif"));
  CHECK(plain_back.crs().empty());
  CHECK(std::isnan(plain_back.heights()(36, 22)));
  CHECK(plain_back.heights()(0, 0) == plain.heights()(0, 0));
  // A CRS text that is not one is an error naming the file.
  const Dsm bad_crs = sample_dsm(GeoTransform::north_up(0, 0, 1), "not a crs");
  try {
    diachron::write_geotiff_dsm(bad_crs, dir.file("bad.tif"));
    FAIL("no error");
  } catch (const diachron::Error& e) {
    CHECK_THAT(e.what(), Catch::Contains("bad.tif"));
  }
}

TEST_CASE("GeoTiff: integer samples, tagged and untagged nodata, bands", "[io]") {
  const TempDir dir("kinds");
  const std::vector<double> values = {1, 2, -9999, 4, 5, 6};
  const double nodata = 5;
  write_raw(dir.file("int16.tif"), 1, GDT_Int16, values, 3, 2, &nodata, true);
  const Dsm ints = diachron::read_geotiff_dsm(dir.file("int16.tif"));
  CHECK(ints.heights()(0, 0) == 1.0f);
  CHECK(ints.heights()(2, 0) == -9999.0f);  // a tagged nodata other than -9999: -9999 is a value
  CHECK(std::isnan(ints.heights()(1, 1)));
  CHECK(ints.cell_size().x() == Approx(10.0));

  write_raw(dir.file("untagged.tif"), 1, GDT_Float32, values, 3, 2, nullptr, true);
  CHECK(diachron::read_geotiff_dsm(dir.file("untagged.tif")).heights()(2, 0) == -9999.0f);
  diachron::GeoTiffReadOptions sentinel;
  sentinel.assume_untagged_nodata = true;
  const Dsm with_sentinel = diachron::read_geotiff_dsm(dir.file("untagged.tif"), sentinel);
  CHECK(std::isnan(with_sentinel.heights()(2, 0)));
  CHECK(with_sentinel.statistics().count == 5);

  write_raw(dir.file("two_bands.tif"), 2, GDT_Float32, values, 3, 2, nullptr, true);
  try {
    diachron::read_geotiff_dsm(dir.file("two_bands.tif"));
    FAIL("no error");
  } catch (const diachron::Error& e) {
    CHECK_THAT(e.what(), Catch::Contains("two_bands.tif") && Catch::Contains("2 bands"));
  }
  diachron::GeoTiffReadOptions second;
  second.band = 2;
  CHECK(diachron::read_geotiff_dsm(dir.file("two_bands.tif"), second).heights()(0, 0) == 101.0f);
  second.band = 3;
  CHECK_THROWS_AS(diachron::read_geotiff_dsm(dir.file("two_bands.tif"), second), diachron::Error);

  write_raw(dir.file("no_georef.tif"), 1, GDT_Float32, values, 3, 2, nullptr, false);
  try {
    diachron::read_geotiff_dsm(dir.file("no_georef.tif"));
    FAIL("no error");
  } catch (const diachron::Error& e) {
    CHECK_THAT(e.what(), Catch::Contains("no_georef.tif") && Catch::Contains("geotransform"));
  }
  diachron::GeoTiffReadOptions allow;
  allow.allow_missing_geotransform = true;
  CHECK(diachron::read_geotiff_dsm(dir.file("no_georef.tif"), allow).width() == 3);
}

TEST_CASE("GeoTiff: missing and non-raster files are errors naming the file", "[io]") {
  const TempDir dir("errors");
  const std::string missing = dir.file("does_not_exist.tif");
  try {
    diachron::read_geotiff_dsm(missing);
    FAIL("no error");
  } catch (const diachron::Error& e) {
    CHECK_THAT(e.what(), Catch::Contains("does_not_exist.tif") && Catch::Contains("no such file"));
  }
  const std::string text = dir.file("notes.tif");
  std::ofstream(text) << "this is not a raster\n";
  try {
    diachron::read_geotiff_dsm(text);
    FAIL("no error");
  } catch (const diachron::Error& e) {
    CHECK_THAT(e.what(), Catch::Contains("notes.tif") && Catch::Contains("not a raster"));
  }
  try {
    diachron::write_geotiff_dsm(sample_dsm(GeoTransform::north_up(0, 0, 1), ""), dir.file("no/such/dir/x.tif"));
    FAIL("no error");
  } catch (const diachron::Error& e) {
    CHECK_THAT(e.what(), Catch::Contains("x.tif"));
  }
}

TEST_CASE("GeoTiff: 8-bit image writer (PNG and TIFF)", "[io]") {
  const TempDir dir("u8");
  Raster<std::uint8_t> img(17, 9);
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 17; ++x) img(x, y) = static_cast<std::uint8_t>(x * 15 + y);
  for (const std::string name : {"img.png", "img.tif"}) {
    diachron::write_image_u8(img, dir.file(name));
    GDALDataset* ds = GDALDataset::FromHandle(GDALOpen(dir.file(name).c_str(), GA_ReadOnly));
    REQUIRE(ds);
    std::vector<std::uint8_t> back(17 * 9);
    REQUIRE(ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, 17, 9, back.data(), 17, 9, GDT_Byte, 0, 0, nullptr) == CE_None);
    GDALClose(GDALDataset::ToHandle(ds));
    CHECK(std::equal(back.begin(), back.end(), img.begin()));
  }
}

TEST_CASE("GeoTiff: real DEMs", "[io]") {
  {
    const auto path = diachron::test::data_file("mount-st-helens/1_msh00_83.tif");
    DIACHRON_REQUIRE_FILE_OR_SKIP(path, "mount-st-helens/1_msh00_83.tif");
    const Dsm dsm = diachron::read_geotiff_dsm(*path);
    CHECK(dsm.width() == 303);
    CHECK(dsm.height() == 442);
    CHECK(dsm.cell_size().x() == Approx(10.0));
    CHECK(dsm.cell_size().y() == Approx(10.0));
    const auto& s = dsm.statistics();
    CHECK(s.count > 0);
    CHECK(s.count <= std::size_t(303 * 442));
    CHECK(s.min > 500.0);   // no -9999 left among the heights: the crater floor is ~1800 m
    CHECK(s.max < 3000.0);
    CHECK_THAT(dsm.crs(), Catch::Contains("26910") || Catch::Contains("UTM zone 10N"));
    WARN("1_msh00_83.tif: " << dsm.width() << " x " << dsm.height() << ", " << s.count << " valid, Z " << s.min
                            << " .. " << s.max << " m");
  }
  {
    const auto path = diachron::test::data_file("mount-st-helens/msh_2005_07_14_merged.tif");
    DIACHRON_REQUIRE_FILE_OR_SKIP(path, "mount-st-helens/msh_2005_07_14_merged.tif");
    diachron::GeoTiffReadOptions sentinel;
    sentinel.assume_untagged_nodata = true;
    const Dsm raw = diachron::read_geotiff_dsm(*path);
    const Dsm holed = diachron::read_geotiff_dsm(*path, sentinel);
    CHECK(holed.statistics().count <= raw.statistics().count);
    CHECK(holed.statistics().min > 500.0);
  }
  {
    const auto path = diachron::test::data_file("longyearbyen-1990/dem_1990.tif");
    DIACHRON_REQUIRE_FILE_OR_SKIP(path, "longyearbyen-1990/dem_1990.tif");
    const Dsm dsm = diachron::read_geotiff_dsm(*path);
    CHECK(dsm.width() == 1332);
    CHECK(dsm.height() == 985);
    CHECK(dsm.cell_size().x() == Approx(20.0));
    CHECK_THAT(dsm.crs(), Catch::Contains("25833") || Catch::Contains("UTM zone 33N"));
    CHECK(dsm.statistics().count > 0);
  }
  {
    const auto path = diachron::test::data_file("srtm-demcompare/srtm_ref.tif");
    DIACHRON_REQUIRE_FILE_OR_SKIP(path, "srtm-demcompare/srtm_ref.tif");
    const Dsm dsm = diachron::read_geotiff_dsm(*path);
    CHECK(dsm.width() == 1000);
    CHECK(dsm.height() == 1000);
    CHECK_THAT(dsm.crs(), Catch::Contains("4326") || Catch::Contains("WGS 84"));
    CHECK(dsm.cell_size().x() == Approx(1.0 / 1200.0).epsilon(1e-3));
  }
}

TEST_CASE("suspected_untagged_nodata: a sentinel far below every height, and nothing else", "[io]") {
  const GeoTransform gt = GeoTransform::north_up(0.0, 100.0, 1.0);
  auto dsm_of = [&](std::vector<float> values) {
    Raster<float> z(static_cast<int>(values.size()), 1);
    for (std::size_t i = 0; i < values.size(); ++i) z(static_cast<int>(i), 0) = values[i];
    return Dsm(std::move(z), gt);
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  CHECK(diachron::suspected_untagged_nodata(dsm_of({120.0f, -9999.0f, 87.5f, -9999.0f, nan})) == -9999.0);
  CHECK(diachron::suspected_untagged_nodata(dsm_of({-32768.0f, 2.0f, -5.0f})) == -32768.0);
  CHECK(diachron::suspected_untagged_nodata(dsm_of({-std::numeric_limits<float>::max(), 10.0f})) ==
        static_cast<double>(-std::numeric_limits<float>::max()));
  CHECK(diachron::suspected_untagged_nodata(dsm_of({-9999.0f, -9999.0f})) == -9999.0);  // nothing but holes
  // Real heights: no sentinel, or a sentinel value that continues the terrain (deep bathymetry).
  CHECK_FALSE(diachron::suspected_untagged_nodata(dsm_of({120.0f, 87.5f, -3.0f})));
  CHECK_FALSE(diachron::suspected_untagged_nodata(dsm_of({-9999.0f, -9500.0f, -8200.0f})));
  CHECK_FALSE(diachron::suspected_untagged_nodata(dsm_of({-9998.0f, 15.0f})));
  CHECK_FALSE(diachron::suspected_untagged_nodata(dsm_of({nan, nan})));
}
