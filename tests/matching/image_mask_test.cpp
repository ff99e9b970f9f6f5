// ImageMask (matching/image_mask.hpp) against brute force: the box test and the erosion on random
// masks of every shape, including masks smaller than the box; the allowed centres of
// grid_interest_points.

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/matching/grid_interest_points.hpp>
#include <diachron/matching/image_mask.hpp>

#include "support/rasters.hpp"

using namespace diachron;

namespace {

// Random 0 / 255 pixels, a share `holes` of them 0.
Raster<std::uint8_t> random_mask(int w, int h, double holes, std::uint64_t seed) {
  RandomStream random(seed, 0);
  Raster<std::uint8_t> mask(w, h, 255);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (random.uniform(0.0, 1.0) < holes) mask(x, y) = 0;
  return mask;
}

// Written differently from the class: every pixel of the box looked at, inside or not.
bool brute_box_usable(const Raster<std::uint8_t>& mask, int cx, int cy, int half) {
  for (int dy = -half; dy <= half; ++dy)
    for (int dx = -half; dx <= half; ++dx) {
      const int x = cx + dx, y = cy + dy;
      if (x < 0 || y < 0 || x >= mask.width() || y >= mask.height() || mask(x, y) == 0) return false;
    }
  return true;
}

}  // namespace

TEST_CASE("ImageMask: box test and erosion against brute force", "[matching][mask]") {
  std::uint64_t seed = 1;
  for (const int w : {1, 4, 17, 40})
    for (const int h : {1, 5, 23})
      for (const double holes : {0.0, 0.01, 0.1})
        for (const int half : {0, 1, 3, 10}) {
          const Raster<std::uint8_t> raster = random_mask(w, h, holes, seed++);
          const ImageMask mask(raster);
          const Raster<std::uint8_t> eroded = mask.eroded(half);
          REQUIRE(eroded.width() == w);
          REQUIRE(eroded.height() == h);
          for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
              const bool expected = brute_box_usable(raster, x, y, half);
              INFO(w << " x " << h << ", holes " << holes << ", half " << half << ", pixel " << x << ", " << y);
              REQUIRE(mask.box_usable(Eigen::Vector2d(x, y), half) == expected);
              REQUIRE((eroded(x, y) != 0) == expected);
              if (half == 0) REQUIRE(mask.usable(Eigen::Vector2d(x, y)) == (raster(x, y) != 0));
            }
        }
}

TEST_CASE("ImageMask: positions, empty masks and sizes", "[matching][mask]") {
  Raster<std::uint8_t> raster(10, 8, 1);
  raster(4, 3) = 0;
  const ImageMask mask(raster);
  // The pixel containing a position: (3.6, 2.6) lies in pixel (4, 3), (4.4, 3.49) too, (4.6, 3) not.
  CHECK_FALSE(mask.usable(Eigen::Vector2d(3.6, 2.6)));
  CHECK_FALSE(mask.usable(Eigen::Vector2d(4.4, 3.49)));
  CHECK(mask.usable(Eigen::Vector2d(4.6, 3.0)));
  // Outside the image, or not a position at all.
  CHECK_FALSE(mask.usable(Eigen::Vector2d(-0.6, 2.0)));
  CHECK(mask.usable(Eigen::Vector2d(-0.4, 2.0)));
  CHECK_FALSE(mask.usable(Eigen::Vector2d(9.6, 2.0)));
  CHECK_FALSE(mask.usable(Eigen::Vector2d(std::numeric_limits<double>::quiet_NaN(), 2.0)));

  const ImageMask none;
  CHECK(none.empty());
  CHECK(none.usable(Eigen::Vector2d(1e6, -1e6)));
  CHECK(none.box_usable(Eigen::Vector2d(0, 0), 50));
  CHECK(none.eroded(3).empty());
  CHECK_NOTHROW(none.check_size(640, 480, "image a"));

  CHECK_NOTHROW(mask.check_size(10, 8, "image a"));
  CHECK_THROWS_WITH(mask.check_size(8, 10, "image a"),
                    Catch::Contains("the mask of image a is 10 x 8 px, the image 8 x 10"));
  CHECK_THROWS_WITH(mask.box_usable(Eigen::Vector2d(1, 1), -1), Catch::Contains("half_px must be >= 0"));
  CHECK_THROWS_WITH(mask.eroded(-2), Catch::Contains("half_px must be >= 0"));
}

TEST_CASE("grid_interest_points: the strongest allowed point of each cell", "[matching][mask]") {
  const Raster<std::uint8_t> image = diachron::test::uniform_noise_image(96, 64, 7);
  GridInterestOptions options;
  options.cell_px = 16;
  options.window_px = 7;
  options.min_strength = 0.0;
  const std::vector<InterestPoint> all = grid_interest_points(image, options);
  REQUIRE(all.size() >= 12);
  // Everything allowed: the same points.
  const Raster<std::uint8_t> everywhere(96, 64, 1);
  const std::vector<InterestPoint> same = grid_interest_points(image, options, &everywhere);
  REQUIRE(same.size() == all.size());
  for (std::size_t i = 0; i < all.size(); ++i) CHECK(same[i].position == all[i].position);
  // Forbid each cell's best pixel: every cell still has a point, another one, never a forbidden one,
  // and it is the strongest of the rest (each point's strength is its own, whatever the mask).
  Raster<std::uint8_t> allowed(96, 64, 1);
  for (const InterestPoint& p : all) allowed(static_cast<int>(p.position.x()), static_cast<int>(p.position.y())) = 0;
  const std::vector<InterestPoint> others = grid_interest_points(image, options, &allowed);
  REQUIRE(others.size() == all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    CHECK(others[i].position != all[i].position);
    CHECK(allowed(static_cast<int>(others[i].position.x()), static_cast<int>(others[i].position.y())) == 1);
    CHECK(others[i].strength <= all[i].strength);
  }
  // Nothing allowed: no point.
  const Raster<std::uint8_t> nowhere(96, 64, 0);
  CHECK(grid_interest_points(image, options, &nowhere).empty());
  const Raster<std::uint8_t> small(10, 10, 1);
  CHECK_THROWS_WITH(grid_interest_points(image, options, &small), Catch::Contains("allowed_centres is 10 x 10"));
}
