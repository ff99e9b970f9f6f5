#pragma once
/// @file
/// Two images of a pair, the secondary warped into the master's geometry by their homography, as a
/// picture a person judges at a glance: a checkerboard of master and warped secondary tiles, the match
/// points as dots coloured by a value (a score or a residual), a colour bar, a scale bar and a title;
/// at most max_side_px on a side, and written as a JPEG that stays under a byte bound.
///
/// Why a checkerboard. Side by side, two images 140 degrees apart make a fan of crossing lines nobody
/// can judge. Warped into one geometry, a correct homography makes every feature run on unbroken
/// across the edges of the tiles, and a misregistration of a few pixels breaks them there: the eye
/// catches a broken road or roof line at once. Both images keep their own grey levels and contrast, so
/// the coloured dots stay the only colour in the picture. The other common overlay, master in one
/// colour channel and secondary in another, shows misregistration as colour fringes, but those
/// fringes and the images' own differences (another season, another film) take the same colours as
/// the dots, and each image loses contrast.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/vision/draw_legend.hpp>
#include <diachron/vision/draw_matches.hpp>
#include <diachron/vision/image.hpp>

namespace diachron {

/// What the values given with draw_pair_overlay's points are: it sets the legend's wording and unit,
/// and which end of the colour scale is good.
enum class PairOverlayValues {
  Score,      ///< a similarity score, no unit, higher is better (e.g. NCC in [0, 1])
  ResidualPx  ///< a residual, master px, lower is better (e.g. the distance to where the homography puts the point)
};

/// Options of draw_pair_overlay and write_pair_overlay_jpg.
struct DrawPairOverlayOptions {
  /// What the values are (Score by default).
  PairOverlayValues values = PairOverlayValues::Score;
  /// The colour scale's ends, in the values' unit (none for a score, px for a residual); values beyond
  /// saturate. Finite, low < high. Defaults fit an NCC score; for residuals, e.g. 0 and 3 px.
  double value_low = 0.0;
  double value_high = 1.0;
  /// The values' name in the legend ("NCC", "LSM residual"); empty: "score" or "residual".
  std::string value_name;
  /// First line of the picture, e.g. "e1/a.tif -- e3/b.tif"; none when empty.
  std::string title;
  /// The whole picture's longer side is at most this, px: the images shrink to fit (never enlarged).
  /// 1600 by default: legible on a screen at 100 %, and a JPEG of it at quality 85 is about 0.3 MB
  /// for a synthetic aerial scene and 0.6 to 0.8 MB for a 4000 x 3000 pair of pure noise (what stays
  /// above the byte bound write_pair_overlay_jpg handles). >= 400.
  int max_side_px = 1600;
  /// Side of a checkerboard tile, picture px. 64 by default: small enough for every part of the
  /// picture to be near a tile edge, large enough to see what a tile shows. >= 8.
  int tile_px = 64;
  /// Radius of a dot, picture px (drawn after the downscaling, so dots stay visible at any input size).
  /// >= 1.
  int dot_radius_px = 4;
  /// JPEG quality of write_pair_overlay_jpg, in [50, 100] (85: no visible artefact around text and dots).
  int jpeg_quality = 85;
  /// write_pair_overlay_jpg's file is at most this many bytes (1 MB by default: a few hundred pairs
  /// stay browsable). >= 100000.
  std::size_t max_jpeg_bytes = 1000000;

