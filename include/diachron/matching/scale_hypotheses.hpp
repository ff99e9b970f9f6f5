#pragma once
/// @file
/// Scale hypotheses for matching DSM images across a resolution gap: one DSM also resampled 2, 4, 8
/// times coarser before its image is made, beside the quarter-turn rotation hypotheses
/// (matching/rotation_hypotheses.hpp).
///
/// Why: a coarse historical DSM (10 m) against a fine modern one (2 m) gives DSM images whose scales
/// differ by the resolution ratio times the frames' unknown scale. A scale-invariant detector copes
/// in principle, but the fine image's strongest features are details the coarse DSM never had, and
/// a slope image made at 2 m is not a slope image made at 10 m, scaled. Coarsening the finer DSM
/// (block means of heights, then its image) makes both images show the same terrain at the same
/// detail. Which DSM is finer cannot be read from the cell sizes, which are in frames of unknown
/// scale: the hypotheses are ordered by valid-cell counts (the DSM with more valid cells is
/// probably the finer, when the two cover similar ground) and both sides are tried.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of plan_scale_hypotheses() and of the scale search in rough_coregistration().
struct ScaleHypothesesOptions {
  /// Try coarser levels at all. Off: the DSMs are matched at their own resolutions only (small
  /// images are still enlarged: see upsample_below_px).
  bool enabled = true;
  /// Coarsest level: factor 2^max_level (3: 8 times coarser). Each level halves the cell count
  /// along each axis, so a level costs about a quarter of the one before it.
  int max_level = 3;
  /// A level is skipped when the coarsened DSM's shorter side would have fewer cells than this:
  /// too small an image holds too few features to pass the significance test.
  int min_side_cells = 48;
  /// Also coarsen the DSM with fewer valid cells (after every level of the other). The valid-cell
  /// count is only a guess at which DSM is finer: a fine DSM of a small area can have fewer cells.
  bool both_sides = true;
  /// Stop at the first hypothesis whose result passes the significance test (hypotheses run in
  /// order: the DSMs as given first), so DSMs without a resolution gap cost one hypothesis. Off
  /// runs every planned hypothesis and keeps the most significant.
  bool stop_at_first_success = true;
  /// DSM images whose shorter side has fewer pixels than this are enlarged (bilinear, by the smallest
  /// power of two that reaches it, at most `max_upsample`) before matching, at every scale hypothesis
  /// including the DSMs as given; 0 never enlarges. Why: a
  /// DSM of 20 x 30 to 60 x 60 cells (a coarse DSM cut to a small area) gives SIFT too few keypoints
  /// to pass the significance test; interpolated pixels let its finest octaves find blobs a few
  /// cells wide. Measured (docs/rough-coregistration.md, "Small DSM images"): 160 took the
  /// resolution-gap cases from 59 to 70 of 100 with no wrong success; 320 gave 69. Pixels of the
  /// DSM image (one per DSM cell before enlargement).
  int upsample_below_px = 160;
  /// Largest enlargement of a small DSM image (a power of two, 1 to 8).
  int max_upsample = 4;

  void check() const {
    DIACHRON_CHECK(max_level >= 0 && max_level <= 6, "ScaleHypothesesOptions::max_level must be in [0, 6], got "
                                                         << max_level);
    DIACHRON_CHECK(min_side_cells >= 8, "ScaleHypothesesOptions::min_side_cells must be >= 8, got " << min_side_cells);
    DIACHRON_CHECK(upsample_below_px >= 0, "ScaleHypothesesOptions::upsample_below_px must be >= 0, got "
                                               << upsample_below_px);
    DIACHRON_CHECK(max_upsample == 1 || max_upsample == 2 || max_upsample == 4 || max_upsample == 8,
                   "ScaleHypothesesOptions::max_upsample must be 1, 2, 4 or 8, got " << max_upsample);
  }
};

/// One scale hypothesis: how many times each DSM is halved before matching (at most one is).
struct ScaleHypothesis {
  int master_level = 0;     ///< the master DSM is coarsened by 2^master_level
  int secondary_level = 0;  ///< the secondary DSM is coarsened by 2^secondary_level
  int master_factor() const { return 1 << master_level; }
  int secondary_factor() const { return 1 << secondary_level; }
  /// "m/4" for the master 4 times coarser, "s/2" for the secondary twice, "1" for neither.
  std::string name() const {
    if (master_level > 0) return "m/" + std::to_string(master_factor());
    if (secondary_level > 0) return "s/" + std::to_string(secondary_factor());
    return "1";
  }
};

/// The hypotheses to try, in order: {0, 0} first; then levels 1..max_level of the DSM with more
/// valid cells (the master on ties), then (with `both_sides`) those of the other; levels whose
/// coarsened shorter side would fall below `min_side_cells` are left out. Only {0, 0} when disabled.
/// Sizes are in cells; valid counts are the DSMs' cells with a height.
inline std::vector<ScaleHypothesis> plan_scale_hypotheses(int master_width, int master_height,
                                                          std::size_t master_valid, int secondary_width,
                                                          int secondary_height, std::size_t secondary_valid,
                                                          const ScaleHypothesesOptions& options = {}) {
  options.check();
  std::vector<ScaleHypothesis> out{ScaleHypothesis{}};
  if (!options.enabled) return out;
  const bool master_first = master_valid >= secondary_valid;
  auto add_levels = [&](bool master_side) {
    const int side = master_side ? std::min(master_width, master_height) : std::min(secondary_width, secondary_height);
    for (int level = 1; level <= options.max_level; ++level) {
      if (side / (1 << level) < options.min_side_cells) break;
      ScaleHypothesis h;
      (master_side ? h.master_level : h.secondary_level) = level;
      out.push_back(h);
    }
  };
  add_levels(master_first);
  if (options.both_sides) add_levels(!master_first);
  return out;
}

