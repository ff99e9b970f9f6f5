#pragma once
/// @file
/// One-to-many tiling (paper 3.2.1, MicMac's GetPatchPair BruteForce + MergeTiePt): every master
/// tile is matched against every secondary tile with any PairMatcher, the matches are mapped back to
/// full-image pixels, and a match is kept only when its points lie in the tile cores.

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/progress.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/tiling/grid_tiler.hpp>
#include <diachron/tiling/pair_matcher.hpp>

namespace diachron {

/// A copy of the pixels of `rect` from `image`: pixel (x, y) of the result is pixel
/// (rect.x + x, rect.y + y) of `image`, so a point p of the crop is p + (rect.x, rect.y) in `image`
/// (the pixel-centre convention survives an integer shift). Throws diachron::Error when `rect` is
/// not inside the image.
template <class T>
Raster<T> crop_raster(const Raster<T>& image, const PixelRect& rect) {
  DIACHRON_CHECK(rect.width >= 0 && rect.height >= 0 && rect.x >= 0 && rect.y >= 0 &&
                     rect.right() <= image.width() && rect.bottom() <= image.height(),
                 "crop rectangle (" << rect.x << ", " << rect.y << ", " << rect.width << " x "
                                    << rect.height << ") is not inside a " << image.width() << " x "
                                    << image.height() << " raster");
  Raster<T> out(rect.width, rect.height);
  for (int y = 0; y < rect.height; ++y) {
    const T* src = image.row(rect.y + y) + rect.x;
    T* dst = out.row(y);
    for (int x = 0; x < rect.width; ++x) dst[x] = src[x];
  }
  return out;
}

/// Options of match_one_to_many.
struct OneToManyOptions {
  /// Worker threads over tile pairs; 0 = all cores. The result does not depend on it. The matcher
  /// is called concurrently from these threads.
  std::size_t threads = 0;
  /// Keep a match only when its master point lies in the master tile's core (MicMac's MergeTiePt).
  /// Off keeps matches anywhere in the buffered tile, so points near core borders can appear twice.
  bool master_core_only = true;
  /// Keep a match only when its secondary point lies in the secondary tile's core. It changes
  /// nothing without a secondary buffer; with one it removes the duplicates found again in the
  /// neighbouring secondary tile. Off keeps matches anywhere in the buffered secondary tile.
  bool secondary_core_only = true;
  /// Called as tile pairs finish (may be empty); see ProgressCallback for the threading rules.
  ProgressCallback progress;
  /// Stage name in the progress events, e.g. "tile pairs (rotation 90)".
  std::string progress_stage = "tile pairs";

  void check() const {}
};

/// What match_one_to_many found.
struct OneToManyResult {
  /// Kept matches in full-image pixels (a in the master, b in the secondary), ordered by pair index
  /// and, within a pair, in the matcher's order.
  std::vector<PointMatch> matches;
  /// Pair index of each entry of `matches`.
  std::vector<std::size_t> match_pair;
  /// Matches kept per pair, indexed by pair index.
  std::vector<std::size_t> pair_counts;
  /// Matches the matcher returned per pair, before the core filters.
  std::vector<std::size_t> pair_raw_counts;
  /// Number of tile pairs matched: master_tiles.size() * secondary_tiles.size().
  std::size_t pair_count = 0;
  std::vector<Tile> master_tiles;     ///< the master grid (GridTiler::tiles order)
  std::vector<Tile> secondary_tiles;  ///< the secondary grid

