#pragma once
/// @file
/// One-to-one transfer-guided tiling (paper 3.2.2, MicMac's GetPatchPair Guided mode + MergeTiePt +
/// CheckNbPrecise): the master image is cut into buffered tiles; for each tile the secondary image
/// is resampled onto the tile's pixel grid through a PatchWarp fitted from a Transfer, so the pair
/// a matcher sees differs by what the warp could not remove (relief the warp misses, the Transfer's
/// own error) and by the epochs' changes, not by scale, rotation or extent. Any PairMatcher then
/// matches (master tile, resampled patch); matches are mapped back to both images, kept when the
/// master point is in the tile core and the pair is displaced by at most max_displacement_px in the
/// aligned patch.
///
/// Departures from MicMac: the warp may be fitted to a grid rather than the 4 corners, or be
/// piecewise affine (PatchWarpKind); a tile whose warp cannot be fitted (the Transfer fails there)
/// is skipped with its reason instead of aborting; the resampled patch carries a validity mask.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/progress.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/tiling/grid_tiler.hpp>
#include <diachron/tiling/one_to_many.hpp>
#include <diachron/tiling/pair_matcher.hpp>
#include <diachron/tiling/patch_warp.hpp>

namespace diachron {

/// Options of match_one_to_one().
struct OneToOneOptions {
  /// Master tiles: MicMac's precise layout by default (1920 x 1440, buffer 192 x 144 px).
  GridTilerOptions tiles = GridTilerOptions::micmac_precise();
  /// How each tile's secondary patch is warped (piecewise affine on a 9 x 9 grid by default).
  PatchWarpOptions warp;
  /// Drop a match whose two points are more than this apart in the aligned patch (master tile
  /// pixels): the transfer predicts the patch point at the tile point, so a large displacement is
  /// a wrong match. MicMac's CheckNbPrecise uses 100 px. > 0; infinity disables the rule.
  double max_displacement_px = 100.0;
  /// Skip a tile when fewer than this fraction [0, 1] of its pixels resample onto the secondary
  /// image (the tile is off the secondary image's footprint). 0.05 by default.
  double min_valid_fraction = 0.05;
  /// Worker threads over tiles; 0 = all cores. The result does not depend on it. The matcher is
  /// called concurrently from these threads, and so is the Transfer.
  std::size_t threads = 0;
  /// Called as tiles finish (may be empty); see ProgressCallback for the threading rules.
  ProgressCallback progress;
  /// Stage name in the progress events.
  std::string progress_stage = "one-to-one tiles";

  void check() const {
    tiles.check();
    warp.check();
    DIACHRON_CHECK(max_displacement_px > 0.0, "OneToOneOptions::max_displacement_px must be > 0, got "
                                                  << max_displacement_px);
    DIACHRON_CHECK(min_valid_fraction >= 0.0 && min_valid_fraction <= 1.0,
                   "OneToOneOptions::min_valid_fraction must be in [0, 1], got " << min_valid_fraction);
  }
};

/// Why a tile was not matched.
enum class OneToOneSkip {
  none,              ///< it was matched
  warp_failed,       ///< fit_patch_warp failed (see OneToOneTileReport::warp_failure)
  off_secondary,     ///< too few pixels resampled onto the secondary image (min_valid_fraction)
};

/// Short text for a skip reason.
inline const char* to_string(OneToOneSkip skip) {
  switch (skip) {
    case OneToOneSkip::none: return "matched";
    case OneToOneSkip::warp_failed: return "warp could not be fitted";
    case OneToOneSkip::off_secondary: return "patch mostly off the secondary image";
  }
  return "unknown";
}

/// What happened in one master tile. Match counts partition `raw`:
/// raw = outside_core + displaced + off_patch + kept (tested in that order).
struct OneToOneTileReport {
  Tile tile;                                   ///< the master tile
  OneToOneSkip skip = OneToOneSkip::warp_failed;
  PatchWarpFailure warp_failure = PatchWarpFailure::none;
  std::string reason;                          ///< empty when matched
  std::size_t grid_points = 0;                 ///< warp nodes asked of the Transfer
  std::size_t transferred = 0;                 ///< of those, nodes that transferred
  double homography_rms_px = std::numeric_limits<double>::quiet_NaN();  ///< see PatchWarpFit
  std::size_t valid_pixels = 0;                ///< resampled patch pixels on the secondary image
  std::size_t raw = 0;           ///< matches the matcher returned
  std::size_t outside_core = 0;  ///< master point outside the tile core (or not finite)
  std::size_t displaced = 0;     ///< |b - a| > max_displacement_px in the aligned patch
  std::size_t off_patch = 0;     ///< patch point on an invalid (masked) pixel, or the warp has no image for it
  std::size_t kept = 0;