/// `dsm` with `factor` x `factor` blocks of cells merged into one (the block mean of its valid
/// heights), on a grid covering the same ground: the new cell is `factor` times larger and its
/// centre is the centre of its block. A block with fewer than half its cells valid is a hole, so
/// holes neither vanish nor grow by more than half a block. Cells past the last full block are
/// merged into a partial block. factor 1 returns a copy.
inline Dsm coarsen_dsm(const Dsm& dsm, int factor) {
  DIACHRON_CHECK(factor >= 1, "coarsen_dsm: factor must be >= 1, got " << factor);
  DIACHRON_CHECK(!dsm.empty(), "coarsen_dsm: the DSM is empty");
  if (factor == 1) return dsm;
  const int w = (dsm.width() + factor - 1) / factor, h = (dsm.height() + factor - 1) / factor;
  Raster<float> heights(w, h, std::numeric_limits<float>::quiet_NaN());
  for (int by = 0; by < h; ++by)
    for (int bx = 0; bx < w; ++bx) {
      double sum = 0.0;
      int valid = 0, cells = 0;
      for (int y = by * factor; y < std::min((by + 1) * factor, dsm.height()); ++y)
        for (int x = bx * factor; x < std::min((bx + 1) * factor, dsm.width()); ++x) {
          ++cells;
          if (!dsm.valid(x, y)) continue;
          sum += dsm.heights()(x, y);
          ++valid;
        }
      if (2 * valid >= cells && valid > 0) heights(bx, by) = static_cast<float>(sum / valid);
    }
  // New pixel (i, j) is centred on old pixel (f i + (f - 1) / 2, f j + (f - 1) / 2), and a step of
  // one new pixel is f old pixels: compose that affine map into the old geotransform.
  const GeoTransform& g = dsm.transform();
  const double offset = 0.5 * (factor - 1);
  const Eigen::Vector2d origin = g.pixel_to_world(Eigen::Vector2d(offset, offset));
  const Eigen::Vector2d step_x = g.pixel_to_world(Eigen::Vector2d(offset + factor, offset)) - origin;
  const Eigen::Vector2d step_y = g.pixel_to_world(Eigen::Vector2d(offset, offset + factor)) - origin;
  // GDAL's geotransform addresses pixel corners: the corner of new pixel (0, 0) is half a new
  // pixel before its centre.
  const Eigen::Vector2d corner = origin - 0.5 * step_x - 0.5 * step_y;
  GeoTransform out;
  out.c = {corner.x(), step_x.x(), step_y.x(), corner.y(), step_x.y(), step_y.y()};
  return Dsm(std::move(heights), out, dsm.crs());
}

/// The enlargement factor for an image whose shorter side is `side_px` pixels: 1 when `below_px`
/// is 0 or the side already reaches it, else the smallest power of two (at most `max_factor`) that
/// makes the side reach `below_px`.
inline int upsample_factor(int side_px, int below_px, int max_factor) {
  int f = 1;
  while (below_px > 0 && side_px * f < below_px && f < max_factor) f *= 2;
  return f;
}

/// `image` enlarged `factor` times by bilinear interpolation, with pixel centres mapped as
/// cv::resize maps them (new pixel i is at old (i + 0.5) / factor - 0.5, clamped at the borders),
/// so that `upsample_transform` of the old geotransform georeferences the result. factor 1 copies.
inline Raster<std::uint8_t> upsample_bilinear(const Raster<std::uint8_t>& image, int factor) {
  DIACHRON_CHECK(factor >= 1, "upsample_bilinear: factor must be >= 1, got " << factor);
  if (factor == 1 || image.empty()) return image;
  const int w = image.width(), h = image.height();
  Raster<std::uint8_t> out(w * factor, h * factor, 0);
  for (int y = 0; y < out.height(); ++y) {
    const double sy = std::clamp((y + 0.5) / factor - 0.5, 0.0, static_cast<double>(h - 1));
    const int y0 = std::min(static_cast<int>(sy), h - 1), y1 = std::min(y0 + 1, h - 1);
    const double fy = sy - y0;
    for (int x = 0; x < out.width(); ++x) {
      const double sx = std::clamp((x + 0.5) / factor - 0.5, 0.0, static_cast<double>(w - 1));
      const int x0 = std::min(static_cast<int>(sx), w - 1), x1 = std::min(x0 + 1, w - 1);
      const double fx = sx - x0;
      const double top = (1.0 - fx) * image(x0, y0) + fx * image(x1, y0);
      const double bottom = (1.0 - fx) * image(x0, y1) + fx * image(x1, y1);
      out(x, y) = static_cast<std::uint8_t>(std::lround(std::clamp((1.0 - fy) * top + fy * bottom, 0.0, 255.0)));
    }
  }
  return out;
}

/// The geotransform of an image enlarged `factor` times by upsample_bilinear(): the same corner,
/// cells `factor` times smaller (GDAL coefficients address pixel corners, so they scale exactly).
inline GeoTransform upsample_transform(const GeoTransform& g, int factor) {
  GeoTransform out = g;
  for (int i : {1, 2, 4, 5}) out.c[static_cast<std::size_t>(i)] /= factor;
  return out;
}

}  // namespace diachron
