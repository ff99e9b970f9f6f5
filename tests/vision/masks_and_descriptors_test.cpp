// Validity masks through the OpenCV adapters (SIFT, RootSIFT, AKAZE, XFeat, ExtractorPairMatcher)
// and the binary-descriptor layout check of match_features (one float per bit, unpack_bits).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/tiling/pair_matcher.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/cv_features.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/image.hpp>
#include <diachron/vision/sift.hpp>
#include <diachron/vision/xfeat.hpp>

#include "support/test_paths.hpp"
#include "support/textures.hpp"

using diachron::Features;
using diachron::Raster;
using diachron::test::textured;

namespace {

// A textured image with a "hole" filled with 0 (as a slope image writes holes), and the mask that
// excludes the hole and a 6-pixel rim around it.
struct HoleImage {
  Raster<std::uint8_t> image;
  Raster<std::uint8_t> mask;
};

HoleImage hole_image(std::uint64_t seed) {
  HoleImage h{textured(320, 240, seed), Raster<std::uint8_t>(320, 240, 255)};
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x) {
      const double d = std::hypot(x - 160.0, y - 120.0);
      if (d < 50.0) h.image(x, y) = 0;
      if (d < 56.0 || x < 40) h.mask(x, y) = 0;  // the hole, its rim and a masked strip
    }
  return h;
}

int keypoints_under_mask(const Features& f, const Raster<std::uint8_t>& mask) {
  int n = 0;
  for (const auto& k : f.keypoints) {
    const int x = static_cast<int>(std::lround(k.position.x())), y = static_cast<int>(std::lround(k.position.y()));
    if (!mask.contains(x, y) || mask(x, y) == 0) ++n;
  }
  return n;
}

int keypoints_near_hole(const Features& f) {
  int n = 0;
  for (const auto& k : f.keypoints)
    if (std::hypot(k.position.x() - 160.0, k.position.y() - 120.0) < 56.0) ++n;
  return n;
}

template <class Extractor>
void check_masked_extractor(const Extractor& extractor, const char* name) {
  INFO(name);
  const HoleImage h = hole_image(3);
  const Features free = extractor.extract(h.image);
  const Features masked = extractor.extract(h.image, h.mask);
  // Without the mask the hole's rim attracts features; with it none lies where the mask is 0.
  CHECK(keypoints_near_hole(free) > 0);
  CHECK(keypoints_under_mask(masked, h.mask) == 0);
  CHECK(masked.size() > 20);
  CHECK(static_cast<std::size_t>(masked.descriptors.rows()) == masked.size());
  CHECK_THROWS_AS(extractor.extract(h.image, Raster<std::uint8_t>(10, 10, 255)), diachron::Error);
}

// An ORB extractor that stores each descriptor byte in one float (the mistake the check catches)
// or, with `unpack`, one float per bit as the library expects.
struct OrbExtractor {
  bool unpack = false;
  static constexpr diachron::DescriptorMetric descriptor_metric() { return diachron::DescriptorMetric::Hamming; }
  Features extract(const Raster<std::uint8_t>& image) const {
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat desc;
    cv::ORB::create(500)->detectAndCompute(diachron::as_mat(image), cv::noArray(), keypoints, desc);
    Features f;
    for (const auto& kp : keypoints) f.keypoints.push_back(diachron::detail::to_keypoint(kp));
    if (unpack) {
      f.descriptors = diachron::unpack_bits(desc);
    } else {
      f.descriptors.resize(desc.rows, desc.cols);
      for (int r = 0; r < desc.rows; ++r)
        for (int c = 0; c < desc.cols; ++c) f.descriptors(r, c) = desc.at<std::uint8_t>(r, c);
    }
    return f;
  }
};

}  // namespace

TEST_CASE("SIFT, RootSIFT and AKAZE: no keypoint where the mask is 0", "[vision]") {
  check_masked_extractor(diachron::SiftExtractor{}, "SIFT");
  check_masked_extractor(diachron::RootSiftExtractor{}, "RootSIFT");
  check_masked_extractor(diachron::AkazeExtractor{}, "AKAZE");
}

TEST_CASE("XFeatExtractor: keypoints off the mask are dropped", "[vision]") {
  const auto model = diachron::test::model_file("xfeat/xfeat.onnx");
  DIACHRON_REQUIRE_FILE_OR_SKIP(model, "the XFeat ONNX model");
  check_masked_extractor(diachron::XFeatExtractor(*model), "XFeat");
  STATIC_REQUIRE(diachron::is_masked_pair_matcher_v<diachron::XFeatPairMatcher>);
}

