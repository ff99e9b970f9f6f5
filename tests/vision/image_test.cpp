// Raster <-> cv::Mat views and copies, and 8-bit image files.
#include <catch2/catch.hpp>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <type_traits>

#include <opencv2/core.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/vision/image.hpp>

#include "support/temp_folder.hpp"

namespace {

diachron::Raster<std::uint8_t> ramp(int w, int h) {
  diachron::Raster<std::uint8_t> r(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) r(x, y) = static_cast<std::uint8_t>((7 * x + 13 * y) % 256);
  return r;
}

}  // namespace

TEST_CASE("as_mat: views share memory with the raster, both ways", "[vision]") {
  diachron::Raster<std::uint8_t> r = ramp(5, 3);
  cv::Mat view = diachron::as_mat(r);
  REQUIRE(view.type() == CV_8UC1);
  REQUIRE(view.cols == 5);
  REQUIRE(view.rows == 3);
  CHECK(view.data == r.data());
  CHECK(view.at<std::uint8_t>(2, 4) == r(4, 2));  // Mat is (row, col), Raster (x, y)
  view.at<std::uint8_t>(1, 3) = 201;
  CHECK(r(3, 1) == 201);
  r(0, 2) = 17;
  CHECK(view.at<std::uint8_t>(2, 0) == 17);

  diachron::Raster<float> f(4, 2, 0.5f);
  cv::Mat fview = diachron::as_mat(f);
  REQUIRE(fview.type() == CV_32FC1);
  fview.at<float>(1, 2) = -3.25f;
  CHECK(f(2, 1) == -3.25f);

  const diachron::Raster<std::uint8_t>& cr = r;
  CHECK(diachron::as_mat(cr).data == r.data());
  const diachron::Raster<std::uint8_t> empty;
  CHECK(diachron::as_mat(empty).empty());
}

TEST_CASE("to_raster: copies are exact, also from a non-continuous ROI", "[vision]") {
  const diachron::Raster<std::uint8_t> r = ramp(9, 7);
  const diachron::Raster<std::uint8_t> copy = diachron::to_raster<std::uint8_t>(diachron::as_mat(r));
  REQUIRE(copy.width() == 9);
  REQUIRE(copy.height() == 7);
  CHECK(copy.data() != r.data());
  for (int y = 0; y < 7; ++y)
    for (int x = 0; x < 9; ++x) CHECK(copy(x, y) == r(x, y));

  const cv::Mat roi = diachron::as_mat(r)(cv::Rect(2, 1, 4, 5));
  REQUIRE_FALSE(roi.isContinuous());
  const diachron::Raster<std::uint8_t> part = diachron::to_raster<std::uint8_t>(roi);
  REQUIRE(part.width() == 4);
  REQUIRE(part.height() == 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 4; ++x) CHECK(part(x, y) == r(x + 2, y + 1));

  cv::Mat f(3, 2, CV_32FC1);
  f.at<float>(2, 1) = 1.0e-7f;
  CHECK(diachron::to_raster<float>(f)(1, 2) == 1.0e-7f);
}

TEST_CASE("to_raster: a Mat of another type or channel count is an error that names both types", "[vision]") {
  const cv::Mat f(3, 2, CV_32FC1, cv::Scalar(1));
  const cv::Mat bgr(3, 2, CV_8UC3, cv::Scalar(1, 2, 3));
  CHECK_THROWS_AS(diachron::to_raster<std::uint8_t>(f), diachron::Error);
  CHECK_THROWS_WITH(diachron::to_raster<std::uint8_t>(f),
                    Catch::Contains("CV_8UC1") && Catch::Contains("CV_32FC1"));
  CHECK_THROWS_WITH(diachron::to_raster<std::uint8_t>(bgr), Catch::Contains("CV_8UC3"));
  CHECK(diachron::to_raster<std::uint8_t>(cv::Mat()).empty());
}

TEST_CASE("load_gray8 / save_gray8: a PNG round trip is exact; bad files name the path", "[vision]") {
  const std::filesystem::path dir = diachron::test::fresh_temp_folder("vision_image_test");
  const diachron::Raster<std::uint8_t> r = ramp(31, 17);
  const std::string png = (dir / "ramp.png").string();
  diachron::save_gray8(png, r);
  const diachron::Raster<std::uint8_t> back = diachron::load_gray8(png);
  REQUIRE(back.width() == 31);
  REQUIRE(back.height() == 17);
  for (int y = 0; y < 17; ++y)
    for (int x = 0; x < 31; ++x) CHECK(back(x, y) == r(x, y));

  const std::string missing = (dir / "missing.png").string();
  CHECK_THROWS_AS(diachron::load_gray8(missing), diachron::Error);
  CHECK_THROWS_WITH(diachron::load_gray8(missing), Catch::Contains(missing) && Catch::Contains("no such file"));

  const std::string text = (dir / "not_an_image.png").string();
  std::ofstream(text) << "this is text, not a PNG\n";
  CHECK_THROWS_WITH(diachron::load_gray8(text), Catch::Contains(text));

  const std::string nowhere = (dir / "no_such_dir" / "x.png").string();
  CHECK_THROWS_WITH(diachron::save_gray8(nowhere, r), Catch::Contains(nowhere));
  CHECK_THROWS_WITH(diachron::save_gray8((dir / "x.unknownext").string(), r), Catch::Contains("x.unknownext"));
  CHECK_THROWS_AS(diachron::save_gray8(png, diachron::Raster<std::uint8_t>()), diachron::Error);
  std::filesystem::remove_all(dir);
}

namespace {

template <class R, class = void>
struct can_view : std::false_type {};
template <class R>
struct can_view<R, std::void_t<decltype(diachron::as_mat(std::declval<R>()))>> : std::true_type {};

}  // namespace

TEST_CASE("as_mat: a temporary raster does not compile (its view would dangle)", "[vision]") {
  STATIC_REQUIRE(can_view<diachron::Raster<std::uint8_t>&>::value);
  STATIC_REQUIRE(can_view<const diachron::Raster<float>&>::value);
  STATIC_REQUIRE_FALSE(can_view<diachron::Raster<std::uint8_t>>::value);
  STATIC_REQUIRE_FALSE(can_view<diachron::Raster<std::uint8_t>&&>::value);
  STATIC_REQUIRE_FALSE(can_view<const diachron::Raster<float>&&>::value);
}
