// SiftExtractor / RootSiftExtractor and ExtractorPairMatcher on a synthetic texture under known
// shifts, similarities and a 90 degree rotation.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/tiling/pair_matcher.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/image.hpp>
#include <diachron/vision/root_sift.hpp>
#include <diachron/vision/sift.hpp>

#include <diachron/geometry/rotation.hpp>

#include "support/textures.hpp"

namespace {

using diachron::Raster;

using diachron::test::apply;
using diachron::test::fraction_within;
using diachron::test::textured;
using diachron::test::warp;





}  // namespace

TEST_CASE("SiftExtractor: keypoints, scales, angles and descriptors are well formed", "[vision]") {
  const Raster<std::uint8_t> img = textured(480, 360, 1);
  const diachron::Features f = diachron::SiftExtractor().extract(img);
  INFO("keypoints: " << f.size());
  REQUIRE(f.size() > 300);
  REQUIRE(static_cast<std::size_t>(f.descriptors.rows()) == f.size());
  REQUIRE(f.descriptors.cols() == 128);
  for (const auto& kp : f.keypoints) {
    CHECK(kp.position.x() >= -0.5);
    CHECK(kp.position.x() <= 479.5);
    CHECK(kp.scale > 0.0);
    CHECK(kp.angle >= 0.0);
    CHECK(kp.angle < 2.0 * diachron::kPi);
  }

  const diachron::Features limited = diachron::SiftExtractor(diachron::SiftOptions{100}).extract(img);
  CHECK(limited.size() >= 100);
  CHECK(limited.size() <= 110);  // OpenCV keeps ties and second orientations
}

TEST_CASE("RootSiftExtractor: descriptors are the square roots of L1-normalised SIFT", "[vision]") {
  const Raster<std::uint8_t> img = textured(320, 240, 2);
  const diachron::Features sift = diachron::SiftExtractor().extract(img);
  const diachron::Features root = diachron::RootSiftExtractor().extract(img);
  REQUIRE(sift.size() == root.size());
  REQUIRE(sift.size() > 50);
  for (Eigen::Index i = 0; i < sift.descriptors.rows(); ++i) {
    const float l1 = sift.descriptors.row(i).sum();
    REQUIRE(l1 > 0.0f);
    CHECK(root.descriptors.row(i).norm() == Approx(1.0).epsilon(1e-5));
    for (Eigen::Index c = 0; c < 128; c += 17)
      CHECK(root.descriptors(i, c) == Approx(std::sqrt(sift.descriptors(i, c) / l1)).margin(1e-6));
  }
  CHECK(diachron::RootSiftExtractor().options().root_sift);
}

TEST_CASE("SiftExtractor: bad options and empty images throw diachron::Error", "[vision]") {
  diachron::SiftOptions bad;
  bad.octave_layers = 0;
  CHECK_THROWS_AS(diachron::SiftExtractor(bad), diachron::Error);
  bad = {};
  bad.sigma = -1.0;
  CHECK_THROWS_WITH(diachron::SiftExtractor(bad), Catch::Contains("sigma"));
  CHECK_THROWS_AS(diachron::SiftExtractor().extract(Raster<std::uint8_t>()), diachron::Error);
  const diachron::Features flat = diachron::SiftExtractor().extract(Raster<std::uint8_t>(64, 64, 100));
  CHECK(flat.empty());
  CHECK(diachron::ExtractorPairMatcher<diachron::SiftExtractor>()
            .match(Raster<std::uint8_t>(64, 64, 100), textured(64, 64, 3))
            .empty());
}

TEST_CASE("ExtractorPairMatcher<SiftExtractor>: recovers a known sub-pixel shift", "[vision]") {
  const Raster<std::uint8_t> a = textured(480, 360, 4);
  const cv::Matx23d shift(1, 0, 7.3, 0, 1, -4.6);
  const Raster<std::uint8_t> b = warp(a, shift);
  const diachron::ExtractorPairMatcher<diachron::SiftExtractor> matcher;
  const auto matches = matcher.match(a, b);
  const double good = fraction_within(matches, shift, 1.5);
  INFO("matches: " << matches.size() << ", within 1.5 px: " << good);
  CHECK(matches.size() >= 100);
  CHECK(good >= 0.8);
  for (const auto& m : matches) CHECK(m.score <= 0.0);
}

TEST_CASE("ExtractorPairMatcher<RootSiftExtractor>: recovers a known rotation and scale", "[vision]") {
  const Raster<std::uint8_t> a = textured(480, 360, 5);
  const cv::Matx23d similarity = cv::getRotationMatrix2D(cv::Point2f(240, 180), 30.0, 0.9);
  const Raster<std::uint8_t> b = warp(a, similarity);
  const diachron::ExtractorPairMatcher<diachron::RootSiftExtractor> matcher;
  const auto matches = matcher.match(a, b);
  const double good = fraction_within(matches, similarity, 1.5);
  INFO("matches: " << matches.size() << ", within 1.5 px: " << good);
  CHECK(matches.size() >= 100);
  CHECK(good >= 0.8);
}

