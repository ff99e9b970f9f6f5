#pragma once
/// @file
/// Residual vectors drawn over an image, for inspection of an adjustment (match_epochs --adjust
/// writes one picture per image with the reprojection residuals of its tie points).
///
/// Residuals of a good adjustment are a fraction of a pixel: each is drawn magnified (`scale`)
/// from its observation, so that a systematic pattern (an unmodelled distortion, a film deformation)
/// shows as a field of parallel or radial arrows, and a blunder as one long one. The picture says how
/// to read it: a legend with the magnification, a reference arrow of a known residual, what green and
/// red mean, a scale bar in image pixels, the residuals' statistics and an optional title. A large
/// image (a 12000 px scan) is shrunk to max_side_px; the magnification is relative to the drawn
/// picture, so the arrows keep the length that makes them legible at any image size.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/vision/draw_legend.hpp>
#include <diachron/vision/draw_matches.hpp>
#include <diachron/vision/image.hpp>

namespace diachron {

/// Options of draw_residuals.
struct DrawResidualsOptions {
  /// Magnification of the residual vectors: a residual of r image px is drawn r * scale picture
  /// pixels long, whatever the shrinking (max_side_px), so relative to the drawn image it is
  /// magnified scale / ResidualPictureLayout::px_per_image_px. > 0.
  double scale = 50.0;
  /// Residuals at least this long (px, before magnification) are drawn in red, the others green.
  /// > 0.
  double large_px = 1.0;
  /// Line width in picture pixels. >= 1.
  int line_thickness = 1;
  /// First line of the picture, e.g. "e2/IMG_0031.tif, after the adjustment"; none when empty (and
  /// none when legend is off).
  std::string title;
  /// Draw the header (title, statistics) above the image and the legend (scale bar, reference
  /// arrow, colours) under it; off: the image and its vectors alone, as before the legend existed.
  bool legend = true;
  /// The whole picture's longer side is at most this, px: the image shrinks to fit (cv::INTER_AREA,
  /// never enlarged). 1600 by default, as the other pictures (draw_dod, draw_pair_overlay): a 12000
  /// px scan is shrunk 7.5 times and stays readable on a screen. 0: the image at its own size. 0 or
  /// >= 400.
  int max_side_px = 1600;

