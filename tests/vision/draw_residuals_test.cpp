// Tests of vision/draw_residuals.hpp: the magnified vector lands where it should, colours follow
// the threshold, the image is kept; the legend (statistics, reference arrow, colours, scale bar) is
// drawn; a large image is shrunk with the magnification relative to the picture; bad input throws.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include <Eigen/Core>
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
  o.legend = false;   // the bare picture of before the legend: the image at its size, and its vectors
  o.max_side_px = 0;
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
  o = DrawResidualsOptions{};
  o.scale = std::nan("");
  CHECK_THROWS_AS(draw_residuals(image, {}, {}, o), Error);
  o = DrawResidualsOptions{};
  o.max_side_px = 300;  // 0 (no shrinking) or >= 400
  CHECK_THROWS_AS(draw_residuals(image, {}, {}, o), Error);
  o.max_side_px = 0;
  CHECK_NOTHROW(draw_residuals(image, {}, {}, o));
}

namespace residleg_test {

int residleg_count(const cv::Mat& picture, const cv::Rect& area, const cv::Vec3b& colour) {
  int n = 0;
  for (int y = area.y; y < area.y + area.height; ++y)
    for (int x = area.x; x < area.x + area.width; ++x) n += picture.at<cv::Vec3b>(y, x) == colour ? 1 : 0;
  return n;
}

bool residleg_greenish(const cv::Vec3b& c) { return c[1] > 150 && c[2] < 100 && c[0] < 100; }

}  // namespace residleg_test

TEST_CASE("draw_residuals: a legend says how to read the picture", "[vision]") {
  using namespace residleg_test;
  const Raster<std::uint8_t> image(600, 400, 128);
  const std::vector<Eigen::Vector2d> pixels{{100.0, 100.0}, {300.0, 200.0}, {500.0, 300.0}};
  const std::vector<Eigen::Vector2d> residuals{{0.3, 0.0}, {0.0, 0.4}, {1.5, 0.0}};
  DrawResidualsOptions o;
  o.title = "e2/IMG_0031.tif, after the adjustment";
  const ResidualPictureLayout l = residual_picture_layout(image, pixels, residuals, o);
  const cv::Mat p = draw_residuals(image, pixels, residuals, o);
  REQUIRE(p.size() == l.picture);
  // The image at its size (600 px fits 1600), below the header, above the legend.
  CHECK(l.image.size() == cv::Size(600, 400));
  CHECK(l.px_per_image_px_x == 1.0);
  CHECK(l.image.y > 3 * 20);
  CHECK(p.rows > l.image.y + l.image.height + 80);
  CHECK(p.at<cv::Vec3b>(l.image.y + 5, l.image.x + 5) == cv::Vec3b(128, 128, 128));
  // The vectors in the picture: 0.3 px x 50 = 15 px right of (100, 100), green.
  const Eigen::Vector2d a = residual_picture_point(l, pixels[0]);
  CHECK(residleg_greenish(p.at<cv::Vec3b>(static_cast<int>(a.y()), static_cast<int>(a.x()) + 10)));
  CHECK(p.at<cv::Vec3b>(static_cast<int>(a.y()), static_cast<int>(a.x()) + 20) == cv::Vec3b(128, 128, 128));
  // Header: the title, the statistics, the magnification.
  REQUIRE(l.header.size() == 3);
  CHECK(l.header[0] == o.title);
  CHECK(l.header[1].find("3 observations; RMS") != std::string::npos);
  CHECK(l.header[1].find("1 >= 1 px (red)") != std::string::npos);
  CHECK(l.header[1].find("max 1.500 px") != std::string::npos);
  CHECK(l.header[2].find("residuals x50") != std::string::npos);
  // The reference arrow: 1 px at x50, 50 picture px of green from its start, nothing beyond.
  CHECK(l.reference_px == 1.0);
  const cv::Point r = l.reference_from;
  CHECK(r.y > l.image.y + l.image.height);
  CHECK(residleg_greenish(p.at<cv::Vec3b>(r.y, r.x + 25)));
  CHECK(residleg_greenish(p.at<cv::Vec3b>(r.y, r.x + 48)));
  CHECK(p.at<cv::Vec3b>(r.y, r.x + 53) == cv::Vec3b(255, 255, 255));
  // The colours' swatches, and the scale bar: a quarter of 600 px, rounded down to 100 px.
  CHECK(residleg_count(p, l.small_swatch, cv::Vec3b(0, 255, 0)) == l.small_swatch.area());
  CHECK(residleg_count(p, l.large_swatch, cv::Vec3b(0, 0, 255)) == l.large_swatch.area());
  CHECK(l.large_swatch.x > l.small_swatch.x + l.small_swatch.width);
  CHECK(l.scale_bar_image_px == 100.0);
  CHECK(l.scale_bar.width == 100);
  CHECK(residleg_count(p, l.scale_bar, cv::Vec3b(0, 0, 0)) == l.scale_bar.area());
  // Text: dark pixels above the image and right of the swatches and arrow.
  CHECK(residleg_count(p, cv::Rect(0, 0, p.cols, l.image.y - 2), cv::Vec3b(0, 0, 0)) > 300);
  // A small picture: the header wraps at its "; ", the picture keeps to max_side_px.
  DrawResidualsOptions narrow = o;
  narrow.max_side_px = 400;
  const ResidualPictureLayout n = residual_picture_layout(image, pixels, residuals, narrow);
  CHECK(n.header.size() > 3);
  CHECK(n.picture.width <= 400);
  CHECK(n.picture.height <= 400);
  CHECK(draw_residuals(image, pixels, residuals, narrow).size() == n.picture);
  // Other magnifications get a round reference drawn about 100 px long.
  o.scale = 500.0;
  CHECK(residual_picture_layout(image, pixels, residuals, o).reference_px == Approx(0.2));
  o.scale = 5.0;
  CHECK(residual_picture_layout(image, pixels, residuals, o).reference_px == 20.0);
}

