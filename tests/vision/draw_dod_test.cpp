// draw_dod: the colour of known cells, no data in grey, the colour bar beside the map, the range
// option, the percentile default keeping a dome of a few metres visible beside changed buildings, the
// picture's size limits, the PNG and bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <diachron/core/error.hpp>
#include <diachron/vision/draw_dod.hpp>

#include "support/temp_folder.hpp"

using namespace diachron;

namespace draw_dod_test {

// The picture's pixel at the centre of map cell (x, y).
cv::Vec3b at_cell(const cv::Mat& picture, const DodPictureLayout& l, int x, int y) {
  const int px = l.map.x + static_cast<int>((x + 0.5) * l.px_per_cell_x);
  const int py = l.map.y + static_cast<int>((y + 0.5) * l.px_per_cell_y);
  return picture.at<cv::Vec3b>(py, px);
}

bool is_grey(const cv::Vec3b& c) { return c[0] == c[1] && c[1] == c[2]; }

// 40 x 30 cells of 2 m: dZ = -2 in the left third, 0 in the middle, +2 in the right third, a hole.
Dsm thirds() {
  Raster<float> z(40, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) z(x, y) = x < 13 ? -2.0f : x < 27 ? 0.0f : 2.0f;
  for (int y = 5; y < 10; ++y)
    for (int x = 15; x < 20; ++x) z(x, y) = std::numeric_limits<float>::quiet_NaN();
  return Dsm(std::move(z), GeoTransform::north_up(1000.0, 5000.0, 2.0));
}

}  // namespace draw_dod_test

using namespace draw_dod_test;

TEST_CASE("dod_colour: white at 0, red above, blue below, saturated beyond the range, grey for no data", "[vision]") {
  CHECK(dod_colour(0.0, 2.0) == cv::Vec3b(255, 255, 255));
  const cv::Vec3b up = dod_colour(2.0, 2.0), down = dod_colour(-2.0, 2.0);  // BGR
  CHECK(up[2] > 90);
  CHECK(up[0] < 40);
  CHECK(down[0] > 90);
  CHECK(down[2] < 10);
  CHECK(dod_colour(5.0, 2.0) == up);
  CHECK(dod_colour(-5.0, 2.0) == down);
  // Paler towards 0 (green channel rises), each side.
  CHECK(dod_colour(0.5, 2.0)[1] > dod_colour(1.0, 2.0)[1]);
  CHECK(dod_colour(-0.5, 2.0)[1] > dod_colour(-1.0, 2.0)[1]);
  CHECK(dod_colour(std::nan(""), 2.0) == kDodNoDataColour);
  CHECK(is_grey(kDodNoDataColour));
  for (double v = -3.0; v <= 3.0; v += 0.01) CHECK_FALSE(dod_colour(v, 2.0) == kDodNoDataColour);
  CHECK_THROWS_AS(dod_colour(1.0, 0.0), Error);
}

