// draw_pair_overlay: a bright spot of the secondary lands where the homography puts it in the shrunk
// master geometry, the checkerboard alternates master and secondary and darkens the master outside
// the secondary, the dots sit at their points in their value's colour, the colour bar holds the ramp,
// a pair that does not overlap still shows the master and its dots, the JPEG stays under its bound for
// noise (the hardest case), and bad input throws.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/types.hpp>
#include <diachron/vision/draw_pair_overlay.hpp>

#include "support/temp_folder.hpp"

using namespace diachron;

namespace pairov_test {

// master = H * secondary: rotation by `degrees`, scale, a slight perspective, then a shift.
Eigen::Matrix3d pairov_homography(double degrees, double scale, const Eigen::Vector2d& shift, double tilt = 0.0) {
  const double a = degrees * kPi / 180.0;
  Eigen::Matrix3d h;
  h << scale * std::cos(a), -scale * std::sin(a), shift.x(), scale * std::sin(a), scale * std::cos(a), shift.y(),
      tilt, 0.5 * tilt, 1.0;
  return h;
}

Eigen::Vector2d pairov_apply_h(const Eigen::Matrix3d& h, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = h * Eigen::Vector3d(p.x(), p.y(), 1.0);
  return q.head<2>() / q.z();
}

// Intensity-weighted centroid of the picture's image area (the blue channel; the image is grey),
// picture px.
Eigen::Vector2d pairov_centroid(const cv::Mat& picture, const cv::Rect& area) {
  double sum = 0.0, sx = 0.0, sy = 0.0;
  for (int y = area.y; y < area.y + area.height; ++y)
    for (int x = area.x; x < area.x + area.width; ++x) {
      const double v = picture.at<cv::Vec3b>(y, x)[0];
      sum += v;
      sx += v * x;
      sy += v * y;
    }
  return {sx / sum, sy / sum};
}

Raster<std::uint8_t> pairov_noise(int w, int h, std::uint64_t seed) {
  Raster<std::uint8_t> r(w, h);
  RandomStream random(seed);
  std::uint8_t* p = r.data();
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  for (std::size_t i = 0; i < n; i += 8) {
    const std::uint64_t bits = random.next_u64();
    for (std::size_t k = 0; k < 8 && i + k < n; ++k) p[i + k] = static_cast<std::uint8_t>(bits >> (8 * k));
  }
  return r;
}

bool pairov_near(const cv::Vec3b& a, const cv::Vec3b& b, int tolerance) {
  for (int c = 0; c < 3; ++c)
    if (std::abs(a[c] - b[c]) > tolerance) return false;
  return true;
}

}  // namespace pairov_test

using namespace pairov_test;

