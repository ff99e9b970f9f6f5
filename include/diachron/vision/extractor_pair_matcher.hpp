#pragma once
/// @file
/// ExtractorPairMatcher: a PairMatcher made of any FeatureExtractor plus brute-force descriptor
/// matching with OpenCV's cv::BFMatcher (Lowe's ratio test and mutual nearest neighbour, as MicMac's
/// TiePHistorical: ratio 0.8, mutual on).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/tiling/pair_matcher.hpp>
#include <diachron/vision/cv_features.hpp>

namespace diachron {

/// Options of brute-force descriptor matching in ExtractorPairMatcher and match_features.
struct ExtractorMatchOptions {
  /// Lowe's ratio test: keep the nearest neighbour b1 of a descriptor only when
  /// d(a, b1) <= ratio * d(a, b2), with b2 the second nearest (MicMac rejects d1 / d2 > 0.8).
  /// Distances in the metric's units (L2, or bit count for Hamming). 1 disables the test. A
  /// descriptor set B with a single row has no second neighbour: the test is then passed.
  double ratio = 0.8;
  /// Keep a pair only when each is the other's nearest neighbour (the ratio test is applied in the
  /// A -> B direction only, the mutual check uses plain nearest neighbours B -> A).
  bool mutual = true;
  /// Drop pairs whose descriptor distance exceeds this (metric units); infinity keeps all.
  double max_distance = std::numeric_limits<double>::infinity();

  void check() const {
    DIACHRON_CHECK(ratio > 0.0 && ratio <= 1.0, "ExtractorMatchOptions::ratio must be in (0, 1], got " << ratio);
    DIACHRON_CHECK(!std::isnan(max_distance) && max_distance >= 0.0,
                   "ExtractorMatchOptions::max_distance must be >= 0, got " << max_distance);
  }
};

/// One descriptor correspondence: row `a` of the first Features, row `b` of the second, and their
/// distance in the metric's units (L2 distance, or number of differing bits for Hamming).
struct FeatureIndexMatch {
  std::size_t a = 0;
  std::size_t b = 0;
  double distance = 0.0;
};

/// Brute-force matching of two descriptor sets with cv::BFMatcher: nearest neighbours A -> B with
/// the ratio test, then the mutual check. `metric` L2 and Cosine use NORM_L2 (for unit rows the L2
/// distance is sqrt(2 - 2 cos), so the order is the cosine order); Hamming repacks 0/1 float bits
/// (AkazeExtractor's layout, diachron::unpack_bits) and uses NORM_HAMMING. Results are sorted by row
/// of A. Throws diachron::Error when the descriptor widths differ, rows and keypoints disagree, or
/// Hamming descriptors hold a value other than 0 and 1 (check_bit_descriptors).
inline std::vector<FeatureIndexMatch> match_features(const Features& a, const Features& b,
                                                     DescriptorMetric metric,
                                                     const ExtractorMatchOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(static_cast<std::size_t>(a.descriptors.rows()) == a.keypoints.size() &&
                     static_cast<std::size_t>(b.descriptors.rows()) == b.keypoints.size(),
                 "features need one descriptor row per keypoint, got " << a.descriptors.rows() << " rows for "
                     << a.keypoints.size() << " keypoints (A) and " << b.descriptors.rows() << " for "
                     << b.keypoints.size() << " (B)");
  std::vector<FeatureIndexMatch> out;
  if (a.empty() || b.empty()) return out;
  DIACHRON_CHECK(a.descriptors.cols() == b.descriptors.cols(),
                 "descriptor widths differ: " << a.descriptors.cols() << " (A) vs " << b.descriptors.cols() << " (B)");

  const bool binary = metric == DescriptorMetric::Hamming;
  // Packing reads any value > 0.5 as a set bit: bytes stored one per float would pass as 8x fewer,
  // mostly set bits and match as noise, so the layout is checked instead of trusted.
  if (binary) {
    check_bit_descriptors(a.descriptors, "A");
    check_bit_descriptors(b.descriptors, "B");
  }
  // Packed copies for Hamming; for L2 the Mats are views of the Eigen rows (no copy).
  const cv::Mat da = binary ? detail::pack_bits(a.descriptors) : detail::float_view(a.descriptors);
  const cv::Mat db = binary ? detail::pack_bits(b.descriptors) : detail::float_view(b.descriptors);
  std::vector<std::vector<cv::DMatch>> knn;
  std::vector<cv::DMatch> back;
  try {
    cv::BFMatcher matcher(binary ? cv::NORM_HAMMING : cv::NORM_L2, false);
    matcher.knnMatch(da, db, knn, 2);
    if (options.mutual) matcher.match(db, da, back);
  } catch (const cv::Exception& e) {
    DIACHRON_CHECK(false, "descriptor matching failed in OpenCV: " << e.what());
  }
  for (const std::vector<cv::DMatch>& candidates : knn) {
    if (candidates.empty()) continue;
    const cv::DMatch& best = candidates[0];
    const double d1 = best.distance;
    if (candidates.size() > 1 && options.ratio < 1.0 && d1 > options.ratio * candidates[1].distance) continue;
    if (d1 > options.max_distance) continue;
    if (options.mutual && back[static_cast<std::size_t>(best.trainIdx)].trainIdx != best.queryIdx) continue;
    out.push_back({static_cast<std::size_t>(best.queryIdx), static_cast<std::size_t>(best.trainIdx), d1});
  }
  return out;
}

namespace detail {

template <class E, class = void>
struct HasDescriptorMetric : std::false_type {};
template <class E>
struct HasDescriptorMetric<E, std::void_t<decltype(std::declval<const E&>().descriptor_metric())>>
    : std::true_type {};

template <class E, class = void>
struct HasExtract : std::false_type {};
template <class E>
struct HasExtract<E, std::void_t<decltype(std::declval<const E&>().extract(
                         std::declval<const Raster<std::uint8_t>&>()))>>
    : std::is_same<decltype(std::declval<const E&>().extract(std::declval<const Raster<std::uint8_t>&>())),
                   Features> {};

}  // namespace detail

/// PairMatcher (docs/architecture.md) from a FeatureExtractor: extracts features in both rasters and
/// matches them with match_features. The metric is `Extractor::descriptor_metric()` when the
/// extractor has one (SiftExtractor: L2, AkazeExtractor: Hamming), otherwise L2 on real-valued
/// rows: the FeatureExtractor concept (tiling/pair_matcher.hpp) documents L2 as the default, and a
/// binary extractor must say Hamming. With a masked extractor (`extract(image, mask)`) it is a
/// masked PairMatcher too: no feature where a mask is 0.
/// `PointMatch::score` is minus the descriptor distance (higher is better).
///
/// Thread safety: `match` is const and keeps no state between calls (the extractors in vision/
/// create their OpenCV objects per call, and so does the matching), so one matcher can serve many
/// threads when its extractor's `extract` can.
template <class Extractor>
class ExtractorPairMatcher {
  static_assert(detail::HasExtract<Extractor>::value,
                "ExtractorPairMatcher<Extractor>: Extractor must have "
                "`Features extract(const Raster<std::uint8_t>&) const` (the FeatureExtractor concept)");

