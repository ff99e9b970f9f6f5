#pragma once
/// @file
/// MSAC scoring (Torr and Zisserman, "MLESAC", CVIU 78(1) 2000): the truncated quadratic loss
/// min(r^2, t^2), written as a gain in [0, 1] to model the Scoring concept of
/// robust/inlier_count_scoring.hpp.

#include <diachron/robust/inlier_count_scoring.hpp>

namespace diachron {

/// Truncated quadratic: an inlier adds 1 - (r / t)^2, an outlier 0. Summed over the data this is
/// N - (sum of min(r^2, t^2)) / t^2, so maximising it minimises MSAC's loss; unlike the inlier
/// count it prefers, of two models with the same inliers, the one that fits them more tightly.
struct Msac {
  /// Stop scoring a hypothesis once it cannot beat the best (exact; see the concept).
  bool early_exit = true;

  double gain(double residual, double threshold) const {
    if (!(residual <= threshold)) return 0.0;
    const double q = residual / threshold;
    return q < 1.0 ? 1.0 - q * q : 0.0;
  }

  /// The gain of an inlier from its squared residual (see the concept): 1 - r2 / t2, with the
  /// reciprocal formed once. At r2 == t2 rounding may leave a gain of order 1e-16 of either sign
  /// where gain() gives 0; Ransac's exact bounds carry a margin for such rounding.
  auto inlier_gain(double squared_threshold) const {
    const double inverse = 1.0 / squared_threshold;
    return [inverse](double r2) { return 1.0 - r2 * inverse; };
  }
};

static_assert(is_scoring_v<Msac>, "Msac must model the Scoring concept");

}  // namespace diachron
