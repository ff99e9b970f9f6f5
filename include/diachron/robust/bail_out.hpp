#pragma once
/// @file
/// The bail-out test (Capel, "An effective bail-out test for RANSAC consensus scoring", BMVC 2005):
/// a hypothesis is first scored on a random sample of the data and dropped as soon as its partial
/// score is, with high confidence, below the best model's; only survivors get a full pass.
///
/// Why a separate random sample. A sequential test judges a model from the data seen so far, which
/// says something about the rest only if those data are a random draw. Real correspondence lists
/// are ordered (tile by tile, image by image, by descriptor distance), and a tile without overlap
/// at the head of the list would make any test on the input order reject the right model. So the
/// tests run on a random sample of the whole input (see "The sample"), drawn once per run.
///
/// The bound. Gains are in [0, 1] (the Scoring concept). For a hypothesis whose mean gain over all
/// data is at least the best's, mu_best = score_best / N, the sum S_n of its gains on n sampled
/// data satisfies, by Hoeffding's inequality (which holds for independent draws, identically
/// distributed or not, and for draws without replacement),
///   P(S_n < n mu_best - sqrt(n ln(K / risk) / 2)) <= risk / K.
/// The test runs at K checkpoints (n = 64, 128, 256, ... up to the sample size), so a hypothesis
/// at least as good as the best is dropped with probability at most `risk` (union bound). Models
/// clearly worse go early: at 50 % inliers, a wrong model (a few % of chance inliers) is dropped
/// after 64 data; a model with a quarter less mean gain, after about a thousand.
///
/// The sample. Up to kMaxCompleteBailOutSample data it is a random permutation of all of them:
/// scoring in that order IS the full score, so a hypothesis that survives every checkpoint needs
/// nothing more (the sample is `complete`). Above, it is N / 8 independent draws (at least
/// kMaxCompleteBailOutSample, at most kMaxBailOutSample), stratified over the input between
/// checkpoints (see make_bail_out_sample), and a survivor then gets the full pass in input order;
/// before that, it must also score strictly more on the sample than the best model did (or than 0
/// when there is no best yet). That last rule is a comparison of estimates, not a bound: a
/// hypothesis better than the best by d in mean gain per datum fails it with probability at most
/// exp(-M d^2 / 2) for a sample of M (below 1e-5 for d = 0.02 and M = 65536), while near-ties,
/// which local optimisation and the final refit make moot, go either way. It also drops a model
/// with no inlier in the sample, which happens to one with k inliers with probability about
/// exp(-k M / N): below 1e-3 from k = 56 inliers in N / 8 draws, k = 105 of 1M data (M = 65536).
/// Without the rule, every wrong hypothesis met before the first right one, and at high outlier
/// rates that is most of them, would cost a full pass.
///
/// Cost. The sample takes at most 0.5 MB of indices and is drawn once per run. Its reads are
/// scattered (a permutation) or strided (the stratified draws) and cost about three times a
/// sequential read, which the early decisions repay many times over; a wrong hypothesis met while
/// the best is still wrong costs M such reads, an eighth of the data or less. Fewer than
/// kMinBailOutData data are not screened (a pass over them is cheap).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <diachron/core/random.hpp>

namespace diachron {

/// Most data a hypothesis is screened on before its full pass.
inline constexpr std::size_t kMaxBailOutSample = std::size_t{1} << 16;
/// Up to this many data, the sample is a permutation of all of them.
inline constexpr std::size_t kMaxCompleteBailOutSample = 4096;
/// Fewest data to screen: below this a pass is cheap.
inline constexpr std::size_t kMinBailOutData = 256;
/// The first checkpoint; later ones double.
inline constexpr std::size_t kFirstBailOutCheckpoint = 64;

/// The random sample and checkpoints of one run (read-only once built; shared by all threads).
struct BailOutSample {
  /// Indices into the data: a permutation of all of them when `complete`, otherwise independent
  /// draws, one per stratum of the input between consecutive checkpoints.
  std::vector<std::size_t> indices;
  /// True when `indices` visits every datum exactly once.
  bool complete = false;
  /// Increasing prefix lengths of `indices` at which the tests run; the last is indices.size().
  std::vector<std::size_t> checkpoints;
  /// ln(K / risk) / 2 for K checkpoints: the bail-out margin at n data is sqrt(n * log_term).
  /// +inf when the bail-out test is off (the sample then serves the SPRT only).
  double log_term = std::numeric_limits<double>::infinity();

