#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include <ogr_spatialref.h>

#include <diachron/core/error.hpp>
#include <diachron/io/dsm_reproject.hpp>
#include <diachron/terrain/crs_kind.hpp>

using diachron::CrsKind;
using diachron::Dsm;

namespace {

std::string wkt_of(int epsg, const char* format = nullptr) {
  OGRSpatialReference srs;
  REQUIRE(srs.importFromEPSG(epsg) == OGRERR_NONE);
  char* wkt = nullptr;
  const char* options[] = {format, nullptr};
  CPLPushErrorHandler(CPLQuietErrorHandler);  // ESRI's WKT has no geocentric CRS: empty, skipped
  srs.exportToWkt(&wkt, format ? options : nullptr);
  CPLPopErrorHandler();
  const std::string out = wkt ? wkt : "";
  CPLFree(wkt);
  return out;
}

// Heights as a smooth function of longitude and latitude, so that a reprojected cell can be checked
// against the function at its own longitude and latitude.
double height_at(double lon, double lat) { return 800.0 + 3000.0 * (lon - 12.0) - 2000.0 * (lat - 46.0); }

// A 3-arc-second DSM in WGS 84 (like SRTM) around lon 12.1, lat 46.1, with a square hole.
Dsm geographic_dsm() {
  const double cell = 1.0 / 1200.0;
  diachron::Raster<float> z(240, 180);
  diachron::GeoTransform gt;
  gt.c = {12.0, cell, 0.0, 46.2, 0.0, -cell};
  for (int y = 0; y < z.height(); ++y)
    for (int x = 0; x < z.width(); ++x) {
      const double lon = gt.c[0] + (x + 0.5) * cell, lat = gt.c[3] - (y + 0.5) * cell;
      z(x, y) = static_cast<float>(height_at(lon, lat));
      if (x >= 100 && x < 130 && y >= 80 && y < 110) z(x, y) = std::numeric_limits<float>::quiet_NaN();
    }
  return Dsm(std::move(z), gt, wkt_of(4326));
}

}  // namespace

TEST_CASE("crs_kind agrees with OGR on the CRSs DSMs come in, WKT1 and WKT2", "[io][crs]") {
  // 4326 WGS 84, 4979 WGS 84 3D, 4269 NAD83, 32633 UTM 33N, 26910 NAD83 UTM 10N, 2056 Swiss LV95,
  // 3857 web Mercator, 4978 WGS 84 geocentric.
  for (int epsg : {4326, 4979, 4269, 32633, 26910, 2056, 3857, 4978}) {
    OGRSpatialReference srs;
    REQUIRE(srs.importFromEPSG(epsg) == OGRERR_NONE);
    const CrsKind expected = srs.IsProjected()   ? CrsKind::projected
                             : srs.IsGeocentric() ? CrsKind::geocentric
                             : srs.IsGeographic() ? CrsKind::geographic
                                                  : CrsKind::unknown;
    for (const char* format : {static_cast<const char*>(nullptr), "FORMAT=WKT2_2018", "FORMAT=WKT1_ESRI"}) {
      const std::string wkt = wkt_of(epsg, format);
      INFO("EPSG:" << epsg << " " << (format ? format : "WKT1") << ": " << wkt.substr(0, 60));
      if (!wkt.empty()) CHECK(diachron::crs_kind(wkt) == expected);
    }
  }
  // A compound CRS (horizontal + vertical) as GDAL writes it.
  OGRSpatialReference compound;
  REQUIRE(compound.SetFromUserInput("EPSG:32633+5773") == OGRERR_NONE);
  char* wkt = nullptr;
  compound.exportToWkt(&wkt);
  CHECK(diachron::crs_kind(wkt) == CrsKind::projected);
  CPLFree(wkt);
}

TEST_CASE("utm_crs_of names the UTM zone of the DSM's centre", "[io][crs]") {
  CHECK(diachron::utm_crs_of(geographic_dsm()) == "EPSG:32633");  // lon 12.1: zone 33, north
  diachron::GeoTransform south;
  south.c = {-70.5, 0.01, 0.0, -33.0, 0.0, -0.01};  // Santiago de Chile
  CHECK(diachron::utm_crs_of(Dsm(diachron::Raster<float>(10, 10, 500.0f), south, wkt_of(4326))) == "EPSG:32719");
  diachron::GeoTransform utm;
  utm.c = {500000.0, 20.0, 0.0, 5000000.0, 0.0, -20.0};  // already projected: its centre decides
  CHECK(diachron::utm_crs_of(Dsm(diachron::Raster<float>(10, 10, 5.0f), utm, wkt_of(32610))) == "EPSG:32610");
  CHECK_THROWS_WITH(diachron::utm_crs_of(Dsm(diachron::Raster<float>(10, 10, 5.0f), utm)),
                    Catch::Contains("has no CRS"));
}

