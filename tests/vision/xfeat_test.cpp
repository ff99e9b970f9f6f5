// XFeatExtractor / XFeatPairMatcher through cv::dnn: loading errors always; with the model file
// (../shared/models/xfeat/xfeat.onnx, skipped when absent): well-formed features, exact mapping of
// keypoints from a resized tile, recovery of a known shift, and concurrent use of one extractor.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/tiling/pair_matcher.hpp>
#include <diachron/vision/image.hpp>
#include <diachron/vision/xfeat.hpp>

#include "support/temp_folder.hpp"
#include "support/test_paths.hpp"
#include "support/textures.hpp"

namespace {

using diachron::Raster;

using diachron::test::apply;
using diachron::test::fraction_within;
using diachron::test::textured;
using diachron::test::warp;

// Overlapping flat rectangles, lightly blurred: sharp corners, like buildings in a DSM image.
Raster<std::uint8_t> rectangles(int w, int h, std::uint64_t seed) {
  diachron::RandomStream rng(seed);
  cv::Mat img(h, w, CV_8U, cv::Scalar(128));
  for (int i = 0; i < w * h / 300; ++i) {
    // One draw per statement, the second argument first (y before x, height before width): the order
    // of a call's arguments is unspecified (core/random.hpp, "Order of draws").
    const int y = static_cast<int>(rng.uniform(-20, h));
    const cv::Point corner(static_cast<int>(rng.uniform(-20, w)), y);
    const int height = static_cast<int>(rng.uniform(4, 40));
    const cv::Size size(static_cast<int>(rng.uniform(4, 40)), height);
    cv::rectangle(img, cv::Rect(corner, size), cv::Scalar(static_cast<int>(rng.uniform(0, 255))), cv::FILLED);
  }
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.7);
  return diachron::to_raster<std::uint8_t>(img);
}

}  // namespace

