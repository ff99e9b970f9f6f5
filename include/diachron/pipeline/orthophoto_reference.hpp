#pragma once
/// @file
/// An orthophoto and its DSM as the reference of the combined adjustment: each inter-epoch match
/// between a photo of epoch 1 and a tile of the orthophoto gives the ground point under the tile
/// pixel (its X, Y through the geotransform, its Z from the DSM), which becomes a control point
/// observed in that photo. The orthophoto itself is not adjusted: it is the reference, as a fixed
/// photo epoch would be. Needs Ceres (diachron::adjustment), as combined_adjustment does.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/frame.hpp>
#include <diachron/camera/ortho_frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/pipeline/combined_adjustment.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/gsd.hpp>
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

/// The control-point sigma for matches to an orthophoto reference, in the reference's units:
/// `sigma_px` of epoch 1's pixels on the ground, i.e. sigma_px times the median GSD of `frames1`
/// (epoch 1's images, Frame<D> of any distortion, moved into the reference's frame by
/// `epoch2_from_epoch1`) at their centre over `reference_height` (e.g. the DSM's mean).
/// Inter-epoch matches are weighted as 6 px observations of epoch 1 in the combined adjustment
/// (CombinedAdjustmentOptions), hence match_epochs' sigma_px: a matched ground point may be that many
/// of epoch 1's pixels off. When no centre ray meets that height, sigma_px times `fallback_gsd` (> 0,
/// e.g. the orthophoto's cell).
/// @throws diachron::Error for a non-positive or non-finite sigma_px or fallback_gsd.
template <class Distortion>
double orthophoto_control_sigma(const std::vector<Frame<Distortion>>& frames1, const Helmert3& epoch2_from_epoch1,
                                double reference_height, double fallback_gsd, double sigma_px) {
  DIACHRON_CHECK(std::isfinite(sigma_px) && sigma_px > 0.0,
                 "orthophoto_control_sigma: sigma_px must be finite and > 0, got " << sigma_px);
  DIACHRON_CHECK(std::isfinite(fallback_gsd) && fallback_gsd > 0.0,
                 "orthophoto_control_sigma: fallback_gsd must be finite and > 0, got " << fallback_gsd);
  std::vector<double> gsd;
  for (const Frame<Distortion>& f : transformed_frames(frames1, epoch2_from_epoch1)) {
    const Eigen::Vector2d centre(0.5 * (f.camera().width() - 1), 0.5 * (f.camera().height() - 1));
    if (const std::optional<double> g = gsd_at_height(f, reference_height, centre); g && *g > 0.0)
      gsd.push_back(*g);
  }
  if (gsd.empty()) return sigma_px * fallback_gsd;
  std::nth_element(gsd.begin(), gsd.begin() + static_cast<std::ptrdiff_t>(gsd.size() / 2), gsd.end());
  return sigma_px * gsd[gsd.size() / 2];
}

}  // namespace diachron
