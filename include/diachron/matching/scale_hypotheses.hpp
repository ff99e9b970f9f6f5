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
  /// Try coarser levels at all. Off: the DSMs are matched at their own resolutions only.
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

  void check() const {
    DIACHRON_CHECK(max_level >= 0 && max_level <= 6, "ScaleHypothesesOptions::max_level must be in [0, 6], got "
                                                         << max_level);
    DIACHRON_CHECK(min_side_cells >= 8, "ScaleHypothesesOptions::min_side_cells must be >= 8, got " << min_side_cells);
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

}  // namespace diachron
