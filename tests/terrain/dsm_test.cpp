// Tests of diachron::Dsm: construction checks, bilinear look-up, holes, statistics, bounds.
#include <cmath>
#include <limits>

#include <catch2/catch.hpp>

#include <diachron/terrain/dsm.hpp>

using diachron::Dsm;
using diachron::GeoTransform;
using diachron::Raster;

namespace {

// A 20 x 15 DSM of the plane Z = 100 + 0.5 X - 0.25 Y over a 2 m grid whose corner is at (1000, 5000).
Dsm plane_dsm() {
  const GeoTransform gt = GeoTransform::north_up(1000.0, 5000.0, 2.0);
  Raster<float> z(20, 15);
  for (int y = 0; y < 15; ++y)
    for (int x = 0; x < 20; ++x) {
      const Eigen::Vector2d w = gt.pixel_to_world({x, y});
      z(x, y) = static_cast<float>(100.0 + 0.5 * (w.x() - 1000.0) - 0.25 * (w.y() - 5000.0));
    }
  return Dsm(std::move(z), gt, "EPSG:32633");
}

double plane(double X, double Y) { return 100.0 + 0.5 * (X - 1000.0) - 0.25 * (Y - 5000.0); }

}  // namespace

TEST_CASE("Dsm: construction checks", "[terrain]") {
  const GeoTransform gt = GeoTransform::north_up(0, 0, 1);
  CHECK_THROWS_AS(Dsm(Raster<float>(0, 3), gt), diachron::Error);
  GeoTransform singular{{0, 1, 2, 0, 0.5, 1}};
  CHECK_THROWS_AS(Dsm(Raster<float>(2, 2), singular), diachron::Error);
  GeoTransform nan_gt{{0, 1, 0, std::nan(""), 0, -1}};
  CHECK_THROWS_AS(Dsm(Raster<float>(2, 2), nan_gt), diachron::Error);
  Raster<float> z(2, 2, 1.0f);
  z(1, 1) = std::numeric_limits<float>::infinity();
  const Dsm dsm(z, gt);
  CHECK(std::isnan(dsm.heights()(1, 1)));
  CHECK_FALSE(dsm.valid(1, 1));
  CHECK(dsm.valid(0, 0));
  CHECK_FALSE(dsm.valid(2, 0));
  CHECK(dsm.statistics().count == 3);
  CHECK(Dsm().empty());
  CHECK(std::isnan(Dsm().height_at(0, 0)));
}

TEST_CASE("Dsm: bilinear height is exact on a plane", "[terrain]") {
  const Dsm dsm = plane_dsm();
  CHECK(dsm.cell_size().x() == Approx(2.0));
  CHECK(dsm.min_cell_size() == Approx(2.0));
  CHECK(dsm.crs() == "EPSG:32633");
  // Pixel (0, 0) is the centre of the first cell: (1001, 4999).
  CHECK(dsm.height_at(1001.0, 4999.0) == Approx(plane(1001, 4999)).margin(1e-4));
  for (double X = 1001.0; X <= 1039.0; X += 0.37)
    for (double Y = 4971.0; Y <= 4999.0; Y += 0.53) {
      INFO("X " << X << " Y " << Y);
      REQUIRE(dsm.height_at(X, Y) == Approx(plane(X, Y)).margin(1e-4));
    }
  // The last pixel centres are inside; beyond them (the outer half cell) is NaN.
  CHECK(dsm.height_at(1039.0, 4971.0) == Approx(plane(1039, 4971)).margin(1e-4));
  CHECK(std::isnan(dsm.height_at(1039.5, 4980.0)));
  CHECK(std::isnan(dsm.height_at(1000.5, 4980.0)));
  CHECK(std::isnan(dsm.height_at(1020.0, 4999.5)));
  CHECK(std::isnan(dsm.height_at(std::nan(""), 4980.0)));
  CHECK(std::isnan(dsm.height_at(1e300, 4980.0)));
}

TEST_CASE("Dsm: holes give NaN nearby, never garbage", "[terrain]") {
  Raster<float> z(6, 6, 10.0f);
  z(3, 3) = std::numeric_limits<float>::quiet_NaN();
  const Dsm dsm(z, GeoTransform::north_up(0, 6, 1));
  // In each of the four cells around the hole: NaN.
  for (double dx : {-0.5, 0.5})
    for (double dy : {-0.5, 0.5}) CHECK(std::isnan(dsm.height_at_pixel({3 + dx, 3 + dy})));
  CHECK(std::isnan(dsm.height_at_pixel({3.0, 3.0})));
  // A pixel centre next to the hole keeps its value; so does the edge shared with a hole cell.
  CHECK(dsm.height_at_pixel({2.0, 3.0}) == 10.0);
  CHECK(dsm.height_at_pixel({2.0, 2.5}) == 10.0);
  // One cell away it is valid.
  CHECK(dsm.height_at_pixel({1.5, 1.5}) == 10.0);
  CHECK(dsm.height_at_pixel({4.5, 1.5}) == 10.0);
}

TEST_CASE("Dsm: statistics over valid pixels and bounds", "[terrain]") {
  Raster<float> z(3, 2);
  const float values[6] = {1, 2, 3, 4, std::numeric_limits<float>::quiet_NaN(), 10};
  for (int i = 0; i < 6; ++i) z.data()[i] = values[i];
  const Dsm dsm(z, GeoTransform::north_up(500, 200, 10));
  const auto& s = dsm.statistics();
  CHECK(s.count == 5);
  CHECK(s.mean == Approx(4.0));
  CHECK(s.std == Approx(std::sqrt((9 + 4 + 1 + 0 + 36) / 5.0)));
  CHECK(s.min == 1.0);
  CHECK(s.max == 10.0);
  const auto b = dsm.bounds();
  CHECK(b.min_x == Approx(500));
  CHECK(b.max_x == Approx(530));
  CHECK(b.min_y == Approx(180));
  CHECK(b.max_y == Approx(200));
  CHECK(dsm.contains(500.1, 199.9));
  CHECK(dsm.contains(529.9, 180.1));
  CHECK_FALSE(dsm.contains(530.1, 190));
  CHECK_FALSE(dsm.contains(510, 200.1));

  Raster<float> holes(2, 2, std::numeric_limits<float>::quiet_NaN());
  const Dsm empty_stats(holes, GeoTransform::north_up(0, 0, 1));
  CHECK(empty_stats.statistics().count == 0);
  CHECK(std::isnan(empty_stats.statistics().mean));
}

TEST_CASE("Dsm: rotated geotransform", "[terrain]") {
  // 30 degree rotated grid: heights = X so bilinear must reproduce X wherever defined.
  const double c = std::cos(0.5), s = std::sin(0.5);
  GeoTransform gt{{100, 2 * c, -2 * s, 50, 2 * s, 2 * c}};
  Raster<float> z(10, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) z(x, y) = static_cast<float>(gt.pixel_to_world({x, y}).x());
  const Dsm dsm(z, gt);
  const Eigen::Vector2d w = gt.pixel_to_world({4.3, 6.8});
  CHECK(dsm.height_at(w) == Approx(w.x()).margin(1e-4));
  CHECK(dsm.cell_size().x() == Approx(2.0));
  CHECK(dsm.contains(w.x(), w.y()));
}
