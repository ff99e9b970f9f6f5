#pragma once
/// @file
/// tile_agreement(): does a placement of one raster on another hold piece by piece? The overlap of
/// a moving raster placed on a fixed one at an integer shift is cut into tiles, each tile is
/// correlated on its own (masked ZNCC, terrain/masked_ncc.hpp) over every shift within a radius of
/// the placement, and a tile agrees when its own peak lies within one pixel of the placement.
///
/// Why: a placement that is right is right everywhere, so independent pieces of it find their peaks
/// at the same shift. A wrong placement that won a global correlation by a small margin (a broad
/// slope that fits several places, the best of hundreds of hypotheses) is held by a few pieces at
/// most: the others peak anywhere in their window. The number of agreeing tiles is then compared with
/// what chance gives (binomial_tail()).
///
/// Conventions: moving(x, y) lies on fixed(x + dx, y + dy), as masked_ncc_at(); holes are NaN; the
/// signal may have several channels of the same size and holes (e.g. a gradient's two components).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/terrain/masked_ncc.hpp>

namespace diachron {

/// Options of tile_agreement(). Sizes in raster pixels.
struct TileAgreementOptions {
  /// Tiles per side of the overlap's bounding box (4: 16 tiles).
  int tiles_per_side = 4;
  /// Each tile searches shifts within this many pixels of the placement along each axis. The chance
  /// that a tile of a wrong placement peaks within one pixel falls with it, as 9 / (2 r + 1)^2 for a
  /// peak anywhere in the window; a right placement that is off by a pixel or two still agrees.
  int radius_px = 6;
  /// A tile counts when the overlap holds at least this share of its pixels, and at least
  /// `min_tile_px` of them: a tile cut by a hole or the overlap's edge correlates too few samples.
  double min_valid_share = 0.5;
  int min_tile_px = 16;

  void check() const {
    DIACHRON_CHECK(tiles_per_side >= 1 && tiles_per_side <= 64, "tiles_per_side must be in [1, 64]");
    DIACHRON_CHECK(radius_px >= 2 && radius_px <= 64, "radius_px must be in [2, 64]");
    DIACHRON_CHECK(min_valid_share > 0.0 && min_valid_share <= 1.0, "min_valid_share must be in (0, 1]");
    DIACHRON_CHECK(min_tile_px >= 4, "min_tile_px must be >= 4");
  }
};

/// What tile_agreement() found. Default: no tile, nothing agrees.
struct TileAgreement {
  int tiles = 0;   ///< tiles with enough overlap to correlate
  int agree = 0;   ///< of which peak within one pixel of the placement
  /// agree / tiles; NaN without tiles.
  double share() const {
    return tiles > 0 ? static_cast<double>(agree) / tiles : std::numeric_limits<double>::quiet_NaN();
  }
};

/// P(X >= k) for X binomial with n trials of probability p: how often chance alone makes k of n
/// tiles agree. 1 for k <= 0; 0 for k > n.
inline double binomial_tail(int k, int n, double p) {
  DIACHRON_CHECK(n >= 0 && p >= 0.0 && p <= 1.0, "binomial_tail needs n >= 0 and p in [0, 1]");
  if (k <= 0) return 1.0;
  if (k > n) return 0.0;
  // Terms from i = k up, each from the last by the ratio of binomial coefficients, in logs for the
  // first so that large n and tiny p do not underflow before the sum.
  if (p <= 0.0) return 0.0;
  if (p >= 1.0) return 1.0;
  const double log_first = std::lgamma(n + 1.0) - std::lgamma(k + 1.0) - std::lgamma(n - k + 1.0) +
                           k * std::log(p) + (n - k) * std::log1p(-p);
  double term = std::exp(log_first), sum = 0.0;
  for (int i = k; i <= n; ++i) {
    sum += term;
    term *= static_cast<double>(n - i) / (i + 1) * p / (1.0 - p);
  }
  return std::min(1.0, sum);
}

/// Cuts the overlap of `moving` placed on `fixed` at (dx, dy) into tiles and counts those whose own
/// ZNCC peak, over the shifts within options.radius_px, lies within one pixel of (dx, dy) along each
/// axis (see the file doc). Throws diachron::Error when the signals differ in channels or sizes.
inline TileAgreement tile_agreement(const std::vector<Raster<float>>& fixed, const std::vector<Raster<float>>& moving,
                                    int dx, int dy, const TileAgreementOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!fixed.empty() && fixed.size() == moving.size(), "tile_agreement: the signals differ in channels");
  for (std::size_t c = 1; c < fixed.size(); ++c)
    DIACHRON_CHECK(fixed[c].width() == fixed[0].width() && fixed[c].height() == fixed[0].height() &&
                       moving[c].width() == moving[0].width() && moving[c].height() == moving[0].height(),
                   "tile_agreement: channels of one signal differ in size");
  TileAgreement out;
  const Raster<float>& m0 = moving[0];
  const Raster<float>& f0 = fixed[0];
  // The bounding box of the overlap's valid pixels, in moving's coordinates.
  int x0 = m0.width(), y0 = m0.height(), x1 = -1, y1 = -1;
  for (int y = 0; y < m0.height(); ++y)
    for (int x = 0; x < m0.width(); ++x) {
      if (std::isnan(m0(x, y)) || !f0.contains(x + dx, y + dy) || std::isnan(f0(x + dx, y + dy))) continue;
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  if (x1 < x0) return out;
  const int n = options.tiles_per_side, r = options.radius_px;
  const int bw = x1 - x0 + 1, bh = y1 - y0 + 1;
  std::vector<Raster<float>> tile(moving.size());
  for (int ty = 0; ty < n; ++ty)
    for (int tx = 0; tx < n; ++tx) {
      const int ax = x0 + tx * bw / n, bx = x0 + (tx + 1) * bw / n;
      const int ay = y0 + ty * bh / n, by = y0 + (ty + 1) * bh / n;
      const int area = (bx - ax) * (by - ay);
      if (area < options.min_tile_px) continue;
      for (std::size_t c = 0; c < moving.size(); ++c) {
        tile[c] = Raster<float>(bx - ax, by - ay);
        for (int y = ay; y < by; ++y)
          for (int x = ax; x < bx; ++x) tile[c](x - ax, y - ay) = moving[c](x, y);
      }
      // The tile at (ax, ay) of moving is the raster `tile` shifted by (dx + ax, dy + ay).
      int valid = 0;
      masked_ncc_at(fixed, tile, dx + ax, dy + ay, 1, 0.0, &valid);
      if (valid < options.min_tile_px || valid < options.min_valid_share * area) continue;
      // Shifts that leave less than half of the tile's samples in the overlap do not compete: at the
      // window's rim a sliver of the tile would otherwise win by chance.
      const int min_overlap = std::max(options.min_tile_px, valid / 2);
      double best = -std::numeric_limits<double>::infinity();
      int best_x = 0, best_y = 0;
      for (int sy = -r; sy <= r; ++sy)
        for (int sx = -r; sx <= r; ++sx) {
          const double z = masked_ncc_at(fixed, tile, dx + ax + sx, dy + ay + sy, min_overlap, 1e-12);
          if (z > best) {  // NaN never is: flat or too small overlaps do not compete
            best = z;
            best_x = sx;
            best_y = sy;
          }
        }
      ++out.tiles;
      if (std::isfinite(best) && std::abs(best_x) <= 1 && std::abs(best_y) <= 1) ++out.agree;
    }
  return out;
}

}  // namespace diachron
