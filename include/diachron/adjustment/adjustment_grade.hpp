#pragma once
/// @file
/// grade_adjustment(): whether a successful adjustment deserves trust, from what its report says
/// about the cameras. A self-calibrating adjustment fed wrong tie points (a model that disagrees
/// with its DSM makes every transfer wrong by tens of pixels) still converges, with a small RMS:
/// the free camera absorbs the error. What gives it away is the camera itself: a principal
/// distance or principal point that moved by a large share of the focal length and by many of
/// its own sigmas, a covariance that cannot be computed (the intrinsics are not determined), or
/// a distortion so wild that no COLMAP model can hold it. Each finding is a reason to grade the
/// result down; none refuses it (the orientation may still be the best there is).
///
/// The thresholds are set against the synthetic decades scenes, where a film camera's SfM
/// intrinsics are corrected by up to 1 % of f (f, cx, cy) and many sigmas for K1 (normal
/// self-calibration: the distortion terms are not graded per sigma), and a model 130 units off
/// its DSM moves f by 6 % with no covariance. Needs the standard library only.

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <diachron/adjustment/bundle_report.hpp>
#include <diachron/core/error.hpp>

namespace diachron {

/// Options of grade_adjustment().
struct AdjustmentGradeOptions {
  /// f, cx or cy moved by more than this share of f (before) ... > 0.
  double max_relative_change = 0.03;
  /// ... and by more than this many of its a-posteriori sigmas (when it has one). > 0.
  double max_sigmas = 5.0;
  /// A free camera without a covariance (rank-deficient normal equations: something is not
  /// determined) grades the result down.
  bool require_covariance = true;
  /// Largest conversion error of an exported camera (COLMAP's OPENCV / FULL_OPENCV) tolerated,
  /// px; NaN passed to grade_adjustment() for "not exported". > 0.
  double max_conversion_error_px = 1.0;

  void check() const {
    DIACHRON_CHECK(max_relative_change > 0.0 && max_sigmas > 0.0 && max_conversion_error_px > 0.0,
                   "AdjustmentGradeOptions: max_relative_change, max_sigmas and max_conversion_error_px must be > 0");
  }
};

/// The grade of an adjustment. Default: not graded, low.
struct AdjustmentGrade {
  bool graded = false;
  /// True when no reason was found (and the adjustment succeeded).
  bool high = false;
  /// Each reason, with its figures, e.g. "camera 1: f moved 60.2 px (5.6 % of f)".
  std::vector<std::string> reasons;
};

/// Grades `report` (see the file comment); `conversion_error_px` is the largest error of the
/// cameras' export (NaN: none). A failed adjustment is graded low with its message as the reason.
inline AdjustmentGrade grade_adjustment(const BundleReport& report, double conversion_error_px = std::nan(""),
                                        const AdjustmentGradeOptions& options = {}) {
  options.check();
  AdjustmentGrade out;
  out.graded = true;
  if (!report.success) {
    out.reasons.push_back("the adjustment failed: " + report.message);
    return out;
  }
  for (const CameraReport& c : report.cameras) {
    if (!c.free) continue;
    double f = std::nan("");
    for (const ParameterChange& p : c.values)
      if (p.name == "f") f = p.before;
    bool any_sigma = false;
    for (const ParameterChange& p : c.values) {
      any_sigma = any_sigma || std::isfinite(p.sigma);
      if (p.name != "f" && p.name != "cx" && p.name != "cy") continue;
      const double change = std::abs(p.after - p.before);
      if (!std::isfinite(change) || !(std::abs(f) > 0.0)) continue;
      const double share = change / std::abs(f);
      const bool many_sigmas = !std::isfinite(p.sigma) || change > options.max_sigmas * p.sigma;
      if (share > options.max_relative_change && many_sigmas) {
        std::ostringstream m;
        m.precision(3);
        m << "camera " << c.camera << ": " << p.name << " moved " << change << " px (" << share * 100.0 << " % of f";
        if (std::isfinite(p.sigma)) m << ", " << change / p.sigma << " sigmas";
        m << ")";
        out.reasons.push_back(m.str());
      }
    }
    if (options.require_covariance && !any_sigma && c.held.size() < c.values.size()) {
      std::ostringstream m;
      m << "camera " << c.camera << ": no covariance (" << report.covariance_message
        << "): its intrinsics are not determined by the tie points";
      out.reasons.push_back(m.str());
    }
  }
  if (std::isfinite(conversion_error_px) && conversion_error_px > options.max_conversion_error_px) {
    std::ostringstream m;
    m.precision(3);
    m << "the exported COLMAP cameras differ from the adjusted ones by up to " << conversion_error_px
      << " px (bound " << options.max_conversion_error_px << " px): a distortion that wild is suspect";
    out.reasons.push_back(m.str());
  }
  out.high = out.reasons.empty();
  return out;
}

}  // namespace diachron
