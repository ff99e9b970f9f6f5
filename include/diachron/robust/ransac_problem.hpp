#pragma once
/// @file
/// The view of one Ransac run that local-optimisation policies work on: estimator, data, threshold
/// and scoring, with the one scoring loop (early exit included) that every part of Ransac uses.

#include <cfloat>
#include <cstddef>
#include <vector>

#include <diachron/robust/estimator.hpp>
#include <diachron/robust/inlier_count_scoring.hpp>

namespace diachron {

/// How well a model is supported by the data.
struct Support {
  /// Sum of the Scoring policy's gains (higher is better). Valid only when `complete`.
  double score = 0.0;
  /// Data with residual <= threshold. Valid only when `complete`.
  std::size_t num_inliers = 0;
  /// False when scoring stopped early: the model provably could not beat the bound it was given.
  bool complete = false;
};

/// Estimator, data, threshold and scoring of one run. Holds references and pointers only: all of
/// them must outlive it. Its member functions are const and thread-safe (the counters they update
/// are the caller's).
template <class Estimator, class Scoring>
class RansacProblem {
 public:
  using Datum = typename Estimator::Datum;
  using Model = typename Estimator::Model;

  RansacProblem(const Estimator& estimator, const Scoring& scoring, const Datum* data,
                std::size_t size, double threshold)
      : estimator_(estimator), scoring_(scoring), data_(data), size_(size), threshold_(threshold) {}

  const Estimator& estimator() const { return estimator_; }
  const Scoring& scoring() const { return scoring_; }
  const Datum* data() const { return data_; }
  std::size_t size() const { return size_; }
  /// Inlier threshold, data units.
  double threshold() const { return threshold_; }

  /// Scores `model` on all data. With early exit enabled in the Scoring policy, stops (and returns
  /// complete == false) once the score can no longer exceed `to_beat` strictly.
  /// Adds the residuals it computed to `residual_evaluations`.
  Support score(const Model& model, double to_beat, std::size_t& residual_evaluations) const {
    Support support;
    double score = 0.0;
    std::size_t inliers = 0;
    const auto residual = make_residual_function(estimator_, model);
    if (scoring_.early_exit) {
      // Every gain is <= 1, so a hypothesis at `score` with `left` data to go ends at most at
      // score + left. The margin covers rounding in the two sums being compared (each at most
      // size^2 * eps off), so a stop is never wrong.
      const double n = static_cast<double>(size_);
      const double bar = to_beat - 4.0 * (n + 1.0) * (n + 1.0) * DBL_EPSILON;
      double left = n;
      for (std::size_t i = 0; i < size_; ++i) {
        const double r = residual(data_[i]);
        score += scoring_.gain(r, threshold_);
        inliers += r <= threshold_ ? 1 : 0;
        left -= 1.0;
        if (score + left <= bar) {
          residual_evaluations += i + 1;
          return support;
        }
      }
    } else {
      for (std::size_t i = 0; i < size_; ++i) {
        const double r = residual(data_[i]);
        score += scoring_.gain(r, threshold_);
        inliers += r <= threshold_ ? 1 : 0;
      }
    }
    residual_evaluations += size_;
    support.score = score;
    support.num_inliers = inliers;
    support.complete = true;
    return support;
  }

  /// Indices of the inliers of `model` (increasing) into `indices`, and, when `residuals` is not
  /// null, their residuals in the same order. Reuses the vectors' storage.
  void inliers(const Model& model, std::vector<std::size_t>& indices, std::vector<double>* residuals,
               std::size_t& residual_evaluations) const {
    indices.clear();
    if (residuals) residuals->clear();
    const auto residual = make_residual_function(estimator_, model);
    for (std::size_t i = 0; i < size_; ++i) {
      const double r = residual(data_[i]);
      if (r <= threshold_) {
        indices.push_back(i);
        if (residuals) residuals->push_back(r);
      }
    }
    residual_evaluations += size_;
  }

 private:
  const Estimator& estimator_;
  const Scoring& scoring_;
  const Datum* data_;
  std::size_t size_;
  double threshold_;
};

}  // namespace diachron
