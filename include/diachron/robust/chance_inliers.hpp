#pragma once
/// @file
/// How many inliers a RANSAC winner needs before it means anything: an a-contrario bound on the
/// inlier count that random correspondences reach by chance.
///
/// With no true correspondence at all (two DSMs that do not overlap), RANSAC still returns the
/// hypothesis with the most inliers; over many hypotheses that count is not zero. Reporting it as a
/// result would give a wrong transform. The bound below says how large a count random data make.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include <diachron/core/error.hpp>

namespace diachron {

/// Log of P(X >= k) for X ~ Binomial(n, p), accurate for tiny tails (summed upwards in log space).
inline double log_binomial_tail(std::size_t n, double p, std::size_t k) {
  DIACHRON_CHECK(p >= 0.0 && p <= 1.0, "binomial probability must be in [0, 1], got " << p);
  if (k == 0) return 0.0;
  if (k > n || p == 0.0) return -std::numeric_limits<double>::infinity();
  if (p == 1.0) return 0.0;
  const double nd = static_cast<double>(n);
  const double lp = std::log(p), lq = std::log1p(-p);
  auto log_pmf = [&](double j) {
    return std::lgamma(nd + 1.0) - std::lgamma(j + 1.0) - std::lgamma(nd - j + 1.0) + j * lp + (nd - j) * lq;
  };
  // Terms fall geometrically past the mode, so the sum stops once they stop mattering.
  double first = log_pmf(static_cast<double>(k));
  double sum = 1.0;  // relative to exp(first)
  double term = 1.0;
  for (std::size_t j = k + 1; j <= n; ++j) {
    const double jd = static_cast<double>(j);
    term *= (nd - jd + 1.0) / jd * (p / (1.0 - p));
    sum += term;
    if (jd > nd * p && term < 1e-16 * sum) break;
  }
  return first + std::log(sum);
}

/// Upper Wilson score bound of a rate `share` observed on `n` > 0 trials, at `z` standard deviations
/// (3.09: one-sided 99.9 %), in [share, 1]. Stays above 0 when share is 0: a rate measured on a few
/// hundred samples is known only to about a percent.
inline double wilson_upper_bound(double share, double n, double z) {
  DIACHRON_CHECK(share >= 0.0 && share <= 1.0 && n > 0.0 && z >= 0.0,
                 "wilson_upper_bound needs share in [0, 1], n > 0 and z >= 0, got " << share << ", " << n << ", " << z);
  const double z2n = z * z / n;
  const double centre = share + 0.5 * z2n;
  const double spread = z * std::sqrt(share * (1.0 - share) / n + 0.25 * z2n / n);
  return std::min(1.0, (centre + spread) / (1.0 + z2n));
}

/// The smallest inlier count that fewer than `alpha` of all `trials` hypotheses reach by chance,
/// when each of `n_data` correspondences is an inlier of a wrong hypothesis with probability
/// `p_chance` independently, and each hypothesis counts its own `sample_size` data as inliers.
///
/// For 2D matches spread over an image of area A (px^2) and a threshold t (px), p_chance is about
/// pi t^2 / A. `trials` is the number of hypotheses scored, times the number of independent searches
/// (e.g. 4 rotation hypotheses). Returns at least sample_size + 1.
inline std::size_t min_significant_inliers(std::size_t n_data, double p_chance, double trials, double alpha,
                                           std::size_t sample_size) {
  DIACHRON_CHECK(alpha > 0.0 && alpha < 1.0, "alpha must be in (0, 1), got " << alpha);
  DIACHRON_CHECK(trials >= 1.0, "trials must be >= 1, got " << trials);
  if (n_data <= sample_size) return sample_size + 1;
  const std::size_t n = n_data - sample_size;
  const double log_budget = std::log(alpha) - std::log(trials);
  std::size_t k = 1;
  while (k <= n && log_binomial_tail(n, std::min(std::max(p_chance, 0.0), 1.0), k) > log_budget) ++k;
  return sample_size + k;
}

}  // namespace diachron