TEST_CASE("draw_dod: known cells in their colours, no data grey, colour bar and scale bar beside the map", "[vision]") {
  const Dsm dz = thirds();
  DrawDodOptions o;
  o.range_m = 2.0;
  o.title = "e1 - e3, rough";
  const DodPictureLayout l = dod_picture_layout(dz, o);
  const cv::Mat p = draw_dod(dz, o);
  REQUIRE(p.type() == CV_8UC3);
  REQUIRE(p.size() == l.picture);
  // A small map is enlarged by an integer factor to at least 600 px, cells as blocks.
  CHECK(l.map.width == 600);
  CHECK(l.map.height == 450);
  CHECK(l.px_per_cell_x == 15.0);
  CHECK(std::max(p.cols, p.rows) <= 1600);
  CHECK(at_cell(p, l, 2, 20) == dod_colour(-2.0, 2.0));
  CHECK(at_cell(p, l, 20, 20) == cv::Vec3b(255, 255, 255));
  CHECK(at_cell(p, l, 35, 3) == dod_colour(2.0, 2.0));
  CHECK(at_cell(p, l, 17, 7) == kDodNoDataColour);
  // The legend: the picture is wider than the map and its bar, right of the map, runs red to blue.
  CHECK(p.cols > l.map.x + l.map.width + 100);
  CHECK(l.colour_bar.x > l.map.x + l.map.width);
  const cv::Vec3b top = p.at<cv::Vec3b>(l.colour_bar.y, l.colour_bar.x + 5);
  const cv::Vec3b bottom = p.at<cv::Vec3b>(l.colour_bar.y + l.colour_bar.height - 1, l.colour_bar.x + 5);
  const cv::Vec3b middle = p.at<cv::Vec3b>(l.colour_bar.y + l.colour_bar.height / 2, l.colour_bar.x + 5);
  CHECK(top[2] > 90);
  CHECK(top[0] < 40);
  CHECK(bottom[0] > 90);
  CHECK(bottom[2] < 10);
  CHECK(middle[0] > 240);
  CHECK(middle[1] > 240);
  CHECK(middle[2] > 240);
  // Tick labels right of the bar, text above the map: dark pixels there.
  const auto dark_pixels = [&](const cv::Rect& r) {
    int n = 0;
    for (int y = r.y; y < r.y + r.height; ++y)
      for (int x = r.x; x < r.x + r.width; ++x) {
        const cv::Vec3b c = p.at<cv::Vec3b>(y, x);
        n += (c[0] < 80 && c[1] < 80 && c[2] < 80) ? 1 : 0;
      }
    return n;
  };
  const int labels_x = l.colour_bar.x + l.colour_bar.width + 8;
  CHECK(dark_pixels(cv::Rect(labels_x, l.colour_bar.y, p.cols - labels_x, l.colour_bar.height)) > 50);
  CHECK(dark_pixels(cv::Rect(0, 0, p.cols, l.map.y - 2)) > 300);
  // Scale bar: 2 m cells at 15 px -> a round length near a quarter of the 80 m map.
  CHECK(l.scale_bar_ground == 20.0);
  CHECK(l.scale_bar.width == 150);
  CHECK(p.at<cv::Vec3b>(l.scale_bar.y + 1, l.scale_bar.x + 75) == cv::Vec3b(0, 0, 0));
  CHECK(l.scale_bar.y > l.map.y + l.map.height);
  // Statistics in the header: the title, all cells, the colour range.
  REQUIRE(l.header.size() == 3);
  CHECK(l.header[0] == "e1 - e3, rough");
  CHECK(l.header[1].find("median") != std::string::npos);
  CHECK(l.header[1].find("NMAD") != std::string::npos);
  CHECK(l.header[2].find("fixed") != std::string::npos);
}

TEST_CASE("draw_dod: the range option changes the colours, the default comes from the percentile", "[vision]") {
  const Dsm dz = thirds();
  DrawDodOptions wide;
  wide.range_m = 4.0;
  const DodPictureLayout l = dod_picture_layout(dz, wide);
  const cv::Mat p = draw_dod(dz, wide);
  CHECK(at_cell(p, l, 35, 3) == dod_colour(2.0, 4.0));
  CHECK_FALSE(at_cell(p, l, 35, 3) == dod_colour(2.0, 2.0));
  // |dZ| is 2 on two thirds of the cells: every percentile above a third gives 2.
  CHECK(dod_colour_range(dz) == 2.0);
  DrawDodOptions low;
  low.percentile = 20.0;  // within the zero third: falls back to the largest |dZ|
  CHECK(dod_colour_range(dz, low) == 2.0);
  const Dsm zero(Raster<float>(5, 5, 0.0f), GeoTransform::north_up(0.0, 0.0, 1.0));
  CHECK(dod_colour_range(zero) == 1.0);
  const Dsm nothing(Raster<float>(5, 5, std::numeric_limits<float>::quiet_NaN()), GeoTransform::north_up(0.0, 0.0, 1.0));
  CHECK(dod_colour_range(nothing) == 1.0);
  const cv::Mat grey = draw_dod(nothing);  // drawn all grey, "no valid cell" in the header
  CHECK(at_cell(grey, dod_picture_layout(nothing), 2, 2) == kDodNoDataColour);
  CHECK(dod_picture_layout(nothing).header[0].find("no valid cell") != std::string::npos);
}

