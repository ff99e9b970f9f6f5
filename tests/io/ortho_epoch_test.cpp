#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <diachron/camera/epoch_frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/terrain/transfer.hpp>

#include "support/temp_folder.hpp"

namespace {

using diachron::GeoTransform;

// The grey value of orthophoto pixel (x, y): a pattern no two nearby pixels share.
std::uint8_t ortho_test_value(int x, int y) { return static_cast<std::uint8_t>((x * 7 + y * 13 + (x * y) % 11) % 256); }

// Writes a w x h 8-bit orthophoto with `geo` (none when null) and `epsg` (none when 0) to `path`.
void write_test_ortho(const std::string& path, int w, int h, const GeoTransform* geo, int epsg, int bands = 1) {
  diachron::detail::gdal_register_once();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  REQUIRE(driver);
  GDALDataset* ds = driver->Create(path.c_str(), w, h, bands, GDT_Byte, nullptr);
  REQUIRE(ds);
  std::vector<std::uint8_t> v(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) v[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)] = ortho_test_value(x, y);
  for (int b = 1; b <= bands; ++b)
    REQUIRE(ds->GetRasterBand(b)->RasterIO(GF_Write, 0, 0, w, h, v.data(), w, h, GDT_Byte, 0, 0, nullptr) == CE_None);
  if (geo) ds->SetGeoTransform(const_cast<double*>(geo->c.data()));
  if (epsg) {
    OGRSpatialReference srs;
    srs.importFromEPSG(epsg);
    ds->SetSpatialRef(&srs);
  }
  GDALClose(GDALDataset::ToHandle(ds));
}

// A DSM of `cell` units over [x0, x0 + w cell] x [y0 - h cell, y0], heights z(X, Y) = 0.01 X + 100.
void write_test_dsm(const std::string& path, double x0, double y0, double cell, int w, int h, int epsg) {
  diachron::Raster<float> z(w, h);
  const GeoTransform geo = GeoTransform::north_up(x0, y0, cell);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) z(x, y) = static_cast<float>(0.01 * geo.pixel_to_world({x, y}).x() + 100.0);
  std::string crs;
  if (epsg) crs = "EPSG:" + std::to_string(epsg);
  diachron::write_geotiff_dsm(diachron::Dsm(z, geo, crs), path);
}

// An orthophoto epoch folder: a w x h orthophoto of 0.5 units per pixel at (1000, 2000) and a DSM
// over it, both in `epsg_dsm` / `epsg_ortho`.
std::string write_ortho_epoch(const std::string& name, int w, int h, int epsg_ortho = 32631, int epsg_dsm = 32631,
                              const GeoTransform* geo = nullptr) {
  const std::string dir = diachron::test::fresh_temp_folder(name);
  const GeoTransform north_up = GeoTransform::north_up(1000.0, 2000.0, 0.5);
  write_test_ortho(dir + "/ortho.tif", w, h, geo ? geo : &north_up, epsg_ortho);
  write_test_dsm(dir + "/dsm.tif", 990.0, 2010.0, 2.0, w / 4 + 12, h / 4 + 12, epsg_dsm);
  return dir;
}

}  // namespace

TEST_CASE("ortho_tile_spans: tiles cover the side, share at least the overlap, none longer than a tile", "[io]") {
  diachron::OrthoTileOptions options;
  options.tile_px = 100;
  options.overlap_px = 10;
  for (int size : {1, 50, 110, 111, 191, 200, 1000, 1003}) {
    const auto spans = diachron::ortho_tile_spans(size, options);
    REQUIRE(!spans.empty());
    // Every pixel in some tile (brute force), the last tile ends at the side's end.
    std::vector<int> covered(static_cast<std::size_t>(size), 0);
    for (const auto& [start, length] : spans) {
      CHECK(start >= 0);
      CHECK(start + length <= size);
      CHECK(length <= (spans.size() == 1 ? options.tile_px + options.overlap_px : options.tile_px));
      for (int x = start; x < start + length; ++x) ++covered[static_cast<std::size_t>(x)];
    }
    for (int c : covered) CHECK(c >= 1);
    for (std::size_t k = 1; k < spans.size(); ++k)
      CHECK(spans[k - 1].first + spans[k - 1].second - spans[k].first >= options.overlap_px);
  }
  CHECK(diachron::ortho_tile_spans(110, options).size() == 1);  // fits with the overlap
  CHECK(diachron::ortho_tile_spans(111, options).size() == 2);
  options.overlap_px = 50;
  CHECK_THROWS_AS(diachron::ortho_tile_spans(500, options), diachron::Error);
}

