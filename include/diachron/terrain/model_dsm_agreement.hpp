#pragma once
/// @file
/// model_dsm_agreement(): whether an epoch's SfM model and its DSM are in one frame, checked before
/// anything trusts them. Both come from the same images, so the model's 3D points lie on the DSM's
/// surface to within its noise; a model brought into the DSM's frame by a poor alignment (a
/// `model_aligner` on a few GNSS centres, a DSM from another run) sits metres away, and every
/// transfer through the DSM is then wrong by as much, while the pipeline downstream cannot see it.
/// The check compares every point's height with the DSM's below it, searches the horizontal offset
/// that makes them agree best (the remedy's figures), and grades the agreement: `gross` (refuse)
/// when most points miss the DSM's surface by more than the tolerance, the median is beyond 3
/// tolerances, or a horizontal shift of more than 3 tolerances (or at the search's edge) explains
/// the heights clearly better than none (options.shifted_nmad_ratio); `mild` (warn) for less, e.g. the whole model offset
/// by one to three tolerances. Needs Eigen only.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/surface_alignment.hpp>  // detail::median_in_place, robust_sigma_in_place

namespace diachron {

/// Options of model_dsm_agreement. Tolerances scale with the data: a point agrees with the DSM when
/// |dZ| <= max(tolerance_cells x the DSM's cell, tolerance_gsd x the images' GSD).
struct ModelDsmAgreementOptions {
  double tolerance_cells = 3.0;  ///< >= 0
  double tolerance_gsd = 3.0;    ///< >= 0 (with tolerance_cells, not both 0)
  /// Agreement: at least this share of the points on the DSM agree, and the median dZ within the
  /// tolerance. In (0, 1].
  double agree_share = 0.7;
  /// Gross disagreement (refuse): fewer than this share lie within the tolerance of the median dZ,
  /// or that median is beyond 3 tolerances, or fewer than half the points fall on the DSM at all.
  /// In (0, agree_share].
  double gross_share = 0.4;
  /// The horizontal offset searched, +- this many DSM cells in steps of one cell. >= 0.
  int search_cells = 25;
  /// Fewest points on the DSM for a verdict. >= 1.
  std::size_t min_points = 20;
  /// A horizontal shift counts only when the heights' NMAD there is below this share of the NMAD
  /// unshifted (on flat ground every shift fits alike, and the best one is noise). In (0, 1).
  /// 0.8: the 60 synthetic epochs at hand in one frame with their DSM (decades, three-epoch and
  /// plain scenes) gave 0.89 to 1.00, and their best shifts were within a third of a tolerance; e1
  /// of decades seeds 0-2 moved (25, -15) sideways (3.1 to 5.1 tolerances) gave 0.34 to 0.54 (0.5
  /// missed seed 2's 0.54).
  double shifted_nmad_ratio = 0.8;

