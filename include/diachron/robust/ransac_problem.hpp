#pragma once
/// @file
/// The view of one Ransac run that local-optimisation policies work on: estimator, data, threshold
/// and scoring, with the one scoring loop (early exit and the optional SPRT included) that every
/// part of Ransac uses.
///
/// Fast path. When the estimator's residual function (see make_residual_function) also has
/// `double squared(const Datum&) const` returning the SQUARED residual, with operator() equal to
/// std::sqrt(squared(datum)), and the Scoring policy has `inlier_gain(double squared_threshold)`
/// (see inlier_count_scoring.hpp), data are evaluated in blocks of kScoreBlock: first the squared
/// residuals of the block, then per datum a 0/1 inlier flag `r2 <= t2` (t2 chosen so that this holds
/// exactly when `std::sqrt(r2) <= threshold`) and the gain `flag * inlier_gain(r2)`. No sqrt, no
/// division and no data-dependent branch per datum: at 50 % outliers a branch on the inlier test
/// is mispredicted half of the time, which made a pass 2.6 times slower. A block whose sums come out
/// NaN (a non-finite residual times a 0 flag) is redone datum by datum with a test, so non-finite
/// residuals still count as outliers with gain 0. The inlier set is the same as with the distance;
/// MSAC gains may differ from Msac::gain in the last bits.
/// The early-exit bound is checked between blocks, never per datum.
///
/// Screening. Given a BailOutSample (robust/bail_out.hpp), score() first evaluates a hypothesis
/// on that random sample, applying the bail-out test and the SPRT at its checkpoints, and makes the
/// full pass in input order only for a hypothesis that survives; when the sample is a permutation
/// of all data, scoring it is the full pass.

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include <diachron/robust/bail_out.hpp>
#include <diachron/robust/estimator.hpp>
#include <diachron/robust/inlier_count_scoring.hpp>
#include <diachron/robust/sprt.hpp>

namespace diachron {

/// How well a model is supported by the data.
struct Support {
  /// Sum of the Scoring policy's gains (higher is better). Valid only when `complete`.
  double score = 0.0;
  /// Data with residual <= threshold. Valid only when `complete`.
  std::size_t num_inliers = 0;
  /// False when scoring stopped early: the model provably could not beat the bound it was given,
  /// or (with `rejected_by_sprt`) the SPRT rejected it.
  bool complete = false;
  /// True when the SPRT (not the exact bound) stopped the scoring.
  bool rejected_by_sprt = false;
  /// True when the bail-out test on the random sample (not the exact bound) stopped the scoring.
  bool bailed_out = false;
  /// Data evaluated and inliers among them (filled in for every outcome; the SPRT's delta
  /// estimate uses them).
  std::size_t evaluated = 0;
  std::size_t inliers_seen = 0;
};

namespace detail {

template <class F, class D, class = void>
struct has_squared_residual : std::false_type {};
template <class F, class D>
struct has_squared_residual<
    F, D,
    std::enable_if_t<std::is_convertible_v<
        decltype(std::declval<const F&>().squared(std::declval<const D&>())), double>>>
    : std::true_type {};

template <class S, class = void>
struct has_inlier_gain : std::false_type {};
template <class S>
struct has_inlier_gain<
    S, std::enable_if_t<std::is_convertible_v<
           decltype(std::declval<const S&>().inlier_gain(1.0)(0.0)), double>>>
    : std::true_type {};

}  // namespace detail

/// True when the residual function of E (make_residual_function) has `squared(datum)`.
template <class E>
inline constexpr bool estimator_has_squared_residual_v = detail::has_squared_residual<
    decltype(make_residual_function(std::declval<const E&>(),
                                    std::declval<const typename E::Model&>())),
    typename E::Datum>::value;

/// True when the Scoring policy S has the optional `inlier_gain(squared_threshold)`.
template <class S>
inline constexpr bool scoring_has_inlier_gain_v = detail::has_inlier_gain<S>::value;

/// The largest double t2 with std::sqrt(t2) <= threshold (threshold finite, > 0): since sqrt is
/// correctly rounded and monotone, `r2 <= t2` is then exactly `std::sqrt(r2) <= threshold`.
inline double exact_squared_threshold(double threshold) {
  double t2 = threshold * threshold;
  while (t2 > 0.0 && std::sqrt(t2) > threshold) t2 = std::nextafter(t2, 0.0);
  for (;;) {
    const double up = std::nextafter(t2, std::numeric_limits<double>::infinity());
    if (!(std::sqrt(up) <= threshold)) break;
    t2 = up;
  }
  return t2;
}

/// Data evaluated together: the unit between two checks of the early-exit bound and of the SPRT.
inline constexpr std::size_t kScoreBlock = 64;

namespace detail {

// The Scoring policy's inlier_gain callable, or a placeholder for policies without one (whose
// gains come from Scoring::gain on distances).
template <class S>
auto make_inlier_gain(const S& scoring, double squared_threshold) {
  if constexpr (scoring_has_inlier_gain_v<S>) {
    return scoring.inlier_gain(squared_threshold);
  } else {
    static_cast<void>(scoring);
    static_cast<void>(squared_threshold);
    return 0;
  }
}

}  // namespace detail


/// Estimator, data, threshold and scoring of one run. Holds references and pointers only: all of
/// them must outlive it. Its member functions are const and thread-safe (the counters they update
/// are the caller's).
template <class Estimator, class Scoring>
class RansacProblem {
 public:
  using Datum = typename Estimator::Datum;
  using Model = typename Estimator::Model;
  /// True when scoring runs on squared residuals (see the file comment).
  static constexpr bool kSquared =
      estimator_has_squared_residual_v<Estimator> && scoring_has_inlier_gain_v<Scoring>;

