#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>

TEST_CASE("GeoTransform: pixel (0,0) is the centre of the first cell", "[core]") {
  const auto gt = diachron::GeoTransform::north_up(500000.0, 5000000.0, 10.0);
  const Eigen::Vector2d w = gt.pixel_to_world({0.0, 0.0});
  REQUIRE(w.x() == Approx(500005.0));
  REQUIRE(w.y() == Approx(4999995.0));
  const Eigen::Vector2d w2 = gt.pixel_to_world({2.0, 3.0});
  REQUIRE(w2.x() == Approx(500025.0));
  REQUIRE(w2.y() == Approx(4999965.0));
}

TEST_CASE("GeoTransform: world_to_pixel inverts pixel_to_world, also when rotated", "[core]") {
  diachron::GeoTransform gt{{1000.0, 0.8, 0.6, 2000.0, 0.6, -0.8}};
  for (double x : {-3.5, 0.0, 17.25})
    for (double y : {-1.0, 0.5, 40.0}) {
      const Eigen::Vector2d px(x, y);
      const Eigen::Vector2d back = gt.world_to_pixel(gt.pixel_to_world(px));
      REQUIRE(back.x() == Approx(x).margin(1e-9));
      REQUIRE(back.y() == Approx(y).margin(1e-9));
    }
  REQUIRE(gt.cell_size().x() == Approx(1.0));
}

TEST_CASE("GeoTransform: singular or non-positive cells are rejected", "[core]") {
  diachron::GeoTransform singular{{0, 1, 1, 0, 1, 1}};
  REQUIRE_THROWS_AS(singular.world_to_pixel({1, 1}), diachron::Error);
  REQUIRE_THROWS_AS(diachron::GeoTransform::north_up(0, 0, 0.0), diachron::Error);
}