  void check() const {
    DIACHRON_CHECK(std::isfinite(value_low) && std::isfinite(value_high) && value_low < value_high,
                   "DrawPairOverlayOptions: value_low < value_high must hold and both be finite, got "
                       << value_low << " and " << value_high);
    DIACHRON_CHECK(max_side_px >= 400, "DrawPairOverlayOptions::max_side_px must be >= 400, got " << max_side_px);
    DIACHRON_CHECK(tile_px >= 8, "DrawPairOverlayOptions::tile_px must be >= 8, got " << tile_px);
    DIACHRON_CHECK(dot_radius_px >= 1, "DrawPairOverlayOptions::dot_radius_px must be >= 1, got " << dot_radius_px);
    DIACHRON_CHECK(jpeg_quality >= 50 && jpeg_quality <= 100,
                   "DrawPairOverlayOptions::jpeg_quality must be in [50, 100], got " << jpeg_quality);
    DIACHRON_CHECK(max_jpeg_bytes >= 100000,
                   "DrawPairOverlayOptions::max_jpeg_bytes must be >= 100000, got " << max_jpeg_bytes);
  }
};

/// The BGR colour of `value` in a pair overlay: from red (bad) through orange and yellow to blue
/// (good), after ColorBrewer's RdYlBu without its two palest classes (they vanish on a light image),
/// a scale people with red-green colour blindness read too. `value` is placed between
/// options.value_low and options.value_high (saturating beyond); a score is good high, a residual low.
inline cv::Vec3b pair_overlay_colour(double value, const DrawPairOverlayOptions& options) {
  // RdYlBu (11 classes) minus (255, 255, 191) and (224, 243, 248), RGB, from bad to good.
  static constexpr std::array<std::array<double, 3>, 9> stops{{{165, 0, 38},
                                                              {215, 48, 39},
                                                              {244, 109, 67},
                                                              {253, 174, 97},
                                                              {254, 224, 144},
                                                              {171, 217, 233},
                                                              {116, 173, 209},
                                                              {69, 117, 180},
                                                              {49, 54, 149}}};
  double t = std::clamp((value - options.value_low) / (options.value_high - options.value_low), 0.0, 1.0);
  if (std::isnan(t)) t = 0.0;
  if (options.values == PairOverlayValues::ResidualPx) t = 1.0 - t;
  const double u = t * static_cast<double>(stops.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(u), stops.size() - 2);
  const double f = u - static_cast<double>(i);
  cv::Vec3b bgr;
  for (int c = 0; c < 3; ++c)
    bgr[2 - c] = cv::saturate_cast<std::uint8_t>(stops[i][c] + f * (stops[i + 1][c] - stops[i][c]));
  return bgr;
}

/// Where draw_pair_overlay puts things, picture pixels (x right, y down; OpenCV's Rect), and what it
/// found about the pair.
struct PairOverlayLayout {
  cv::Size picture;                  ///< the whole picture
  cv::Rect image;                    ///< the master's geometry, shrunk: master pixel (x, y) -> pair_overlay_picture_point
  double px_per_master_px_x = 0.0;   ///< picture px per master column (<= 1)
  double px_per_master_px_y = 0.0;   ///< picture px per master row (<= 1)
  cv::Rect colour_bar;               ///< value_high at its top row, value_low at its bottom row
  cv::Rect scale_bar;                ///< the scale bar's line
  double scale_bar_master_px = 0.0;  ///< the scale bar's length, master px
  double coverage = 0.0;             ///< share of the master the warped secondary covers, [0, 1] (on a 100 x 100 grid)
  std::vector<std::string> header;   ///< text lines above the image
};

/// Where master pixel `master_px` (diachron's convention: (0, 0) = centre of the top-left pixel) is in
/// the picture, picture px in the same convention: the shrinking maps pixel edges to pixel edges,
/// so x -> image.x + (x + 0.5) * px_per_master_px_x - 0.5.
inline Eigen::Vector2d pair_overlay_picture_point(const PairOverlayLayout& l, const Eigen::Vector2d& master_px) {
  return {l.image.x + (master_px.x() + 0.5) * l.px_per_master_px_x - 0.5,
          l.image.y + (master_px.y() + 0.5) * l.px_per_master_px_y - 0.5};
}

namespace detail {

inline constexpr int kPairOverlayFooterHeight = 44;
inline constexpr int kPairOverlayGrid = 100;  // coverage and scale are sampled on this many x this many master points
inline constexpr double kPairOverlayDim = 0.45;  // master grey levels outside the secondary, times this

inline std::string pairov_value_name(const DrawPairOverlayOptions& o) {
  if (!o.value_name.empty()) return o.value_name;
  return o.values == PairOverlayValues::Score ? "score" : "residual";
}

inline std::string pairov_unit(const DrawPairOverlayOptions& o) {
  return o.values == PairOverlayValues::ResidualPx ? " px" : "";
}

// (x, y) of a homography's image of `p`; false when it is at infinity.
inline bool pairov_apply(const Eigen::Matrix3d& h, const Eigen::Vector2d& p, Eigen::Vector2d& out) {
  const Eigen::Vector3d q = h * Eigen::Vector3d(p.x(), p.y(), 1.0);
  if (q.z() == 0.0) return false;
  out = q.head<2>() / q.z();
  return out.allFinite();
}

// The pair's geometry on a grid of master pixels: the share that falls inside the secondary, and
// the median linear scale (master px per secondary px) of the homography there, from its Jacobian at
// each covered sample.
struct PairOverlayGeometry {
  double coverage = 0.0;
  double master_px_per_secondary_px = 1.0;
};

inline PairOverlayGeometry pairov_geometry(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                                           const Eigen::Matrix3d& master_from_secondary) {
  const Eigen::Matrix3d secondary_from_master = master_from_secondary.inverse();
  const Eigen::Matrix3d& h = master_from_secondary;
  std::vector<double> scales;
  int inside = 0;
  const int n = kPairOverlayGrid;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d m((i + 0.5) / n * master.width() - 0.5, (j + 0.5) / n * master.height() - 0.5);
      Eigen::Vector2d s;
      if (!pairov_apply(secondary_from_master, m, s)) continue;
      if (s.x() < -0.5 || s.y() < -0.5 || s.x() > secondary.width() - 0.5 || s.y() > secondary.height() - 0.5)
        continue;
      ++inside;
      // d(master)/d(secondary) at s: (1 / w) [h_00 - x h_20, h_01 - x h_21; h_10 - y h_20, h_11 - y h_21].
      const double w = h.row(2).dot(Eigen::Vector3d(s.x(), s.y(), 1.0));
      Eigen::Matrix2d jacobian;
      jacobian << h(0, 0) - m.x() * h(2, 0), h(0, 1) - m.x() * h(2, 1), h(1, 0) - m.y() * h(2, 0),
          h(1, 1) - m.y() * h(2, 1);
      jacobian /= w;
      const double scale = std::sqrt(std::abs(jacobian.determinant()));
      if (std::isfinite(scale) && scale > 0.0) scales.push_back(scale);
    }
  PairOverlayGeometry g;
  g.coverage = static_cast<double>(inside) / (static_cast<double>(n) * n);
  if (!scales.empty()) {
    const auto mid = scales.begin() + static_cast<std::ptrdiff_t>(scales.size() / 2);
    std::nth_element(scales.begin(), mid, scales.end());
    g.master_px_per_secondary_px = *mid;
  }
  return g;
}

inline void pairov_check_inputs(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                                const Eigen::Matrix3d& master_from_secondary,
                                const std::vector<Eigen::Vector2d>& master_points, const std::vector<double>& values,
                                const DrawPairOverlayOptions& options) {
  options.check();
  DIACHRON_CHECK(!master.empty() && !secondary.empty(),
                 "draw_pair_overlay: empty image (master " << master.width() << " x " << master.height()
                                                           << ", secondary " << secondary.width() << " x "
                                                           << secondary.height() << ")");
  DIACHRON_CHECK(master_from_secondary.allFinite(), "draw_pair_overlay: the homography has a non-finite entry");
  Eigen::FullPivLU<Eigen::Matrix3d> lu(master_from_secondary);
  DIACHRON_CHECK(lu.isInvertible(), "draw_pair_overlay: the homography is singular");
  DIACHRON_CHECK(master_points.size() == values.size(),
                 "draw_pair_overlay: " << master_points.size() << " points but " << values.size() << " values");
  for (std::size_t i = 0; i < master_points.size(); ++i)
    DIACHRON_CHECK(master_points[i].allFinite() && std::isfinite(values[i]),
                   "draw_pair_overlay: point " << i << " has a non-finite coordinate or value");
}

inline PairOverlayLayout pairov_layout(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                                       const Eigen::Matrix3d& master_from_secondary, const std::vector<double>& values,
                                       const DrawPairOverlayOptions& options, PairOverlayGeometry& geometry) {
  PairOverlayLayout l;
  // Header text first: its line count sets the room left for the image.
  const std::string name = pairov_value_name(options), unit = pairov_unit(options);
  if (!options.title.empty()) l.header.push_back(options.title);
  std::string counts = std::to_string(values.size()) + (values.size() == 1 ? " point" : " points");
  if (!values.empty()) {
    std::vector<double> v = values;
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    counts += ", median " + name + " " + legend_number(*mid) + unit;
  }
  const bool score = options.values == PairOverlayValues::Score;
  counts += "; dots: " + name + ", " + (score ? "red " : "blue ") + legend_number(options.value_low) + unit +
            (score ? " (bad)" : " (good)") + " to " + (score ? "blue " : "red ") + legend_number(options.value_high) +
            unit + (score ? " (good)" : " (bad)");
  l.header.push_back(counts);
  // How much of the master the secondary covers.
  geometry = pairov_geometry(master, secondary, master_from_secondary);
  l.coverage = geometry.coverage;
  if (l.coverage == 0.0) {
    l.header.push_back("the secondary does not overlap the master under this homography: master only");
  } else {
    const double percent = 100.0 * l.coverage;
    l.header.push_back("tiles: master | secondary warped onto it; edges break where misregistered; "
                       "dark: master only; the secondary covers " +
                       (percent < 1.0 ? std::string("< 1") : legend_fixed(percent, 0)) + " % of the master");
  }
  l.header = legend_wrap(l.header, options.max_side_px - 2 * kLegendMargin, !options.title.empty());
  const int header_height = static_cast<int>(l.header.size()) * kLegendLineHeight + 6;

  // The image: shrunk to fit beside the colour bar and between the header and the footer.
  const int legend_width = kLegendBarGap + kLegendBarWidth + kLegendLabelWidth;
  const double room_w = options.max_side_px - 2 * kLegendMargin - legend_width;
  const double room_h = options.max_side_px - 2 * kLegendMargin - header_height - kPairOverlayFooterHeight;
  // (A header wrapped into many lines on a small max_side_px could leave no room: 50 px at least.)
  const double factor = std::min({1.0, room_w / master.width(), std::max(room_h, 50.0) / master.height()});
  const int iw = std::max(1, static_cast<int>(std::lround(master.width() * factor)));
  const int ih = std::max(1, static_cast<int>(std::lround(master.height() * factor)));
  l.image = cv::Rect(kLegendMargin, kLegendMargin + header_height, iw, ih);
  l.px_per_master_px_x = static_cast<double>(iw) / master.width();
  l.px_per_master_px_y = static_cast<double>(ih) / master.height();

  // Colour bar beside the image, its name under it; the scale bar under the image.
  const int bar_h = std::max(50, std::min(std::clamp(ih, 150, 500), static_cast<int>(room_h) - 30));
  l.colour_bar = cv::Rect(l.image.x + iw + kLegendBarGap, l.image.y, kLegendBarWidth, bar_h);
  l.scale_bar_master_px = legend_round_down(0.25 * master.width());
  const int bar_px = std::max(1, static_cast<int>(std::lround(l.scale_bar_master_px * l.px_per_master_px_x)));
  const int below = l.image.y + std::max(ih, bar_h + 30);
  l.scale_bar = cv::Rect(l.image.x, below + 14, bar_px, 4);

  const int content_w = l.colour_bar.x + kLegendBarWidth + kLegendLabelWidth + kLegendMargin;
  int text_w = 0;
  for (std::size_t i = 0; i < l.header.size(); ++i)
    text_w = std::max(text_w, 2 * kLegendMargin + legend_text_width(l.header[i], i == 0 && !options.title.empty() ? 2 : 1));
  // Text longer than the picture may be is cut rather than the picture made wider.
  l.picture = cv::Size(std::max(content_w, std::min(text_w, options.max_side_px)),
                       below + kPairOverlayFooterHeight + kLegendMargin);
  return l;
}

}  // namespace detail