  /// Pair index of master tile `m` with secondary tile `s`: m * secondary_tiles.size() + s.
  std::size_t pair_index(std::size_t m, std::size_t s) const { return m * secondary_tiles.size() + s; }
  std::size_t pair_master(std::size_t pair) const { return pair / secondary_tiles.size(); }
  std::size_t pair_secondary(std::size_t pair) const { return pair % secondary_tiles.size(); }
};

namespace detail {

// Both public overloads; a null mask means "no mask" for that image.
template <class Matcher>
OneToManyResult match_one_to_many_impl(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>* master_mask,
                                       const Raster<std::uint8_t>& secondary,
                                       const Raster<std::uint8_t>* secondary_mask, const GridTiler& master_tiler,
                                       const GridTiler& secondary_tiler, const Matcher& matcher,
                                       const OneToManyOptions& options) {
  static_assert(check_pair_matcher<Matcher>());
  options.check();
  DIACHRON_CHECK(!master.empty(), "master image is empty (" << master.width() << " x " << master.height() << ")");
  DIACHRON_CHECK(!secondary.empty(),
                 "secondary image is empty (" << secondary.width() << " x " << secondary.height() << ")");
  auto check_mask = [](const Raster<std::uint8_t>* mask, const Raster<std::uint8_t>& image, const char* which) {
    DIACHRON_CHECK(!mask || mask->empty() || (mask->width() == image.width() && mask->height() == image.height()),
                   which << " mask is " << mask->width() << " x " << mask->height() << ", its image "
                         << image.width() << " x " << image.height());
  };
  check_mask(master_mask, master, "master");
  check_mask(secondary_mask, secondary, "secondary");
  if (master_mask && master_mask->empty()) master_mask = nullptr;
  if (secondary_mask && secondary_mask->empty()) secondary_mask = nullptr;
  // A matcher without the masked overload never sees the masks; one with it gets an all-valid mask
  // for the image that has none.
  constexpr bool masked_matcher = is_masked_pair_matcher_v<Matcher>;
  const bool use_masks = masked_matcher && (master_mask || secondary_mask);

  OneToManyResult result;
  result.master_tiles = master_tiler.tiles(master.width(), master.height());
  result.secondary_tiles = secondary_tiler.tiles(secondary.width(), secondary.height());
  const std::size_t nm = result.master_tiles.size(), ns = result.secondary_tiles.size();
  result.pair_count = nm * ns;
  result.pair_counts.assign(result.pair_count, 0);
  result.pair_raw_counts.assign(result.pair_count, 0);

  std::vector<Raster<std::uint8_t>> master_crops(nm), secondary_crops(ns);
  std::vector<Raster<std::uint8_t>> master_mask_crops(use_masks ? nm : 0), secondary_mask_crops(use_masks ? ns : 0);
  auto crop_mask = [](const Raster<std::uint8_t>* mask, const PixelRect& rect) {
    return mask ? crop_raster(*mask, rect) : Raster<std::uint8_t>(rect.width, rect.height, 255);
  };
  parallel_for(nm + ns, options.threads, [&](std::size_t i) {
    if (i < nm) {
      master_crops[i] = crop_raster(master, result.master_tiles[i].buffered);
      if (use_masks) master_mask_crops[i] = crop_mask(master_mask, result.master_tiles[i].buffered);
    } else {
      secondary_crops[i - nm] = crop_raster(secondary, result.secondary_tiles[i - nm].buffered);
      if (use_masks) secondary_mask_crops[i - nm] = crop_mask(secondary_mask, result.secondary_tiles[i - nm].buffered);
    }
  });

  // One slot per pair, concatenated in pair order afterwards: the output cannot depend on which
  // thread finished first.
  std::vector<std::vector<PointMatch>> per_pair(result.pair_count);
  ProgressReporter reporter(options.progress, options.progress_stage, result.pair_count);
  parallel_for(result.pair_count, options.threads, [&](std::size_t pair) {
    const Tile& tm = result.master_tiles[pair / ns];
    const Tile& ts = result.secondary_tiles[pair % ns];
    std::vector<PointMatch> raw;
    if constexpr (masked_matcher) {
      if (use_masks)
        raw = matcher.match(master_crops[pair / ns], secondary_crops[pair % ns], master_mask_crops[pair / ns],
                            secondary_mask_crops[pair % ns]);
      else
        raw = matcher.match(master_crops[pair / ns], secondary_crops[pair % ns]);
    } else {
      raw = matcher.match(master_crops[pair / ns], secondary_crops[pair % ns]);
    }
    result.pair_raw_counts[pair] = raw.size();
    const Eigen::Vector2d shift_m(tm.buffered.x, tm.buffered.y);
    const Eigen::Vector2d shift_s(ts.buffered.x, ts.buffered.y);
    std::vector<PointMatch>& kept = per_pair[pair];
    for (PointMatch m : raw) {
      m.a += shift_m;
      m.b += shift_s;
      // contains() is false for NaN, so non-finite points from a matcher are dropped here too.
      if (options.master_core_only ? !tm.core.contains(m.a) : !tm.buffered.contains(m.a)) continue;
      if (options.secondary_core_only ? !ts.core.contains(m.b) : !ts.buffered.contains(m.b)) continue;
      kept.push_back(m);
    }
    result.pair_counts[pair] = kept.size();
    reporter.advance();
  });

  std::size_t total = 0;
  for (const auto& v : per_pair) total += v.size();
  result.matches.reserve(total);
  result.match_pair.reserve(total);
  for (std::size_t pair = 0; pair < per_pair.size(); ++pair) {
    result.matches.insert(result.matches.end(), per_pair[pair].begin(), per_pair[pair].end());
    result.match_pair.insert(result.match_pair.end(), per_pair[pair].size(), pair);
  }
  return result;
}

}  // namespace detail

/// Matches every tile of `master` (cut by `master_tiler`) against every tile of `secondary` (cut by
/// `secondary_tiler`) with `matcher`, which sees the buffered rectangles as separate images.
/// Matches are shifted back to full-image pixels and filtered by the tile cores (see
/// OneToManyOptions). The work is M x N matcher calls; the tile crops are made once.
/// Throws diachron::Error for an empty image; rethrows what the matcher throws.
/// @tparam Matcher a PairMatcher (tiling/pair_matcher.hpp)
template <class Matcher>
OneToManyResult match_one_to_many(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                                  const GridTiler& master_tiler, const GridTiler& secondary_tiler,
                                  const Matcher& matcher, const OneToManyOptions& options = {}) {
  return detail::match_one_to_many_impl(master, nullptr, secondary, nullptr, master_tiler, secondary_tiler, matcher,
                                        options);
}

/// The same with validity masks (the size of their images; nonzero = valid, an empty mask = all
/// valid). A masked PairMatcher receives the masks' crops with the tiles; another matcher is called
/// unmasked, as by the overload above.
template <class Matcher>
OneToManyResult match_one_to_many(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& master_mask,
                                  const Raster<std::uint8_t>& secondary, const Raster<std::uint8_t>& secondary_mask,
                                  const GridTiler& master_tiler, const GridTiler& secondary_tiler,
                                  const Matcher& matcher, const OneToManyOptions& options = {}) {
  return detail::match_one_to_many_impl(master, &master_mask, secondary, &secondary_mask, master_tiler,
                                        secondary_tiler, matcher, options);
}

}  // namespace diachron
