#pragma once
/// @file
/// Features: keypoints with scale and orientation plus one descriptor per keypoint, as
/// FeatureExtractors return them and descriptor matchers consume them.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>

namespace diachron {

/// A detected keypoint. `position` in pixels (docs/conventions.md); `scale` in pixels (the
/// detector's characteristic size, e.g. OpenCV's KeyPoint::size; 0 when the detector has none);
/// `angle` in radians, measured from the +x axis towards +y (clockwise as seen on screen, since y
/// points down), in [0, 2 pi); negative when the detector gives no orientation. `response` is the
/// detector strength (higher is stronger).
struct Keypoint {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double scale = 0.0;
  double angle = -1.0;
  double response = 0.0;
};

/// Row-major float descriptors, one row per keypoint.
using DescriptorMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Keypoints and their descriptors: descriptors.rows() == keypoints.size().
struct Features {
  std::vector<Keypoint> keypoints;
  DescriptorMatrix descriptors;

  std::size_t size() const { return keypoints.size(); }
  bool empty() const { return keypoints.empty(); }
};

/// Binary descriptors in the layout the library stores them: `bytes` holds `rows` rows of
/// `bytes_per_row` packed bytes; bit b of byte j becomes column 8 j + b, as a float 0 or 1 (OpenCV's
/// bit order, so packing back for NORM_HAMMING is exact). Use it for ORB, BRISK or any descriptor
/// declared DescriptorMetric::Hamming: one byte per float is not this layout and is rejected.
inline DescriptorMatrix unpack_bits(const std::uint8_t* bytes, Eigen::Index rows, Eigen::Index bytes_per_row) {
  DescriptorMatrix out(rows, bytes_per_row * 8);
  for (Eigen::Index i = 0; i < rows; ++i) {
    const std::uint8_t* src = bytes + i * bytes_per_row;
    for (Eigen::Index j = 0; j < bytes_per_row; ++j)
      for (int b = 0; b < 8; ++b) out(i, 8 * j + b) = static_cast<float>((src[j] >> b) & 1u);
  }
  return out;
}

/// Throws diachron::Error unless `descriptors` is in the bit layout of unpack_bits(): a multiple of
/// 8 columns, every value 0 or 1. The message names the first offending value and says how to fix
/// it; `which` names the descriptor set in it (e.g. "A").
inline void check_bit_descriptors(const DescriptorMatrix& descriptors, const char* which = "") {
  DIACHRON_CHECK(descriptors.cols() % 8 == 0,
                 "Hamming descriptors " << which << " have " << descriptors.cols()
                                        << " columns, not a multiple of 8: binary descriptors are stored one float "
                                           "per bit (diachron::unpack_bits)");
  for (Eigen::Index r = 0; r < descriptors.rows(); ++r)
    for (Eigen::Index c = 0; c < descriptors.cols(); ++c) {
      const float v = descriptors(r, c);
      DIACHRON_CHECK(v == 0.0f || v == 1.0f,
                     "Hamming descriptors " << which << ": row " << r << " column " << c << " is " << v
                                            << ", not a bit (0 or 1); binary descriptors are stored one float per "
                                               "bit, so unpack the bytes with diachron::unpack_bits (one byte per "
                                               "float, e.g. ORB's 32 bytes as 32 floats, is not that layout)");
    }
}

/// Removes the keypoints (and their descriptor rows) whose nearest pixel is outside `mask` or 0 in
/// it; the order of the others is kept. `mask` has the size of the image the features come from.
inline void drop_masked_features(Features& features, const Raster<std::uint8_t>& mask) {
  std::vector<Eigen::Index> keep;
  for (std::size_t i = 0; i < features.keypoints.size(); ++i) {
    const Eigen::Vector2d& p = features.keypoints[i].position;
    if (!std::isfinite(p.x()) || !std::isfinite(p.y())) continue;
    const long x = std::lround(p.x()), y = std::lround(p.y());
    if (x < 0 || y < 0 || x >= mask.width() || y >= mask.height()) continue;
    if (mask(static_cast<int>(x), static_cast<int>(y)) != 0) keep.push_back(static_cast<Eigen::Index>(i));
  }
  if (keep.size() == features.keypoints.size()) return;
  Features out;
  out.keypoints.reserve(keep.size());
  out.descriptors.resize(static_cast<Eigen::Index>(keep.size()), features.descriptors.cols());
  for (std::size_t k = 0; k < keep.size(); ++k) {
    out.keypoints.push_back(features.keypoints[static_cast<std::size_t>(keep[k])]);
    if (features.descriptors.rows() > keep[k])
      out.descriptors.row(static_cast<Eigen::Index>(k)) = features.descriptors.row(keep[k]);
  }
  features = std::move(out);
}

namespace detail {

inline void check_mask_size(const Raster<std::uint8_t>& image, const Raster<std::uint8_t>& mask, const char* who) {
  DIACHRON_CHECK(mask.width() == image.width() && mask.height() == image.height(),
                 who << ": the mask is " << mask.width() << " x " << mask.height() << ", the image "
                     << image.width() << " x " << image.height());
}

}  // namespace detail

}  // namespace diachron