TEST_CASE("draw_pair_overlay: a bright spot of the secondary lands where the homography puts it", "[vision]") {
  // A 2000 x 1500 master shrunk about 4.5 times, a secondary 140 degrees off, 1.2 times larger, with a
  // slight perspective. Half a pixel lost in the shrinking's convention would move the spot by 0.4 px.
  const Raster<std::uint8_t> master(2000, 1500, 0);
  Raster<std::uint8_t> secondary(1500, 1100, 0);
  const Eigen::Vector2d spot(600.0, 400.0);
  for (int y = 380; y <= 420; ++y)
    for (int x = 580; x <= 620; ++x)
      if (std::hypot(x - spot.x(), y - spot.y()) <= 14.0) secondary(x, y) = 255;
  for (const double tilt : {0.0, 2e-5}) {
    const Eigen::Matrix3d h = pairov_homography(140.0, 1.2, {1500.0, 900.0}, tilt);
    const Eigen::Vector2d in_master = pairov_apply_h(h, spot);
    REQUIRE(in_master.x() > 100.0);
    REQUIRE(in_master.x() < 1900.0);
    REQUIRE(in_master.y() > 100.0);
    REQUIRE(in_master.y() < 1400.0);
    DrawPairOverlayOptions o;
    o.max_side_px = 600;
    o.tile_px = 100000;  // one tile: the warped secondary everywhere it reaches
    const PairOverlayLayout l = pair_overlay_layout(master, secondary, h, {}, {}, o);
    const cv::Mat p = draw_pair_overlay(master, secondary, h, {}, {}, o);
    REQUIRE(p.size() == l.picture);
    CHECK(std::max(p.cols, p.rows) <= 600);
    CHECK(l.px_per_master_px_x < 0.25);
    const Eigen::Vector2d expected = pair_overlay_picture_point(l, in_master);
    const Eigen::Vector2d found = pairov_centroid(p, l.image);
    CHECK((found - expected).norm() < 0.15);
    // Bright where expected.
    CHECK(p.at<cv::Vec3b>(static_cast<int>(std::lround(expected.y())), static_cast<int>(std::lround(expected.x())))[0] >
          200);
  }
  // Not shrunk: the spot at H * spot exactly (master pixels = picture pixels + the image's corner).
  const Raster<std::uint8_t> small_master(600, 450, 0);
  const Eigen::Matrix3d h = pairov_homography(-30.0, 0.4, {50.0, 300.0});
  DrawPairOverlayOptions o;
  o.tile_px = 100000;
  const PairOverlayLayout l = pair_overlay_layout(small_master, secondary, h, {}, {}, o);
  REQUIRE(l.px_per_master_px_x == 1.0);
  REQUIRE(l.px_per_master_px_y == 1.0);
  const cv::Mat p = draw_pair_overlay(small_master, secondary, h, {}, {}, o);
  const Eigen::Vector2d found = pairov_centroid(p, l.image) - Eigen::Vector2d(l.image.x, l.image.y);
  CHECK((found - pairov_apply_h(h, spot)).norm() < 0.1);
}

TEST_CASE("draw_pair_overlay: tiles alternate master and secondary, the master is dark outside the secondary",
          "[vision]") {
  const Raster<std::uint8_t> master(400, 300, 60), secondary(400, 300, 200);
  const Eigen::Matrix3d shifted = pairov_homography(0.0, 1.0, {100.0, 0.0});
  DrawPairOverlayOptions o;
  o.tile_px = 16;
  const PairOverlayLayout l = pair_overlay_layout(master, secondary, shifted, {}, {}, o);
  const cv::Mat p = draw_pair_overlay(master, secondary, shifted, {}, {}, o);
  CHECK(l.coverage == Approx(0.75).margin(0.011));
  const auto grey_at = [&](int x, int y) { return static_cast<int>(p.at<cv::Vec3b>(l.image.y + y, l.image.x + x)[0]); };
  CHECK(grey_at(120, 5) == 60);   // tile (7, 0): master
  CHECK(grey_at(136, 5) == 200);  // tile (8, 0): secondary
  CHECK(grey_at(136, 21) == 60);  // tile (8, 1): master
  CHECK(grey_at(399, 299) == 200);  // tile (24, 18), the last pixel: the secondary's own last pixel
  CHECK(grey_at(99, 160) == 27);    // one pixel left of the secondary
  CHECK(grey_at(100, 160) == 200);  // tile (6, 10): the secondary's first column
  CHECK(grey_at(390, 290) == 200);
  CHECK(grey_at(50, 40) == 27);   // left of the secondary: the master, dark (60 x 0.45), in every tile
  CHECK(grey_at(50, 56) == 27);
  CHECK(l.header.back().find("covers 75 %") != std::string::npos);
}

