#pragma once
/// @file
/// Check-point accuracy as the paper's check-point table gives it: for points of known position
/// (measured in the reference epoch) and positions estimated from the images (triangulated with
/// the adjusted orientation), per axis mu, sigma, |mu| (mean of |e|) and RMS of e = estimated -
/// true, and the 3D RMS, in metres and in ground sampling distances. Needs Eigen and the standard
/// library only; the triangulator is any callable, so the pipeline plugs its own in.
/// docs/evaluation.md.

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/eval/error_statistics.hpp>

namespace diachron {

/// One observation of a check point: the index of the image (in whatever list of oriented images
/// the triangulator holds) and the pixel, px, diachron convention (centre of the top-left pixel at
/// (0, 0)).
struct CheckPointObservation {
  std::size_t image = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

/// A check point: its true position in the evaluation frame (the reference epoch's, metres) and
/// its observations in the images whose orientation is being evaluated.
struct ObservedCheckPoint {
  Eigen::Vector3d truth = Eigen::Vector3d::Zero();
  std::vector<CheckPointObservation> observations;
};

/// Check-point errors e = estimated - true, summarised. `success == false` (with `reason`) when no
/// check point could be estimated; the statistics are then NaN.
struct CheckPointReport {
  bool success = false;
  std::string reason;
  std::size_t num_used = 0;                ///< check points with an estimate
  std::size_t num_failed = 0;              ///< check points without one (triangulation failed)
  std::vector<std::size_t> failed;         ///< their indices in the input, increasing
  std::vector<std::size_t> used;           ///< indices of the used ones, increasing
  std::vector<Eigen::Vector3d> errors_m;   ///< e of each used check point (same order as `used`), metres

  std::array<ErrorStatistics, 3> axes_m;   ///< X, Y, Z, metres
  double rms_3d_m = std::numeric_limits<double>::quiet_NaN();  ///< sqrt(mean |e|^2), metres

  /// The GSD the values below refer to, metres per pixel; NaN when none was given.
  double gsd_m = std::numeric_limits<double>::quiet_NaN();
  std::array<ErrorStatistics, 3> axes_gsd;  ///< X, Y, Z, in GSD (metres / gsd_m); NaN without a GSD
  double rms_3d_gsd = std::numeric_limits<double>::quiet_NaN();  ///< 3D RMS in GSD
};

/// Summarises estimated against true check-point positions (pairs by index). A missing estimate
/// (nullopt) is a failed check point: counted, listed, left out of the statistics.
/// @param estimated positions from the images, evaluation frame, metres (nullopt = failed)
/// @param truth true positions, same frame and order
/// @param gsd_m ground sampling distance for the GSD columns, metres per pixel; 0 (default) or NaN
///        for none
/// Precondition: same sizes, finite truth, finite estimates where present, gsd_m finite and > 0
/// when given; else throws diachron::Error naming the index.
inline CheckPointReport evaluate_check_points(const std::vector<std::optional<Eigen::Vector3d>>& estimated,
                                              const std::vector<Eigen::Vector3d>& truth, double gsd_m = 0.0) {
  DIACHRON_CHECK(estimated.size() == truth.size(), "evaluate_check_points: " << estimated.size()
                                                                              << " estimates for " << truth.size()
                                                                              << " true positions");
  const bool with_gsd = !(std::isnan(gsd_m) || gsd_m == 0.0);
  DIACHRON_CHECK(!with_gsd || (std::isfinite(gsd_m) && gsd_m > 0.0),
                 "evaluate_check_points: gsd_m must be finite and > 0 (or 0 for none), got " << gsd_m);
  CheckPointReport report;
  std::array<std::vector<double>, 3> axis_errors;
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    DIACHRON_CHECK(truth[i].allFinite(), "evaluate_check_points: true position " << i << " is not finite");
    if (!estimated[i]) {
      report.failed.push_back(i);
      continue;
    }
    DIACHRON_CHECK(estimated[i]->allFinite(), "evaluate_check_points: estimate " << i << " is not finite");
    const Vec3 e = *estimated[i] - truth[i];
    report.used.push_back(i);
    report.errors_m.push_back(e);
    for (int a = 0; a < 3; ++a) axis_errors[static_cast<std::size_t>(a)].push_back(e[a]);
    sum_sq += e.squaredNorm();
  }
  report.num_used = report.used.size();
  report.num_failed = report.failed.size();
  for (std::size_t a = 0; a < 3; ++a) report.axes_m[a] = error_statistics(axis_errors[a]);
  if (with_gsd) report.gsd_m = gsd_m;
  if (report.num_used == 0) {
    report.reason = truth.empty() ? "no check points" : "no check point could be estimated (" +
                                                            std::to_string(report.num_failed) + " failed)";
    return report;
  }
  report.rms_3d_m = std::sqrt(sum_sq / static_cast<double>(report.num_used));
  if (with_gsd) {
    for (std::size_t a = 0; a < 3; ++a) report.axes_gsd[a] = report.axes_m[a].scaled(1.0 / gsd_m);
    report.rms_3d_gsd = report.rms_3d_m / gsd_m;
  }
  report.success = true;
  return report;
}

/// Estimates every check point with `triangulate` and summarises the errors against their truth.
/// @tparam Triangulate callable as `std::optional<Eigen::Vector3d>(const
///         std::vector<CheckPointObservation>&)`: the position in the evaluation frame, metres, or
///         nullopt when it cannot (too few rays, behind the cameras...). Called once per check point,
///         in order, from this thread.
/// Precondition: as evaluate_check_points() above; a non-finite position returned by `triangulate`
/// throws diachron::Error (return nullopt for a failure).
template <class Triangulate>
CheckPointReport evaluate_check_points(const std::vector<ObservedCheckPoint>& points, Triangulate&& triangulate,
                                       double gsd_m = 0.0) {
  static_assert(std::is_convertible_v<std::invoke_result_t<Triangulate&, const std::vector<CheckPointObservation>&>,
                                      std::optional<Eigen::Vector3d>>,
                "evaluate_check_points: `triangulate` must be callable with const "
                "std::vector<CheckPointObservation>& and return std::optional<Eigen::Vector3d>");
  std::vector<std::optional<Eigen::Vector3d>> estimated;
  std::vector<Eigen::Vector3d> truth;
  estimated.reserve(points.size());
  truth.reserve(points.size());
  for (const ObservedCheckPoint& p : points) {
    estimated.push_back(triangulate(p.observations));
    truth.push_back(p.truth);
  }
  return evaluate_check_points(estimated, truth, gsd_m);
}

}  // namespace diachron
