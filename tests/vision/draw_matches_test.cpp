// draw_matches: canvas layout, colours by inlier mask, PNG output and errors.
#include <catch2/catch.hpp>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/vision/draw_matches.hpp>

#include "support/temp_folder.hpp"

namespace {

diachron::PointMatch horizontal(double y) {
  diachron::PointMatch m;
  m.a = Eigen::Vector2d(10.0, y);
  m.b = Eigen::Vector2d(50.0, y);  // drawn at x = 50 + width(a)
  return m;
}

cv::Vec3b pixel(const cv::Mat& canvas, int x, int y) { return canvas.at<cv::Vec3b>(y, x); }

// Anti-aliased lines blend slightly with the background: compare channels as high / low.
bool looks(const cv::Vec3b& p, bool blue, bool green, bool red) {
  const auto on = [](std::uint8_t v, bool want) { return want ? v > 200 : v < 60; };
  return on(p[0], blue) && on(p[1], green) && on(p[2], red);
}

}  // namespace

TEST_CASE("draw_matches: side by side canvas, inliers green, outliers red, no mask yellow", "[vision]") {
  const diachron::Raster<std::uint8_t> a(80, 60, 40);
  const diachron::Raster<std::uint8_t> b(100, 40, 90);
  const std::vector<diachron::PointMatch> matches{horizontal(10.0), horizontal(30.0)};
  const std::vector<bool> mask{true, false};
  const cv::Mat canvas = diachron::draw_matches(a, b, matches, mask);
  REQUIRE(canvas.type() == CV_8UC3);
  REQUIRE(canvas.cols == 180);
  REQUIRE(canvas.rows == 60);
  CHECK(pixel(canvas, 5, 50) == cv::Vec3b(40, 40, 40));     // image a
  CHECK(pixel(canvas, 170, 20) == cv::Vec3b(90, 90, 90));   // image b
  CHECK(pixel(canvas, 170, 50) == cv::Vec3b(0, 0, 0));      // padding below the shorter b
  CHECK(looks(pixel(canvas, 70, 10), false, true, false));     // on the inlier line
  CHECK(looks(pixel(canvas, 70, 30), false, false, true));     // on the outlier line

  const cv::Mat plain = diachron::draw_matches(a, b, matches);
  CHECK(looks(pixel(plain, 70, 10), false, true, true));

  diachron::DrawMatchesOptions inliers_only;
  inliers_only.draw_outliers = false;
  const std::vector<std::uint8_t> byte_mask{1, 0};
  const cv::Mat only = diachron::draw_matches(a, b, matches, byte_mask, inliers_only);
  CHECK(looks(pixel(only, 70, 10), false, true, false));
  CHECK(pixel(only, 70, 30) == cv::Vec3b(40, 40, 40));
}

TEST_CASE("write_matches_png: writes a readable PNG; bad input throws diachron::Error", "[vision]") {
  const std::filesystem::path dir = diachron::test::fresh_temp_folder("vision_draw_test");
  const diachron::Raster<std::uint8_t> a(30, 20, 10);
  const diachron::Raster<std::uint8_t> b(30, 25, 200);
  const std::vector<diachron::PointMatch> matches{horizontal(5.0)};
  const std::string path = (dir / "matches.png").string();
  diachron::write_matches_png(path, a, b, matches);
  const cv::Mat back = cv::imread(path, cv::IMREAD_UNCHANGED);
  REQUIRE(back.type() == CV_8UC3);
  CHECK(back.cols == 60);
  CHECK(back.rows == 25);

  CHECK_THROWS_WITH(diachron::draw_matches(a, b, matches, std::vector<bool>{true, false}),
                    Catch::Contains("2 entries for 1 matches"));
  std::vector<diachron::PointMatch> bad = matches;
  bad[0].b.x() = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(diachron::draw_matches(a, b, bad), diachron::Error);
  CHECK_THROWS_AS(diachron::draw_matches(diachron::Raster<std::uint8_t>(), b, matches), diachron::Error);
  const std::string nowhere = (dir / "missing_dir" / "m.png").string();
  CHECK_THROWS_WITH(diachron::write_matches_png(nowhere, a, b, matches), Catch::Contains(nowhere));
  std::filesystem::remove_all(dir);
}