TEST_CASE("ExtractorPairMatcher: masked matching keeps every match inside both masks", "[vision]") {
  const diachron::ExtractorPairMatcher<diachron::SiftExtractor> matcher;
  STATIC_REQUIRE(diachron::is_masked_pair_matcher_v<decltype(matcher)>);
  const HoleImage h = hole_image(5);
  const auto matches = matcher.match(h.image, h.image, h.mask, h.mask);
  REQUIRE(matches.size() > 20);
  for (const auto& m : matches) {
    REQUIRE(h.mask(static_cast<int>(std::lround(m.a.x())), static_cast<int>(std::lround(m.a.y()))) != 0);
    REQUIRE(h.mask(static_cast<int>(std::lround(m.b.x())), static_cast<int>(std::lround(m.b.y()))) != 0);
  }
}

TEST_CASE("unpack_bits: bit b of byte j is column 8 j + b, and packing back is exact", "[vision]") {
  const std::uint8_t bytes[] = {0x01, 0x80, 0xA5, 0x00, 0xFF, 0x3C};
  const diachron::DescriptorMatrix bits = diachron::unpack_bits(bytes, 2, 3);
  REQUIRE(bits.rows() == 2);
  REQUIRE(bits.cols() == 24);
  CHECK(bits(0, 0) == 1.0f);
  CHECK(bits(0, 1) == 0.0f);
  CHECK(bits(0, 15) == 1.0f);  // 0x80 = bit 7 of byte 1
  CHECK(bits.row(0).sum() == 1 + 1 + 4);
  CHECK(bits.row(1).sum() == 0 + 8 + 4);
  cv::Mat mat(2, 3, CV_8UC1);
  for (int i = 0; i < 6; ++i) mat.at<std::uint8_t>(i / 3, i % 3) = bytes[i];
  CHECK(diachron::unpack_bits(mat) == bits);
  const cv::Mat packed = diachron::detail::pack_bits(bits);
  CHECK(cv::countNonZero(packed != mat) == 0);
  CHECK_NOTHROW(diachron::check_bit_descriptors(bits));
}

TEST_CASE("match_features: Hamming descriptors not stored one float per bit are an error naming the fix",
          "[vision]") {
  const Raster<std::uint8_t> image = textured(320, 240, 8);
  const diachron::ExtractorPairMatcher<OrbExtractor> bytes_matcher{OrbExtractor{false}};
  try {
    bytes_matcher.match(image, image);
    FAIL("bytes stored one per float were accepted");
  } catch (const diachron::Error& e) {
    const std::string what = e.what();
    CHECK(what.find("not a bit") != std::string::npos);
    CHECK(what.find("unpack_bits") != std::string::npos);
  }
  // The same descriptors unpacked match the image with itself.
  const diachron::ExtractorPairMatcher<OrbExtractor> bits_matcher{OrbExtractor{true}};
  const auto matches = bits_matcher.match(image, image);
  REQUIRE(matches.size() > 100);
  for (const auto& m : matches) REQUIRE((m.a - m.b).norm() < 1e-9);
  // A width that is not a multiple of 8 is an error too.
  Features odd;
  odd.keypoints.resize(1);
  odd.descriptors = diachron::DescriptorMatrix::Zero(1, 12);
  CHECK_THROWS_AS(diachron::match_features(odd, odd, diachron::DescriptorMetric::Hamming), diachron::Error);
}

TEST_CASE("drop_masked_features: keeps keypoints and rows where the mask is nonzero, in order", "[vision]") {
  Features f;
  for (int i = 0; i < 5; ++i) {
    diachron::Keypoint k;
    k.position = {2.0 * i, 1.0};
    f.keypoints.push_back(k);
  }
  f.descriptors = diachron::DescriptorMatrix(5, 2);
  for (int i = 0; i < 5; ++i) f.descriptors.row(i) << float(i), float(10 * i);
  Raster<std::uint8_t> mask(7, 3, 255);
  mask(2, 1) = 0;  // keypoint 1
  diachron::drop_masked_features(f, mask);  // keypoint 4 (x = 8) is outside the mask
  REQUIRE(f.size() == 3);
  CHECK(f.descriptors(0, 0) == 0.0f);
  CHECK(f.descriptors(1, 0) == 2.0f);
  CHECK(f.descriptors(2, 1) == 30.0f);
}
