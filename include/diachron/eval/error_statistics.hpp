#pragma once
/// @file
/// ErrorStatistics: the summary of one signed error component (a check-point axis, the heights of
/// a DoD) as the paper's accuracy tables give it, mu, sigma and |mu|, plus RMS, median and NMAD.
/// Needs the standard library only.
///
/// The paper's |mu| ("absolute average value") is the mean of the absolute errors, not the
/// absolute value of the mean: its check-point table has mu = 7.23 m and |mu| = 10.60 m for the same
/// column (Frejus, Co-Reg, x), which only the mean of |e| can give. `mean_abs` is that value;
/// `abs_mean()` is |mu| in the other sense.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include <diachron/core/error.hpp>

namespace diachron {

/// Factor that makes the median absolute deviation a consistent estimator of the standard
/// deviation of normally distributed errors (1 / Phi^-1(3/4)): NMAD = 1.4826 median |e - median|.
inline constexpr double kNmadFactor = 1.4826;

/// Statistics of signed errors e_i, all in the unit of the errors (metres, GSD, px). Every value
/// is NaN when `count == 0`.
struct ErrorStatistics {
  std::size_t count = 0;                                        ///< errors summarised
  double mean = std::numeric_limits<double>::quiet_NaN();      ///< mu = mean of e
  double sigma = std::numeric_limits<double>::quiet_NaN();     ///< population standard deviation (divides by count)
  double mean_abs = std::numeric_limits<double>::quiet_NaN();  ///< mean of |e|: the paper's |mu|
  double rms = std::numeric_limits<double>::quiet_NaN();       ///< sqrt(mean of e^2) = sqrt(mu^2 + sigma^2)
  double median = std::numeric_limits<double>::quiet_NaN();    ///< median of e (mean of the middle two for even count)
  double nmad = std::numeric_limits<double>::quiet_NaN();      ///< kNmadFactor * median |e - median|: sigma robust to outliers
  double min = std::numeric_limits<double>::quiet_NaN();       ///< smallest e
  double max = std::numeric_limits<double>::quiet_NaN();       ///< largest e

  /// |mean of e|.
  double abs_mean() const { return std::abs(mean); }

  /// The same statistics in another unit: every value multiplied by `factor` (> 0), e.g. 1 / GSD
  /// to go from metres to GSD. Precondition: finite factor > 0, else throws diachron::Error.
  ErrorStatistics scaled(double factor) const {
    DIACHRON_CHECK(std::isfinite(factor) && factor > 0.0, "ErrorStatistics::scaled: factor must be finite and > 0, got "
                                                               << factor);
    ErrorStatistics s = *this;
    for (double* v : {&s.mean, &s.sigma, &s.mean_abs, &s.rms, &s.median, &s.nmad, &s.min, &s.max}) *v *= factor;
    return s;
  }
};

namespace detail {

// Median of `values` (reordered); NaN when empty.
inline double median_of(std::vector<double>& values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = values.size();
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(n / 2);
  std::nth_element(values.begin(), middle, values.end());
  const double upper = *middle;
  if (n % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), middle);
  return 0.5 * (lower + upper);
}

}  // namespace detail

/// Statistics of `errors` (signed, any unit). An empty list gives count 0 and NaN values.
/// Precondition: every error finite, else throws diachron::Error naming its index.
inline ErrorStatistics error_statistics(const std::vector<double>& errors) {
  ErrorStatistics s;
  s.count = errors.size();
  for (std::size_t i = 0; i < errors.size(); ++i)
    DIACHRON_CHECK(std::isfinite(errors[i]), "error_statistics: error " << i << " is not finite (" << errors[i] << ")");
  if (errors.empty()) return s;
  const double n = static_cast<double>(errors.size());
  double sum = 0.0, sum_abs = 0.0, sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_abs += std::abs(e);
    sum_sq += e * e;
  }
  s.mean = sum / n;
  s.mean_abs = sum_abs / n;
  s.rms = std::sqrt(sum_sq / n);
  // Two-pass variance: the one-pass form sum_sq / n - mean^2 cancels badly for large offsets.
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.sigma = std::sqrt(var / n);
  const auto [lo, hi] = std::minmax_element(errors.begin(), errors.end());
  s.min = *lo;
  s.max = *hi;
  std::vector<double> work = errors;
  s.median = detail::median_of(work);
  for (double& v : work) v = std::abs(v - s.median);
  s.nmad = kNmadFactor * detail::median_of(work);
  return s;
}

}  // namespace diachron