  bool matched() const { return skip == OneToOneSkip::none; }
};

/// What match_one_to_one() found.
struct OneToOneResult {
  bool success = false;  ///< at least one match was kept
  std::string message;   ///< summary, or why nothing was kept
  /// Kept matches in full-image pixels (a in the master, b in the secondary), in tile order and,
  /// within a tile, in the matcher's order.
  std::vector<PointMatch> matches;
  std::vector<std::size_t> match_tile;    ///< tile index of each entry of `matches`
  std::vector<OneToOneTileReport> tiles;  ///< one per master tile, GridTiler::tiles order
  std::size_t tiles_matched = 0, tiles_skipped = 0;
  std::size_t raw = 0, outside_core = 0, displaced = 0, off_patch = 0, kept = 0;  ///< sums over tiles
};

namespace detail {

template <class Transfer, class Matcher>
void match_one_tile(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                    const Transfer& transfer, const Matcher& matcher, const OneToOneOptions& options,
                    OneToOneTileReport& report, std::vector<PointMatch>& kept) {
  const Tile& tile = report.tile;
  const PatchWarpFit fit = fit_patch_warp(transfer, tile.buffered, options.warp);
  report.grid_points = fit.points;
  report.transferred = fit.transferred;
  report.homography_rms_px = fit.homography_rms_px;
  if (!fit.success) {
    report.skip = OneToOneSkip::warp_failed;
    report.warp_failure = fit.failure;
    report.reason = fit.message;
    return;
  }
  const ResampledPatch<std::uint8_t> patch = resample_patch(secondary, fit.warp);
  report.valid_pixels = patch.valid_pixels;
  const double valid_fraction = static_cast<double>(patch.valid_pixels) / static_cast<double>(tile.buffered.area());
  if (patch.valid_pixels == 0 || valid_fraction < options.min_valid_fraction) {
    report.skip = OneToOneSkip::off_secondary;
    std::ostringstream why;
    why << to_string(report.skip) << ": " << patch.valid_pixels << " of " << tile.buffered.area()
        << " pixels resampled";
    report.reason = why.str();
    return;
  }
  report.skip = OneToOneSkip::none;
  const Raster<std::uint8_t> crop = crop_raster(master, tile.buffered);
  std::vector<PointMatch> raw;
  if constexpr (is_masked_pair_matcher_v<Matcher>) {
    raw = matcher.match(crop, patch.pixels, Raster<std::uint8_t>(crop.width(), crop.height(), 255), patch.mask);
  } else {
    raw = matcher.match(crop, patch.pixels);
  }
  report.raw = raw.size();
  const Eigen::Vector2d origin(tile.buffered.x, tile.buffered.y);
  for (const PointMatch& m : raw) {
    const Eigen::Vector2d a = m.a + origin;
    // contains() is false for NaN, so non-finite points are dropped here.
    if (!tile.core.contains(a)) {
      ++report.outside_core;
      continue;
    }
    if (!((m.b - m.a).norm() <= options.max_displacement_px)) {
      ++report.displaced;
      continue;
    }
    const int u = static_cast<int>(std::lround(m.b.x())), v = static_cast<int>(std::lround(m.b.y()));
    const std::optional<Eigen::Vector2d> b = fit.warp(Eigen::Vector2d(m.b + origin));
    // A point on fill pixels is a feature of the patch border, not of the secondary image.
    if (!patch.mask.contains(u, v) || patch.mask(u, v) == 0 || !b) {
      ++report.off_patch;
      continue;
    }
    PointMatch out = m;
    out.a = a;
    out.b = *b;
    kept.push_back(out);
  }
  report.kept = kept.size();
}

}  // namespace detail

/// Matches `master` against `secondary` tile by tile, guided by `transfer` (master px -> secondary
/// px, e.g. a DsmTransfer): see the file comment. Tiles are cut by options.tiles over the master
/// image; each tile's secondary patch is resampled through a PatchWarp fitted over the tile's
/// buffered rectangle; `matcher` sees (master crop, resampled patch), both of the buffered size
/// (with masks when it has the masked overload: all-valid for the master, the resampling's validity
/// for the patch). Parallel over tiles; the output is in tile order whatever the thread count.
/// Throws diachron::Error for empty images or invalid options; rethrows what the matcher throws.
/// @tparam Transfer a Transfer (terrain/transfer.hpp), called concurrently
/// @tparam Matcher a PairMatcher (tiling/pair_matcher.hpp)
template <class Transfer, class Matcher>
OneToOneResult match_one_to_one(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                                const Transfer& transfer, const Matcher& matcher,
                                const OneToOneOptions& options = {}) {
  static_assert(check_transfer<Transfer>());
  static_assert(check_pair_matcher<Matcher>());
  options.check();
  DIACHRON_CHECK(!master.empty(), "master image is empty (" << master.width() << " x " << master.height() << ")");
  DIACHRON_CHECK(!secondary.empty(),
                 "secondary image is empty (" << secondary.width() << " x " << secondary.height() << ")");
  OneToOneResult result;
  const std::vector<Tile> tiles = GridTiler(options.tiles).tiles(master.width(), master.height());
  result.tiles.resize(tiles.size());
  std::vector<std::vector<PointMatch>> per_tile(tiles.size());
  ProgressReporter reporter(options.progress, options.progress_stage, tiles.size());
  parallel_for(tiles.size(), options.threads, [&](std::size_t i) {
    result.tiles[i].tile = tiles[i];
    detail::match_one_tile(master, secondary, transfer, matcher, options, result.tiles[i], per_tile[i]);
    reporter.advance();
  });
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    const OneToOneTileReport& t = result.tiles[i];
    (t.matched() ? result.tiles_matched : result.tiles_skipped) += 1;
    result.raw += t.raw;
    result.outside_core += t.outside_core;
    result.displaced += t.displaced;
    result.off_patch += t.off_patch;
    result.kept += t.kept;
    result.matches.insert(result.matches.end(), per_tile[i].begin(), per_tile[i].end());
    result.match_tile.insert(result.match_tile.end(), per_tile[i].size(), i);
  }
  std::ostringstream summary;
  summary << result.kept << " match(es) kept of " << result.raw << " (" << result.outside_core << " outside the core, "
          << result.displaced << " displaced, " << result.off_patch << " off the patch); " << result.tiles_matched
          << " of " << tiles.size() << " tile(s) matched";
  result.message = summary.str();
  result.success = result.kept > 0;
  return result;
}

}  // namespace diachron
