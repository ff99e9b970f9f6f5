#pragma once
/// @file
/// Side-by-side drawing of two rasters with their matches, for inspection (examples write
/// matches.png with it).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/vision/image.hpp>

namespace diachron {

/// Options of draw_matches.
struct DrawMatchesOptions {
  /// Line width in canvas pixels.
  int line_thickness = 1;
  /// Radius of the circle drawn at each end of a match, in canvas pixels; 0 draws none.
  int point_radius = 2;
  /// Draw at most this many matches, taken evenly through the list (inliers and outliers alike);
  /// 0 draws all.
  std::size_t max_matches = 0;
  /// Draw the matches the mask marks as outliers (in red); off shows the inliers only.
  bool draw_outliers = true;

  void check() const {
    DIACHRON_CHECK(line_thickness >= 1, "DrawMatchesOptions::line_thickness must be >= 1, got " << line_thickness);
    DIACHRON_CHECK(point_radius >= 0, "DrawMatchesOptions::point_radius must be >= 0, got " << point_radius);
  }
};

namespace detail {

/// Sub-pixel drawing: OpenCV's drawing functions take fixed-point coordinates with this many
/// fractional bits, and treat integer coordinates as pixel centres, like diachron.
inline constexpr int kDrawShift = 4;

inline cv::Point fixed_point(double x, double y) {
  constexpr double kScale = 1 << kDrawShift;
  return cv::Point(static_cast<int>(std::lround(x * kScale)), static_cast<int>(std::lround(y * kScale)));
}

}  // namespace detail

/// A BGR canvas with `a` on the left and `b` on the right (top-aligned; the shorter one is padded
/// with black), and one line per match from its point in `a` to its point in `b`. With an inlier
/// mask (one entry per match, anything convertible to bool: std::vector<bool>, std::vector<uint8_t>,
/// a RANSAC report's mask), inliers are green and the others red, drawn below the inliers; without
/// one every match is yellow. Throws diachron::Error for an empty raster, a mask of the wrong
/// length or a non-finite match coordinate.
template <class Mask = std::vector<bool>>
cv::Mat draw_matches(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b,
                     const std::vector<PointMatch>& matches, const Mask& inliers = Mask{},
                     const DrawMatchesOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!a.empty() && !b.empty(), "draw_matches: empty raster (" << a.width() << " x " << a.height()
                                                                          << " and " << b.width() << " x "
                                                                          << b.height() << ")");
  const bool has_mask = inliers.size() != 0;
  DIACHRON_CHECK(!has_mask || inliers.size() == matches.size(),
                 "draw_matches: the inlier mask has " << inliers.size() << " entries for " << matches.size()
                                                      << " matches");
  for (std::size_t i = 0; i < matches.size(); ++i)
    DIACHRON_CHECK(matches[i].a.allFinite() && matches[i].b.allFinite(),
                   "draw_matches: match " << i << " has a non-finite coordinate");

  cv::Mat canvas(std::max(a.height(), b.height()), a.width() + b.width(), CV_8UC3, cv::Scalar::all(0));
  cv::cvtColor(as_mat(a), canvas(cv::Rect(0, 0, a.width(), a.height())), cv::COLOR_GRAY2BGR);
  cv::cvtColor(as_mat(b), canvas(cv::Rect(a.width(), 0, b.width(), b.height())), cv::COLOR_GRAY2BGR);

  const std::size_t n = matches.size();
  const std::size_t shown = options.max_matches == 0 ? n : std::min(n, options.max_matches);
  const cv::Scalar green(0, 255, 0);
  const cv::Scalar red(0, 0, 255);
  const cv::Scalar yellow(0, 255, 255);
  // Outliers first so that inliers stay visible where lines cross.
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t k = 0; k < shown; ++k) {
      const std::size_t i = shown == n ? k : k * n / shown;
      const bool inlier = !has_mask || static_cast<bool>(inliers[i]);
      if ((pass == 0) == inlier) continue;
      if (!inlier && !options.draw_outliers) continue;
      const cv::Scalar colour = !has_mask ? yellow : (inlier ? green : red);
      const cv::Point pa = detail::fixed_point(matches[i].a.x(), matches[i].a.y());
      const cv::Point pb = detail::fixed_point(matches[i].b.x() + a.width(), matches[i].b.y());
      cv::line(canvas, pa, pb, colour, options.line_thickness, cv::LINE_AA, detail::kDrawShift);
      if (options.point_radius > 0) {
        const int radius = options.point_radius << detail::kDrawShift;
        cv::circle(canvas, pa, radius, colour, 1, cv::LINE_AA, detail::kDrawShift);
        cv::circle(canvas, pb, radius, colour, 1, cv::LINE_AA, detail::kDrawShift);
      }
    }
  }
  return canvas;
}

/// draw_matches written to `path` (PNG when the name ends in .png). Throws diachron::Error naming
/// the file when it cannot be written, and for draw_matches' reasons.
template <class Mask = std::vector<bool>>
void write_matches_png(const std::string& path, const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b,
                       const std::vector<PointMatch>& matches, const Mask& inliers = Mask{},
                       const DrawMatchesOptions& options = {}) {
  save_image(path, draw_matches(a, b, matches, inliers, options));
}

}  // namespace diachron
