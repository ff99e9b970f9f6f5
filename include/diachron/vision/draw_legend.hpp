#pragma once
/// @file
/// The legend pieces diachron's pictures share (draw_dod, draw_pair_overlay, draw_residuals): text
/// lines, a colour bar with ticks at round values, a swatch with its label and a scale bar, in one
/// font and one set of sizes, so that every picture reads the same way.
///
/// Everything draws on a BGR canvas (CV_8UC3) in black on a light background, at picture pixels
/// (OpenCV's Rect and Point: x right, y down, integer = pixel). The sizes are fixed in pixels, not
/// relative to the picture: the pictures are at most a couple of thousand pixels wide and meant to
/// be looked at at 100 %, where 0.45 to 0.55 of Hershey's simplex font is legible.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>

namespace diachron {

/// Margin around a picture's content, px.
inline constexpr int kLegendMargin = 12;
/// Height of one text line (draw_legend_lines), px.
inline constexpr int kLegendLineHeight = 24;
/// Font scale of text lines (titles, statistics) and of their width (legend_text_width).
inline constexpr double kLegendFontScale = 0.55;
/// Font scale of the labels beside a colour bar, a swatch or a scale bar.
inline constexpr double kLegendLabelFontScale = 0.45;
/// A colour bar: gap from what it describes, its width and the room its tick labels take, px.
inline constexpr int kLegendBarGap = 16, kLegendBarWidth = 22, kLegendLabelWidth = 92;

/// The largest of 1, 2 and 5 times a power of ten that is not above `v` (> 0): the length of a scale
/// bar, the step between colour-bar ticks. Throws diachron::Error when v is not finite and > 0.
inline double legend_round_down(double v) {
  DIACHRON_CHECK(std::isfinite(v) && v > 0.0, "legend_round_down: expected a finite value > 0, got " << v);
  const double p = std::pow(10.0, std::floor(std::log10(v)));
  for (const double m : {5.0, 2.0, 1.0})
    if (m * p <= v * (1.0 + 1e-9)) return m * p;
  return p;
}

/// The number of decimals that shows every multiple of `step` (from legend_round_down) exactly:
/// 0 for 1, 20 or 500; 1 for 0.5; 2 for 0.02.
inline int legend_decimals(double step) {
  return std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
}

/// `v` with `decimals` decimals, with a sign ("+0.50", "-2") when `sign` is set.
inline std::string legend_fixed(double v, int decimals, bool sign = false) {
  char format[16];
  std::snprintf(format, sizeof format, sign ? "%%+.%df" : "%%.%df", decimals);
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, v);
  return buffer;
}

/// `v` with at most two decimals, trailing zeros dropped: "0.87", "3", "0.5", "1500".
inline std::string legend_number(double v) {
  std::string s = legend_fixed(v, 2);
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

/// Width of `text` in picture pixels, in the legend font at `font_scale` and `thickness` (2 for a
/// title line, 1 otherwise).
inline int legend_text_width(const std::string& text, int thickness, double font_scale = kLegendFontScale) {
  int baseline = 0;
  return cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, font_scale, thickness, &baseline).width;
}

/// `lines` with each line wider than `width_px` (in the legend font; the first line bold when
/// `bold_first`) broken at its "; " separators into as few lines as fit. A piece wider than
/// `width_px` on its own stays whole: the picture cuts it.
inline std::vector<std::string> legend_wrap(const std::vector<std::string>& lines, int width_px, bool bold_first) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const int thickness = i == 0 && bold_first ? 2 : 1;
    std::string current;
    std::size_t start = 0;
    for (;;) {
      const std::size_t end = lines[i].find("; ", start);
      const std::string piece = lines[i].substr(start, end == std::string::npos ? std::string::npos : end - start);
      const std::string joined = current.empty() ? piece : current + "; " + piece;
      if (current.empty() || legend_text_width(joined, thickness) <= width_px) {
        current = joined;
      } else {
        out.push_back(current);
        current = piece;
      }
      if (end == std::string::npos) break;
      start = end + 2;
    }
    out.push_back(current);
  }
  return out;
}

/// Text lines from `top_left` down, kLegendLineHeight apart, at kLegendFontScale; the first in bold
/// (a title) when `bold_first`. Lines wider than the canvas are cut by it.
inline void draw_legend_lines(cv::Mat& canvas, const std::vector<std::string>& lines, cv::Point top_left,
                              bool bold_first) {
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const bool bold = i == 0 && bold_first;
    cv::putText(canvas, lines[i], cv::Point(top_left.x, top_left.y + 17 + static_cast<int>(i) * kLegendLineHeight),
                cv::FONT_HERSHEY_SIMPLEX, kLegendFontScale, cv::Scalar(0, 0, 0), bold ? 2 : 1, cv::LINE_AA);
  }
}