TEST_CASE("draw_pair_overlay: dots at their points in their value's colour, the colour bar holds the ramp",
          "[vision]") {
  const Raster<std::uint8_t> master(800, 600, 128), secondary(800, 600, 128);
  const Eigen::Matrix3d h = pairov_homography(10.0, 1.0, {20.0, -10.0});
  const std::vector<Eigen::Vector2d> points{{100.3, 100.0}, {400.0, 300.6}, {700.0, 500.0}, {250.0, 480.0}};
  for (const PairOverlayValues kind : {PairOverlayValues::Score, PairOverlayValues::ResidualPx}) {
    DrawPairOverlayOptions o;
    o.values = kind;
    o.value_high = kind == PairOverlayValues::Score ? 1.0 : 3.0;
    o.title = "e1/a.tif -- e2/b.tif";
    const std::vector<double> values{0.0, 0.5 * o.value_high, o.value_high, 7.0};  // 7 saturates
    const PairOverlayLayout l = pair_overlay_layout(master, secondary, h, points, values, o);
    const cv::Mat p = draw_pair_overlay(master, secondary, h, points, values, o);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d c = pair_overlay_picture_point(l, points[i]);
      const int x = static_cast<int>(std::lround(c.x())), y = static_cast<int>(std::lround(c.y()));
      CHECK(p.at<cv::Vec3b>(y, x) == pair_overlay_colour(values[i], o));
      CHECK(p.at<cv::Vec3b>(y, x + 2) == pair_overlay_colour(values[i], o));
      CHECK(p.at<cv::Vec3b>(y + 8, x) == cv::Vec3b(128, 128, 128));  // beyond the dot and its ring
    }
    // Good is blue, bad is red: high scores, low residuals.
    const cv::Vec3b good = pair_overlay_colour(kind == PairOverlayValues::Score ? 1.0 : 0.0, o);
    const cv::Vec3b bad = pair_overlay_colour(kind == PairOverlayValues::Score ? 0.0 : 3.0, o);
    CHECK(good[0] > good[2] + 80);
    CHECK(bad[2] > bad[0] + 80);
    // The colour bar: value_high's colour at the top, value_low's at the bottom, the ramp between.
    const cv::Rect& bar = l.colour_bar;
    CHECK(bar.x > l.image.x + l.image.width);
    const cv::Vec3b top = p.at<cv::Vec3b>(bar.y, bar.x + bar.width / 2);
    const cv::Vec3b bottom = p.at<cv::Vec3b>(bar.y + bar.height - 1, bar.x + bar.width / 2);
    CHECK(pairov_near(top, pair_overlay_colour(o.value_high, o), 6));
    CHECK(pairov_near(bottom, pair_overlay_colour(o.value_low, o), 6));
    int ramp = 0;
    for (int j = 0; j < bar.height; ++j) {
      const double v = o.value_high - (o.value_high - o.value_low) * (j + 0.5) / bar.height;
      ramp += pairov_near(p.at<cv::Vec3b>(bar.y + j, bar.x + 3), pair_overlay_colour(v, o), 1) ? 1 : 0;
    }
    CHECK(ramp == bar.height);
    // Tick labels right of the bar, the title and counts above the image, the scale bar under it.
    int dark = 0;
    for (int y = bar.y; y < bar.y + bar.height; ++y)
      for (int x = bar.x + bar.width + 8; x < p.cols; ++x) dark += p.at<cv::Vec3b>(y, x)[1] < 80 ? 1 : 0;
    CHECK(dark > 50);
    CHECK(l.header[0] == "e1/a.tif -- e2/b.tif");
    CHECK(l.header[1].find("4 points") != std::string::npos);
    CHECK(l.scale_bar.y > l.image.y + l.image.height);
    CHECK(p.at<cv::Vec3b>(l.scale_bar.y + 1, l.scale_bar.x + l.scale_bar.width / 2) == cv::Vec3b(0, 0, 0));
    CHECK(l.scale_bar_master_px == 200.0);
  }
  // Saturation and the colour of a residual against a score.
  DrawPairOverlayOptions score, residual;
  residual.values = PairOverlayValues::ResidualPx;
  CHECK(pair_overlay_colour(-3.0, score) == pair_overlay_colour(0.0, score));
  CHECK(pair_overlay_colour(0.25, residual) == pair_overlay_colour(0.75, score));
}