  /// `screening` (may be null or empty: no screening) must outlive the problem.
  RansacProblem(const Estimator& estimator, const Scoring& scoring, const Datum* data,
                std::size_t size, double threshold, const BailOutSample* screening = nullptr)
      : estimator_(estimator),
        scoring_(scoring),
        data_(data),
        size_(size),
        threshold_(threshold),
        squared_threshold_(exact_squared_threshold(threshold)),
        screening_(screening != nullptr && !screening->empty() ? screening : nullptr),
        inlier_gain_(detail::make_inlier_gain(scoring, squared_threshold_)) {}

  const Estimator& estimator() const { return estimator_; }
  const Scoring& scoring() const { return scoring_; }
  const Datum* data() const { return data_; }
  std::size_t size() const { return size_; }
  /// Inlier threshold, data units.
  double threshold() const { return threshold_; }
  /// The random sample hypotheses are screened on; null when there is none.
  const BailOutSample* screening() const { return screening_; }

  /// Calls `visit(index, gain, is_inlier, squared_residual)` for the `count` data at `indices`
  /// (or the first `count` data when `indices` is null) under `model`. For policies that work on
  /// subsets; the per-datum callback may branch freely.
  template <class Visit>
  void for_each(const Model& model, const std::size_t* indices, std::size_t count,
                Visit&& visit) const {
    const auto residual = make_residual_function(estimator_, model);
    double values[kScoreBlock];
    for (std::size_t begin = 0; begin < count; begin += kScoreBlock) {
      const std::size_t n = std::min(kScoreBlock, count - begin);
      evaluate(residual, indices, begin, n, values);
      for (std::size_t k = 0; k < n; ++k) {
        const std::size_t i = indices ? indices[begin + k] : begin + k;
        const bool inlier = is_inlier(values[k]);
        visit(i, inlier ? inlier_gain(values[k]) : 0.0, inlier, squared(values[k]));
      }
    }
  }

  /// Scores `model` on all data. With early exit enabled in the Scoring policy, stops (and returns
  /// complete == false) once the score can no longer exceed `to_beat` strictly. With a screening
  /// sample and the bail-out test on, the model is first scored on the sample and may be dropped
  /// there (bailed_out == true; see BailOutSample); when the sample is a permutation of all data,
  /// that scoring is the whole of it. With an active `sprt`, also stops (complete == false,
  /// rejected_by_sprt == true) when the test rejects the model: on the screening sample when there
  /// is one, otherwise on the data in input order.
  /// Adds the residuals it computed (screening included) to `residual_evaluations`.
  ///
  /// `sample_to_beat`: the best model's score on the screening sample (sample_score()), 0 when
  /// there is no best yet, -inf to skip that comparison (see BailOutSample).
  Support score(const Model& model, double to_beat, std::size_t& residual_evaluations,
                const SprtTest* sprt = nullptr,
                double sample_to_beat = -std::numeric_limits<double>::infinity()) const {
    const auto residual = make_residual_function(estimator_, model);
    const SprtTest* test = sprt != nullptr && sprt->active ? sprt : nullptr;
    const bool bail = scoring_.early_exit && screening_ != nullptr && screening_->bails_out();
    if (screening_ != nullptr && (bail || test != nullptr)) {
      Support support;
      if (screen(residual, to_beat, bail ? sample_to_beat : -std::numeric_limits<double>::infinity(),
                 bail, test, residual_evaluations, support)) {
        return support;
      }
      test = nullptr;  // settled on the random sample, which input order cannot bias
    }
    return sequential(residual, to_beat, test, residual_evaluations);
  }