/// The layout draw_pair_overlay draws with: the sizes, where the image, colour bar and scale bar go,
/// the header text and the secondary's coverage of the master. Throws diachron::Error for the reasons
/// draw_pair_overlay does.
inline PairOverlayLayout pair_overlay_layout(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                                             const Eigen::Matrix3d& master_from_secondary,
                                             const std::vector<Eigen::Vector2d>& master_points,
                                             const std::vector<double>& values,
                                             const DrawPairOverlayOptions& options = {}) {
  detail::pairov_check_inputs(master, secondary, master_from_secondary, master_points, values, options);
  detail::PairOverlayGeometry geometry;
  return detail::pairov_layout(master, secondary, master_from_secondary, values, options, geometry);
}

/// A BGR picture of an image pair in the master's geometry (see the file comment for why this form):
///
/// - the master, shrunk to fit (never enlarged) with cv::INTER_AREA, in a checkerboard of
///   options.tile_px tiles whose top-left one, and every other one, shows the secondary warped onto
///   the master by `master_from_secondary` (master px = H * secondary px, both in diachron's
///   convention: (0, 0) = centre of the top-left pixel, which is also cv::warpPerspective's, so H is
///   composed with the shrinking's pixel-edge-to-pixel-edge scaling and nothing else). The secondary is
///   first shrunk (INTER_AREA) to about the picture's resolution, so that a 12000 px scan does not
///   alias; the warp is bilinear. Where the secondary does not reach, the master is drawn dark (x 0.45)
///   in every tile. When no part of the secondary lands on the master (coverage 0 on a 100 x 100 grid),
///   the master is drawn plain and the header says so;
/// - a dot per point (`master_points`, master px) of options.dot_radius_px, filled with
///   pair_overlay_colour of its value and ringed in black, the best drawn first so that the bad ones
///   stay on top; points outside the master are left out;
/// - a colour bar (value_high at the top, the unit at its top label, the values' name under it), a
///   scale bar in master pixels, the title and a line with the count and median value, and one saying
///   how to read the tiles and how much of the master the secondary covers.
///
/// Layout in pair_overlay_layout. Throws diachron::Error for an empty image, a homography with a
/// non-finite entry or that is singular, points and values of different lengths, a non-finite point
/// or value, or bad options.
inline cv::Mat draw_pair_overlay(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                                 const Eigen::Matrix3d& master_from_secondary,
                                 const std::vector<Eigen::Vector2d>& master_points, const std::vector<double>& values,
                                 const DrawPairOverlayOptions& options = {}) {
  using namespace detail;
  pairov_check_inputs(master, secondary, master_from_secondary, master_points, values, options);
  PairOverlayGeometry geometry;
  const PairOverlayLayout l = pairov_layout(master, secondary, master_from_secondary, values, options, geometry);
  const cv::Scalar white(255, 255, 255), black(0, 0, 0);
  cv::Mat canvas(l.picture, CV_8UC3, white);

  // The master at the picture's size. Shrinking maps pixel edges to edges: picture = s (x + 0.5) - 0.5.
  const cv::Size size = l.image.size();
  cv::Mat grey;
  cv::resize(as_mat(master), grey, size, 0.0, 0.0, cv::INTER_AREA);
  const double sx = l.px_per_master_px_x, sy = l.px_per_master_px_y;
  Eigen::Matrix3d picture_from_master;
  picture_from_master << sx, 0.0, 0.5 * sx - 0.5, 0.0, sy, 0.5 * sy - 0.5, 0.0, 0.0, 1.0;

  if (geometry.coverage > 0.0) {
    // The secondary shrunk to about the picture's resolution first (a bilinear warp alone would alias),
    // in the same edge-to-edge convention, then warped straight into the picture's geometry.
    const double q = std::min(1.0, geometry.master_px_per_secondary_px * std::sqrt(sx * sy));
    cv::Mat small;
    const cv::Size small_size(std::max(1, static_cast<int>(std::lround(secondary.width() * q))),
                              std::max(1, static_cast<int>(std::lround(secondary.height() * q))));
    if (small_size == cv::Size(secondary.width(), secondary.height()))
      small = as_mat(secondary);
    else
      cv::resize(as_mat(secondary), small, small_size, 0.0, 0.0, cv::INTER_AREA);
    const double qx = static_cast<double>(small.cols) / secondary.width();
    const double qy = static_cast<double>(small.rows) / secondary.height();
    Eigen::Matrix3d secondary_from_small;
    secondary_from_small << 1.0 / qx, 0.0, 0.5 / qx - 0.5, 0.0, 1.0 / qy, 0.5 / qy - 0.5, 0.0, 0.0, 1.0;
    const Eigen::Matrix3d picture_from_small = picture_from_master * master_from_secondary * secondary_from_small;
    cv::Mat m(3, 3, CV_64F);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m.at<double>(r, c) = picture_from_small(r, c);
    cv::Mat warped, reach;
    cv::warpPerspective(small, warped, m, size, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
    // Where the secondary reaches: its all-white twin warped the same way, half-covered pixels in.
    cv::warpPerspective(cv::Mat(small.size(), CV_8UC1, cv::Scalar(255)), reach, m, size, cv::INTER_LINEAR,
                        cv::BORDER_CONSTANT, cv::Scalar(0));
    for (int y = 0; y < size.height; ++y) {
      std::uint8_t* g = grey.ptr<std::uint8_t>(y);
      const std::uint8_t* w = warped.ptr<std::uint8_t>(y);
      const std::uint8_t* r = reach.ptr<std::uint8_t>(y);
      for (int x = 0; x < size.width; ++x) {
        if (r[x] < 128)
          g[x] = static_cast<std::uint8_t>(std::lround(kPairOverlayDim * g[x]));
        else if ((x / options.tile_px + y / options.tile_px) % 2 == 0)
          g[x] = w[x];
      }
    }
  }
  cv::Mat image_view = canvas(l.image);  // writes into the canvas: same size and type
  cv::cvtColor(grey, image_view, cv::COLOR_GRAY2BGR);
  cv::rectangle(canvas, cv::Rect(l.image.x - 1, l.image.y - 1, l.image.width + 2, l.image.height + 2), black, 1);

  // Dots, the best first. Clipped to the image so that none spills over the legend.
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < master_points.size(); ++i) {
    const Eigen::Vector2d& p = master_points[i];
    if (p.x() >= -0.5 && p.y() >= -0.5 && p.x() <= master.width() - 0.5 && p.y() <= master.height() - 0.5)
      order.push_back(i);
  }
  const bool score = options.values == PairOverlayValues::Score;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return score ? values[a] > values[b] : values[a] < values[b]; });
  cv::Mat dots = canvas(l.image);
  const int radius = options.dot_radius_px << kDrawShift;
  for (const std::size_t i : order) {
    const Eigen::Vector2d p = pair_overlay_picture_point(l, master_points[i]);
    const cv::Point c = fixed_point(p.x() - l.image.x, p.y() - l.image.y);
    cv::circle(dots, c, radius + (1 << kDrawShift), black, -1, cv::LINE_AA, kDrawShift);
    cv::circle(dots, c, radius, cv::Scalar(pair_overlay_colour(values[i], options)), -1, cv::LINE_AA, kDrawShift);
  }

  // Header, colour bar with the values' name under it, scale bar.
  draw_legend_lines(canvas, l.header, cv::Point(kLegendMargin, kLegendMargin), !options.title.empty());
  const cv::Rect& bar = l.colour_bar;
  draw_legend_colour_bar(
      canvas, bar, options.value_low, options.value_high,
      [&](double v) { return pair_overlay_colour(v, options); }, score ? "" : "px", options.value_low < 0.0);
  cv::putText(canvas, pairov_value_name(options), cv::Point(bar.x, bar.y + bar.height + 22), cv::FONT_HERSHEY_SIMPLEX,
              kLegendLabelFontScale, black, 1, cv::LINE_AA);
  draw_legend_scale_bar(canvas, l.scale_bar, legend_number(l.scale_bar_master_px) + " px (master)");
  return canvas;
}

