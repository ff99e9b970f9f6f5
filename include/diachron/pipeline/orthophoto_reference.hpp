#pragma once
/// @file
/// An orthophoto and its DSM as the reference of the combined adjustment: each inter-epoch match
/// between a photo of epoch 1 and a tile of the orthophoto gives the ground point under the tile
/// pixel (its X, Y through the geotransform, its Z from the DSM), which becomes a control point
/// observed in that photo. The orthophoto itself is not adjusted: it is the reference, as a fixed
/// photo epoch would be. Needs Ceres (diachron::adjustment), as combined_adjustment does.

#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/ortho_frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/pipeline/combined_adjustment.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/transfer.hpp>

namespace diachron {

/// What orthophoto_control_points() made of the matches.
struct OrthophotoControlPoints {
  std::vector<CombinedControlPoint> points;  ///< one per match whose tile pixel has ground under it
  std::size_t matches = 0;                   ///< matches given
  std::size_t off_dsm = 0;                   ///< matches whose tile pixel has no DSM height (a hole, off the grid)
};

/// The matches of `pairs` (any list of pair reports with `master`, `secondary` and `matches`, e.g.
/// PreciseMatchingReport::pairs; `secondary` indexes `tiles`) as control points in the
/// orthophoto's frame, each observed in its epoch-1 image at the match's master pixel, with a prior
/// of `sigma` per axis (the reference's units, > 0: how far a matched ground point may be from the
/// truth, e.g. a few of epoch 1's GSD for matches across decades).
/// @throws diachron::Error for a pair whose secondary is not a tile, or an invalid sigma.
template <class PairReports>
OrthophotoControlPoints orthophoto_control_points(const PairReports& pairs, const std::vector<OrthoFrame>& tiles,
                                                  const Dsm& dsm, double sigma) {
  DIACHRON_CHECK(std::isfinite(sigma) && sigma > 0.0, "orthophoto_control_points: sigma must be finite and > 0, got " << sigma);
  OrthophotoControlPoints out;
  for (const auto& pair : pairs) {
    DIACHRON_CHECK(pair.secondary < tiles.size(),
                   "orthophoto_control_points: a pair names tile " << pair.secondary << " of " << tiles.size());
    const DsmLift<OrthoFrame> lift(tiles[pair.secondary], dsm);
    for (const auto& m : pair.matches) {
      ++out.matches;
      const std::optional<Eigen::Vector3d> ground = lift(m.b);
      if (!ground) {
        ++out.off_dsm;
        continue;
      }
      CombinedControlPoint c;
      c.position = *ground;
      c.sigma = sigma;
      c.epoch1.push_back({static_cast<int>(pair.master), m.a});
      out.points.push_back(std::move(c));
    }
  }
  return out;
}

}  // namespace diachron
