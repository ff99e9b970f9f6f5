#pragma once
/// @file
/// A DoD map (eval/dod_map.hpp) as a picture a person judges at a glance: a diverging colour map
/// (blue where the moved epoch is lower, white at 0, red where it is higher, grey where there is no
/// data), a colour bar with ticks in metres, a scale bar in ground units, a title and the map's
/// median and NMAD.
///
/// The colour range is symmetric and, by default, the 95th percentile of |dZ|: a few changed buildings
/// (a few per cent of the cells) saturate, and a systematic error that covers the map (a dome, a tilt
/// left by a poor co-registration) spans the whole colour range instead of fading to white next to
/// them, as a range from the largest |dZ| would make it. docs/evaluation.md, "DoD maps".

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/eval/dod_map.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/vision/draw_legend.hpp>
#include <diachron/vision/image.hpp>

namespace diachron {

/// Options of draw_dod.
struct DrawDodOptions {
  /// Half-range of the colour scale, dZ units (metres): -range_m is full blue, +range_m full red, beyond
  /// saturates. 0 (default): from `percentile`. >= 0.
  double range_m = 0.0;
  /// When range_m == 0, the range is this percentile of |dZ| over the valid cells, in (0, 100]. 95 by
  /// default (why: see the file comment); 100 is the largest |dZ|.
  double percentile = 95.0;
  /// First line of the picture, e.g. "e1 - e3, rough"; none when empty.
  std::string title;
  /// Print the median and NMAD of dZ (all valid cells; and the stable ones when `stable` is set).
  bool show_statistics = true;
  /// Optional stable-terrain mask of the map's size (non-zero = stable, e.g. from
  /// stable_mask_near_points): its cells' median and NMAD are printed too. Not owned; may be null.
  const Raster<std::uint8_t>* stable = nullptr;
  /// The whole picture's longer side is at most this, px (the map shrinks to fit). >= 400.
  int max_side_px = 1600;
  /// A map whose longer side is shorter than this is enlarged by an integer factor, each cell a block
  /// of identical pixels (nearest neighbour), so that the text beside it is legible. px, in
  /// [1, max_side_px].
  int min_map_side_px = 600;