/// What write_pair_overlay_jpg wrote.
struct PairOverlayJpeg {
  int quality = 0;         ///< the JPEG quality used, [5, 100]
  int max_side_px = 0;     ///< the max_side_px the picture was drawn with
  cv::Size size;           ///< the picture's size, px
  std::size_t bytes = 0;   ///< the file's size, bytes (<= options.max_jpeg_bytes)
};

/// draw_pair_overlay written to `path` as a JPEG of options.jpeg_quality, at most
/// options.max_jpeg_bytes long. The picture is encoded in memory first; while it is too long, the
/// quality drops by 10 down to 50 (text and dots stay clean down there), then the picture is drawn
/// again smaller (max_side_px times about sqrt(bound / bytes at quality 50), never under 400 px, so the
/// dots and legend keep their size in pixels) from the requested quality; at 400 px the quality goes
/// on down to 5. Noise, the hardest to compress: a 4000 x 3000 pair (averaged by the shrinking) fits
/// 1 MB at quality 85; a 1440 x 1080 pair, drawn at its size, needs quality 75. Throws diachron::Error
/// naming the file when it cannot be written (or, not seen in practice, when even 400 px at quality 5
/// is too long), and for draw_pair_overlay's reasons.
inline PairOverlayJpeg write_pair_overlay_jpg(const std::string& path, const Raster<std::uint8_t>& master,
                                              const Raster<std::uint8_t>& secondary,
                                              const Eigen::Matrix3d& master_from_secondary,
                                              const std::vector<Eigen::Vector2d>& master_points,
                                              const std::vector<double>& values,
                                              const DrawPairOverlayOptions& options = {}) {
  options.check();
  DrawPairOverlayOptions o = options;
  std::vector<unsigned char> buffer;
  PairOverlayJpeg written;
  for (;;) {
    const cv::Mat picture = draw_pair_overlay(master, secondary, master_from_secondary, master_points, values, o);
    const int lowest = o.max_side_px == 400 ? 5 : 50;
    for (int q = o.jpeg_quality;; q = std::max(q - 10, lowest)) {
      cv::imencode(".jpg", picture, buffer, {cv::IMWRITE_JPEG_QUALITY, q});
      if (buffer.size() <= o.max_jpeg_bytes) {
        written = PairOverlayJpeg{q, o.max_side_px, picture.size(), buffer.size()};
        break;
      }
      if (q == lowest) break;
    }
    if (written.bytes > 0) break;
    DIACHRON_CHECK(o.max_side_px > 400, "cannot write '" << path << "' within " << o.max_jpeg_bytes
                                                         << " bytes: " << buffer.size()
                                                         << " at 400 px and quality 5");
    const double shrink = 0.95 * std::sqrt(static_cast<double>(o.max_jpeg_bytes) / static_cast<double>(buffer.size()));
    o.max_side_px = std::clamp(static_cast<int>(o.max_side_px * shrink), 400, o.max_side_px - 1);
  }
  std::ofstream file(path, std::ios::binary);
  if (file) file.write(reinterpret_cast<const char*>(buffer.data()), static_cast<std::streamsize>(buffer.size()));
  DIACHRON_CHECK(file.good() && file.is_open(),
                 "cannot write image '" << path << "' (directory missing or not writable?)");
  return written;
}

}  // namespace diachron