TEST_CASE("ExtractorPairMatcher: the ratio test and the mutual check only remove matches", "[vision]") {
  const Raster<std::uint8_t> a = textured(320, 240, 6);
  const cv::Matx23d similarity = cv::getRotationMatrix2D(cv::Point2f(160, 120), -50.0, 1.1);
  const Raster<std::uint8_t> b = warp(a, similarity);
  const diachron::SiftExtractor sift;
  const diachron::Features fa = sift.extract(a);
  const diachron::Features fb = sift.extract(b);
  diachron::ExtractorMatchOptions loose;
  loose.ratio = 1.0;
  loose.mutual = false;
  const auto all = diachron::match_features(fa, fb, diachron::DescriptorMetric::L2, loose);
  const auto strict = diachron::match_features(fa, fb, diachron::DescriptorMetric::L2);
  CHECK(all.size() == fa.size());  // plain nearest neighbour: one per row of A
  CHECK(strict.size() < all.size());
  for (const auto& m : strict) {
    bool found = false;
    for (const auto& n : all) found = found || (n.a == m.a && n.b == m.b && n.distance == m.distance);
    CHECK(found);
  }
  diachron::ExtractorMatchOptions bad;
  bad.ratio = 0.0;
  CHECK_THROWS_AS(diachron::match_features(fa, fb, diachron::DescriptorMetric::L2, bad), diachron::Error);
}

TEST_CASE("SiftExtractor: keypoint angles turn by +pi/2 when the image turns 90 degrees clockwise", "[vision]") {
  const Raster<std::uint8_t> a = textured(320, 240, 7);
  cv::Mat rotated;
  cv::rotate(diachron::as_mat(a), rotated, cv::ROTATE_90_CLOCKWISE);
  const Raster<std::uint8_t> b = diachron::to_raster<std::uint8_t>(rotated);
  // Clockwise on screen is from +x towards +y: (x, y) -> (h - 1 - y, x), directions turn by +pi/2.
  const cv::Matx23d truth(0, -1, a.height() - 1, 1, 0, 0);
  const diachron::SiftExtractor sift;
  const diachron::Features fa = sift.extract(a);
  const diachron::Features fb = sift.extract(b);
  const auto matches = diachron::match_features(fa, fb, diachron::SiftExtractor::descriptor_metric());
  std::size_t located = 0;
  std::size_t turned = 0;
  for (const auto& m : matches) {
    const auto& ka = fa.keypoints[m.a];
    const auto& kb = fb.keypoints[m.b];
    if ((apply(truth, ka.position) - kb.position).norm() > 1.0) continue;
    ++located;
    if (std::abs(diachron::wrap_angle(kb.angle - ka.angle - diachron::kPi / 2)) < diachron::deg_to_rad(5.0)) ++turned;
  }
  INFO("matches: " << matches.size() << ", located: " << located << ", turned by pi/2: " << turned);
  REQUIRE(located >= 50);
  CHECK(static_cast<double>(turned) >= 0.9 * static_cast<double>(located));
}

namespace {
// A user's extractor without descriptor_metric(): ExtractorPairMatcher falls back to L2.
struct PlainSift {
  diachron::Features extract(const Raster<std::uint8_t>& image) const { return diachron::SiftExtractor().extract(image); }
};
}  // namespace

TEST_CASE("ExtractorPairMatcher: satisfies the PairMatcher concept, with any FeatureExtractor", "[vision]") {
  static_assert(diachron::check_feature_extractor<diachron::SiftExtractor>());
  static_assert(diachron::check_feature_extractor<diachron::RootSiftExtractor>());
  static_assert(diachron::check_pair_matcher<diachron::ExtractorPairMatcher<diachron::SiftExtractor>>());
  static_assert(diachron::check_pair_matcher<diachron::ExtractorPairMatcher<PlainSift>>());
  const diachron::ExtractorPairMatcher<PlainSift> plain;
  CHECK(plain.metric() == diachron::DescriptorMetric::L2);
  const Raster<std::uint8_t> a = textured(320, 240, 8);
  const diachron::ExtractorPairMatcher<diachron::SiftExtractor> sift;
  const auto m1 = plain.match(a, a);
  const auto m2 = sift.match(a, a);
  REQUIRE(m1.size() == m2.size());
  CHECK(m1.size() > 100);
  for (std::size_t i = 0; i < m1.size(); ++i) CHECK(m1[i].a == m2[i].a);
}
