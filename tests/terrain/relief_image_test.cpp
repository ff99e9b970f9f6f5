#include <catch2/catch.hpp>

#include <cmath>

#include <diachron/geometry/rotation.hpp>
#include <diachron/terrain/relief_image.hpp>

namespace {

diachron::Dsm bumpy(double cell, double z_scale, double rotation = 0.0) {
  const int n = 120;
  diachron::Raster<float> z(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      // Terrain defined in ground coordinates, so a rotated grid samples the same surface turned.
      const double u = x - n / 2.0, v = y - n / 2.0;
      const double gx = std::cos(rotation) * u - std::sin(rotation) * v;
      const double gy = std::sin(rotation) * u + std::cos(rotation) * v;
      z(x, y) = static_cast<float>(z_scale * (1000.0 + 30.0 * std::exp(-(gx * gx + gy * gy) / 300.0) + 0.5 * gx));
    }
  return diachron::Dsm(std::move(z), diachron::GeoTransform::north_up(0.0, 0.0, cell));
}

}  // namespace

TEST_CASE("slope_image: independent of the frame's scale and of a turn of the terrain", "[terrain]") {
  const auto a = diachron::slope_image(bumpy(1.0, 1.0));
  const auto b = diachron::slope_image(bumpy(3.0, 3.0));  // a similarity scales Z and XY alike
  int differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differ += std::abs(int(a.data()[i]) - int(b.data()[i])) > 1;
  REQUIRE(differ == 0);
  // Slope of a turned terrain, read at the turned position, is the same value.
  const auto c = diachron::slope_image(bumpy(1.0, 1.0, diachron::kPi / 2));
  int bad = 0, n = 0;
  for (int y = 20; y < 100; y += 5)
    for (int x = 20; x < 100; x += 5) {
      ++n;
      // grid (x, y) of the turned terrain shows the ground point of grid (120 - y, x) of the original
      bad += std::abs(int(c(x, y)) - int(a(120 - y, x))) > 6;
    }
  REQUIRE(bad <= n / 10);
}

TEST_CASE("slope_image and local_relief_image: holes get fill and stay out of the statistics", "[terrain]") {
  diachron::Dsm base = bumpy(1.0, 1.0);
  diachron::Raster<float> z = base.heights();
  for (int y = 50; y < 60; ++y)
    for (int x = 50; x < 60; ++x) z(x, y) = std::nanf("");
  const diachron::Dsm holed(std::move(z), base.transform());
  diachron::SlopeImageOptions so;
  so.fill = 7;
  diachron::LocalReliefOptions ro;
  ro.fill = 9;
  const auto s = diachron::slope_image(holed, so);
  const auto r = diachron::local_relief_image(holed, ro);
  REQUIRE(s(55, 55) == 7);
  REQUIRE(r(55, 55) == 9);
  REQUIRE(r(10, 10) != 9);
}

TEST_CASE("local_relief_image: a local peak is bright, a pit dark, a plane mid-gray", "[terrain]") {
  const int n = 60;
  diachron::Raster<float> z(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) z(x, y) = static_cast<float>(500.0 + 2.0 * x + 1.0 * y);
  z(20, 20) += 100.0f;
  z(40, 40) -= 100.0f;
  const diachron::Dsm dsm(std::move(z), diachron::GeoTransform::north_up(0, 0, 1.0));
  const auto r = diachron::local_relief_image(dsm);
  REQUIRE(r(20, 20) > 220);
  REQUIRE(r(40, 40) < 35);
  // On a plane, the box mean equals the centre height where the box is symmetric (peak and pit cancel).
  REQUIRE(std::abs(int(r(30, 30)) - 128) <= 2);
  // Invariant to a height offset and scale of the whole DSM (a frame change).
  diachron::Raster<float> z2 = dsm.heights();
  for (float& v : z2) v = 3.0f * v - 700.0f;
  const auto r2 = diachron::local_relief_image(diachron::Dsm(std::move(z2), diachron::GeoTransform::north_up(0, 0, 3.0)));
  int differ = 0;
  for (std::size_t i = 0; i < r.size(); ++i) differ += std::abs(int(r.data()[i]) - int(r2.data()[i])) > 1;
  REQUIRE(differ == 0);
}

TEST_CASE("multidirectional_hillshade: nearly unchanged by a quarter turn of the terrain", "[terrain]") {
  const auto a = diachron::multidirectional_hillshade(bumpy(1.0, 1.0));
  const auto c = diachron::multidirectional_hillshade(bumpy(1.0, 1.0, diachron::kPi / 2));
  int bad = 0, n = 0;
  for (int y = 20; y < 100; y += 5)
    for (int x = 20; x < 100; x += 5) {
      ++n;
      bad += std::abs(int(c(x, y)) - int(a(120 - y, x))) > 8;
    }
  REQUIRE(bad <= n / 10);
  REQUIRE_THROWS_AS(diachron::multidirectional_hillshade(bumpy(1.0, 1.0), 0), diachron::Error);
}
