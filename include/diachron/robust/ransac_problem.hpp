#pragma once
/// @file
/// The view of one Ransac run that local-optimisation policies work on: estimator, data, threshold
/// and scoring, with the one scoring loop (early exit and the optional SPRT included) that every
/// part of Ransac uses.
///
/// Fast path. When the estimator's residual function (see make_residual_function) also has
/// `double squared(const Datum&) const` returning the SQUARED residual, with operator() equal to
/// std::sqrt(squared(datum)), and the Scoring policy has `squared_gain(double squared_threshold)`
/// (a callable double(double squared_residual), see inlier_count_scoring.hpp), the loop compares
/// squared residuals against a squared threshold chosen so that `r2 <= t2` holds exactly when
/// `std::sqrt(r2) <= threshold`: no sqrt, no division, no branch per datum. The inlier set is the
/// same as with the distance; MSAC gains may differ from Msac::gain in the last bits.
/// The early-exit bound (and the SPRT) are checked once per block of kScoreBlock data, so the
/// per-datum loop is straight-line code.

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

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
struct has_squared_gain : std::false_type {};
template <class S>
struct has_squared_gain<
    S, std::enable_if_t<std::is_convertible_v<
           decltype(std::declval<const S&>().squared_gain(1.0)(0.0)), double>>>
    : std::true_type {};

}  // namespace detail

/// True when the residual function of E (make_residual_function) has `squared(datum)`.
template <class E>
inline constexpr bool estimator_has_squared_residual_v = detail::has_squared_residual<
    decltype(make_residual_function(std::declval<const E&>(),
                                    std::declval<const typename E::Model&>())),
    typename E::Datum>::value;

/// True when the Scoring policy S has the optional `squared_gain(squared_threshold)`.
template <class S>
inline constexpr bool scoring_has_squared_gain_v = detail::has_squared_gain<S>::value;

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