  void check() const {
    DIACHRON_CHECK(std::isfinite(range_m) && range_m >= 0.0, "DrawDodOptions::range_m must be finite and >= 0, got "
                                                                  << range_m);
    DIACHRON_CHECK(percentile > 0.0 && percentile <= 100.0,
                   "DrawDodOptions::percentile must be in (0, 100], got " << percentile);
    DIACHRON_CHECK(max_side_px >= 400, "DrawDodOptions::max_side_px must be >= 400, got " << max_side_px);
    DIACHRON_CHECK(min_map_side_px >= 1 && min_map_side_px <= max_side_px,
                   "DrawDodOptions::min_map_side_px must be in [1, max_side_px], got " << min_map_side_px);
  }
};

/// BGR colour of no data in a DoD picture: a neutral grey, which no value's colour is.
inline const cv::Vec3b kDodNoDataColour(150, 150, 150);

/// The BGR colour of `dz_m` on a symmetric scale of half-range `range_m` (> 0): white at 0, through
/// ColorBrewer's RdBu (light to dark red for positive dZ, blue for negative) to full colour at
/// +-range_m and beyond; kDodNoDataColour for NaN.
inline cv::Vec3b dod_colour(double dz_m, double range_m) {
  DIACHRON_CHECK(std::isfinite(range_m) && range_m > 0.0, "dod_colour: range_m must be finite and > 0, got " << range_m);
  if (std::isnan(dz_m)) return kDodNoDataColour;
  // RdBu's stops from the centre outwards (RGB), the centre made pure white so that 0 reads as "no change".
  static constexpr std::array<std::array<double, 3>, 6> red{
      {{255, 255, 255}, {253, 219, 199}, {244, 165, 130}, {214, 96, 77}, {178, 24, 43}, {103, 0, 31}}};
  static constexpr std::array<std::array<double, 3>, 6> blue{
      {{255, 255, 255}, {209, 229, 240}, {146, 197, 222}, {67, 147, 195}, {33, 102, 172}, {5, 48, 97}}};
  const double t = std::min(std::abs(dz_m) / range_m, 1.0) * 5.0;
  const auto& stops = dz_m >= 0.0 ? red : blue;
  const int i = std::min(static_cast<int>(t), 4);
  const double f = t - i;
  cv::Vec3b bgr;
  for (int c = 0; c < 3; ++c)
    bgr[2 - c] = cv::saturate_cast<std::uint8_t>(stops[i][c] + f * (stops[i + 1][c] - stops[i][c]));
  return bgr;
}

/// The colour half-range draw_dod uses for `dz`, metres: options.range_m when set, else the
/// options.percentile-th percentile of |dZ| over the valid cells (nearest rank). When that is 0 it
/// falls back to the largest |dZ|, and to 1 when that is 0 too or no cell is valid.
inline double dod_colour_range(const Dsm& dz, const DrawDodOptions& options = {}) {
  options.check();
  if (options.range_m > 0.0) return options.range_m;
  std::vector<double> magnitudes;
  for (const float v : dz.heights())
    if (!std::isnan(v)) magnitudes.push_back(std::abs(static_cast<double>(v)));
  if (magnitudes.empty()) return 1.0;
  const double rank = options.percentile / 100.0 * static_cast<double>(magnitudes.size() - 1);
  const auto k = magnitudes.begin() + static_cast<std::ptrdiff_t>(std::lround(rank));
  std::nth_element(magnitudes.begin(), k, magnitudes.end());
  if (*k > 0.0) return *k;
  const double largest = *std::max_element(magnitudes.begin(), magnitudes.end());
  return largest > 0.0 ? largest : 1.0;
}

/// Where draw_dod puts things, picture pixels (x right, y down; OpenCV's Rect). Cell (x, y) of the
/// map covers map.x + [x, x + 1) * px_per_cell_x, map.y + [y, y + 1) * px_per_cell_y.
struct DodPictureLayout {
  cv::Size picture;            ///< the whole picture
  cv::Rect map;                ///< the map (rows and columns of the DSM as they are: north up for a north-up DSM)
  double px_per_cell_x = 0.0;  ///< picture px per map column
  double px_per_cell_y = 0.0;  ///< picture px per map row
  cv::Rect colour_bar;         ///< the colour bar: +range at its top row, -range at its bottom row
  cv::Rect scale_bar;          ///< the scale bar's line (ground units, labelled in metres)
  double scale_bar_ground = 0.0;  ///< the scale bar's length, ground units
  double range_m = 0.0;           ///< colour half-range (dod_colour_range)
  std::vector<std::string> header;  ///< text lines above the map
};

namespace detail {

inline constexpr int kDodFooterHeight = 44;

inline std::string dod_length(double ground) {
  if (ground >= 1000.0) return legend_fixed(ground / 1000.0, legend_decimals(ground / 1000.0)) + " km";
  return legend_fixed(ground, legend_decimals(ground)) + " m";
}

inline std::string dod_statistics_line(const char* what, const ErrorStatistics& s, std::size_t cells) {
  if (s.count == 0) return std::string(what) + ": no valid cell";
  const double share = 100.0 * static_cast<double>(s.count) / static_cast<double>(std::max<std::size_t>(cells, 1));
  return std::string(what) + ": median " + legend_fixed(s.median, 3, true) + " m, NMAD " + legend_fixed(s.nmad, 3, false) +
         " m, n = " + std::to_string(s.count) + " (" + legend_fixed(share, 1, false) + " % of the map)";
}

}  // namespace detail

/// The layout draw_dod draws `dz` with: sizes, where the map, colour bar and scale bar go, the colour
/// range and the header text. Throws diachron::Error for an empty map, bad options or a stable mask of
/// another size.
inline DodPictureLayout dod_picture_layout(const Dsm& dz, const DrawDodOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!dz.empty(), "draw_dod: empty DoD map");
  using namespace detail;
  DodPictureLayout l;
  l.range_m = dod_colour_range(dz, options);
  if (!options.title.empty()) l.header.push_back(options.title);
  if (options.show_statistics) {
    const DodMapStatistics s = dod_map_statistics(dz, options.stable);
    l.header.push_back(dod_statistics_line("all cells", s.all, s.num_cells));
    if (options.stable != nullptr) l.header.push_back(dod_statistics_line("stable cells", s.stable, s.num_cells));
  }
  l.header.push_back("colour: +-" + legend_fixed(l.range_m, l.range_m < 1.0 ? 3 : 2, false) + " m" +
                     (options.range_m > 0.0 ? std::string(" (fixed)")
                                            : " (" + legend_fixed(options.percentile, 0, false) + "th percentile of |dZ|)") +
                     ", red: higher than the reference");
  const int header_height = static_cast<int>(l.header.size()) * kLegendLineHeight + 6;
  const int legend_width = kLegendBarGap + kLegendBarWidth + kLegendLabelWidth;