TEST_CASE("XFeatExtractor: a missing, empty or non-ONNX model file is a diachron::Error naming the path",
          "[vision]") {
  const std::filesystem::path dir = diachron::test::fresh_temp_folder("vision_xfeat_test");
  const std::string missing = (dir / "missing.onnx").string();
  CHECK_THROWS_AS(diachron::XFeatExtractor(missing), diachron::Error);
  CHECK_THROWS_WITH(diachron::XFeatExtractor(missing), Catch::Contains(missing) && Catch::Contains("no such file"));
  CHECK_THROWS_WITH(diachron::XFeatPairMatcher(missing), Catch::Contains(missing));

  const std::string text = (dir / "not_a_model.onnx").string();
  std::ofstream(text) << "this is a text file, not an ONNX model\n";
  CHECK_THROWS_AS(diachron::XFeatExtractor(text), diachron::Error);
  CHECK_THROWS_WITH(diachron::XFeatExtractor(text), Catch::Contains(text) && Catch::Contains("ONNX"));

  const std::string empty = (dir / "empty.onnx").string();
  std::ofstream{empty};
  CHECK_THROWS_WITH(diachron::XFeatExtractor(empty), Catch::Contains(empty) && Catch::Contains("empty"));

  CHECK_THROWS_WITH(diachron::XFeatExtractor(dir.string()), Catch::Contains(dir.string()));

  diachron::XFeatOptions bad;
  bad.nms_window = 4;
  CHECK_THROWS_WITH(diachron::XFeatExtractor(text, bad), Catch::Contains("nms_window"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("XFeatExtractor: features on a 640 x 480 tile are well formed", "[vision]") {
  const auto model = diachron::test::model_file("xfeat/xfeat.onnx");
  DIACHRON_REQUIRE_FILE_OR_SKIP(model, "the XFeat ONNX model");
  const diachron::XFeatExtractor xfeat(*model);
  const Raster<std::uint8_t> img = textured(640, 480, 21);
  const diachron::Features f = xfeat.extract(img);
  INFO("keypoints: " << f.size());
  REQUIRE(f.size() > 300);
  REQUIRE(f.size() <= 4096);
  REQUIRE(f.descriptors.rows() == static_cast<Eigen::Index>(f.size()));
  REQUIRE(f.descriptors.cols() == 64);
  for (std::size_t i = 0; i < f.size(); ++i) {
    const auto& kp = f.keypoints[i];
    // s = 1: keypoints are the tile's own pixel centres, never in the mirrored padding.
    CHECK(kp.position.x() == std::round(kp.position.x()));
    CHECK(kp.position.y() == std::round(kp.position.y()));
    CHECK(img.contains(static_cast<int>(kp.position.x()), static_cast<int>(kp.position.y())));
    CHECK(kp.angle < 0.0);
    CHECK(kp.response > 0.0);
    if (i > 0) CHECK(kp.response <= f.keypoints[i - 1].response);
    CHECK(f.descriptors.row(static_cast<Eigen::Index>(i)).norm() == Approx(1.0).epsilon(1e-5));
  }

  diachron::XFeatOptions few;
  few.top_k = 100;
  const diachron::Features top = diachron::XFeatExtractor(*model, few).extract(img);
  REQUIRE(top.size() == 100);
  for (std::size_t i = 0; i < top.size(); ++i) {
    CHECK(top.keypoints[i].position == f.keypoints[i].position);  // the best 100 of the same list
  }
  CHECK_THROWS_AS(xfeat.extract(Raster<std::uint8_t>()), diachron::Error);
}

TEST_CASE("XFeatExtractor: keypoints of a tile twice as large map back exactly", "[vision]") {
  const auto model = diachron::test::model_file("xfeat/xfeat.onnx");
  DIACHRON_REQUIRE_FILE_OR_SKIP(model, "the XFeat ONNX model");
  const diachron::XFeatExtractor xfeat(*model);
  // Each pixel of `small` becomes a 2 x 2 block of `big`; INTER_AREA halves `big` back to `small`
  // exactly, so the network sees the same input and network pixel u is big's 2 u + 0.5.
  const Raster<std::uint8_t> small = textured(640, 440, 22);
  Raster<std::uint8_t> big(1280, 880);
  for (int y = 0; y < big.height(); ++y)
    for (int x = 0; x < big.width(); ++x) big(x, y) = small(x / 2, y / 2);
  const diachron::Features fs = xfeat.extract(small);
  const diachron::Features fb = xfeat.extract(big);
  REQUIRE(fs.size() > 100);
  REQUIRE(fs.size() == fb.size());
  for (std::size_t i = 0; i < fs.size(); ++i) {
    CHECK(fb.keypoints[i].position.x() == 2.0 * fs.keypoints[i].position.x() + 0.5);
    CHECK(fb.keypoints[i].position.y() == 2.0 * fs.keypoints[i].position.y() + 0.5);
  }
  CHECK(fb.descriptors == fs.descriptors);
}

TEST_CASE("XFeatPairMatcher: recovers known shifts on a textured tile", "[vision]") {
  const auto model = diachron::test::model_file("xfeat/xfeat.onnx");
  DIACHRON_REQUIRE_FILE_OR_SKIP(model, "the XFeat ONNX model");
  static_assert(diachron::check_feature_extractor<diachron::XFeatExtractor>());
  static_assert(diachron::check_pair_matcher<diachron::XFeatPairMatcher>());
  const diachron::XFeatPairMatcher matcher(*model);
  const Raster<std::uint8_t> a = rectangles(640, 480, 23);
  const diachron::Features fa = matcher.extractor().extract(a);
  {
    // A whole number of 8-px cells: the network sees the same cells, keypoints land on the same
    // scene points, so nearly every match is exact.
    const cv::Matx23d shift(1, 0, 16, 0, 1, -8);
    const auto matches = matcher.match(fa, matcher.extractor().extract(warp(a, shift)));
    const double good = fraction_within(matches, shift, 1.5);
    INFO("cell-aligned shift: matches " << matches.size() << ", within 1.5 px: " << good);
    CHECK(matches.size() >= 500);
    CHECK(good >= 0.8);
    for (const auto& m : matches) {
      CHECK(m.score > 0.82);
      CHECK(m.score <= 1.0 + 1e-6);
    }
  }
  {
    // Any other shift moves the scene against the cell grid. XFeat's keypoint head sees one 8 x 8
    // cell at a time and picks a pixel of it, so localisation is only good to a few pixels
    // (measured: about half the matches within 1.5 px, three quarters within 3 px); the shift is
    // still recovered, without bias, by the median of the match displacements.
    const cv::Matx23d shift(1, 0, 11.4, 0, 1, -6.7);
    const auto matches = matcher.match(fa, matcher.extractor().extract(warp(a, shift)));
    REQUIRE(matches.size() >= 500);
    std::vector<double> dx;
    std::vector<double> dy;
    for (const auto& m : matches) {
      dx.push_back(m.b.x() - m.a.x());
      dy.push_back(m.b.y() - m.a.y());
    }
    std::nth_element(dx.begin(), dx.begin() + static_cast<std::ptrdiff_t>(dx.size() / 2), dx.end());
    std::nth_element(dy.begin(), dy.begin() + static_cast<std::ptrdiff_t>(dy.size() / 2), dy.end());
    const double good = fraction_within(matches, shift, 3.0);
    INFO("sub-pixel shift: matches " << matches.size() << ", median shift (" << dx[dx.size() / 2] << ", "
                                     << dy[dy.size() / 2] << "), within 3 px: " << good);
    CHECK(dx[dx.size() / 2] == Approx(11.4).margin(1.0));
    CHECK(dy[dy.size() / 2] == Approx(-6.7).margin(1.0));
    CHECK(good >= 0.6);
  }
}

TEST_CASE("XFeatExtractor: concurrent calls on one extractor give the serial results", "[vision]") {
  const auto model = diachron::test::model_file("xfeat/xfeat.onnx");
  DIACHRON_REQUIRE_FILE_OR_SKIP(model, "the XFeat ONNX model");
  const diachron::XFeatExtractor xfeat(*model);
  const Raster<std::uint8_t> a = textured(400, 300, 24);
  const Raster<std::uint8_t> b = textured(300, 400, 25);
  const diachron::Features serial_a = xfeat.extract(a);
  const diachron::Features serial_b = xfeat.extract(b);
  diachron::Features parallel_a;
  diachron::Features parallel_b;
  std::thread ta([&] { parallel_a = xfeat.extract(a); });
  std::thread tb([&] { parallel_b = xfeat.extract(b); });
  ta.join();
  tb.join();
  REQUIRE(parallel_a.size() == serial_a.size());
  REQUIRE(parallel_b.size() == serial_b.size());
  CHECK(parallel_a.descriptors == serial_a.descriptors);
  CHECK(parallel_b.descriptors == serial_b.descriptors);
}

TEST_CASE("match_mutual_cosine: mutual nearest neighbours above the similarity floor", "[vision]") {
  diachron::Features a;
  diachron::Features b;
  a.keypoints.resize(3);
  b.keypoints.resize(3);
  a.descriptors.resize(3, 2);
  b.descriptors.resize(3, 2);
  const double c = std::cos(0.1);
  const double s = std::sin(0.1);
  a.descriptors << 1, 0, 0, 1, static_cast<float>(std::sqrt(0.5)), static_cast<float>(std::sqrt(0.5));
  // b0 ~ a0 (cos 0.995), b1 ~ a1, b2 = a1 rotated by 0.8 rad (not mutual: a1 prefers b1).
  b.descriptors << static_cast<float>(c), static_cast<float>(s), static_cast<float>(s), static_cast<float>(c),
      static_cast<float>(std::sin(0.8)), static_cast<float>(std::cos(0.8));
  const auto m = diachron::match_mutual_cosine(a, b);
  // a2 (45 deg) is nearest to b0 (5.7 deg), b1 (84 deg) or b2 (44 deg): b2 at 1 deg, cos 0.9998,
  // and b2's nearest is a2: mutual.
  REQUIRE(m.size() == 3);
  CHECK(m[0].a == 0);
  CHECK(m[0].b == 0);
  CHECK(m[1].a == 1);
  CHECK(m[1].b == 1);
  CHECK(m[2].a == 2);
  CHECK(m[2].b == 2);
  CHECK(m[0].distance == Approx(1.0 - c).margin(1e-6));
  diachron::XFeatMatchOptions strict;
  strict.min_similarity = 0.999;
  const auto few = diachron::match_mutual_cosine(a, b, strict);
  REQUIRE(few.size() == 1);
  CHECK(few[0].a == 2);
}