TEST_CASE("draw_pair_overlay: a secondary mapped away still shows the master, its dots and a note", "[vision]") {
  const Raster<std::uint8_t> master(300, 200, 90), secondary(300, 200, 250);
  const Eigen::Matrix3d away = pairov_homography(0.0, 1.0, {10000.0, 0.0});
  const std::vector<Eigen::Vector2d> points{{150.0, 100.0}};
  const std::vector<double> values{0.9};
  const PairOverlayLayout l = pair_overlay_layout(master, secondary, away, points, values);
  const cv::Mat p = draw_pair_overlay(master, secondary, away, points, values);
  CHECK(l.coverage == 0.0);
  CHECK(l.header.back().find("does not overlap") != std::string::npos);
  CHECK(p.at<cv::Vec3b>(l.image.y + 10, l.image.x + 10) == cv::Vec3b(90, 90, 90));    // plain, not dark
  CHECK(p.at<cv::Vec3b>(l.image.y + 10, l.image.x + 80) == cv::Vec3b(90, 90, 90));
  const Eigen::Vector2d c = pair_overlay_picture_point(l, points[0]);
  CHECK(p.at<cv::Vec3b>(static_cast<int>(c.y()), static_cast<int>(c.x())) == pair_overlay_colour(0.9, {}));
}

TEST_CASE("write_pair_overlay_jpg: at most 1 MB for images of noise, and under a tighter bound",
          "[vision]") {
  const Raster<std::uint8_t> master = pairov_noise(4000, 3000, 1), secondary = pairov_noise(4000, 3000, 2);
  const Eigen::Matrix3d h = pairov_homography(5.0, 1.0, {150.0, -100.0});
  RandomStream random(3);
  std::vector<Eigen::Vector2d> points;
  std::vector<double> values;
  for (int i = 0; i < 2000; ++i) {
    const double y = random.uniform(0.0, 2999.0);
    points.emplace_back(random.uniform(0.0, 3999.0), y);
    values.push_back(random.uniform01());
  }
  const std::string folder = test::fresh_temp_folder("draw_pair_overlay");
  const std::string path = folder + "/pair.jpg";
  const PairOverlayJpeg j = write_pair_overlay_jpg(path, master, secondary, h, points, values);
  CHECK(j.bytes <= 1000000);
  CHECK(std::filesystem::file_size(path) == j.bytes);
  CHECK(std::max(j.size.width, j.size.height) <= 1600);
  const cv::Mat read = cv::imread(path, cv::IMREAD_COLOR);
  REQUIRE_FALSE(read.empty());
  CHECK(read.size() == j.size);

  // Noise that is not shrunk (1440 px fits the picture) does not average out: 85 would exceed 1 MB.
  const Raster<std::uint8_t> sharp = pairov_noise(1440, 1080, 4);
  const PairOverlayJpeg s = write_pair_overlay_jpg(path, sharp, sharp, h, {}, {});
  CHECK(s.bytes <= 1000000);
  CHECK(s.quality < 85);
  CHECK(std::filesystem::file_size(path) == s.bytes);

  // 250 kB: noise needs a lower quality and then a smaller picture.
  DrawPairOverlayOptions tight;
  tight.max_jpeg_bytes = 250000;
  const PairOverlayJpeg t = write_pair_overlay_jpg(path, master, secondary, h, points, values, tight);
  CHECK(t.bytes <= 250000);
  CHECK(std::filesystem::file_size(path) == t.bytes);
  CHECK(t.max_side_px < 1600);
  CHECK(std::max(t.size.width, t.size.height) <= t.max_side_px);
  CHECK_FALSE(cv::imread(path, cv::IMREAD_COLOR).empty());
}