TEST_CASE("read_epoch_folder: an orthophoto epoch is its tiles, each a window of the orthophoto with its frame", "[io]") {
  const std::string dir = write_ortho_epoch("ortho_epoch", 300, 140);
  diachron::OrthoTileOptions tiles;
  tiles.tile_px = 128;
  tiles.overlap_px = 16;
  const diachron::EpochFolder e = diachron::read_epoch_folder(dir, {}, tiles);
  REQUIRE(e.is_ortho());
  CHECK(e.model.images.empty());
  // 300 px: 3 tiles of 128 (starts 0, 86, 172); 140 px: one tile (fits in 128 + 16).
  REQUIRE(e.images.size() == 3);
  CHECK(e.images[0].name == "ortho_x0_y0.tif");
  CHECK(e.images[1].name == "ortho_x86_y0.tif");
  CHECK(e.images[2].name == "ortho_x172_y0.tif");
  for (std::size_t i = 0; i < e.images.size(); ++i) {
    const diachron::EpochImage& tile = e.images[i];
    REQUIRE(tile.ortho);
    CHECK(tile.width() == (i == 2 ? 128 : 128));
    CHECK(tile.height() == 140);
    const diachron::Raster<std::uint8_t> pixels = e.load_image(i);
    REQUIRE(pixels.width() == tile.width());
    REQUIRE(pixels.height() == tile.height());
    // Each tile pixel is the orthophoto's pixel at the tile's offset ...
    bool same = true;
    for (int y = 0; y < pixels.height(); ++y)
      for (int x = 0; x < pixels.width(); ++x) same = same && pixels(x, y) == ortho_test_value(x + tile.tile_x, y + tile.tile_y);
    CHECK(same);
    // ... and lies where the orthophoto's geotransform puts that pixel.
    const Eigen::Vector2d world = e.ortho.geo_transform().pixel_to_world({tile.tile_x + 5.0, tile.tile_y + 7.0});
    const std::optional<Eigen::Vector2d> px = tile.epoch_frame().project({world.x(), world.y(), 123.0});
    REQUIRE(px);
    CHECK(px->x() == Approx(5.0).margin(1e-9));
    CHECK(px->y() == Approx(7.0).margin(1e-9));
  }
  // A colour orthophoto reads as grey.
  const std::string rgb = diachron::test::fresh_temp_folder("ortho_epoch_rgb");
  const GeoTransform geo = GeoTransform::north_up(1000.0, 2000.0, 0.5);
  write_test_ortho(rgb + "/ortho.tif", 60, 40, &geo, 32631, 3);
  write_test_dsm(rgb + "/dsm.tif", 990.0, 2010.0, 2.0, 30, 30, 32631);
  const diachron::EpochFolder c = diachron::read_epoch_folder(rgb);
  REQUIRE(c.images.size() == 1);
  CHECK(c.load_image(0)(3, 4) == ortho_test_value(3, 4));
}

TEST_CASE("Orthophoto tiles transfer through the DSM like photos: ortho to ortho in one frame is the geotransforms", "[io]") {
  const std::string dir = write_ortho_epoch("ortho_transfer", 200, 100);
  diachron::OrthoTileOptions tiles;
  tiles.tile_px = 64;
  tiles.overlap_px = 8;
  const diachron::EpochFolder e = diachron::read_epoch_folder(dir, {}, tiles);
  REQUIRE(e.images.size() > 2);
  const diachron::EpochFrame a = e.images[0].epoch_frame(), b = e.images[1].epoch_frame();
  const auto transfer = diachron::make_dsm_transfer(a, e.dsm, b);
  // Pixel (60, 30) of tile 0 is orthophoto pixel (60, 30), hence tile 1's (60 - x1, 30 - y1).
  const std::optional<Eigen::Vector2d> p = transfer(Eigen::Vector2d(60.0, 30.0));
  REQUIRE(p);
  CHECK(p->x() == Approx(60.0 - e.images[1].tile_x).margin(1e-6));
  CHECK(p->y() == Approx(30.0 - e.images[1].tile_y).margin(1e-6));
  // The lifted point lies on the DSM: z = 0.01 X + 100.
  const std::optional<Eigen::Vector3d> x = transfer.master_point(Eigen::Vector2d(60.0, 30.0));
  REQUIRE(x);
  CHECK(x->z() == Approx(0.01 * x->x() + 100.0).margin(1e-3));
}

TEST_CASE("read_epoch_folder refuses orthophotos it cannot trust, naming the remedy", "[io]") {
  // No geotransform.
  const std::string none = diachron::test::fresh_temp_folder("ortho_no_geo");
  write_test_ortho(none + "/ortho.tif", 40, 30, nullptr, 0);
  write_test_dsm(none + "/dsm.tif", 0.0, 30.0, 1.0, 40, 30, 0);
  CHECK_THROWS_WITH(diachron::read_epoch_folder(none), Catch::Contains("no geotransform"));
  // A rotated geotransform.
  GeoTransform rotated = GeoTransform::north_up(1000.0, 2000.0, 0.5);
  rotated.c[2] = 0.1;
  const std::string rot = write_ortho_epoch("ortho_rotated", 40, 30, 32631, 32631, &rotated);
  CHECK_THROWS_WITH(diachron::read_epoch_folder(rot), Catch::Contains("rotated"));
  // Another CRS than its DSM.
  const std::string crs = write_ortho_epoch("ortho_crs", 40, 30, 32631, 32632);
  CHECK_THROWS_WITH(diachron::read_epoch_folder(crs), Catch::Contains("different CRS"));
  // Both a model and an orthophoto.
  const std::string both = write_ortho_epoch("ortho_and_model", 40, 30);
  std::ofstream(both + "/images.txt") << "# nothing\n";
  CHECK_THROWS_WITH(diachron::read_epoch_folder(both), Catch::Contains("both a COLMAP model and ortho.tif"));
}

TEST_CASE("read_raster_georeference and same_crs", "[io]") {
  const std::string dir = write_ortho_epoch("ortho_georeference", 50, 20);
  const diachron::RasterGeoreference g = diachron::read_raster_georeference(dir + "/ortho.tif");
  CHECK(g.width == 50);
  CHECK(g.height == 20);
  CHECK(g.has_geotransform);
  CHECK(g.transform.c[1] == 0.5);
  CHECK(diachron::same_crs(g.crs, diachron::read_geotiff_dsm(dir + "/dsm.tif").crs()));
  CHECK(diachron::same_crs("", ""));
  CHECK_FALSE(diachron::same_crs(g.crs, ""));
  CHECK_THROWS_WITH(diachron::read_raster_georeference(dir + "/nothing.tif"), Catch::Contains("no such file"));
}