  /// True when there is no sample to screen on.
  bool empty() const { return indices.empty(); }
  /// True when the bail-out test itself is on (risk > 0).
  bool bails_out() const { return !empty() && std::isfinite(log_term); }

  /// True when a partial score `partial` on the first `n` sampled data shows, at the sample's risk,
  /// that the hypothesis's mean gain is below `mean_to_beat` (the best's score / data count).
  bool should_bail(double partial, std::size_t n, double mean_to_beat) const {
    const double count = static_cast<double>(n);
    return partial < count * mean_to_beat - std::sqrt(count * log_term);
  }
};

/// Sample size for `num_data` data: 0 below kMinBailOutData, all of them up to
/// kMaxCompleteBailOutSample, then num_data / 8 clamped to [kMaxCompleteBailOutSample,
/// kMaxBailOutSample].
inline std::size_t bail_out_sample_size(std::size_t num_data) {
  if (num_data < kMinBailOutData) return 0;
  if (num_data <= kMaxCompleteBailOutSample) return num_data;
  return std::clamp(num_data / 8, kMaxCompleteBailOutSample, kMaxBailOutSample);
}

/// Draws the sample of one run from `rng`. `risk` in [0, 1): probability, per hypothesis at least
/// as good as the best, of dropping it at a checkpoint; 0 builds the sample without the bail-out
/// test (for the SPRT alone). Empty when the data are too few (bail_out_sample_size == 0).
inline BailOutSample make_bail_out_sample(std::size_t num_data, double risk, RandomStream& rng) {
  BailOutSample sample;
  const std::size_t size = bail_out_sample_size(num_data);
  if (size == 0) return sample;
  sample.indices.resize(size);
  if (size == num_data) {
    for (std::size_t i = 0; i < size; ++i) sample.indices[i] = i;
    for (std::size_t i = 0; i + 1 < size; ++i) {
      std::swap(sample.indices[i], sample.indices[i + rng.uniform_index(size - i)]);
    }
    sample.complete = true;
  }
  for (std::size_t n = kFirstBailOutCheckpoint; n < size; n *= 2) sample.checkpoints.push_back(n);
  sample.checkpoints.push_back(size);
  if (!sample.complete) {
    // Each stretch between checkpoints is a stratified sample of the whole input: its k-th of L
    // indices is floor((k + u_k) N / L) with independent u_k uniform in [0, 1). The strata tile
    // [0, N) exactly, so every datum is drawn with total probability L / N and a stretch's sum has
    // the population mean as expectation even when L does not divide N; the draws are independent,
    // so Hoeffding's bound holds. The sample covers every part of an ordered list, and comes out
    // increasing, which turns scattered reads into strided ones.
    const double n = static_cast<double>(num_data);
    std::size_t begin = 0;
    for (const std::size_t end : sample.checkpoints) {
      const double strata = static_cast<double>(end - begin);
      for (std::size_t k = begin; k < end; ++k) {
        const double position = (static_cast<double>(k - begin) + rng.uniform01()) * n / strata;
        sample.indices[k] = std::min(static_cast<std::size_t>(position), num_data - 1);
      }
      begin = end;
    }
  }
  if (risk > 0.0) {
    sample.log_term = 0.5 * std::log(static_cast<double>(sample.checkpoints.size()) / risk);
  }
  return sample;
}

}  // namespace diachron