  /// Score of `model` on the whole screening sample (-inf when there is none), summed as score()
  /// sums it there. Adds the residuals it computed to `residual_evaluations`.
  double sample_score(const Model& model, std::size_t& residual_evaluations) const {
    if (screening_ == nullptr) return -std::numeric_limits<double>::infinity();
    const auto residual = make_residual_function(estimator_, model);
    double partial = 0.0;
    std::size_t inliers = 0;
    std::size_t done = 0;
    for (const std::size_t checkpoint : screening_->checkpoints) {
      sample_to(residual, checkpoint, done, partial, inliers);
    }
    residual_evaluations += done;
    return partial;
  }

  /// Indices of the inliers of `model` (increasing) into `indices`, and, when `residuals` is not
  /// null, their residuals in the same order; when `sum_squares` is not null, the sum of the
  /// inliers' squared residuals (summed as final_pass sums it). Reuses the vectors' storage.
  void inliers(const Model& model, std::vector<std::size_t>& indices, std::vector<double>* residuals,
               std::size_t& residual_evaluations, double* sum_squares = nullptr) const {
    indices.clear();
    if (residuals) residuals->clear();
    double squares = 0.0;
    std::size_t found[kScoreBlock];
    in_blocks(make_residual_function(estimator_, model),
              [&](std::size_t begin, std::size_t n, const double* values) {
                const std::size_t count = compact_inliers(values, n, begin, found);
                indices.insert(indices.end(), found, found + count);
                if (residuals) {
                  for (std::size_t j = 0; j < count; ++j) {
                    residuals->push_back(std::sqrt(squared(values[found[j] - begin])));
                  }
                }
                if (sum_squares) {
                  for (std::size_t j = 0; j < count; ++j) squares += squared(values[found[j] - begin]);
                }
                return true;
              });
    if (sum_squares) *sum_squares = squares;
    residual_evaluations += size_;
  }

  /// MSAC's truncated quadratic cost of a model with `num_inliers` inliers whose squared residuals
  /// sum to `sum_squares`: sum over all data of min(r^2, t^2), in squared data units. Lower is
  /// better, whatever the Scoring policy.
  double truncated_cost(std::size_t num_inliers, double sum_squares) const {
    return sum_squares + static_cast<double>(size_ - num_inliers) * squared_threshold_;
  }

  /// The final pass of a run: inlier mask (0/1 per datum), inlier indices (increasing), the score
  /// (summed in input order, in blocks as score() sums it without a complete screening sample) and
  /// the sum of the inliers' squared residuals.
  void final_pass(const Model& model, std::vector<char>& mask,
                  std::vector<std::size_t>& indices, double& score, double& sum_squares) const {
    mask.assign(size_, 0);
    indices.clear();
    score = 0.0;
    sum_squares = 0.0;
    std::size_t found[kScoreBlock];
    in_blocks(make_residual_function(estimator_, model),
              [&](std::size_t begin, std::size_t n, const double* values) {
                std::size_t inliers = 0;
                score += block_gain(values, n, inliers);
                const std::size_t count = compact_inliers(values, n, begin, found);
                indices.insert(indices.end(), found, found + count);
                for (std::size_t j = 0; j < count; ++j) {
                  mask[found[j]] = 1;
                  sum_squares += squared(values[found[j] - begin]);
                }
                return true;
              });
  }

 private:
  using InlierGain = decltype(detail::make_inlier_gain(std::declval<const Scoring&>(), 1.0));

