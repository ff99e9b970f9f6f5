#pragma once
/// @file
/// PROSAC's own stopping rule (Chum and Matas, "Matching with PROSAC - progressive sample
/// consensus", CVPR 2005, section 2.2): stop once, for some termination length n, the best model's
/// inliers among the top n quality-sorted data are both non-random and maximal. Models the
/// Termination concept of robust/fixed_iterations.hpp (its TerminationState form); meant for
/// ProsacSampler, whose early samples come from the top of the data.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/robust/adaptive_termination.hpp>
#include <diachron/robust/chance_inliers.hpp>
#include <diachron/robust/fixed_iterations.hpp>
#include <diachron/robust/ransac_options.hpp>

namespace diachron {

/// I_min(n) of PROSAC's non-randomness constraint: the fewest inliers among the top `n` data that a
/// wrong model reaches with probability below `non_randomness` (psi), when each of the n - m data
/// outside its own sample of `sample_size` (m) is an inlier by chance with probability
/// `chance_inlier_rate` (beta): the smallest I with P(Binomial(n - m, beta) >= I - m) < psi.
/// n + 1 (unreachable) when no count of n data is significant. Search starts at `hint` (a lower
/// bound, e.g. the value for a smaller n: I_min grows with n).
inline std::size_t prosac_min_non_random_inliers(std::size_t n, std::size_t sample_size,
                                                 double chance_inlier_rate, double non_randomness,
                                                 std::size_t hint = 0) {
  if (n <= sample_size) return n + 1;
  const std::size_t trials = n - sample_size;
  const double log_psi = std::log(non_randomness);
  const auto significant = [&](std::size_t k) {
    return log_binomial_tail(trials, chance_inlier_rate, k) < log_psi;
  };
  // Smallest k in [lo, trials + 1] with significant(k) (true at trials + 1: an empty tail).
  std::size_t lo = hint > sample_size ? hint - sample_size : 0;
  if (lo > trials + 1) lo = trials + 1;
  if (significant(lo)) return sample_size + lo;
  std::size_t step = 1;
  std::size_t hi = lo;
  while (hi <= trials) {  // exponential search for a significant count above lo
    lo = hi;
    hi = std::min(trials + 1, hi + step);
    step *= 2;
    if (significant(hi)) break;
  }
  while (hi - lo > 1) {  // invariant: !significant(lo), significant(hi)
    const std::size_t mid = lo + (hi - lo) / 2;
    (significant(mid) ? hi : lo) = mid;
  }
  return sample_size + hi;
}

/// PROSAC termination. For every termination length n considered (all n up to 64, then steps of
/// about 1/64 of n, and N itself), with I_n the best model's inliers among the top n data:
/// - non-randomness: I_n >= I_min(n) (prosac_min_non_random_inliers), so that a wrong model is
///   unlikely (probability < `non_randomness`) to have that much support among the top n;
/// - maximality: the iterations needed to draw an all-inlier sample from the top n with probability
///   options.confidence, k_n = adaptive_iterations(I_n, n, m, confidence) (the exact
///   without-replacement rule of Adaptive, with the inlier rate of the top n).
/// The answer is the smallest k_n over the lengths that pass non-randomness, clamped to
/// [min_iterations, max_iterations]; max_iterations while none passes, so the run never stops on
/// a model whose support could be chance. n = N is among the lengths, so on data without any
/// quality order it answers what Adaptive would (given a non-random model).
///
/// As in the paper, k_n is compared with all iterations done, including those whose pool had grown
/// past n (the sampler draws from the top n(t), which grows slowly: the first T'_n samples all come
/// from the top n). confidence = 1 runs max_iterations.
///
/// chance_inlier_rate (beta) is the probability that a datum supports a wrong model. The default
/// 0.05 is conservative for image matches (pi t^2 / image area is far smaller, e.g. 8e-5 for
/// t = 10 px on 2000 x 2000 px; see robust/chance_inliers.hpp); a larger beta asks for more inliers
/// before stopping. Requires kNeedsBestInliers: Ransac makes one more pass over the data per new
/// best. Cost per call: a binary search in the inlier indices per length (about 64 ln(N / 64)
/// lengths).
class ProsacTermination {
 public:
  static constexpr bool kNeedsBestInliers = true;