/// A vertical colour bar in `bar` (`high` at its top row, `low` at its bottom row, each row in
/// `colour_of(value)`, a cv::Vec3b or a cv::Scalar), framed in black, with ticks and labels right of it
/// at the multiples of a round step (legend_round_down of a quarter of the range) within [low, high].
/// Labels carry a sign when `signed_labels` (a diverging scale); `unit`, when not empty, follows the
/// top label ("+2.00 m"). Leave kLegendLabelWidth px right of the bar for the labels.
/// Throws diachron::Error when low < high does not hold or a bound is not finite.
template <class ColourOf>
void draw_legend_colour_bar(cv::Mat& canvas, const cv::Rect& bar, double low, double high, ColourOf colour_of,
                            const std::string& unit, bool signed_labels) {
  DIACHRON_CHECK(std::isfinite(low) && std::isfinite(high) && low < high,
                 "draw_legend_colour_bar: expected finite low < high, got " << low << " and " << high);
  const cv::Scalar black(0, 0, 0);
  // In mid +- half form, so that a symmetric scale (low = -high) computes exactly what draw_dod always
  // did with its half-range alone: its pictures stay the same to the pixel.
  const double mid = (low + high) / 2.0, half = (high - low) / 2.0;
  for (int j = 0; j < bar.height; ++j) {
    const double v = mid + half * (1.0 - 2.0 * (j + 0.5) / bar.height);
    canvas(cv::Rect(bar.x, bar.y + j, bar.width, 1)).setTo(cv::Scalar(colour_of(v)));
  }
  cv::rectangle(canvas, cv::Rect(bar.x - 1, bar.y - 1, bar.width + 2, bar.height + 2), black, 1);
  const double step = legend_round_down(half / 2.0);
  const int decimals = legend_decimals(step);
  const int first = static_cast<int>(std::ceil(low / step - 1e-9));
  const int last = static_cast<int>(std::floor(high / step + 1e-9));
  for (int k = first; k <= last; ++k) {
    const double v = k * step;
    const int ty = bar.y + static_cast<int>(std::lround((1.0 - (v - mid) / half) / 2.0 * bar.height));
    cv::line(canvas, cv::Point(bar.x + bar.width, ty), cv::Point(bar.x + bar.width + 5, ty), black, 1);
    std::string label = k == 0 ? std::string("0") : legend_fixed(v, decimals, signed_labels);
    if (k == last && !unit.empty()) label += " " + unit;
    cv::putText(canvas, label, cv::Point(bar.x + bar.width + 8, ty + 5), cv::FONT_HERSHEY_SIMPLEX,
                kLegendLabelFontScale, black, 1, cv::LINE_AA);
  }
}

/// A swatch: `box` filled with `colour`, framed in black, `label` right of it (e.g. grey, "no data").
inline void draw_legend_swatch(cv::Mat& canvas, const cv::Rect& box, const cv::Scalar& colour,
                               const std::string& label) {
  const cv::Scalar black(0, 0, 0);
  canvas(box).setTo(colour);
  cv::rectangle(canvas, cv::Rect(box.x - 1, box.y - 1, box.width + 2, box.height + 2), black, 1);
  cv::putText(canvas, label, cv::Point(box.x + box.width + 6, box.y + 12), cv::FONT_HERSHEY_SIMPLEX,
              kLegendLabelFontScale, black, 1, cv::LINE_AA);
}

/// A scale bar: `line` filled in black (its width is the length shown), a tick down and up at each
/// end, `label` right of it (e.g. "20 m", "500 px").
inline void draw_legend_scale_bar(cv::Mat& canvas, const cv::Rect& line, const std::string& label) {
  const cv::Scalar black(0, 0, 0);
  canvas(line).setTo(black);
  cv::line(canvas, cv::Point(line.x, line.y - 5), cv::Point(line.x, line.y + line.height + 4), black, 1);
  cv::line(canvas, cv::Point(line.x + line.width - 1, line.y - 5),
           cv::Point(line.x + line.width - 1, line.y + line.height + 4), black, 1);
  cv::putText(canvas, label, cv::Point(line.x + line.width + 8, line.y + 6), cv::FONT_HERSHEY_SIMPLEX,
              kLegendLabelFontScale, black, 1, cv::LINE_AA);
}

}  // namespace diachron
