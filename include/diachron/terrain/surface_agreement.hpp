#pragma once
/// @file
/// surface_agreement(): how closely two DSM surfaces agree under a Helmert, against how closely
/// each DSM agrees with itself.
///
/// A misfit in metres says nothing alone: 40 m is a right placement on a 720 m grid with 36 m of
/// noise and a wrong one on a 2 m lidar grid. So the misfit (robust sigma of the vertical
/// residuals z2(X, Y) - Z of the moved master cells) is divided by the DSMs' own cell-scale noise
/// (dsm_cell_noise(): the robust sigma of each height against the mean of its four neighbours,
/// which holds the noise and the relief a cell does not resolve, both of which a right placement
/// keeps in its residuals). A right placement leaves about that much; a wrong one leaves the
/// relief. Measured on real DEMs moved by known similarities (docs/rough-coregistration.md,
/// "Confirmation by the surfaces"): 18 right placements 0.80 to 2.57 times the noise after a surface
/// refinement, 49 wrong ones on DSM pairs that do not overlap 3.17 times and more.
///
/// Units: heights and planimetry of each DSM in its own frame (metric); the misfit and both noises
/// in the secondary's units (the master's noise times the Helmert's scale). Deterministic (fixed
/// sampling grids, sorts).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/surface_alignment.hpp>  // detail::robust_sigma_in_place, sampling_stride

namespace diachron {

/// Options of surface_agreement() and dsm_cell_noise().
struct SurfaceAgreementOptions {
  /// Cells sampled on a regular grid of each DSM (every k-th cell in both directions, k chosen so
  /// that at most this many are taken). >= 100.
  int max_points = 20000;
  /// Fewest moved master cells on valid secondary heights (and fewest cells with four valid
  /// neighbours per DSM) for a measurement. >= 10.
  int min_points = 200;

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    DIACHRON_CHECK(max_points >= 100, "SurfaceAgreementOptions::max_points must be >= 100, got " << max_points);
    DIACHRON_CHECK(min_points >= 10, "SurfaceAgreementOptions::min_points must be >= 10, got " << min_points);
  }
};

/// What surface_agreement() measured. Defaults: nothing measured.
struct SurfaceAgreement {
  bool valid = false;      ///< enough cells on both sides for every figure below
  std::size_t points = 0;  ///< moved master cells on valid secondary heights (sampled)
  /// The ground those cover, in cells of the coarser DSM (the master's cell times the Helmert's
  /// scale, or the secondary's): how many independent heights the misfit rests on.
  double overlap_cells = 0.0;
  /// Robust sigma (1.4826 x median absolute deviation) of z2(X, Y) - Z over those cells, secondary units.
  double misfit = std::numeric_limits<double>::infinity();
  /// dsm_cell_noise() of the master times the Helmert's scale, and of the secondary: secondary units.
  double master_noise = std::numeric_limits<double>::quiet_NaN();
  double secondary_noise = std::numeric_limits<double>::quiet_NaN();
  /// misfit / sqrt(master_noise^2 + secondary_noise^2): about 1 where the surfaces agree as well
  /// as each agrees with itself; infinity when not valid or when both noises are 0.
  double noise_ratio = std::numeric_limits<double>::infinity();
};

/// Cell-scale noise of a DSM's heights, in its height units: the robust sigma of z(x, y) minus the
/// mean of its four neighbours over the cells where all five are valid, divided by sqrt(1.25) so
/// that white noise of sigma s gives s. On real terrain it also holds the relief between
/// neighbouring cells that a plane does not follow (curvature), which bilinear interpolation of
/// the DSM misses too. NaN when fewer than `options.min_points` cells have four valid neighbours.
/// @throws diachron::Error for invalid options.
inline double dsm_cell_noise(const Dsm& dsm, const SurfaceAgreementOptions& options = {}) {
  options.check();
  const int w = dsm.width(), h = dsm.height();
  if (w < 3 || h < 3) return std::numeric_limits<double>::quiet_NaN();
  const int stride = detail::sampling_stride(static_cast<double>(w - 2) * (h - 2), options.max_points);
  const auto& z = dsm.heights();
  std::vector<double> residuals;
  for (int y = 1; y + 1 < h; y += stride)
    for (int x = 1; x + 1 < w; x += stride) {
      if (!dsm.valid(x, y) || !dsm.valid(x - 1, y) || !dsm.valid(x + 1, y) || !dsm.valid(x, y - 1) ||
          !dsm.valid(x, y + 1))
        continue;
      residuals.push_back(static_cast<double>(z(x, y)) -
                          0.25 * (static_cast<double>(z(x - 1, y)) + z(x + 1, y) + z(x, y - 1) + z(x, y + 1)));
    }
  if (residuals.size() < static_cast<std::size_t>(options.min_points)) return std::numeric_limits<double>::quiet_NaN();
  return detail::robust_sigma_in_place(residuals) / std::sqrt(1.25);
}

/// How closely the master, moved by `epoch2_from_epoch1` (X2 = scale R X1 + T), lies on the
/// secondary surface, against the two DSMs' cell-scale noise (see the file comment). Never throws
/// for DSMs that do not overlap: the result is then not valid.
/// @throws diachron::Error for empty DSMs, invalid options or a non-finite Helmert.
inline SurfaceAgreement surface_agreement(const Dsm& master, const Dsm& secondary, const Helmert3& epoch2_from_epoch1,
                                          const SurfaceAgreementOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!master.empty() && !secondary.empty(), "surface_agreement needs two non-empty DSMs");
  DIACHRON_CHECK(std::isfinite(epoch2_from_epoch1.scale) && epoch2_from_epoch1.scale > 0.0 &&
                     epoch2_from_epoch1.rotation.allFinite() && epoch2_from_epoch1.translation.allFinite(),
                 "surface_agreement needs a finite Helmert with a positive scale");
  SurfaceAgreement out;
  const int stride =
      detail::sampling_stride(static_cast<double>(master.width()) * master.height(), options.max_points);
  std::vector<double> residuals;
  for (int y = stride / 2; y < master.height(); y += stride)
    for (int x = stride / 2; x < master.width(); x += stride) {
      if (!master.valid(x, y)) continue;
      const Eigen::Vector2d w = master.pixel_to_world(Eigen::Vector2d(x, y));
      const Eigen::Vector3d moved = epoch2_from_epoch1(Eigen::Vector3d(w.x(), w.y(), master.heights()(x, y)));
      const double z2 = secondary.height_at(moved.x(), moved.y());
      if (std::isfinite(z2)) residuals.push_back(z2 - moved.z());
    }
  out.points = residuals.size();
  const Eigen::Vector2d master_cell = master.cell_size() * epoch2_from_epoch1.scale;
  const double coarser_area = std::max(master_cell.prod(), secondary.cell_size().prod());
  out.overlap_cells = static_cast<double>(out.points) * stride * stride * master_cell.prod() / coarser_area;
  out.master_noise = dsm_cell_noise(master, options) * epoch2_from_epoch1.scale;
  out.secondary_noise = dsm_cell_noise(secondary, options);
  if (out.points < static_cast<std::size_t>(options.min_points) || std::isnan(out.master_noise) ||
      std::isnan(out.secondary_noise))
    return out;
  out.misfit = detail::robust_sigma_in_place(residuals);
  out.valid = true;
  const double noise = std::hypot(out.master_noise, out.secondary_noise);
  out.noise_ratio = noise > 0.0 ? out.misfit / noise : std::numeric_limits<double>::infinity();
  return out;
}

}  // namespace diachron
