#pragma once
/// @file
/// Sparse DoD (difference of DSMs, paper section 4.6): 3D points (e.g. epoch-1 tie points
/// triangulated after the adjustment, moved into epoch 2's frame) against a DSM of the same frame
/// (epoch 2's), dZ = Z_point - Z_dsm(X, Y) with the DSM's bilinear height, summarised as the paper's
/// DoD table (mu, sigma, |mu| = mean |dZ|) plus median and NMAD, which real scene changes
/// (buildings, trees) do not drag as far. Needs Eigen and the standard library only.
/// docs/evaluation.md.

#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/eval/error_statistics.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// What the DSM says at a point's X, Y.
enum class DodStatus {
  used,     ///< the DSM has a height there: dZ is defined
  outside,  ///< X, Y not between four pixel centres of the DSM (off it, or within half a cell of its edge)
  hole,     ///< inside, but a DSM sample that carries weight is a hole (NaN)
};

/// The sparse DoD of a set of points. `success == false` (with `reason`) when no point has a DSM
/// height; the statistics are then NaN.
struct DodReport {
  bool success = false;
  std::string reason;
  std::size_t num_used = 0;     ///< points with a dZ
  std::size_t num_outside = 0;  ///< points off the DSM
  std::size_t num_hole = 0;     ///< points on a hole of the DSM
  std::vector<DodStatus> status;  ///< per input point
  /// dZ = Z_point - Z_dsm(X, Y) per input point, DSM height units (metres); NaN unless used.
  std::vector<double> dz;
  /// Statistics of the used dZ: mean = the paper's mu, sigma, mean_abs = its |mu|, median, nmad.
  ErrorStatistics statistics;
};

/// The sparse DoD of `points` against `dsm` (both in the DSM's frame, Z up).
/// dZ is positive where the point lies above the DSM.
/// Precondition: every point finite, else throws diachron::Error naming its index. An empty DSM
/// is allowed (every point is then outside).
inline DodReport sparse_dod(const std::vector<Eigen::Vector3d>& points, const Dsm& dsm) {
  DodReport r;
  r.status.reserve(points.size());
  r.dz.reserve(points.size());
  std::vector<double> used;
  used.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& p = points[i];
    DIACHRON_CHECK(p.allFinite(), "sparse_dod: point " << i << " is not finite");
    const double z = dsm.height_at(p.x(), p.y());
    if (std::isnan(z)) {
      // height_at() is NaN off the grid of pixel centres and next to holes; tell the two apart.
      const Eigen::Vector2d px = dsm.empty() ? Eigen::Vector2d::Constant(-1.0) : dsm.world_to_pixel(p.head<2>());
      const bool inside = !dsm.empty() && px.x() >= 0.0 && px.y() >= 0.0 && px.x() <= dsm.width() - 1 &&
                          px.y() <= dsm.height() - 1;
      r.status.push_back(inside ? DodStatus::hole : DodStatus::outside);
      ++(inside ? r.num_hole : r.num_outside);
      r.dz.push_back(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    r.status.push_back(DodStatus::used);
    r.dz.push_back(p.z() - z);
    used.push_back(p.z() - z);
  }
  r.num_used = used.size();
  r.statistics = error_statistics(used);
  if (r.num_used == 0) {
    r.reason = points.empty() ? "no points"
                              : "no point has a DSM height (" + std::to_string(r.num_outside) + " outside, " +
                                    std::to_string(r.num_hole) + " on holes)";
    return r;
  }
  r.success = true;
  return r;
}

}  // namespace diachron