  // What the fast path evaluates per datum: the squared residual, else the residual.
  template <class F>
  double value(const F& residual, const Datum& datum) const {
    if constexpr (kSquared) {
      return residual.squared(datum);
    } else {
      return residual(datum);
    }
  }
  bool is_inlier(double v) const {
    if constexpr (kSquared) {
      return v <= squared_threshold_;
    } else {
      return v <= threshold_;
    }
  }
  double squared(double v) const {
    if constexpr (kSquared) {
      return v;
    } else {
      return v * v;
    }
  }
  // Gain of an inlier (is_inlier(v) true).
  double inlier_gain(double v) const {
    if constexpr (kSquared) {
      return inlier_gain_(v);
    } else {
      return scoring_.gain(v, threshold_);
    }
  }

  // values[k] for k < n: datum indices[first + k], or datum first + k when indices is null.
  template <class F>
  void evaluate(const F& residual, const std::size_t* indices, std::size_t first, std::size_t n,
                double* values) const {
    if (indices) {
      for (std::size_t k = 0; k < n; ++k) values[k] = value(residual, data_[indices[first + k]]);
    } else {
      const Datum* block = data_ + first;
      for (std::size_t k = 0; k < n; ++k) values[k] = value(residual, block[k]);
    }
  }

  // Sum of the gains of n evaluated data; adds their inlier count to `inliers`. The fast path
  // multiplies by a 0/1 flag instead of branching; a NaN sum means a non-finite residual met a 0
  // flag, and the block is summed again with a test (same order, so the same finite sum).
  double block_gain(const double* values, std::size_t n, std::size_t& inliers) const {
    if constexpr (kSquared) {
      const double t2 = squared_threshold_;
      double sum = 0.0;
      double count = 0.0;
      for (std::size_t k = 0; k < n; ++k) {
        const double flag = values[k] <= t2 ? 1.0 : 0.0;
        count += flag;
        sum += flag * inlier_gain_(values[k]);
      }
      if (sum != sum) {
        sum = 0.0;
        for (std::size_t k = 0; k < n; ++k) {
          if (values[k] <= t2) sum += inlier_gain_(values[k]);
        }
      }
      inliers += static_cast<std::size_t>(count);
      return sum;
    } else {
      double sum = 0.0;
      for (std::size_t k = 0; k < n; ++k) {
        sum += scoring_.gain(values[k], threshold_);
        inliers += values[k] <= threshold_ ? 1 : 0;
      }
      return sum;
    }
  }

  // Writes the indices (first + k) of the inliers among n evaluated data to `found`, in order,
  // without a branch per datum; returns their number.
  std::size_t compact_inliers(const double* values, std::size_t n, std::size_t first,
                              std::size_t* found) const {
    std::size_t count = 0;
    for (std::size_t k = 0; k < n; ++k) {
      found[count] = first + k;
      count += static_cast<std::size_t>(is_inlier(values[k]));
    }
    return count;
  }

  // The bail-out test, the SPRT and (on a complete sample) the exact early exit at the
  // checkpoints of the screening sample, then, on a partial sample, the comparison with the best's
  // sample score. True when scoring is over: the model was dropped (`support` says why) or the
  // complete sample gave its full score (`support.complete`). False when it survived a partial
  // sample, and the full pass in input order should follow.
  template <class F>
  bool screen(const F& residual, double to_beat, double sample_to_beat, bool bail,
              const SprtTest* test, std::size_t& residual_evaluations, Support& support) const {
    const BailOutSample& sample = *screening_;
    const double mean_to_beat = to_beat / static_cast<double>(size_);
    const bool bound = bail && to_beat > 0.0;
    const bool early = sample.complete && scoring_.early_exit;
    const double bar = exit_bar(to_beat);
    double partial = 0.0;
    std::size_t inliers = 0;
    std::size_t done = 0;
    double log_ratio = 0.0;
    const auto stop = [&]() {
      support.evaluated = done;
      support.inliers_seen = inliers;
      residual_evaluations += done;
      return true;
    };
    for (const std::size_t checkpoint : sample.checkpoints) {
      const std::size_t done_before = done;
      const std::size_t inliers_before = inliers;
      sample_to(residual, checkpoint, done, partial, inliers);
      if (early && partial + static_cast<double>(size_ - done) <= bar) return stop();
      if (bound && sample.should_bail(partial, done, mean_to_beat)) {
        support.bailed_out = true;
        return stop();
      }
      if (test != nullptr &&
          sprt_rejects(*test, inliers - inliers_before, done - done_before, log_ratio)) {
        support.rejected_by_sprt = true;
        return stop();
      }
    }
    if (sample.complete) {
      residual_evaluations += done;
      support = complete_support(partial, inliers, done);
      return true;
    }
    if (partial <= sample_to_beat) {
      support.bailed_out = true;
      return stop();
    }
    residual_evaluations += done;
    return false;
  }

