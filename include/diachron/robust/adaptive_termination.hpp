#pragma once
/// @file
/// Adaptive termination: stop once an all-inlier sample has been drawn with a given confidence,
/// using the exact without-replacement probability (Schoenberger, Larsson and Pollefeys, "Fixing
/// the RANSAC stopping criterion", 2025). Models the Termination concept of
/// robust/fixed_iterations.hpp.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include <diachron/core/error.hpp>
#include <diachron/robust/fixed_iterations.hpp>
#include <diachron/robust/ransac_options.hpp>

namespace diachron {

/// Probability that a minimal sample of `sample_size` distinct data, drawn uniformly from
/// `num_data` of which `num_inliers` are inliers, holds inliers only:
/// prod_{i < m} (I - i) / (N - i). Not the classic (I / N)^m, which overestimates it and so
/// stops too early, worst for few inliers and larger samples. 0 when I < m.
inline double all_inlier_sample_probability(std::size_t num_inliers, std::size_t num_data,
                                            std::size_t sample_size) {
  if (num_inliers < sample_size || num_data < sample_size) return 0.0;
  double p = 1.0;
  for (std::size_t i = 0; i < sample_size; ++i) {
    p *= static_cast<double>(num_inliers - i) / static_cast<double>(num_data - i);
  }
  return p;
}

/// Iterations needed to draw at least one all-inlier sample with probability `confidence`:
/// ceil(log(1 - confidence) / log(1 - p)) with p = all_inlier_sample_probability(...).
/// +inf when p == 0 or confidence == 1 (never certain); 1 when p == 1 and confidence < 1.
inline double adaptive_iterations(std::size_t num_inliers, std::size_t num_data,
                                  std::size_t sample_size, double confidence) {
  const double p = all_inlier_sample_probability(num_inliers, num_data, sample_size);
  if (p <= 0.0 || confidence >= 1.0) return std::numeric_limits<double>::infinity();
  if (p >= 1.0) return 1.0;
  // log1p keeps the small p of heavily contaminated data exact.
  return std::max(1.0, std::ceil(std::log1p(-confidence) / std::log1p(-p)));
}

/// Stops after multiplier x adaptive_iterations(best inliers, N, m, options.confidence), clamped to
/// [options.min_iterations, options.max_iterations]. confidence = 1 runs max_iterations always.
class Adaptive {
 public:
  /// Multiplier 1.
  Adaptive() = default;

  /// @param multiplier factor on the iteration count of the stopping rule, finite and >= 1
  ///        (COLMAP and PoseLib use 3). Throws diachron::Error otherwise, here rather than from
  ///        Ransac::run, so that a bad value is caught where it is written.
  explicit Adaptive(double multiplier) : multiplier_(multiplier) {
    DIACHRON_CHECK(std::isfinite(multiplier) && multiplier >= 1.0,
                   "Adaptive multiplier must be finite and >= 1, got " << multiplier);
  }

  /// The rule assumes that any all-inlier sample yields the best model; noise makes that
  /// optimistic, and the multiplier buys margin. Default 1: local optimisation already recovers the
  /// consensus from a near-all-inlier sample.
  double multiplier() const { return multiplier_; }

  std::size_t required_iterations(const RansacOptions& options, std::size_t best_inliers,
                                  std::size_t num_data, std::size_t sample_size) const {
    const double k = std::ceil(
        multiplier_ * adaptive_iterations(best_inliers, num_data, sample_size, options.confidence));
    const double cap = static_cast<double>(options.max_iterations);
    const std::size_t needed = k >= cap ? options.max_iterations : static_cast<std::size_t>(k);
    return needed < options.min_iterations ? options.min_iterations : needed;
  }

 private:
  double multiplier_ = 1.0;
};

static_assert(is_termination_v<Adaptive>, "Adaptive must model the Termination concept");

}  // namespace diachron
