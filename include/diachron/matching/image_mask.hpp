#pragma once
/// @file
/// Which pixels of an image may carry a match. Scans of archive photographs hold more than the
/// ground: the film's frame, fiducial marks, the data strip (clock, altimeter, frame number), and
/// photographs may show clouds or water. Their edges are the strongest texture of the image, so a
/// matcher that is not told picks them first. The convention is COLMAP's (its
/// `ImageReader.mask_path`): a grey raster of the image's size where 0 marks a pixel to ignore and
/// any other value a usable one. Std and Eigen only.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>

namespace diachron {

/// An image's mask: 0 = ignore the pixel, anything else = usable (COLMAP's convention). Pixels
/// follow docs/conventions.md: the pixel containing (x, y) is (round(x), round(y)). A default
/// (empty) mask masks nothing, whatever the image's size.
class ImageMask {
 public:
  ImageMask() = default;
  /// Takes the mask raster (0 = ignore).
  explicit ImageMask(Raster<std::uint8_t> mask) : mask_(std::move(mask)) {}

  /// No mask: every pixel is usable.
  bool empty() const { return mask_.empty(); }
  int width() const { return mask_.width(); }
  int height() const { return mask_.height(); }
  const Raster<std::uint8_t>& raster() const { return mask_; }

  /// Throws diachron::Error unless the mask is empty or `width` x `height` (`what` names the image
  /// in the message).
  void check_size(int width, int height, const std::string& what) const {
    DIACHRON_CHECK(empty() || (mask_.width() == width && mask_.height() == height),
                   "the mask of " << what << " is " << mask_.width() << " x " << mask_.height()
                                  << " px, the image " << width << " x " << height);
  }

  /// The pixel containing `px` is usable: inside the mask and not 0. Always true for an empty mask;
  /// false for a non-finite position.
  bool usable(const Eigen::Vector2d& px) const { return box_usable(px, 0); }

  /// Every pixel of the square of (2 half_px + 1)^2 pixels centred on the pixel containing `px` is
  /// inside the mask and usable (half_px >= 0). Always true for an empty mask; false for a
  /// non-finite position. Costs (2 half_px + 1)^2 look-ups: for a few points per window; eroded()
  /// answers every pixel at once.
  bool box_usable(const Eigen::Vector2d& px, int half_px) const {
    DIACHRON_CHECK(half_px >= 0, "ImageMask::box_usable: half_px must be >= 0, got " << half_px);
    if (empty()) return true;
    if (!px.allFinite()) return false;
    const double cx = std::round(px.x()), cy = std::round(px.y());
    if (cx - half_px < 0.0 || cy - half_px < 0.0 || cx + half_px > mask_.width() - 1.0 ||
        cy + half_px > mask_.height() - 1.0)
      return false;
    const int x0 = static_cast<int>(cx) - half_px, y0 = static_cast<int>(cy) - half_px;
    for (int y = y0; y <= y0 + 2 * half_px; ++y) {
      const std::uint8_t* row = mask_.row(y);
      for (int x = x0; x <= x0 + 2 * half_px; ++x)
        if (row[x] == 0) return false;
    }
    return true;
  }

  /// The mask eroded by a square of half side half_px (>= 0): 1 where box_usable(pixel, half_px), 0
  /// elsewhere, pixels nearer than half_px to the edge included. O(pixels) whatever half_px (two
  /// passes of running counts), one byte per pixel. An empty mask gives an empty raster.
  Raster<std::uint8_t> eroded(int half_px) const {
    DIACHRON_CHECK(half_px >= 0, "ImageMask::eroded: half_px must be >= 0, got " << half_px);
    if (empty()) return Raster<std::uint8_t>{};
    const int w = mask_.width(), h = mask_.height();
    Raster<std::uint8_t> out(w, h, 0);
    const int side = 2 * half_px + 1;
    // Rows: a pixel is 1 when the side pixels centred on it along its row are all usable.
    Raster<std::uint8_t> rows(w, h, 0);
    for (int y = 0; y < h; ++y) {
      int run = 0;  // usable pixels in a row ending at x
      const std::uint8_t* in = mask_.row(y);
      std::uint8_t* r = rows.row(y);
      for (int x = 0; x < w; ++x) {
        run = in[x] != 0 ? run + 1 : 0;
        if (run >= side) r[x - half_px] = 1;
      }
    }
    // Columns of the row result: the same along each column.
    std::vector<int> run(static_cast<std::size_t>(w), 0);
    for (int y = 0; y < h; ++y) {
      const std::uint8_t* r = rows.row(y);
      for (int x = 0; x < w; ++x) {
        int& n = run[static_cast<std::size_t>(x)];
        n = r[x] != 0 ? n + 1 : 0;
        if (n >= side) out(x, y - half_px) = 1;
      }
    }
    return out;
  }

 private:
  Raster<std::uint8_t> mask_;
};

}  // namespace diachron
