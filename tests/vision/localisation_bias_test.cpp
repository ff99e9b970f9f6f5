// Localisation bias of every shipped extractor (SIFT, RootSIFT, AKAZE, XFeat): a textured image
// against its exact 180-degree rotation. A point p of the image is at (W - 1 - x, H - 1 - y) in the
// rotation; an extractor that reports every keypoint b px off (the same b in both images, since the
// offset is in image axes) gives pairs whose mapped-back positions differ by -2 b. The mean of that
// residual is what these tests bound (0.05 px, i.e. a bias below 0.025 px).
//
// Pairs are found by position, not by descriptor: a keypoint of the image and a mapped-back keypoint
// of the rotation pair up when each is the other's nearest within 1.5 px. That works for XFeat too,
// whose descriptors do not survive a half turn, and the radius leaves room for biases up to 0.5 px.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/raster.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/matching/rotation_hypotheses.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/root_sift.hpp>
#include <diachron/vision/sift.hpp>
#include <diachron/vision/xfeat.hpp>

#include "support/test_paths.hpp"
#include "support/textures.hpp"

namespace {

using diachron::Raster;

struct Bias {
  std::size_t pairs = 0;
  Eigen::Vector2d mean_residual = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
};

// 320 x 240: multiples of 8, so XFeat's 8 x 8 cells of the image and of its rotation cover the
// same pixels, and small enough for the sanitizer build.
constexpr int kWidth = 320;
constexpr int kHeight = 240;
constexpr double kPairRadius = 1.5;  // px
constexpr double kLimit = 0.05;      // px, mean residual (= 2 x bias)

std::size_t nearest(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& points, double& distance) {
  std::size_t best = points.size();
  distance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double d = (points[i] - p).norm();
    if (d < distance) {
      distance = d;
      best = i;
    }
  }
  return best;
}

template <class Extractor>
Bias measure_bias(const Extractor& extractor, std::uint64_t seed) {
  const Raster<std::uint8_t> image = diachron::test::textured(kWidth, kHeight, seed);
  const Raster<std::uint8_t> turned = diachron::rotate_quarter_turns(image, 2);
  const diachron::Features a = extractor.extract(image);
  const diachron::Features b = extractor.extract(turned);
  std::vector<Eigen::Vector2d> pa, pb;
  for (const auto& kp : a.keypoints) pa.push_back(kp.position);
  for (const auto& kp : b.keypoints)
    pb.push_back(diachron::unrotate_point_quarter_turns(kp.position, 2, kWidth, kHeight));
  Bias out;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < pa.size(); ++i) {
    double d_ab = 0.0, d_ba = 0.0;
    const std::size_t j = nearest(pa[i], pb, d_ab);
    if (j == pb.size() || d_ab > kPairRadius) continue;
    // Mutual: SIFT reports a location twice when it has two orientations; the copies are at the
    // same position, so either is the nearest and the pair counts once.
    if ((pa[nearest(pb[j], pa, d_ba)] - pa[i]).norm() > 0.0) continue;
    sum += pb[j] - pa[i];
    ++out.pairs;
  }
  if (out.pairs > 0) out.mean_residual = sum / static_cast<double>(out.pairs);
  return out;
}

template <class Extractor>
void check_unbiased(const Extractor& extractor, const char* name, double limit = kLimit) {
  for (std::uint64_t seed : {3u, 4u}) {
    const Bias bias = measure_bias(extractor, seed);
    INFO(name << ", seed " << seed << ": " << bias.pairs << " pairs, mean residual (" << bias.mean_residual.x()
              << ", " << bias.mean_residual.y() << ") px, norm " << bias.mean_residual.norm() << " px");
    REQUIRE(bias.pairs >= 50);
    CHECK(std::abs(bias.mean_residual.x()) < limit);
    CHECK(std::abs(bias.mean_residual.y()) < limit);
    CHECK(bias.mean_residual.norm() < limit);
  }
}

}  // namespace

TEST_CASE("Localisation bias: SIFT keypoints are unbiased to 0.025 px", "[vision]") {
  check_unbiased(diachron::SiftExtractor(), "SIFT");
}

TEST_CASE("Localisation bias: RootSIFT keypoints are unbiased to 0.025 px", "[vision]") {
  check_unbiased(diachron::RootSiftExtractor(), "RootSIFT");
}

TEST_CASE("Localisation bias: without the correction SIFT is 0.25 px right and down (OpenCV's doubling)",
          "[vision]") {
  // The measurement must see the bias it bounds: OpenCV's own positions give a residual of -0.5 px.
  diachron::SiftOptions raw;
  raw.correct_upscale_offset = false;
  const Bias bias = measure_bias(diachron::SiftExtractor(raw), 3);
  INFO(bias.pairs << " pairs, mean residual (" << bias.mean_residual.x() << ", " << bias.mean_residual.y() << ") px");
  REQUIRE(bias.pairs >= 50);
  CHECK(bias.mean_residual.x() == Approx(-0.5).margin(kLimit));
  CHECK(bias.mean_residual.y() == Approx(-0.5).margin(kLimit));
}

TEST_CASE("Localisation bias: AKAZE keypoints are unbiased to 0.025 px", "[vision]") {
  check_unbiased(diachron::AkazeExtractor(), "AKAZE");
}

TEST_CASE("Localisation bias: XFeat keypoints are within the documented 0.15 px", "[vision]") {
  // XFeat keypoints are whole network pixels and its learned heatmap is not symmetric under a half
  // turn: most pairs differ by one pixel, and the mean residual was (0.10, -0.09) and (0.13, -0.16)
  // px on these two images, (-0.02..0.15, -0.24..-0.20) px on 640 x 640 ones, i.e. a bias of up to
  // about 0.1 px that depends on the image; no coordinate mapping removes it (a parabolic
  // sub-pixel peak did not either). docs/vision.md documents it; this bounds it, 0.3 px residual.
  const auto model = diachron::test::model_file("xfeat/xfeat.onnx");
  DIACHRON_REQUIRE_FILE_OR_SKIP(model, "the XFeat ONNX model");
  check_unbiased(diachron::XFeatExtractor(*model), "XFeat", 0.3);
}