 public:
  explicit ExtractorPairMatcher(Extractor extractor = Extractor{}, ExtractorMatchOptions options = {})
      : extractor_(std::move(extractor)), options_(options) {
    options_.check();
  }

  const Extractor& extractor() const { return extractor_; }
  /// Whether the extractor says its features do not change when the image turns (false when it
  /// does not say). Lets a pipeline skip rotation hypotheses.
  bool rotation_invariant() const { return diachron::rotation_invariant(extractor_); }
  const ExtractorMatchOptions& options() const { return options_; }

  /// The metric descriptors are compared with (see the class comment).
  DescriptorMetric metric() const {
    if constexpr (detail::HasDescriptorMetric<Extractor>::value) {
      return extractor_.descriptor_metric();
    } else {
      return DescriptorMetric::L2;
    }
  }

  /// Matches of raster `a` (master) against raster `b` (secondary), in each raster's pixels.
  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b) const {
    return match(extractor_.extract(a), extractor_.extract(b));
  }

  /// Masked matching (only with a masked extractor): features only where the masks are nonzero.
  template <class E = Extractor, std::enable_if_t<is_masked_feature_extractor_v<E>, int> = 0>
  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b,
                                const Raster<std::uint8_t>& mask_a, const Raster<std::uint8_t>& mask_b) const {
    return match(extractor_.extract(a, mask_a), extractor_.extract(b, mask_b));
  }

  /// Matches of already extracted features (useful to reuse one image's features against many).
  std::vector<PointMatch> match(const Features& a, const Features& b) const {
    std::vector<PointMatch> out;
    for (const FeatureIndexMatch& m : match_features(a, b, metric(), options_))
      out.push_back({a.keypoints[m.a].position, b.keypoints[m.b].position, -m.distance});
    return out;
  }

 private:
  Extractor extractor_;
  ExtractorMatchOptions options_;
};

}  // namespace diachron