  // Map size: cells keep their ground aspect; enlarged by an integer factor when small, shrunk to fit.
  const Eigen::Vector2d cell = dz.cell_size();
  const double w = dz.width(), h = dz.height() * (cell.y() / cell.x());
  const double room_w = options.max_side_px - 2 * kLegendMargin - legend_width;
  const double room_h = options.max_side_px - 2 * kLegendMargin - header_height - kDodFooterHeight;
  const double fit = std::min(room_w / w, room_h / h);
  double factor = std::min(1.0, fit);
  if (std::max(w, h) < options.min_map_side_px) {
    factor = std::min(std::ceil(options.min_map_side_px / std::max(w, h)), fit);
    if (factor > 1.0) factor = std::floor(factor);
  }
  const int map_w = std::max(1, static_cast<int>(std::lround(w * factor)));
  const int map_h = std::max(1, static_cast<int>(std::lround(h * factor)));
  l.map = cv::Rect(kLegendMargin, kLegendMargin + header_height, map_w, map_h);
  l.px_per_cell_x = static_cast<double>(map_w) / dz.width();
  l.px_per_cell_y = static_cast<double>(map_h) / dz.height();

  const int bar_h = std::clamp(map_h, 200, 500);
  l.colour_bar = cv::Rect(l.map.x + map_w + kLegendBarGap, l.map.y, kLegendBarWidth, bar_h);
  // Scale bar: a round length near a quarter of the map's width.
  const double ground_per_px = cell.x() / l.px_per_cell_x;
  l.scale_bar_ground = legend_round_down(0.25 * map_w * ground_per_px);
  const int bar_px = std::max(1, static_cast<int>(std::lround(l.scale_bar_ground / ground_per_px)));
  const int below = l.map.y + std::max(map_h, bar_h + 40);  // the no-data swatch sits under the colour bar
  l.scale_bar = cv::Rect(l.map.x, below + 14, bar_px, 4);

  int width = l.colour_bar.x + kLegendBarWidth + kLegendLabelWidth + kLegendMargin;
  for (std::size_t i = 0; i < l.header.size(); ++i)
    width = std::max(width, 2 * kLegendMargin + legend_text_width(l.header[i], i == 0 && !options.title.empty() ? 2 : 1));
  l.picture = cv::Size(width, below + kDodFooterHeight + kLegendMargin);
  return l;
}

/// A BGR picture of the DoD map `dz` (e.g. DodMap::dz; metres, NaN = no data): the map in the
/// diverging colours of dod_colour over a symmetric range (dod_colour_range), a colour bar with ticks
/// in metres and a no-data swatch, a scale bar (ground units of the geotransform, labelled in metres:
/// meant for metric CRSs), the title and the statistics (dod_map_statistics). The map keeps the DSM's
/// rows and columns (north up for a north-up DSM) and its cells' ground aspect; layout in
/// dod_picture_layout. Throws diachron::Error for an empty map, bad options or a stable mask of another
/// size.
inline cv::Mat draw_dod(const Dsm& dz, const DrawDodOptions& options = {}) {
  using namespace detail;
  const DodPictureLayout l = dod_picture_layout(dz, options);
  const cv::Scalar white(255, 255, 255), black(0, 0, 0);
  cv::Mat canvas(l.picture, CV_8UC3, white);

  // The map, coloured cell by cell, then resized: nearest neighbour up (cells stay blocks), area down.
  cv::Mat cells(dz.height(), dz.width(), CV_8UC3);
  for (int y = 0; y < dz.height(); ++y)
    for (int x = 0; x < dz.width(); ++x) cells.at<cv::Vec3b>(y, x) = dod_colour(dz.heights()(x, y), l.range_m);
  const bool enlarge = l.map.width >= dz.width() && l.map.height >= dz.height();
  cv::Mat map_view = canvas(l.map);  // writes into the canvas: same size and type, no reallocation
  cv::resize(cells, map_view, l.map.size(), 0.0, 0.0, enlarge ? cv::INTER_NEAREST : cv::INTER_AREA);
  cv::rectangle(canvas, cv::Rect(l.map.x - 1, l.map.y - 1, l.map.width + 2, l.map.height + 2), black, 1);

  // Header lines, the colour bar (+range at the top, ticks at round values) with the no-data swatch
  // under it, the scale bar.
  draw_legend_lines(canvas, l.header, cv::Point(kLegendMargin, kLegendMargin), !options.title.empty());
  const cv::Rect& bar = l.colour_bar;
  draw_legend_colour_bar(
      canvas, bar, -l.range_m, l.range_m, [&](double v) { return dod_colour(v, l.range_m); }, "m", true);
  draw_legend_swatch(canvas, cv::Rect(bar.x, bar.y + bar.height + 14, bar.width, 14), cv::Scalar(kDodNoDataColour),
                     "no data");
  draw_legend_scale_bar(canvas, l.scale_bar, dod_length(l.scale_bar_ground));
  return canvas;
}

/// draw_dod written to `path` (PNG when the name ends in .png). Throws diachron::Error naming the file
/// when it cannot be written, and for draw_dod's reasons.
inline void write_dod_png(const std::string& path, const Dsm& dz, const DrawDodOptions& options = {}) {
  save_image(path, draw_dod(dz, options));
}

}  // namespace diachron