  void check() const {
    DIACHRON_CHECK(std::isfinite(scale) && scale > 0.0 && std::isfinite(large_px) && large_px > 0.0 &&
                       line_thickness >= 1,
                   "DrawResidualsOptions: scale and large_px must be finite and > 0 and line_thickness >= 1");
    DIACHRON_CHECK(max_side_px == 0 || max_side_px >= 400,
                   "DrawResidualsOptions::max_side_px must be 0 or >= 400, got " << max_side_px);
  }
};

/// Where draw_residuals puts things, picture pixels (x right, y down; OpenCV's Rect).
struct ResidualPictureLayout {
  cv::Size picture;                 ///< the whole picture
  cv::Rect image;                   ///< the image, shrunk: image pixel (x, y) -> residual_picture_point
  double px_per_image_px_x = 1.0;   ///< picture px per image column (<= 1)
  double px_per_image_px_y = 1.0;   ///< picture px per image row (<= 1)
  cv::Rect scale_bar;               ///< the scale bar's line (empty without legend)
  double scale_bar_image_px = 0.0;  ///< the scale bar's length, image px
  cv::Point reference_from;         ///< start of the reference arrow (a green residual drawn like the others)
  double reference_px = 0.0;        ///< the residual it stands for, image px (drawn reference_px * scale long)
  cv::Rect small_swatch;            ///< the green swatch (residuals < large_px)
  cv::Rect large_swatch;            ///< the red swatch (residuals >= large_px)
  std::vector<std::string> header;  ///< text lines above the image
};

/// Where image pixel `pixel` (diachron's convention: (0, 0) = centre of the top-left pixel) is in the
/// picture, picture px in the same convention: x -> image.x + (x + 0.5) * px_per_image_px_x - 0.5.
inline Eigen::Vector2d residual_picture_point(const ResidualPictureLayout& l, const Eigen::Vector2d& pixel) {
  return {l.image.x + (pixel.x() + 0.5) * l.px_per_image_px_x - 0.5,
          l.image.y + (pixel.y() + 0.5) * l.px_per_image_px_y - 0.5};
}

namespace detail {

inline constexpr int kResidualFooterRow = 28;  // px per legend row under the image
inline constexpr int kResidualFooterRows = 3;  // scale bar; reference arrow; colours

inline void residuals_check_inputs(const Raster<std::uint8_t>& image, const std::vector<Eigen::Vector2d>& pixels,
                                   const std::vector<Eigen::Vector2d>& residuals,
                                   const DrawResidualsOptions& options) {
  options.check();
  DIACHRON_CHECK(!image.empty(), "draw_residuals: empty image");
  DIACHRON_CHECK(pixels.size() == residuals.size(),
                 "draw_residuals: " << pixels.size() << " pixels but " << residuals.size() << " residuals");
  for (std::size_t i = 0; i < pixels.size(); ++i)
    DIACHRON_CHECK(pixels[i].allFinite() && residuals[i].allFinite(),
                   "draw_residuals: observation " << i << " has a non-finite pixel or residual");
}

// The residual the reference arrow stands for: 1 px when that is drawn 20 to 150 px long, else a
// round residual drawn about 100 px long.
inline double residuals_reference_px(double scale) {
  if (scale >= 20.0 && scale <= 150.0) return 1.0;
  return legend_round_down(100.0 / scale);
}

inline std::string residuals_reference_label(double reference_px, double scale) {
  return "= " + legend_number(reference_px) + " px residual (residuals x" + legend_number(scale) + ")";
}

}  // namespace detail

/// The layout draw_residuals draws with: sizes, where the image and the legend's parts go, the header
/// text. Throws diachron::Error for the reasons draw_residuals does.
inline ResidualPictureLayout residual_picture_layout(const Raster<std::uint8_t>& image,
                                                     const std::vector<Eigen::Vector2d>& pixels,
                                                     const std::vector<Eigen::Vector2d>& residuals,
                                                     const DrawResidualsOptions& options = {}) {
  using namespace detail;
  residuals_check_inputs(image, pixels, residuals, options);
  ResidualPictureLayout l;
  if (options.legend) {
    if (!options.title.empty()) l.header.push_back(options.title);
    std::vector<double> lengths;
    lengths.reserve(residuals.size());
    double squares = 0.0;
    for (const Eigen::Vector2d& r : residuals) {
      lengths.push_back(r.norm());
      squares += r.squaredNorm();
    }
    std::string line = std::to_string(residuals.size()) + (residuals.size() == 1 ? " observation" : " observations");
    if (!lengths.empty()) {
      const std::size_t large = static_cast<std::size_t>(
          std::count_if(lengths.begin(), lengths.end(), [&](double v) { return v >= options.large_px; }));
      const double rms = std::sqrt(squares / static_cast<double>(lengths.size()));
      const auto mid = lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2);
      std::nth_element(lengths.begin(), mid, lengths.end());
      const double median = *mid;
      const double largest = *std::max_element(lengths.begin(), lengths.end());
      line += "; RMS " + legend_fixed(rms, 3) + " px; median " + legend_fixed(median, 3) + " px; max " +
              legend_fixed(largest, 3) + " px; " + std::to_string(large) + " >= " + legend_number(options.large_px) +
              " px (red)";
    }
    l.header.push_back(line);
    l.header.push_back("residuals x" + legend_number(options.scale) +
                       " (relative to this picture); from each observation (dot)");
    if (options.max_side_px > 0)
      l.header = legend_wrap(l.header, options.max_side_px - 2 * kLegendMargin, !options.title.empty());
  }
  const int margin = options.legend ? kLegendMargin : 0;
  const int header_height = options.legend ? static_cast<int>(l.header.size()) * kLegendLineHeight + 6 : 0;
  const int footer_height = options.legend ? kResidualFooterRows * kResidualFooterRow + 10 : 0;

  double factor = 1.0;
  if (options.max_side_px > 0) {
    const double room_w = options.max_side_px - 2 * margin;
    const double room_h = options.max_side_px - 2 * margin - header_height - footer_height;
    // (A header wrapped into many lines on a small max_side_px could leave no room: 50 px at least.)
    factor = std::min({1.0, room_w / image.width(), std::max(room_h, 50.0) / image.height()});
  }
  const int iw = std::max(1, static_cast<int>(std::lround(image.width() * factor)));
  const int ih = std::max(1, static_cast<int>(std::lround(image.height() * factor)));
  l.image = cv::Rect(margin, margin + header_height, iw, ih);
  l.px_per_image_px_x = static_cast<double>(iw) / image.width();
  l.px_per_image_px_y = static_cast<double>(ih) / image.height();
  if (!options.legend) {
    l.picture = l.image.size();
    return l;
  }

  // Footer rows: the scale bar (a round length near a quarter of the image), the reference arrow,
  // the two colours.
  const int below = l.image.y + ih;
  l.scale_bar_image_px = legend_round_down(0.25 * image.width());
  const int bar_px = std::max(1, static_cast<int>(std::lround(l.scale_bar_image_px * l.px_per_image_px_x)));
  l.scale_bar = cv::Rect(l.image.x, below + 14, bar_px, 4);
  l.reference_px = residuals_reference_px(options.scale);
  l.reference_from = cv::Point(l.image.x + 4, below + 14 + kResidualFooterRow);
  const int arrow_end = l.reference_from.x + static_cast<int>(std::lround(l.reference_px * options.scale));
  const int swatch_y = below + 14 + 2 * kResidualFooterRow - 7;
  l.small_swatch = cv::Rect(l.image.x, swatch_y, kLegendBarWidth, 14);
  const std::string small_label = "< " + legend_number(options.large_px) + " px";
  l.large_swatch = cv::Rect(l.small_swatch.x + kLegendBarWidth + 14 + legend_text_width(small_label, 1), swatch_y,
                            kLegendBarWidth, 14);