TEST_CASE("draw_dod: a dome of 3 m beside changed buildings of 12 m is not washed out by the default", "[vision]") {
  // A systematic dome (a co-registration error) over the whole map, and 2 % of the cells changed by
  // 12 m (buildings). A range from the largest |dZ| would leave the dome pale pink.
  const int w = 200, h = 150;
  Raster<float> z(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double dx = (x - w / 2.0) / (w / 2.0), dy = (y - h / 2.0) / (h / 2.0);
      z(x, y) = static_cast<float>(3.0 * (1.0 - 0.5 * (dx * dx + dy * dy)));
    }
  int changed = 0;
  for (int y = 10; y < h; y += 30)
    for (int x = 10; x < w; x += 40)
      for (int j = 0; j < 5; ++j)
        for (int i = 0; i < 5; ++i, ++changed) z(x + i, y + j) = 12.0f;
  REQUIRE(changed < w * h / 40);
  const Dsm dz(std::move(z), GeoTransform::north_up(0.0, 0.0, 1.0));
  const double range = dod_colour_range(dz);
  CHECK(range > 0.85 * 3.0);
  CHECK(range < 3.0);
  const DodPictureLayout l = dod_picture_layout(dz);
  const cv::Mat p = draw_dod(dz);
  const cv::Vec3b saturated = dod_colour(1e9, 1.0);
  // The dome keeps its gradation: its half height (at the corners' 1.5 m ... ) is a mid red, below the
  // top not saturated; the buildings are.
  const cv::Vec3b half = at_cell(p, l, 0, h / 2);  // dZ = 3 (1 - 0.5) = 1.5 m
  CHECK(half[1] < 200);                            // not pale
  CHECK(half[1] > 60);                             // not saturated
  CHECK(half[2] > 200);
  for (int x = 0; x < w; x += 7) {
    const double v = dz.heights()(x, h / 2 + 3);
    if (v < 0.95 * range) CHECK_FALSE(at_cell(p, l, x, h / 2 + 3) == saturated);
  }
  CHECK(at_cell(p, l, 12, 12) == saturated);
  // Versus a range from the largest |dZ|: the same cell goes pale.
  DrawDodOptions max_range;
  max_range.percentile = 100.0;
  CHECK(dod_colour_range(dz, max_range) == 12.0);
  CHECK(dod_colour(1.5, 12.0)[1] > 200);
}

TEST_CASE("draw_dod: at most 1600 px, non-square cells keep their aspect, the PNG is the picture", "[vision]") {
  const Dsm big(Raster<float>(3000, 1000, 0.5f), GeoTransform::north_up(0.0, 0.0, 1.0));
  const cv::Mat p = draw_dod(big);
  CHECK(std::max(p.cols, p.rows) <= 1600);
  CHECK(std::max(p.cols, p.rows) >= 1400);
  const DodPictureLayout l = dod_picture_layout(big);
  CHECK(l.map.width == Approx(3.0 * l.map.height).epsilon(0.01));

  // Cells of 1 m across and 3 m down: the map is three times as tall per cell as wide.
  const Dsm tall(Raster<float>(90, 20, 1.0f), GeoTransform{{0.0, 1.0, 0.0, 0.0, 0.0, -3.0}});
  const DodPictureLayout t = dod_picture_layout(tall);
  CHECK(t.px_per_cell_y == Approx(3.0 * t.px_per_cell_x));
  CHECK(std::max(t.map.width, t.map.height) >= 600);

  // A narrow map: the picture is still wide enough for its text.
  const Dsm narrow(Raster<float>(5, 300, 1.0f), GeoTransform::north_up(0.0, 0.0, 1.0));
  const DodPictureLayout n = dod_picture_layout(narrow);
  CHECK(n.picture.width > 400);

  const std::string path = test::fresh_temp_folder("draw_dod") + "/dod.png";
  DrawDodOptions o;
  o.title = "written";
  write_dod_png(path, thirds(), o);
  const cv::Mat read = cv::imread(path, cv::IMREAD_COLOR);
  REQUIRE_FALSE(read.empty());
  const cv::Mat drawn = draw_dod(thirds(), o);
  REQUIRE(read.size() == drawn.size());
  CHECK(cv::norm(read, drawn, cv::NORM_INF) == 0.0);
}

TEST_CASE("draw_dod: bad input", "[vision]") {
  const Dsm dz = thirds();
  CHECK_THROWS_AS(draw_dod(Dsm()), Error);
  DrawDodOptions o;
  o.range_m = -1.0;
  CHECK_THROWS_AS(draw_dod(dz, o), Error);
  o = DrawDodOptions{};
  o.percentile = 0.0;
  CHECK_THROWS_AS(draw_dod(dz, o), Error);
  o.percentile = 101.0;
  CHECK_THROWS_AS(draw_dod(dz, o), Error);
  o = DrawDodOptions{};
  o.max_side_px = 100;
  CHECK_THROWS_AS(draw_dod(dz, o), Error);
  o = DrawDodOptions{};
  o.min_map_side_px = 2000;
  CHECK_THROWS_AS(draw_dod(dz, o), Error);
  const Raster<std::uint8_t> wrong(3, 3, 1);
  o = DrawDodOptions{};
  o.stable = &wrong;
  CHECK_THROWS_AS(draw_dod(dz, o), Error);
  CHECK_THROWS_AS(write_dod_png("/nonexistent_folder_for_draw_dod/x.png", dz), Error);
}
