#pragma once
/// @file
/// Local optimisation by iterated weighted least squares on the inliers (in the spirit of LO-RANSAC,
/// Chum, Matas and Kittler, DAGM 2003). Models the LocalOptimization concept of
/// robust/no_local_optimization.hpp.

#include <cstddef>
#include <vector>

#include <diachron/core/subset.hpp>
#include <diachron/robust/estimator.hpp>
#include <diachron/robust/no_local_optimization.hpp>
#include <diachron/robust/ransac_problem.hpp>

namespace diachron {

/// Each step refits the model on the current model's inliers with Estimator::refine, then keeps the
/// refit only if its score is strictly higher; the step repeats on the new inliers up to
/// `max_steps` times. Guards (COLMAP #4678 crashed here): a step with fewer than kSampleSize
/// inliers, a refit that fails, or one that does not strictly improve ends the optimisation, so a
/// shrinking inlier set can neither reach refine nor loop.
/// Estimators without `refine` make this policy a no-op (it compiles and returns false).
struct Refit {
  /// Refits per local optimisation, >= 0 (0 turns the policy off).
  std::size_t max_steps = 10;
  /// true: Tukey biweight IRLS weights (1 - (r / t)^2)^2, which let inliers near the threshold (the
  /// likeliest to be outliers in disguise) count less; false: unit weights, i.e. plain least
  /// squares on the inliers (IRLS for the truncated quadratic).
  bool tukey_weights = true;

  template <class Estimator, class Scoring>
  bool optimize(const RansacProblem<Estimator, Scoring>& problem, typename Estimator::Model& model,
                Support& support, std::size_t& residual_evaluations) const {
    if constexpr (!estimator_has_refine_v<Estimator>) {
      (void)problem;
      (void)model;
      (void)support;
      (void)residual_evaluations;
      return false;
    } else {
      using Model = typename Estimator::Model;
      std::vector<std::size_t> indices;
      std::vector<double> residuals;
      std::vector<double> weights;
      Model current = model;
      Support current_support = support;
      bool improved = false;
      for (std::size_t step = 0; step < max_steps; ++step) {
        problem.inliers(current, indices, &residuals, residual_evaluations);
        if (indices.size() < Estimator::kSampleSize) break;
        const double* weight_ptr = nullptr;
        if (tukey_weights) {
          weights.resize(residuals.size());
          for (std::size_t i = 0; i < residuals.size(); ++i) {
            const double q = residuals[i] / problem.threshold();
            weights[i] = (1.0 - q * q) * (1.0 - q * q);
          }
          weight_ptr = weights.data();
        }
        const Subset<typename Estimator::Datum> subset(problem.data(), indices.data(),
                                                       indices.size());
        const auto refined = problem.estimator().refine(current, subset, weight_ptr);
        if (!refined) break;
        const Support refined_support =
            problem.score(*refined, current_support.score, residual_evaluations);
        if (!refined_support.complete || !(refined_support.score > current_support.score)) break;
        current = *refined;
        current_support = refined_support;
        improved = true;
      }
      if (improved) {
        model = current;
        support = current_support;
      }
      return improved;
    }
  }
};

}  // namespace diachron
