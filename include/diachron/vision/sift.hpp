#pragma once
/// @file
/// SiftExtractor: OpenCV SIFT (Lowe 2004) as a diachron FeatureExtractor, optionally with the
/// RootSIFT descriptor mapping (Arandjelovic and Zisserman 2012) that MicMac's guided matching uses.

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

/// Options of SiftExtractor; the defaults are OpenCV's (cv::SIFT::create), which are Lowe's.
struct SiftOptions {
  /// Keep at most this many keypoints, the strongest by response (OpenCV `nfeatures`); 0 keeps all.
  /// OpenCV may return a few more when responses tie, and counts a location with two orientations
  /// as two keypoints.
  int max_features = 0;
  /// Scale levels per octave (OpenCV `nOctaveLayers`, Lowe's 3). The octave count follows the image size.
  int octave_layers = 3;
  /// DoG contrast threshold on images scaled to [0, 1] (OpenCV `contrastThreshold`). OpenCV divides it
  /// by `octave_layers` before use, so 0.04 means 0.04 / 3 on the DoG. Lower it for flat DSM images.
  double contrast_threshold = 0.04;
  /// Edge rejection: principal-curvature ratio limit r (OpenCV `edgeThreshold`); larger keeps more edges.
  double edge_threshold = 10.0;
  /// Gaussian blur of the base level, in pixels of the (internally doubled) input (OpenCV `sigma`).
  double sigma = 1.6;
  /// Map each descriptor to RootSIFT: L1-normalise, then take element-wise square roots. Comparing
  /// RootSIFT with L2 is comparing SIFT with the Hellinger kernel; the rows have unit L2 norm.
  bool root_sift = false;
  /// Undo OpenCV's upscaling offset: true (default) moves every keypoint 0.25 px left and up, so
  /// positions follow diachron's pixel-centre convention exactly. Why: SIFT detects on the image
  /// doubled by cv::resize, whose output pixel X samples the input at X / 2 - 0.25 (half-pixel
  /// centres), but OpenCV maps keypoints back with x = X / 2, so its positions are 0.25 px too far
  /// right and down (OpenCV issue 23123; 4.8 added `enable_precise_upscale`, off by default, and
  /// 4.6 has no fix). Every octave inherits the offset of the doubled base, so it is the same at
  /// all scales; the keypoint size needs no change (the doubling is an exact factor 2, which
  /// OpenCV undoes). Measured on a texture against its 180-degree rotation
  /// (tests/vision/localisation_bias_test.cpp): mean residual 0.50 px (2 x 0.25) without, below
  /// 0.01 px with. false returns OpenCV's positions unchanged.
  bool correct_upscale_offset = true;

  void check() const {
    DIACHRON_CHECK(max_features >= 0, "SiftOptions::max_features must be >= 0, got " << max_features);
    DIACHRON_CHECK(octave_layers >= 1, "SiftOptions::octave_layers must be >= 1, got " << octave_layers);
    DIACHRON_CHECK(std::isfinite(contrast_threshold) && contrast_threshold >= 0.0,
                   "SiftOptions::contrast_threshold must be finite and >= 0, got " << contrast_threshold);
    DIACHRON_CHECK(std::isfinite(edge_threshold) && edge_threshold > 0.0,
                   "SiftOptions::edge_threshold must be finite and > 0, got " << edge_threshold);
    DIACHRON_CHECK(std::isfinite(sigma) && sigma > 0.0, "SiftOptions::sigma must be finite and > 0, got " << sigma);
  }
};

namespace detail {

/// RootSIFT in place: each row L1-normalised then square-rooted (rows of zeros stay zero).
inline void apply_root_sift(DescriptorMatrix& desc) {
  for (Eigen::Index i = 0; i < desc.rows(); ++i) {
    auto row = desc.row(i);
    const float l1 = row.cwiseAbs().sum();
    if (l1 > 0.0f) row = (row.cwiseAbs() / l1).cwiseSqrt();
  }
}

}  // namespace detail