TEST_CASE("draw_residuals: a large image is shrunk, the magnification stays relative to the picture", "[vision]") {
  using namespace residleg_test;
  const Raster<std::uint8_t> image(6000, 4000, 128);
  const std::vector<Eigen::Vector2d> pixels{{3000.0, 2000.0}, {1000.0, 1000.0}};
  const std::vector<Eigen::Vector2d> residuals{{0.0, 0.8}, {-2.0, 0.0}};
  const ResidualPictureLayout l = residual_picture_layout(image, pixels, residuals);
  const cv::Mat p = draw_residuals(image, pixels, residuals);
  CHECK(std::max(p.cols, p.rows) <= 1600);
  CHECK(std::max(p.cols, p.rows) >= 1400);
  CHECK(l.px_per_image_px_x < 0.3);
  CHECK(l.px_per_image_px_x == Approx(l.px_per_image_px_y).epsilon(0.002));
  // 0.8 px down x50 = 40 picture px (not 40 image px = 10 picture px): green at 30, not at 45.
  const Eigen::Vector2d a = residual_picture_point(l, pixels[0]);
  CHECK(residleg_greenish(p.at<cv::Vec3b>(static_cast<int>(std::lround(a.y())) + 30, static_cast<int>(std::lround(a.x())))));
  CHECK(p.at<cv::Vec3b>(static_cast<int>(std::lround(a.y())) + 45, static_cast<int>(std::lround(a.x()))) ==
        cv::Vec3b(128, 128, 128));
  // 2 px left x50 = 100 picture px, red.
  const Eigen::Vector2d b = residual_picture_point(l, pixels[1]);
  const cv::Vec3b at = p.at<cv::Vec3b>(static_cast<int>(std::lround(b.y())), static_cast<int>(std::lround(b.x())) - 90);
  CHECK(at[2] > 200);
  CHECK(at[1] < 60);
  // The scale bar in image pixels: 1000 px (a quarter of 6000, rounded down) drawn shrunk.
  CHECK(l.scale_bar_image_px == 1000.0);
  CHECK(l.scale_bar.width == static_cast<int>(std::lround(1000.0 * l.px_per_image_px_x)));
  // max_side_px = 0 keeps the image's size.
  DrawResidualsOptions full;
  full.max_side_px = 0;
  const ResidualPictureLayout f = residual_picture_layout(image, pixels, residuals, full);
  CHECK(f.image.size() == cv::Size(6000, 4000));
}
