#pragma once
/// @file
/// AkazeExtractor: OpenCV AKAZE (Alcantarilla et al. 2013) as a diachron FeatureExtractor, with its
/// binary MLDB descriptors unpacked to one float per bit.
///
/// Why unpack: diachron::Features holds float descriptors so that every extractor fits every
/// descriptor matcher. With bits stored as 0/1 floats, the Hamming distance equals the L1 distance
/// and the squared L2 distance, so an Eigen-only matcher gives Hamming results exactly (use
/// squared-L2 or L1, or take sqrt into account in a ratio test). ExtractorPairMatcher repacks the
/// bits and matches with OpenCV's NORM_HAMMING (descriptor_metric() says Hamming), so its ratio
/// test is on Hamming distances, as for any binary descriptor.

#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/vision/cv_features.hpp>
#include <diachron/vision/image.hpp>

namespace diachron {

/// Options of AkazeExtractor; the defaults are OpenCV's (cv::AKAZE::create).
struct AkazeOptions {
  /// Keep at most this many keypoints, the strongest by detector response; 0 keeps all. Applied
  /// after detection (OpenCV 4.6's AKAZE has no such limit itself), in the detector's order.
  int max_features = 0;
  /// Detector response threshold on the Hessian determinant of the [0, 1]-scaled image (OpenCV
  /// `threshold`, 0.001). Lower it for low-contrast images.
  double threshold = 0.001;
  /// Octaves of the nonlinear scale space (OpenCV `nOctaves`, 4).
  int octaves = 4;
  /// Sublevels per octave (OpenCV `nOctaveLayers`, 4).
  int octave_layers = 4;
  /// Conductance function of the nonlinear diffusion (OpenCV `diffusivity`, Perona-Malik g2).
  cv::KAZE::DiffusivityType diffusivity = cv::KAZE::DIFF_PM_G2;
  /// MLDB descriptor length in bits; 0 means the full descriptor (486 bits, stored in 61 bytes,
  /// hence 488 float columns whose last two are always 0). Otherwise one of OpenCV's sizes (<= 486).
  int descriptor_bits = 0;
  /// Channels compared by MLDB: 1 (intensity), 2 (+ gradient sum), 3 (+ gradient x and y; OpenCV's 3).
  int descriptor_channels = 3;
  /// Upright MLDB: no orientation is computed, keypoint angles are reported as none (-1). Faster,
  /// and right when the images are known to be aligned within a few degrees.
  bool upright = false;

  void check() const {
    DIACHRON_CHECK(max_features >= 0, "AkazeOptions::max_features must be >= 0, got " << max_features);
    DIACHRON_CHECK(std::isfinite(threshold) && threshold > 0.0,
                   "AkazeOptions::threshold must be finite and > 0, got " << threshold);
    DIACHRON_CHECK(octaves >= 1, "AkazeOptions::octaves must be >= 1, got " << octaves);
    DIACHRON_CHECK(octave_layers >= 1, "AkazeOptions::octave_layers must be >= 1, got " << octave_layers);
    DIACHRON_CHECK(descriptor_bits >= 0 && descriptor_bits <= 486,
                   "AkazeOptions::descriptor_bits must be in [0, 486], got " << descriptor_bits);
    DIACHRON_CHECK(descriptor_channels >= 1 && descriptor_channels <= 3,
                   "AkazeOptions::descriptor_channels must be 1, 2 or 3, got " << descriptor_channels);
  }
};

/// FeatureExtractor (docs/architecture.md) running OpenCV AKAZE on an 8-bit raster.
///
/// Output: positions in diachron's pixel convention; `scale` = KeyPoint::size (pixels);
/// `angle` = KeyPoint::angle in radians from +x towards +y in [0, 2 pi), or -1 when upright;
/// `response` = Hessian response; descriptors = MLDB bits unpacked to 0/1 floats (8 columns per
/// OpenCV byte, bit b of byte j in column 8 j + b). Compare with DescriptorMetric::Hamming.
///
/// Thread safety: `extract` is const and creates its cv::AKAZE per call.
class AkazeExtractor {
 public:
  explicit AkazeExtractor(AkazeOptions options = {}) : options_(options) { options_.check(); }

  const AkazeOptions& options() const { return options_; }
  static constexpr DescriptorMetric descriptor_metric() { return DescriptorMetric::Hamming; }
  /// Oriented MLDB descriptors do not change when the image turns; upright ones do.
  bool rotation_invariant() const { return !options_.upright; }

  /// Keypoints and descriptors of `image`. An empty raster throws diachron::Error; an image
  /// without texture gives empty Features.
  Features extract(const Raster<std::uint8_t>& image) const { return extract_impl(image, nullptr); }

  /// The same, detecting only where `mask` (the image's size) is nonzero (cv::Feature2D's mask).
  Features extract(const Raster<std::uint8_t>& image, const Raster<std::uint8_t>& mask) const {
    detail::check_mask_size(image, mask, "AkazeExtractor");
    return extract_impl(image, &mask);
  }

 private:
  Features extract_impl(const Raster<std::uint8_t>& image, const Raster<std::uint8_t>* mask) const {
    DIACHRON_CHECK(!image.empty(), "AkazeExtractor: the image is empty");
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat desc;
    const cv::Mat mask_mat = mask ? as_mat(*mask) : cv::Mat();  // empty: OpenCV's "no mask"
    try {
      cv::Ptr<cv::AKAZE> akaze = cv::AKAZE::create(
          options_.upright ? cv::AKAZE::DESCRIPTOR_MLDB_UPRIGHT : cv::AKAZE::DESCRIPTOR_MLDB,
          options_.descriptor_bits, options_.descriptor_channels, static_cast<float>(options_.threshold),
          options_.octaves, options_.octave_layers, options_.diffusivity);
      akaze->detectAndCompute(as_mat(image), mask_mat, keypoints, desc);
    } catch (const cv::Exception& e) {
      DIACHRON_CHECK(false, "AkazeExtractor: OpenCV failed on a " << image.width() << " x " << image.height()
                                                                  << " image: " << e.what());
    }
    Features out;
    if (keypoints.empty()) return out;
    const std::vector<int> rows = detail::strongest(keypoints, options_.max_features);
    out.keypoints.reserve(rows.size());
    for (int r : rows) {
      Keypoint kp = detail::to_keypoint(keypoints[static_cast<std::size_t>(r)]);
      if (options_.upright) kp.angle = -1.0;
      out.keypoints.push_back(kp);
    }
    out.descriptors = detail::unpack_bits(desc, rows);
    return out;
  }

  AkazeOptions options_;
};

}  // namespace diachron