/// FeatureExtractor (docs/architecture.md) running OpenCV SIFT on an 8-bit raster.
///
/// Output: positions in diachron's pixel convention (OpenCV's 0.25 px upscaling offset removed, see
/// SiftOptions::correct_upscale_offset); `scale` = KeyPoint::size (the diameter of
/// the descriptor's neighbourhood, in pixels); `angle` = KeyPoint::angle in radians, from +x towards
/// +y, in [0, 2 pi) (see cv_features.hpp); `response` = DoG contrast; 128 float descriptors
/// (RootSIFT when `options.root_sift`). Compare with DescriptorMetric::L2.
///
/// Thread safety: `extract` is const and creates its cv::SIFT per call, so one extractor can serve
/// many threads. OpenCV's own parallelism (cv::setNumThreads) is left as the application set it.
class SiftExtractor {
 public:
  explicit SiftExtractor(SiftOptions options = {}) : options_(options) { options_.check(); }

  const SiftOptions& options() const { return options_; }
  static constexpr DescriptorMetric descriptor_metric() { return DescriptorMetric::L2; }
  /// SIFT descriptors are computed in the keypoint's orientation: turning the image does not change
  /// them, so rotation hypotheses add nothing (pipeline/rough_coregistration.hpp asks this).
  static constexpr bool rotation_invariant() { return true; }

  /// Keypoints and descriptors of `image`. An empty raster throws diachron::Error; an image
  /// without texture gives empty Features.
  Features extract(const Raster<std::uint8_t>& image) const { return extract_impl(image, nullptr); }

  /// The same, detecting only where `mask` (the image's size) is nonzero (cv::Feature2D's mask).
  Features extract(const Raster<std::uint8_t>& image, const Raster<std::uint8_t>& mask) const {
    detail::check_mask_size(image, mask, "SiftExtractor");
    return extract_impl(image, &mask);
  }

 private:
  Features extract_impl(const Raster<std::uint8_t>& image, const Raster<std::uint8_t>* mask) const {
    DIACHRON_CHECK(!image.empty(), "SiftExtractor: the image is empty");
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat desc;
    const cv::Mat mask_mat = mask ? as_mat(*mask) : cv::Mat();  // empty: OpenCV's "no mask"
    try {
      cv::Ptr<cv::SIFT> sift = cv::SIFT::create(options_.max_features, options_.octave_layers,
                                                options_.contrast_threshold, options_.edge_threshold,
                                                options_.sigma);
      sift->detectAndCompute(as_mat(image), mask_mat, keypoints, desc);
    } catch (const cv::Exception& e) {
      DIACHRON_CHECK(false, "SiftExtractor: OpenCV failed on a " << image.width() << " x " << image.height()
                                                                 << " image: " << e.what());
    }
    Features out;
    if (keypoints.empty()) {
      out.descriptors.resize(0, 128);
      return out;
    }
    std::vector<int> rows = detail::strongest(keypoints, 0);
    out.keypoints.reserve(keypoints.size());
    const double offset = options_.correct_upscale_offset ? kUpscaleOffset : 0.0;
    for (const cv::KeyPoint& kp : keypoints) {
      Keypoint k = detail::to_keypoint(kp);
      k.position -= Vec2(offset, offset);
      out.keypoints.push_back(k);
    }
    out.descriptors = detail::float_rows(desc, rows);
    if (options_.root_sift) detail::apply_root_sift(out.descriptors);
    return out;
  }

  /// OpenCV's SIFT offset in input pixels (see SiftOptions::correct_upscale_offset).
  static constexpr double kUpscaleOffset = 0.25;

  SiftOptions options_;
};

/// SIFT with RootSIFT descriptors, whatever `options.root_sift` says: the descriptor MicMac's
/// TiePHistorical matches with (ratio 0.8, mutual nearest neighbour).
class RootSiftExtractor : public SiftExtractor {
 public:
  explicit RootSiftExtractor(SiftOptions options = {}) : SiftExtractor(with_root(options)) {}

 private:
  static SiftOptions with_root(SiftOptions options) {
    options.root_sift = true;
    return options;
  }
};

}  // namespace diachron