  void check() const {
    DIACHRON_CHECK(tolerance_cells >= 0.0 && tolerance_gsd >= 0.0 && tolerance_cells + tolerance_gsd > 0.0 &&
                       std::isfinite(tolerance_cells + tolerance_gsd),
                   "ModelDsmAgreementOptions: tolerances must be finite, >= 0 and not both 0");
    DIACHRON_CHECK(agree_share > 0.0 && agree_share <= 1.0, "ModelDsmAgreementOptions::agree_share must be in (0, 1]");
    DIACHRON_CHECK(gross_share > 0.0 && gross_share <= agree_share,
                   "ModelDsmAgreementOptions::gross_share must be in (0, agree_share]");
    DIACHRON_CHECK(search_cells >= 0 && search_cells <= 1000, "ModelDsmAgreementOptions::search_cells must be in [0, 1000]");
    DIACHRON_CHECK(min_points >= 1, "ModelDsmAgreementOptions::min_points must be >= 1");
    DIACHRON_CHECK(shifted_nmad_ratio > 0.0 && shifted_nmad_ratio < 1.0,
                   "ModelDsmAgreementOptions::shifted_nmad_ratio must be in (0, 1)");
  }
};

/// The verdict of model_dsm_agreement.
enum class ModelDsmVerdict {
  unknown,  ///< too few points to tell (default)
  agree,    ///< in one frame, to the DSM's precision
  mild,     ///< a disagreement to warn about: results hold, with less margin
  gross,    ///< not in one frame: refuse, the results would be wrong
};

inline const char* to_string(ModelDsmVerdict v) {
  switch (v) {
    case ModelDsmVerdict::agree: return "agree";
    case ModelDsmVerdict::mild: return "mild disagreement";
    case ModelDsmVerdict::gross: return "gross disagreement";
    default: return "unknown";
  }
}

/// What model_dsm_agreement found. Default: unknown.
struct ModelDsmAgreement {
  ModelDsmVerdict verdict = ModelDsmVerdict::unknown;
  std::string message;            ///< the figures, in words
  std::size_t points = 0;         ///< points given
  std::size_t on_dsm = 0;         ///< of those, with a DSM height below them
  double tolerance = std::numeric_limits<double>::quiet_NaN();  ///< DSM units
  /// dZ = Z_point - Z_dsm(X, Y) over the points on the DSM: median and NMAD, DSM units.
  double median_dz = std::numeric_limits<double>::quiet_NaN();
  double nmad_dz = std::numeric_limits<double>::quiet_NaN();
  double share_within = 0.0;      ///< of the points on the DSM, the share with |dZ| <= tolerance
  /// The horizontal shift of the points (DSM units) that makes the most of them agree, with the
  /// median dZ there, and that share: the offset to correct when the verdict is not `agree`.
  Eigen::Vector3d best_offset = Eigen::Vector3d::Zero();
  double best_share = 0.0;
  double best_nmad_dz = std::numeric_limits<double>::quiet_NaN();  ///< the NMAD of dZ there
  /// The best shift lies on the edge of the search: the true offset may be larger.
  bool best_on_edge = false;
};

/// Compares the model points `points` (the DSM's frame) with `dsm`; `gsd` is the images' ground
/// sampling distance in DSM units (0 when unknown: the DSM's cell alone sets the tolerance).
/// Throws diachron::Error on an empty DSM, non-finite points or GSD, or bad options.
inline ModelDsmAgreement model_dsm_agreement(const std::vector<Eigen::Vector3d>& points, const Dsm& dsm, double gsd,
                                             const ModelDsmAgreementOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!dsm.empty(), "model_dsm_agreement: the DSM is empty");
  DIACHRON_CHECK(std::isfinite(gsd) && gsd >= 0.0, "model_dsm_agreement: the GSD must be finite and >= 0, got " << gsd);
  ModelDsmAgreement out;
  out.points = points.size();
  const double cell = dsm.min_cell_size();
  out.tolerance = std::max(options.tolerance_cells * cell, options.tolerance_gsd * gsd);
  // dZ of every point shifted by (dx, dy); the share within the tolerance.
  std::vector<double> dz;
  const auto heights = [&](double dx, double dy) {
    dz.clear();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d& p = points[i];
      DIACHRON_CHECK(p.allFinite(), "model_dsm_agreement: point " << i << " is not finite");
      const double z = dsm.height_at(p.x() + dx, p.y() + dy);
      if (!std::isnan(z)) dz.push_back(p.z() - z);
    }
    std::size_t within = 0;
    for (double d : dz) within += std::abs(d) <= out.tolerance ? 1 : 0;
    return dz.empty() ? 0.0 : static_cast<double>(within) / static_cast<double>(dz.size());
  };
  out.share_within = heights(0.0, 0.0);
  out.on_dsm = dz.size();
  if (out.on_dsm < options.min_points) {
    std::ostringstream m;
    m << out.on_dsm << " of " << out.points << " model points lie over the DSM (" << options.min_points
      << " needed to judge)";
    out.message = m.str();
    if (out.points >= options.min_points) out.verdict = ModelDsmVerdict::gross;  // the points miss the DSM
    return out;
  }
  std::vector<double> work = dz;
  out.median_dz = detail::median_in_place(work);
  work = dz;
  out.nmad_dz = detail::robust_sigma_in_place(work);  // leaves |dZ - median| in `work`
  // The share within the tolerance of the median: a model offset as a whole, but otherwise on the
  // surface, is a milder fault than one that misses it point by point.
  double centred_share = 0.0;
  for (double d : work) centred_share += d <= out.tolerance ? 1.0 : 0.0;
  centred_share /= static_cast<double>(work.size());
  // The best horizontal shift, cell by cell: the one whose heights spread least about their median
  // (the NMAD of dZ), its vertical offset that median. The share within the tolerance would not
  // do: on gentle ground every small shift keeps all points within it.
  out.best_share = 0.0;
  out.best_nmad_dz = std::numeric_limits<double>::infinity();
  for (int j = -options.search_cells; j <= options.search_cells; ++j)
    for (int i = -options.search_cells; i <= options.search_cells; ++i) {
      heights(i * cell, j * cell);
      if (dz.size() < options.min_points) continue;
      work = dz;
      const double median = detail::median_in_place(work);
      work = dz;
      const double nmad = detail::robust_sigma_in_place(work);
      // Ties (flat ground) go to the smaller shift.
      const bool better = nmad < out.best_nmad_dz - 1e-12 ||
                          (nmad <= out.best_nmad_dz + 1e-12 && std::hypot(i, j) * cell < out.best_offset.head<2>().norm());
      if (!better) continue;
      std::size_t within = 0;
      for (double d : dz) within += std::abs(d - median) <= out.tolerance ? 1 : 0;
      out.best_share = static_cast<double>(within) / static_cast<double>(dz.size());
      out.best_nmad_dz = nmad;
      out.best_offset = Eigen::Vector3d(i * cell, j * cell, -median);
      out.best_on_edge = std::max(std::abs(i), std::abs(j)) == options.search_cells && options.search_cells > 0;
    }
  // A horizontal offset counts only when it explains the heights far better than none does (on
  // flat ground every shift fits alike, and the best one is noise).
  const double horizontal = out.best_offset.head<2>().norm();
  const bool shifted = horizontal > 0.0 && out.best_nmad_dz < options.shifted_nmad_ratio * out.nmad_dz;
  const bool enough_on = 2 * out.on_dsm >= out.points;
  const bool off_a_bit = shifted && horizontal > out.tolerance;
  const bool off_far = shifted && (horizontal > 3.0 * out.tolerance || out.best_on_edge);
  if (enough_on && out.share_within >= options.agree_share && std::abs(out.median_dz) <= out.tolerance && !off_a_bit)
    out.verdict = ModelDsmVerdict::agree;
  else if (enough_on && centred_share >= options.gross_share && std::abs(out.median_dz) <= 3.0 * out.tolerance &&
           !off_far)
    out.verdict = ModelDsmVerdict::mild;
  else
    out.verdict = ModelDsmVerdict::gross;
  std::ostringstream m;
  m.precision(3);
  m << out.on_dsm << " of " << out.points << " model points over the DSM, Z_point - Z_dsm median " << out.median_dz
    << ", NMAD " << out.nmad_dz << "; " << 100.0 * out.share_within << " % within " << out.tolerance
    << " (DSM units)";
  if (out.verdict != ModelDsmVerdict::agree)
    m << "; the best shift of the points found is (" << out.best_offset.x() << ", " << out.best_offset.y() << ", "
      << out.best_offset.z() << ")" << (out.best_on_edge ? " or more (the search's edge)" : "") << ", "
      << 100.0 * out.best_share << " % within and NMAD " << out.best_nmad_dz << " then";
  out.message = m.str();
  return out;
}

}  // namespace diachron