TEST_CASE("draw_pair_overlay: a large image fits max_side_px, long lines wrap", "[vision]") {
  const Raster<std::uint8_t> master(6000, 4000, 100), secondary(3000, 2000, 150);
  const Eigen::Matrix3d h = pairov_homography(0.0, 2.0, {0.0, 0.0});
  const cv::Mat p = draw_pair_overlay(master, secondary, h, {}, {});
  CHECK(std::max(p.cols, p.rows) <= 1600);
  CHECK(std::max(p.cols, p.rows) >= 1500);
  DrawPairOverlayOptions narrow;
  narrow.max_side_px = 400;
  narrow.title = "e1/a.tif -- e2/b.tif";
  const PairOverlayLayout l = pair_overlay_layout(master, secondary, h, {}, {}, narrow);
  CHECK(l.header.size() > 3);
  CHECK(l.picture.width <= 400);
  CHECK(l.picture.height <= 400);
  CHECK(l.coverage == 1.0);
}

TEST_CASE("draw_pair_overlay: bad input", "[vision]") {
  const Raster<std::uint8_t> image(50, 40, 100);
  const Eigen::Matrix3d h = Eigen::Matrix3d::Identity();
  CHECK_THROWS_AS(draw_pair_overlay(Raster<std::uint8_t>(), image, h, {}, {}), Error);
  CHECK_THROWS_AS(draw_pair_overlay(image, Raster<std::uint8_t>(), h, {}, {}), Error);
  Eigen::Matrix3d bad = h;
  bad(0, 2) = std::nan("");
  CHECK_THROWS_AS(draw_pair_overlay(image, image, bad, {}, {}), Error);
  bad = h;
  bad(1, 1) = std::numeric_limits<double>::infinity();
  CHECK_THROWS_AS(draw_pair_overlay(image, image, bad, {}, {}), Error);
  CHECK_THROWS_AS(draw_pair_overlay(image, image, Eigen::Matrix3d::Zero(), {}, {}), Error);
  bad = h;
  bad.row(2) = bad.row(0);  // singular
  CHECK_THROWS_AS(draw_pair_overlay(image, image, bad, {}, {}), Error);
  CHECK_THROWS_AS(draw_pair_overlay(image, image, h, {{1.0, 1.0}}, {}), Error);
  CHECK_THROWS_AS(draw_pair_overlay(image, image, h, {{1.0, 1.0}}, {0.5, 0.5}), Error);
  CHECK_THROWS_AS(draw_pair_overlay(image, image, h, {{1.0, std::nan("")}}, {0.5}), Error);
  CHECK_THROWS_AS(draw_pair_overlay(image, image, h, {{1.0, 1.0}}, {std::nan("")}), Error);
  CHECK_NOTHROW(draw_pair_overlay(image, image, h, {{1.0, 1.0}}, {0.5}));
  DrawPairOverlayOptions o;
  o.value_high = 0.0;
  CHECK_THROWS_AS(draw_pair_overlay(image, image, h, {}, {}, o), Error);
  o = DrawPairOverlayOptions{};
  o.max_side_px = 300;
  CHECK_THROWS_AS(draw_pair_overlay(image, image, h, {}, {}, o), Error);
  o = DrawPairOverlayOptions{};
  o.tile_px = 4;
  CHECK_THROWS_AS(draw_pair_overlay(image, image, h, {}, {}, o), Error);
  o = DrawPairOverlayOptions{};
  o.jpeg_quality = 101;
  CHECK_THROWS_AS(write_pair_overlay_jpg("/tmp/unused.jpg", image, image, h, {}, {}, o), Error);
  o = DrawPairOverlayOptions{};
  o.max_jpeg_bytes = 1000;
  CHECK_THROWS_AS(write_pair_overlay_jpg("/tmp/unused.jpg", image, image, h, {}, {}, o), Error);
  CHECK_THROWS_AS(write_pair_overlay_jpg("/nonexistent_folder_for_pair_overlay/x.jpg", image, image, h, {}, {}), Error);
}