  int width = l.image.x + iw + kLegendMargin;
  width = std::max(width, bar_px + l.image.x + 8 + 120 + kLegendMargin);
  width = std::max(width, arrow_end + 8 + legend_text_width(residuals_reference_label(l.reference_px, options.scale), 1) +
                              kLegendMargin);
  width = std::max(width, l.large_swatch.x + kLegendBarWidth + 6 + 80 + kLegendMargin);
  int text_w = 0;
  for (std::size_t i = 0; i < l.header.size(); ++i)
    text_w = std::max(text_w, 2 * kLegendMargin + legend_text_width(l.header[i], i == 0 && !options.title.empty() ? 2 : 1));
  // Text wider than the picture may be is cut rather than the picture made wider.
  width = std::max(width, options.max_side_px > 0 ? std::min(text_w, options.max_side_px) : text_w);
  l.picture = cv::Size(width, below + footer_height + kLegendMargin);
  return l;
}

/// A BGR picture of `image` (shrunk to options.max_side_px, never enlarged) with, for each
/// observation, a dot at its pixel and a line along its residual (observed - projected, image px)
/// magnified by options.scale relative to the picture (a residual of r px is r * scale picture px
/// long, see DrawResidualsOptions::scale), green below options.large_px and red from it. With
/// options.legend (default), a title, the residuals' count, RMS, median and maximum above the image,
/// and under it a scale bar in image pixels, a reference arrow (ResidualPictureLayout::reference_px,
/// 1 px for magnifications 20 to 150) and the two colours' meaning; layout in
/// residual_picture_layout. With legend off and max_side_px 0, the picture is the image at its size
/// with the vectors, as before the legend existed. Throws diachron::Error for an empty image, lists of
/// different lengths, non-finite values or bad options.
inline cv::Mat draw_residuals(const Raster<std::uint8_t>& image, const std::vector<Eigen::Vector2d>& pixels,
                              const std::vector<Eigen::Vector2d>& residuals, const DrawResidualsOptions& options = {}) {
  using namespace detail;
  const ResidualPictureLayout l = residual_picture_layout(image, pixels, residuals, options);
  const cv::Scalar white(255, 255, 255), black(0, 0, 0), green(0, 255, 0), red(0, 0, 255);
  cv::Mat canvas(l.picture, CV_8UC3, white);
  cv::Mat image_view = canvas(l.image);  // writes into the canvas: same size and type
  if (l.image.size() == cv::Size(image.width(), image.height())) {
    cv::cvtColor(as_mat(image), image_view, cv::COLOR_GRAY2BGR);
  } else {
    cv::Mat grey;
    cv::resize(as_mat(image), grey, l.image.size(), 0.0, 0.0, cv::INTER_AREA);
    cv::cvtColor(grey, image_view, cv::COLOR_GRAY2BGR);
  }
  // Drawn in the image's view: vectors are clipped at its edge instead of running over the legend.
  const auto draw_vector = [&](cv::Mat& target, const Eigen::Vector2d& from, const Eigen::Vector2d& residual,
                               const cv::Scalar& colour) {
    const Eigen::Vector2d tip = from + options.scale * residual;
    const cv::Point start = fixed_point(from.x(), from.y());
    cv::line(target, start, fixed_point(tip.x(), tip.y()), colour, options.line_thickness, cv::LINE_AA, kDrawShift);
    cv::circle(target, start, 1 << kDrawShift, colour, -1, cv::LINE_AA, kDrawShift);
  };
  const Eigen::Vector2d origin(l.image.x, l.image.y);
  for (std::size_t i = 0; i < pixels.size(); ++i)
    draw_vector(image_view, residual_picture_point(l, pixels[i]) - origin, residuals[i],
                residuals[i].norm() >= options.large_px ? red : green);
  if (!options.legend) return canvas;

  cv::rectangle(canvas, cv::Rect(l.image.x - 1, l.image.y - 1, l.image.width + 2, l.image.height + 2), black, 1);
  draw_legend_lines(canvas, l.header, cv::Point(kLegendMargin, kLegendMargin), !options.title.empty());
  draw_legend_scale_bar(canvas, l.scale_bar, legend_number(l.scale_bar_image_px) + " px (image)");
  // The reference arrow: a residual of reference_px along +x, drawn exactly as the others.
  const Eigen::Vector2d from(l.reference_from.x, l.reference_from.y);
  draw_vector(canvas, from, Eigen::Vector2d(l.reference_px, 0.0), green);
  const int arrow_end = l.reference_from.x + static_cast<int>(std::lround(l.reference_px * options.scale));
  cv::putText(canvas, residuals_reference_label(l.reference_px, options.scale),
              cv::Point(arrow_end + 8, l.reference_from.y + 5), cv::FONT_HERSHEY_SIMPLEX, kLegendLabelFontScale, black,
              1, cv::LINE_AA);
  draw_legend_swatch(canvas, l.small_swatch, green, "< " + legend_number(options.large_px) + " px");
  draw_legend_swatch(canvas, l.large_swatch, red, ">= " + legend_number(options.large_px) + " px");
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