TEST_CASE("reproject_dsm: a geographic DSM in metres, heights and holes where they belong", "[io][crs]") {
  const Dsm input = geographic_dsm();
  REQUIRE(diachron::crs_kind(input.crs()) == CrsKind::geographic);
  const Dsm out = diachron::reproject_dsm(input, "EPSG:32633");
  CHECK(diachron::crs_kind(out.crs()) == CrsKind::projected);
  // 3 arc seconds are about 64 m east and 93 m north at 46 degrees: square cells of the finer side.
  CHECK(out.transform().c[1] == Approx(64.3).margin(0.5));
  CHECK(std::abs(out.transform().c[5] + out.transform().c[1]) < 1e-9);

  OGRSpatialReference utm, wgs84;
  utm.importFromEPSG(32633);
  wgs84.importFromEPSG(4326);
  utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  const std::unique_ptr<OGRCoordinateTransformation> to_lonlat(OGRCreateCoordinateTransformation(&utm, &wgs84));
  REQUIRE(to_lonlat);
  int checked = 0, holes = 0;
  for (int y = 0; y < out.height(); y += 3)
    for (int x = 0; x < out.width(); x += 3) {
      const Eigen::Vector2d w = out.transform().pixel_to_world(Eigen::Vector2d(x, y));  // cell centre
      double lon = w.x(), lat = w.y();
      REQUIRE(to_lonlat->Transform(1, &lon, &lat));
      const double col = (lon - 12.0) * 1200.0, row = (46.2 - lat) * 1200.0;  // input pixel (edges)
      const bool inside = col > 1.0 && col < 239.0 && row > 1.0 && row < 179.0;
      const bool near_hole = col > 98.0 && col < 132.0 && row > 78.0 && row < 112.0;
      const bool in_hole = col > 101.0 && col < 129.0 && row > 81.0 && row < 109.0;
      if (in_hole) {
        CHECK_FALSE(out.valid(x, y));
        ++holes;
      } else if (inside && !near_hole) {
        REQUIRE(out.valid(x, y));
        // Bilinear resampling of a function linear in longitude and latitude: exact up to float.
        CHECK(std::abs(out.heights()(x, y) - height_at(lon, lat)) < 0.05);
        ++checked;
      }
    }
  CHECK(checked > 1000);
  CHECK(holes > 10);
}

TEST_CASE("dsm_in_metres warps a DSM in degrees to its UTM zone and leaves a projected one alone", "[io][crs]") {
  const Dsm input = geographic_dsm();
  std::string utm = "not cleared";
  const Dsm out = diachron::dsm_in_metres(input, &utm);
  CHECK(utm == "EPSG:32633");
  const Dsm direct = diachron::reproject_dsm(input, "EPSG:32633");
  CHECK(out.crs() == direct.crs());
  CHECK(out.transform().c == direct.transform().c);
  REQUIRE(out.width() == direct.width());
  REQUIRE(out.height() == direct.height());
  int same = 0;
  for (int y = 0; y < out.height(); ++y)
    for (int x = 0; x < out.width(); ++x)
      same += (out.valid(x, y) == direct.valid(x, y)) && (!out.valid(x, y) || out.heights()(x, y) == direct.heights()(x, y));
  CHECK(same == out.width() * out.height());

  // Already in metres: returned as it is, nothing named.
  const Dsm again = diachron::dsm_in_metres(out, &utm);
  CHECK(utm.empty());
  CHECK(again.crs() == out.crs());
  CHECK(again.transform().c == out.transform().c);
  CHECK(diachron::dsm_in_metres(out).width() == out.width());
}

TEST_CASE("reproject_dsm: bad input throws diachron::Error", "[io][crs]") {
  const Dsm input = geographic_dsm();
  CHECK_THROWS_AS(diachron::reproject_dsm(Dsm(input.heights(), input.transform()), "EPSG:32633"), diachron::Error);
  CHECK_THROWS_WITH(diachron::reproject_dsm(input, "EPSG:999999"), Catch::Contains("neither WKT nor a known code"));
  diachron::DsmReprojectOptions bad;
  bad.cell_size = -1.0;
  CHECK_THROWS_WITH(diachron::reproject_dsm(input, "EPSG:32633", bad), Catch::Contains("cell_size"));
  bad = {};
  bad.resampling = "lanczos";
  CHECK_THROWS_WITH(diachron::reproject_dsm(input, "EPSG:32633", bad), Catch::Contains("resampling"));
  diachron::DsmReprojectOptions fixed;
  fixed.cell_size = 90.0;
  const Dsm out = diachron::reproject_dsm(input, "EPSG:32633", fixed);
  CHECK(out.transform().c[1] == Approx(90.0));
}
