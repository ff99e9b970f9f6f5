// Tests for matching/grid_interest_points.hpp: one strongest point per cell, against a brute-force
// structure tensor; flat images give none; edges (one gradient direction) are weak.

#include <cmath>
#include <cstdint>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/grid_interest_points.hpp>

#include "support/rasters.hpp"

using diachron::GridInterestOptions;
using diachron::InterestPoint;
using diachron::Raster;

namespace {

Raster<std::uint8_t> noise(int w, int h, std::uint64_t seed) { return diachron::test::uniform_noise_image(w, h, seed); }

// Smallest structure-tensor eigenvalue per pixel over the window, computed directly.
double brute_strength(const Raster<std::uint8_t>& img, int x, int y, int window) {
  double a = 0, b = 0, c = 0;
  for (int j = -window / 2; j <= window / 2; ++j)
    for (int i = -window / 2; i <= window / 2; ++i) {
      const int u = x + i, v = y + j;
      const double gx = 0.5 * (double(img(u + 1, v)) - img(u - 1, v)), gy = 0.5 * (double(img(u, v + 1)) - img(u, v - 1));
      a += gx * gx;
      b += gx * gy;
      c += gy * gy;
    }
  const double n = double(window) * window;
  a /= n;
  b /= n;
  c /= n;
  return 0.5 * (a + c) - std::sqrt(0.25 * (a - c) * (a - c) + b * b);
}

}  // namespace

TEST_CASE("grid interest points: the strongest pixel of each cell, by brute force", "[grid_interest_points]") {
  const Raster<std::uint8_t> img = noise(90, 70, 5);
  GridInterestOptions o;
  o.cell_px = 30;
  o.window_px = 5;
  o.min_strength = 0.0;
  const std::vector<InterestPoint> points = diachron::grid_interest_points(img, o);
  REQUIRE(points.size() == 9);  // 3 x 3 cells
  for (const InterestPoint& p : points) {
    const int cx = static_cast<int>(p.position.x()) / 30, cy = static_cast<int>(p.position.y()) / 30;
    double best = -1.0;
    for (int y = std::max(3, cy * 30); y < std::min(70 - 3, cy * 30 + 30); ++y)
      for (int x = std::max(3, cx * 30); x < std::min(90 - 3, cx * 30 + 30); ++x)
        best = std::max(best, brute_strength(img, x, y, 5));
    CHECK(p.strength == Approx(best).epsilon(1e-9));
    CHECK(brute_strength(img, int(p.position.x()), int(p.position.y()), 5) == Approx(best).epsilon(1e-9));
  }
  // Deterministic.
  const std::vector<InterestPoint> again = diachron::grid_interest_points(img, o);
  REQUIRE(again.size() == points.size());
  for (std::size_t k = 0; k < points.size(); ++k) CHECK(again[k].position == points[k].position);
}

TEST_CASE("grid interest points: odd cells, window and border, every cell against brute force",
          "[grid_interest_points]") {
  // Cells that do not divide the image, a border wider than the window's half: the row bands the
  // sums are built in must give each cell's first strongest pixel, exactly (8-bit sums are exact).
  const Raster<std::uint8_t> img = noise(73, 58, 11);
  GridInterestOptions o;
  o.cell_px = 7;
  o.window_px = 9;
  o.border_px = 6;
  o.min_strength = 0.0;
  const std::vector<InterestPoint> points = diachron::grid_interest_points(img, o);
  std::vector<InterestPoint> expected;
  for (int cy = 0; cy * 7 < 58; ++cy)
    for (int cx = 0; cx * 7 < 73; ++cx) {
      InterestPoint best;
      best.strength = -1.0;
      for (int y = std::max(6, cy * 7); y < std::min(58 - 6, cy * 7 + 7); ++y)
        for (int x = std::max(6, cx * 7); x < std::min(73 - 6, cx * 7 + 7); ++x) {
          const double s = brute_strength(img, x, y, 9);
          if (s > best.strength + 1e-9) best.strength = s, best.position = Eigen::Vector2d(x, y);
        }
      if (best.strength >= 0.0) expected.push_back(best);
    }
  REQUIRE(points.size() == expected.size());
  CHECK(points.size() == 10 * 8);  // the cells holding a pixel 6 px or more from the edges
  for (std::size_t k = 0; k < points.size(); ++k) {
    CHECK(points[k].position == expected[k].position);
    CHECK(points[k].strength == Approx(expected[k].strength).epsilon(1e-12));
  }
}

TEST_CASE("grid interest points: flat images and straight edges give none", "[grid_interest_points]") {
  const Raster<std::uint8_t> flat(64, 64, 90);
  CHECK(diachron::grid_interest_points(flat).empty());
  Raster<std::uint8_t> edge(64, 64, 20);
  for (int y = 0; y < 64; ++y)
    for (int x = 32; x < 64; ++x) edge(x, y) = 220;
  // One gradient direction only: the smallest eigenvalue is zero.
  CHECK(diachron::grid_interest_points(edge).empty());
  // A corner is found, in the cell that holds it.
  Raster<std::uint8_t> corner(64, 64, 20);
  for (int y = 32; y < 64; ++y)
    for (int x = 32; x < 64; ++x) corner(x, y) = 220;
  GridInterestOptions o;
  o.cell_px = 64;
  o.window_px = 5;
  const std::vector<InterestPoint> p = diachron::grid_interest_points(corner, o);
  REQUIRE(p.size() == 1);
  CHECK(std::abs(p[0].position.x() - 31.5) <= 1.5);
  CHECK(std::abs(p[0].position.y() - 31.5) <= 1.5);
}

TEST_CASE("grid interest points: bad options throw, tiny images give none", "[grid_interest_points]") {
  const Raster<std::uint8_t> img = noise(40, 40, 1);
  GridInterestOptions o;
  o.window_px = 4;
  CHECK_THROWS_AS(diachron::grid_interest_points(img, o), diachron::Error);
  o = {};
  o.cell_px = 1;
  CHECK_THROWS_AS(diachron::grid_interest_points(img, o), diachron::Error);
  o = {};
  o.min_strength = std::nan("");
  CHECK_THROWS_AS(diachron::grid_interest_points(img, o), diachron::Error);
  CHECK(diachron::grid_interest_points(Raster<std::uint8_t>()).empty());
  CHECK(diachron::grid_interest_points(noise(10, 10, 2)).empty());  // smaller than one 15 px window
}
