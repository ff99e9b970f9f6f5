#pragma once
/// @file
/// Conversions between OpenCV keypoints / descriptor Mats and diachron::Features, shared by the
/// extractors in vision/.
///
/// Angles: OpenCV's KeyPoint::angle is in degrees, [0, 360), -1 when the detector has none. For
/// SIFT and AKAZE (OpenCV 4.x) it is measured from +x towards +y in image coordinates (y down), i.e.
/// clockwise on screen: SIFT builds its orientation histogram with the y-up gradient and stores
/// 360 - peak, AKAZE takes atan2 of the y-down gradient directly. That is diachron's convention, so
/// the conversion is a plain degrees-to-radians with wrap-around into [0, 2 pi); the tests check it
/// by rotating an image by 90 degrees. Positions: KeyPoint::pt has (0, 0) at the centre of the
/// top-left pixel for these detectors, as diachron, so to_keypoint copies positions unchanged. One
/// exception is corrected by its adapter: OpenCV's SIFT reports keypoints 0.25 px right and down
/// (SiftOptions::correct_upscale_offset in sift.hpp); AKAZE's are unbiased
/// (tests/vision/localisation_bias_test.cpp measures both).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/matching/features.hpp>

namespace diachron {

/// The distance a descriptor family is meant to be compared with.
/// `L2` for real-valued descriptors (SIFT, RootSIFT); `Hamming` for binary descriptors stored as
/// one float per bit (0 or 1), e.g. AKAZE's MLDB: the Hamming distance is then also the squared L2
/// distance and the L1 distance of the float rows; `Cosine` for L2-normalised learned descriptors.
enum class DescriptorMetric { L2, Hamming, Cosine };

namespace detail {

/// OpenCV angle (degrees, -1 = none) to diachron's (radians in [0, 2 pi), negative = none).
inline double cv_angle_to_radians(float angle_deg) {
  if (angle_deg < 0.0f) return -1.0;
  double rad = std::fmod(deg_to_rad(static_cast<double>(angle_deg)), 2.0 * kPi);
  if (rad < 0.0) rad += 2.0 * kPi;
  // fmod can return exactly 2 pi after rounding of the product: keep the half-open range.
  if (rad >= 2.0 * kPi) rad = 0.0;
  return rad;
}

inline Keypoint to_keypoint(const cv::KeyPoint& kp) {
  Keypoint out;
  out.position = Vec2(kp.pt.x, kp.pt.y);
  out.scale = kp.size;
  out.angle = cv_angle_to_radians(kp.angle);
  out.response = kp.response;
  return out;
}

/// Copies the selected rows of a CV_32F descriptor Mat into a DescriptorMatrix.
inline DescriptorMatrix float_rows(const cv::Mat& desc, const std::vector<int>& rows) {
  DIACHRON_CHECK(desc.type() == CV_32FC1, "expected CV_32FC1 descriptors, got " << cv::typeToString(desc.type()));
  DescriptorMatrix out(static_cast<Eigen::Index>(rows.size()), desc.cols);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const float* src = desc.ptr<float>(rows[i]);
    for (int c = 0; c < desc.cols; ++c) out(static_cast<Eigen::Index>(i), c) = src[c];
  }
  return out;
}

/// Unpacks the selected rows of a CV_8U binary descriptor Mat with diachron::unpack_bits (one
/// float, 0 or 1, per bit; bit b of byte j in column 8 j + b, OpenCV's MLDB order).
inline DescriptorMatrix unpack_bits(const cv::Mat& desc, const std::vector<int>& rows) {
  DIACHRON_CHECK(desc.type() == CV_8UC1, "expected CV_8UC1 binary descriptors, got " << cv::typeToString(desc.type()));
  DescriptorMatrix out(static_cast<Eigen::Index>(rows.size()), desc.cols * 8);
  for (std::size_t i = 0; i < rows.size(); ++i)
    out.row(static_cast<Eigen::Index>(i)) = diachron::unpack_bits(desc.ptr<std::uint8_t>(rows[i]), 1, desc.cols);
  return out;
}

/// Inverse of unpack_bits: a float row of 0/1 values (any value > 0.5 counts as 1) packed into
/// CV_8U bytes for OpenCV's Hamming matcher. The column count must be a multiple of 8.
inline cv::Mat pack_bits(const DescriptorMatrix& desc) {
  DIACHRON_CHECK(desc.cols() % 8 == 0,
                 "binary descriptors need a multiple of 8 bit columns, got " << desc.cols());
  cv::Mat out(static_cast<int>(desc.rows()), static_cast<int>(desc.cols() / 8), CV_8UC1, cv::Scalar(0));
  for (int i = 0; i < out.rows; ++i) {
    std::uint8_t* dst = out.ptr<std::uint8_t>(i);
    for (Eigen::Index c = 0; c < desc.cols(); ++c)
      if (desc(i, c) > 0.5f) dst[c / 8] = static_cast<std::uint8_t>(dst[c / 8] | (1u << (c % 8)));
  }
  return out;
}

/// A CV_32F Mat header over a DescriptorMatrix (row-major, so the layouts agree; no copy).
inline cv::Mat float_view(const DescriptorMatrix& desc) {
  if (desc.size() == 0) return cv::Mat();
  return cv::Mat(static_cast<int>(desc.rows()), static_cast<int>(desc.cols()), CV_32FC1,
                 const_cast<float*>(desc.data()));
}

/// Indices 0..n-1 of the `max_count` strongest keypoints (all when max_count is 0 or >= n), in the
/// detector's original order so results do not depend on the sort's handling of ties.
inline std::vector<int> strongest(const std::vector<cv::KeyPoint>& keypoints, int max_count) {
  const int n = static_cast<int>(keypoints.size());
  std::vector<int> rows(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) rows[static_cast<std::size_t>(i)] = i;
  if (max_count <= 0 || max_count >= n) return rows;
  std::vector<int> order = rows;
  std::stable_sort(order.begin(), order.end(), [&](int l, int r) {
    return keypoints[static_cast<std::size_t>(l)].response > keypoints[static_cast<std::size_t>(r)].response;
  });
  order.resize(static_cast<std::size_t>(max_count));
  std::sort(order.begin(), order.end());
  return order;
}

}  // namespace detail

/// Every row of a CV_8U binary descriptor Mat (ORB, BRISK, AKAZE) in the library's bit layout
/// (see diachron::unpack_bits in matching/features.hpp): the Features::descriptors to declare
/// DescriptorMetric::Hamming with.
inline DescriptorMatrix unpack_bits(const cv::Mat& desc) {
  DIACHRON_CHECK(desc.empty() || desc.type() == CV_8UC1,
                 "expected CV_8UC1 binary descriptors, got " << cv::typeToString(desc.type()));
  if (desc.empty()) return DescriptorMatrix(0, 0);
  const cv::Mat packed = desc.isContinuous() ? desc : desc.clone();
  return unpack_bits(packed.ptr<std::uint8_t>(0), packed.rows, packed.cols);
}

}  // namespace diachron
