// AkazeExtractor (MLDB bits unpacked to floats) and ExtractorPairMatcher with the Hamming metric,
// on a synthetic texture under a known shift, a similarity and a 90 degree rotation.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/tiling/pair_matcher.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/image.hpp>

#include <diachron/geometry/rotation.hpp>

#include "support/textures.hpp"

namespace {

using diachron::Raster;

using diachron::test::apply;
using diachron::test::fraction_within;
using diachron::test::textured;
using diachron::test::warp;





}  // namespace

TEST_CASE("AkazeExtractor: binary descriptors unpack to 0/1 floats and repack exactly", "[vision]") {
  const Raster<std::uint8_t> img = textured(480, 360, 11);
  const diachron::Features f = diachron::AkazeExtractor().extract(img);
  INFO("keypoints: " << f.size());
  REQUIRE(f.size() > 200);
  REQUIRE(static_cast<std::size_t>(f.descriptors.rows()) == f.size());
  REQUIRE(f.descriptors.cols() == 488);  // 61 bytes of MLDB
  CHECK(((f.descriptors.array() == 0.0f) || (f.descriptors.array() == 1.0f)).all());
  for (const auto& kp : f.keypoints) {
    CHECK(kp.scale > 0.0);
    CHECK(kp.angle >= 0.0);
    CHECK(kp.angle < 2.0 * diachron::kPi);
  }

  // The same bytes as OpenCV's own descriptors, so Hamming distances are OpenCV's.
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  cv::AKAZE::create()->detectAndCompute(diachron::as_mat(img), cv::noArray(), kps, desc);
  REQUIRE(kps.size() == f.size());
  const cv::Mat packed = diachron::detail::pack_bits(f.descriptors);
  CHECK(cv::norm(packed, desc, cv::NORM_HAMMING) == 0.0);
  // Hamming distance = L1 distance = squared L2 distance of the unpacked rows.
  const double hamming = cv::norm(desc.row(0), desc.row(1), cv::NORM_HAMMING);
  CHECK((f.descriptors.row(0) - f.descriptors.row(1)).cwiseAbs().sum() == Approx(hamming));
  CHECK((f.descriptors.row(0) - f.descriptors.row(1)).squaredNorm() == Approx(hamming));
}

TEST_CASE("AkazeExtractor: max_features keeps the strongest; upright has no angles; bad options throw",
          "[vision]") {
  const Raster<std::uint8_t> img = textured(320, 240, 12);
  const diachron::Features all = diachron::AkazeExtractor().extract(img);
  diachron::AkazeOptions options;
  options.max_features = 50;
  const diachron::Features top = diachron::AkazeExtractor(options).extract(img);
  REQUIRE(all.size() > 50);
  REQUIRE(top.size() == 50);
  double weakest_kept = 1e300;
  for (const auto& kp : top.keypoints) weakest_kept = std::min(weakest_kept, kp.response);
  std::size_t stronger = 0;
  for (const auto& kp : all.keypoints) stronger += kp.response > weakest_kept ? 1 : 0;
  CHECK(stronger < 50);

  options = {};
  options.upright = true;
  const diachron::Features upright = diachron::AkazeExtractor(options).extract(img);
  REQUIRE_FALSE(upright.empty());
  for (const auto& kp : upright.keypoints) CHECK(kp.angle < 0.0);

  options = {};
  options.descriptor_channels = 4;
  CHECK_THROWS_WITH(diachron::AkazeExtractor(options), Catch::Contains("descriptor_channels"));
  CHECK_THROWS_AS(diachron::AkazeExtractor().extract(Raster<std::uint8_t>()), diachron::Error);
  CHECK(diachron::AkazeExtractor().extract(Raster<std::uint8_t>(64, 64, 7)).empty());
}

TEST_CASE("ExtractorPairMatcher<AkazeExtractor>: Hamming matching recovers a shift and a similarity",
          "[vision]") {
  static_assert(diachron::check_feature_extractor<diachron::AkazeExtractor>());
  static_assert(diachron::check_pair_matcher<diachron::ExtractorPairMatcher<diachron::AkazeExtractor>>());
  const diachron::ExtractorPairMatcher<diachron::AkazeExtractor> matcher;
  CHECK(matcher.metric() == diachron::DescriptorMetric::Hamming);
  const Raster<std::uint8_t> a = textured(480, 360, 13);
  {
    const cv::Matx23d shift(1, 0, -5.5, 0, 1, 9.25);
    const auto matches = matcher.match(a, warp(a, shift));
    const double good = fraction_within(matches, shift, 1.5);
    INFO("shift: matches " << matches.size() << ", within 1.5 px: " << good);
    CHECK(matches.size() >= 100);
    CHECK(good >= 0.8);
    for (const auto& m : matches) CHECK(m.score <= 0.0);
  }
  {
    const cv::Matx23d similarity = cv::getRotationMatrix2D(cv::Point2f(240, 180), -35.0, 1.1);
    const auto matches = matcher.match(a, warp(a, similarity));
    const double good = fraction_within(matches, similarity, 1.5);
    INFO("similarity: matches " << matches.size() << ", within 1.5 px: " << good);
    CHECK(matches.size() >= 100);
    CHECK(good >= 0.8);
  }
}

TEST_CASE("AkazeExtractor: keypoint angles turn by +pi/2 when the image turns 90 degrees clockwise",
          "[vision]") {
  const Raster<std::uint8_t> a = textured(320, 240, 14);
  cv::Mat rotated;
  cv::rotate(diachron::as_mat(a), rotated, cv::ROTATE_90_CLOCKWISE);
  const Raster<std::uint8_t> b = diachron::to_raster<std::uint8_t>(rotated);
  const cv::Matx23d truth(0, -1, a.height() - 1, 1, 0, 0);
  const diachron::AkazeExtractor akaze;
  const diachron::Features fa = akaze.extract(a);
  const diachron::Features fb = akaze.extract(b);
  const auto matches = diachron::match_features(fa, fb, diachron::AkazeExtractor::descriptor_metric());
  std::size_t located = 0;
  std::size_t turned = 0;
  double error_sum = 0.0;
  for (const auto& m : matches) {
    const auto& ka = fa.keypoints[m.a];
    const auto& kb = fb.keypoints[m.b];
    if ((apply(truth, ka.position) - kb.position).norm() > 1.0) continue;
    ++located;
    const double error = diachron::wrap_angle(kb.angle - ka.angle - diachron::kPi / 2);
    // AKAZE picks its orientation from 60-degree sectors: less precise than SIFT's histogram peak.
    if (std::abs(error) < diachron::deg_to_rad(15.0)) {
      ++turned;
      error_sum += error;
    }
  }
  INFO("matches: " << matches.size() << ", located: " << located << ", turned by pi/2: " << turned);
  REQUIRE(located >= 50);
  CHECK(static_cast<double>(turned) >= 0.9 * static_cast<double>(located));
  CHECK(std::abs(error_sum / static_cast<double>(turned)) < diachron::deg_to_rad(3.0));
}
