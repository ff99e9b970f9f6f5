#pragma once
// A synthetic test texture for feature extractors and matchers (tests/vision): smoothed noise at
// two scales plus random blobs, so corners and blobs exist at many scales without repetition.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/vision/image.hpp>

namespace diachron::test {

// Smoothed noise at two scales plus random blobs: corners and blobs at many scales, no repetition.
inline diachron::Raster<std::uint8_t> textured(int w, int h, std::uint64_t seed) {
  diachron::RandomStream rng(seed);
  cv::Mat img(h, w, CV_32F, cv::Scalar(0));
  for (int cell : {40, 10}) {
    cv::Mat coarse(h / cell + 3, w / cell + 3, CV_32F);
    for (int y = 0; y < coarse.rows; ++y)
      for (int x = 0; x < coarse.cols; ++x) coarse.at<float>(y, x) = static_cast<float>(rng.uniform(-1, 1));
    cv::Mat fine;
    cv::resize(coarse, fine, cv::Size(coarse.cols * cell, coarse.rows * cell), 0, 0, cv::INTER_CUBIC);
    img += fine(cv::Rect(cell, cell, w, h)) * (cell == 40 ? 1.0 : 0.5);
  }
  for (int i = 0; i < w * h / 800; ++i) {
    // One draw per statement, the last argument first (y before x, the value before the radius): the
    // order of a call's arguments is unspecified (core/random.hpp, "Order of draws").
    const int y = static_cast<int>(rng.uniform(0, h));
    const cv::Point centre(static_cast<int>(rng.uniform(0, w)), y);
    const double value = rng.uniform(-1.5, 1.5);
    cv::circle(img, centre, static_cast<int>(rng.uniform(2, 12)), cv::Scalar(value), cv::FILLED, cv::LINE_AA);
  }
  cv::GaussianBlur(img, img, cv::Size(0, 0), 1.0);
  cv::Mat out;
  cv::normalize(img, img, 0, 255, cv::NORM_MINMAX);
  img.convertTo(out, CV_8U);
  return diachron::to_raster<std::uint8_t>(out);
}

/// `src` warped by the 2x3 affine `m` (cv::warpAffine maps source pixel centres to destination pixel
/// centres, diachron's convention), so `m` is the truth for b given a.
inline diachron::Raster<std::uint8_t> warp(const diachron::Raster<std::uint8_t>& src, const cv::Matx23d& m) {
  cv::Mat dst;
  cv::warpAffine(diachron::as_mat(src), dst, m, cv::Size(src.width(), src.height()), cv::INTER_CUBIC,
                 cv::BORDER_REFLECT_101);
  return diachron::to_raster<std::uint8_t>(dst);
}

inline Eigen::Vector2d apply(const cv::Matx23d& m, const Eigen::Vector2d& p) {
  return {m(0, 0) * p.x() + m(0, 1) * p.y() + m(0, 2), m(1, 0) * p.x() + m(1, 1) * p.y() + m(1, 2)};
}

/// Share of matches whose b lies within `tol` px of m(a).
inline double fraction_within(const std::vector<diachron::PointMatch>& matches, const cv::Matx23d& m, double tol) {
  if (matches.empty()) return 0.0;
  std::size_t good = 0;
  for (const auto& match : matches)
    if ((apply(m, match.a) - match.b).norm() <= tol) ++good;
  return static_cast<double>(good) / static_cast<double>(matches.size());
}

}  // namespace diachron::test