/// Data scored between two checks of the early-exit bound and of the SPRT.
inline constexpr std::size_t kScoreBlock = 64;

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
      estimator_has_squared_residual_v<Estimator> && scoring_has_squared_gain_v<Scoring>;

  RansacProblem(const Estimator& estimator, const Scoring& scoring, const Datum* data,
                std::size_t size, double threshold)
      : estimator_(estimator),
        scoring_(scoring),
        data_(data),
        size_(size),
        threshold_(threshold),
        squared_threshold_(exact_squared_threshold(threshold)) {}

  const Estimator& estimator() const { return estimator_; }
  const Scoring& scoring() const { return scoring_; }
  const Datum* data() const { return data_; }
  std::size_t size() const { return size_; }
  /// Inlier threshold, data units.
  double threshold() const { return threshold_; }

  /// Calls `visit(index, gain, is_inlier, squared_residual)` for datum `index` under `model`;
  /// the per-datum kernel of every loop here. Returns nothing; for policies that score subsets.
  template <class Visit>
  void for_each(const Model& model, const std::size_t* indices, std::size_t count,
                Visit&& visit) const {
    const auto residual = make_residual_function(estimator_, model);
    if constexpr (kSquared) {
      const auto gain = scoring_.squared_gain(squared_threshold_);
      for (std::size_t k = 0; k < count; ++k) {
        const std::size_t i = indices ? indices[k] : k;
        const double r2 = residual.squared(data_[i]);
        visit(i, gain(r2), r2 <= squared_threshold_, r2);
      }
    } else {
      for (std::size_t k = 0; k < count; ++k) {
        const std::size_t i = indices ? indices[k] : k;
        const double r = residual(data_[i]);
        visit(i, scoring_.gain(r, threshold_), r <= threshold_, r * r);
      }
    }
  }

  /// Scores `model` on all data. With early exit enabled in the Scoring policy, stops (and returns
  /// complete == false) once the score can no longer exceed `to_beat` strictly. With an active
  /// `sprt`, also stops (complete == false, rejected_by_sprt == true) when the test rejects the
  /// model. Both are checked after every block of kScoreBlock data.
  /// Adds the residuals it computed to `residual_evaluations`.
  Support score(const Model& model, double to_beat, std::size_t& residual_evaluations,
                const SprtTest* sprt = nullptr) const {
    const auto residual = make_residual_function(estimator_, model);
    if constexpr (kSquared) {
      const auto gain = scoring_.squared_gain(squared_threshold_);
      const double t2 = squared_threshold_;
      return scan(to_beat, residual_evaluations, sprt, [&](const Datum& d, std::size_t& in) {
        const double r2 = residual.squared(d);
        in += r2 <= t2 ? 1 : 0;
        return gain(r2);
      });
    } else {
      const double t = threshold_;
      return scan(to_beat, residual_evaluations, sprt, [&](const Datum& d, std::size_t& in) {
        const double r = residual(d);
        in += r <= t ? 1 : 0;
        return scoring_.gain(r, t);
      });
    }
  }

  /// Indices of the inliers of `model` (increasing) into `indices`, and, when `residuals` is not
  /// null, their residuals in the same order. Reuses the vectors' storage.
  void inliers(const Model& model, std::vector<std::size_t>& indices, std::vector<double>* residuals,
               std::size_t& residual_evaluations) const {
    indices.clear();
    if (residuals) residuals->clear();
    for_each(model, nullptr, size_, [&](std::size_t i, double, bool inlier, double r2) {
      if (inlier) {
        indices.push_back(i);
        if (residuals) residuals->push_back(std::sqrt(r2));
      }
    });
    residual_evaluations += size_;
  }

  /// The final pass of a run: inlier mask (0/1 per datum), inlier indices (increasing), the score
  /// (summed exactly as score() sums it) and the sum of the inliers' squared residuals.
  void final_pass(const Model& model, std::vector<char>& mask,
                  std::vector<std::size_t>& indices, double& score, double& sum_squares) const {
    mask.assign(size_, 0);
    indices.clear();
    score = 0.0;
    sum_squares = 0.0;
    double block = 0.0;
    std::size_t in_block = 0;
    for_each(model, nullptr, size_, [&](std::size_t i, double gain, bool inlier, double r2) {
      block += gain;
      if (inlier) {
        mask[i] = 1;
        indices.push_back(i);
        sum_squares += r2;
      }
      if (++in_block == kScoreBlock) {
        score += block;
        block = 0.0;
        in_block = 0;
      }
    });
    score += block;
  }

 private:
  template <class Kernel>
  Support scan(double to_beat, std::size_t& residual_evaluations, const SprtTest* sprt,
               Kernel&& kernel) const {
    Support support;
    const bool early = scoring_.early_exit;
    const bool test = sprt != nullptr && sprt->active;
    // Every gain is <= 1, so a hypothesis at `score` with `left` data to go ends at most at
    // score + left. The margin covers rounding in the two sums being compared (each at most
    // size^2 * eps off), so a stop is never wrong.
    const double n = static_cast<double>(size_);
    const double bar = to_beat - 4.0 * (n + 1.0) * (n + 1.0) * DBL_EPSILON;
    double score = 0.0;
    std::size_t inliers = 0;
    double log_ratio = 0.0;
    for (std::size_t begin = 0; begin < size_; begin += kScoreBlock) {
      const std::size_t end = std::min(size_, begin + kScoreBlock);
      double block = 0.0;
      std::size_t in = 0;
      for (std::size_t i = begin; i < end; ++i) block += kernel(data_[i], in);
      score += block;
      inliers += in;
      if (early && score + static_cast<double>(size_ - end) <= bar) {
        support.evaluated = end;
        support.inliers_seen = inliers;
        residual_evaluations += end;
        return support;
      }
      if (test) {
        log_ratio += static_cast<double>(in) * sprt->log_inlier +
                     static_cast<double>(end - begin - in) * sprt->log_outlier;
        if (log_ratio > sprt->log_threshold) {
          support.rejected_by_sprt = true;
          support.evaluated = end;
          support.inliers_seen = inliers;
          residual_evaluations += end;
          return support;
        }
      }
    }
    residual_evaluations += size_;
    support.score = score;
    support.num_inliers = inliers;
    support.complete = true;
    support.evaluated = size_;
    support.inliers_seen = inliers;
    return support;
  }

  const Estimator& estimator_;
  const Scoring& scoring_;
  const Datum* data_;
  std::size_t size_;
  double threshold_;
  double squared_threshold_;
};

}  // namespace diachron
