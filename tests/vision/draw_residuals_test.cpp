// Tests of vision/draw_residuals.hpp: the magnified vector lands where it should, colours follow
// the threshold, the image is kept, bad input throws.
#include <cmath>

#include <catch2/catch.hpp>

#include <opencv2/core.hpp>

#include <diachron/core/error.hpp>
#include <diachron/vision/draw_residuals.hpp>

using namespace diachron;

TEST_CASE("draw_residuals: magnified vectors from each observation, red beyond the threshold", "[vision]") {
  Raster<std::uint8_t> image(200, 100, 0);
  image(5, 95) = 77;  // away from every vector: kept as grey
  DrawResidualsOptions o;
  o.scale = 40.0;
  o.large_px = 1.0;
  // A small residual (0.5 px right -> 20 canvas px) and a large one (1.5 px down -> 60 canvas px).
  const cv::Mat c = draw_residuals(image, {{50.0, 20.0}, {150.0, 20.0}}, {{0.5, 0.0}, {0.0, 1.5}}, o);
  REQUIRE(c.rows == 100);
  REQUIRE(c.cols == 200);
  REQUIRE(c.type() == CV_8UC3);
  const auto pixel = [&](int x, int y) { return c.at<cv::Vec3b>(y, x); };
  // Along the first vector, green; just beyond its tip, nothing.
  CHECK(pixel(60, 20)[1] > 200);
  CHECK(pixel(60, 20)[2] < 50);
  CHECK(pixel(75, 20)[1] < 30);
  // Along the second, red, down to about 20 + 60 = 80.
  CHECK(pixel(150, 70)[2] > 200);
  CHECK(pixel(150, 70)[1] < 50);
  CHECK(pixel(150, 90)[2] < 30);
  // The image itself, grey in all three channels.
  CHECK(pixel(5, 95) == cv::Vec3b(77, 77, 77));
}

TEST_CASE("draw_residuals: bad input", "[vision]") {
  const Raster<std::uint8_t> image(20, 10, 0);
  CHECK_THROWS_AS(draw_residuals(Raster<std::uint8_t>(), {}, {}), Error);
  CHECK_THROWS_AS(draw_residuals(image, {{1.0, 1.0}}, {}), Error);
  CHECK_THROWS_AS(draw_residuals(image, {{1.0, 1.0}}, {{std::nan(""), 0.0}}), Error);
  DrawResidualsOptions o;
  o.scale = 0.0;
  CHECK_THROWS_AS(draw_residuals(image, {}, {}, o), Error);
}