  /// beta = 0.05, psi = 0.05 (the paper's psi).
  ProsacTermination() = default;

  /// @param chance_inlier_rate beta, in (0, 1).
  /// @param non_randomness psi, in (0, 1): the most probability with which a wrong model passes.
  /// Throws diachron::Error when either is out of range.
  explicit ProsacTermination(double chance_inlier_rate, double non_randomness = 0.05)
      : chance_inlier_rate_(chance_inlier_rate), non_randomness_(non_randomness) {
    DIACHRON_CHECK(chance_inlier_rate > 0.0 && chance_inlier_rate < 1.0,
                   "ProsacTermination chance_inlier_rate must be in (0, 1), got "
                       << chance_inlier_rate);
    DIACHRON_CHECK(non_randomness > 0.0 && non_randomness < 1.0,
                   "ProsacTermination non_randomness must be in (0, 1), got " << non_randomness);
  }

  double chance_inlier_rate() const { return chance_inlier_rate_; }
  double non_randomness() const { return non_randomness_; }

  /// Chooses the termination lengths and their I_min for `num_data` data (once per run).
  void prepare(std::size_t num_data, std::size_t sample_size) {
    sample_size_ = sample_size;
    lengths_.clear();
    min_inliers_.clear();
    std::size_t hint = 0;
    for (std::size_t n = sample_size + 1; n <= num_data;) {
      hint = prosac_min_non_random_inliers(n, sample_size, chance_inlier_rate_, non_randomness_,
                                           hint);
      lengths_.push_back(n);
      min_inliers_.push_back(hint);
      if (n == num_data) break;
      n = std::min(num_data, n + std::max<std::size_t>(1, n / 64));
    }
  }

  /// The termination lengths of the last prepare(), and I_min for each (for tests and diagnostics).
  const std::vector<std::size_t>& lengths() const { return lengths_; }
  const std::vector<std::size_t>& min_inliers() const { return min_inliers_; }

  /// The length n* whose constraints give the fewest iterations, and that count; {0, +inf} while
  /// no length passes non-randomness (or without inlier indices). Requires prepare().
  std::pair<std::size_t, double> termination_length(const RansacOptions& options,
                                                     const TerminationState& state) const {
    std::pair<std::size_t, double> best{0, std::numeric_limits<double>::infinity()};
    if (state.best_inlier_indices == nullptr) return best;
    const std::vector<std::size_t>& inliers = *state.best_inlier_indices;
    for (std::size_t g = 0; g < lengths_.size(); ++g) {
      const std::size_t n = lengths_[g];
      const std::size_t in_top = static_cast<std::size_t>(
          std::lower_bound(inliers.begin(), inliers.end(), n) - inliers.begin());
      if (in_top < min_inliers_[g]) continue;
      const double k = adaptive_iterations(in_top, n, sample_size_, options.confidence);
      if (k < best.second) best = {n, k};
    }
    return best;
  }

  std::size_t required_iterations(const RansacOptions& options,
                                  const TerminationState& state) const {
    const double k = termination_length(options, state).second;
    const std::size_t needed = k >= static_cast<double>(options.max_iterations)
                                   ? options.max_iterations
                                   : static_cast<std::size_t>(k);
    return std::max(needed, options.min_iterations);
  }

 private:
  double chance_inlier_rate_ = 0.05;
  double non_randomness_ = 0.05;
  std::size_t sample_size_ = 0;
  std::vector<std::size_t> lengths_;
  std::vector<std::size_t> min_inliers_;
};

static_assert(is_termination_v<ProsacTermination>,
              "ProsacTermination must model the Termination concept");

}  // namespace diachron