  // The exact pass over all data in input order, with the exact early exit and the optional SPRT.
  template <class F>
  Support sequential(const F& residual, double to_beat, const SprtTest* test,
                     std::size_t& residual_evaluations) const {
    Support support;
    const bool early = scoring_.early_exit;
    const double bar = exit_bar(to_beat);
    double score = 0.0;
    std::size_t inliers = 0;
    double log_ratio = 0.0;
    bool stopped = false;
    in_blocks(residual, [&](std::size_t begin, std::size_t count, const double* values) {
      const std::size_t end = begin + count;
      std::size_t in = 0;
      score += block_gain(values, count, in);
      inliers += in;
      const bool exact_stop = early && score + static_cast<double>(size_ - end) <= bar;
      const bool sprt_stop =
          !exact_stop && test != nullptr && sprt_rejects(*test, in, count, log_ratio);
      if (!exact_stop && !sprt_stop) return true;
      support.rejected_by_sprt = sprt_stop;
      support.evaluated = end;
      support.inliers_seen = inliers;
      residual_evaluations += end;
      stopped = true;
      return false;
    });
    if (stopped) return support;
    residual_evaluations += size_;
    return complete_support(score, inliers, size_);
  }

  // Evaluates all data in input order, a block of at most kScoreBlock at a time, and calls
  // visit(begin, n, values) on each; stops early when visit returns false.
  template <class F, class Visit>
  void in_blocks(const F& residual, Visit&& visit) const {
    double values[kScoreBlock];
    for (std::size_t begin = 0; begin < size_; begin += kScoreBlock) {
      const std::size_t n = std::min(kScoreBlock, size_ - begin);
      evaluate(residual, nullptr, begin, n, values);
      if (!visit(begin, n, values)) return;
    }
  }

  // Scores the screening sample from position `done` up to `checkpoint`, in blocks that never
  // straddle a checkpoint (so every caller sums the sample in the same order), adding to
  // `partial` and `inliers` and advancing `done`.
  template <class F>
  void sample_to(const F& residual, std::size_t checkpoint, std::size_t& done, double& partial,
                 std::size_t& inliers) const {
    double values[kScoreBlock];
    while (done < checkpoint) {
      const std::size_t n = std::min(kScoreBlock, checkpoint - done);
      evaluate(residual, screening_->indices.data(), done, n, values);
      partial += block_gain(values, n, inliers);
      done += n;
    }
  }

  // The support of a hypothesis scored on all `evaluated` data.
  static Support complete_support(double score, std::size_t inliers, std::size_t evaluated) {
    Support support;
    support.score = score;
    support.num_inliers = inliers;
    support.complete = true;
    support.evaluated = evaluated;
    support.inliers_seen = inliers;
    return support;
  }

  // Adds `count` more data, `in` of them inliers, to the SPRT's log likelihood ratio; true when
  // the test then rejects the model.
  static bool sprt_rejects(const SprtTest& test, std::size_t in, std::size_t count,
                           double& log_ratio) {
    log_ratio += static_cast<double>(in) * test.log_inlier +
                 static_cast<double>(count - in) * test.log_outlier;
    return log_ratio > test.log_threshold;
  }

  // The early-exit bar for a hypothesis that must beat `to_beat`: every gain is <= 1, so one at
  // `score` with `left` data to go ends at most at score + left; the margin covers rounding in
  // the two sums being compared (each at most size^2 * eps off), so a stop is never wrong.
  double exit_bar(double to_beat) const {
    const double n = static_cast<double>(size_);
    return to_beat - 4.0 * (n + 1.0) * (n + 1.0) * DBL_EPSILON;
  }

  const Estimator& estimator_;
  const Scoring& scoring_;
  const Datum* data_;
  std::size_t size_;
  double threshold_;
  double squared_threshold_;
  const BailOutSample* screening_;
  InlierGain inlier_gain_;
};

}  // namespace diachron
