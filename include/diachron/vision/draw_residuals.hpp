#pragma once
/// @file
/// Residual vectors drawn over an image, for inspection of an adjustment (match_epochs --adjust
/// writes one picture per image with the reprojection residuals of its tie points).
///
/// Residuals of a good adjustment are a fraction of a pixel: each is drawn magnified (`scale`)
/// from its observation, so that a systematic pattern (an unmodelled distortion, a film deformation)
/// shows as a field of parallel or radial arrows, and a blunder as one long one.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/vision/draw_matches.hpp>
#include <diachron/vision/image.hpp>

namespace diachron {

/// Options of draw_residuals.
struct DrawResidualsOptions {
  /// Magnification of the residual vectors: a residual of r px is drawn r * scale canvas pixels
  /// long. > 0.
  double scale = 50.0;
  /// Residuals at least this long (px, before magnification) are drawn in red, the others green.
  /// > 0.
  double large_px = 1.0;
  /// Line width in canvas pixels. >= 1.
  int line_thickness = 1;

  void check() const {
    DIACHRON_CHECK(scale > 0.0 && large_px > 0.0 && line_thickness >= 1,
                   "DrawResidualsOptions: scale and large_px must be > 0 and line_thickness >= 1");
  }
};

/// A BGR copy of `image` with, for each observation, a dot at its pixel and a line along its
/// residual (observed - projected, px) magnified by options.scale. Throws diachron::Error for an
/// empty image, lists of different lengths or non-finite values.
inline cv::Mat draw_residuals(const Raster<std::uint8_t>& image, const std::vector<Eigen::Vector2d>& pixels,
                              const std::vector<Eigen::Vector2d>& residuals, const DrawResidualsOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!image.empty(), "draw_residuals: empty image");
  DIACHRON_CHECK(pixels.size() == residuals.size(),
                 "draw_residuals: " << pixels.size() << " pixels but " << residuals.size() << " residuals");
  cv::Mat canvas;
  cv::cvtColor(as_mat(image), canvas, cv::COLOR_GRAY2BGR);
  const cv::Scalar green(0, 255, 0), red(0, 0, 255);
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    DIACHRON_CHECK(pixels[i].allFinite() && residuals[i].allFinite(),
                   "draw_residuals: observation " << i << " has a non-finite pixel or residual");
    const cv::Scalar colour = residuals[i].norm() >= options.large_px ? red : green;
    const Eigen::Vector2d tip = pixels[i] + options.scale * residuals[i];
    const cv::Point from = detail::fixed_point(pixels[i].x(), pixels[i].y());
    cv::line(canvas, from, detail::fixed_point(tip.x(), tip.y()), colour, options.line_thickness, cv::LINE_AA,
             detail::kDrawShift);
    cv::circle(canvas, from, 1 << detail::kDrawShift, colour, -1, cv::LINE_AA, detail::kDrawShift);
  }
  return canvas;
}

/// draw_residuals written to `path` (PNG when the name ends in .png). Throws diachron::Error naming
/// the file when it cannot be written, and for draw_residuals' reasons.
inline void write_residuals_png(const std::string& path, const Raster<std::uint8_t>& image,
                                const std::vector<Eigen::Vector2d>& pixels,
                                const std::vector<Eigen::Vector2d>& residuals, const DrawResidualsOptions& options = {}) {
  save_image(path, draw_residuals(image, pixels, residuals, options));
}

}  // namespace diachron
