#pragma once
/// @file
/// What diachron::Ransac returns: the model, its inliers, and counters of the work done, so a
/// benchmark can compare compositions by effort as well as by result.

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace diachron {

/// Result of one Ransac run. A default-constructed report means failure: `success == false`, no
/// inliers, infinite rms. When `success` is false, `message` says why and the other result fields
/// must not be used (the counters stay meaningful).
/// @tparam Model the estimator's model type (default-constructible).
template <class Model>
struct RansacReport {
  /// True when a model with at least RansacOptions::min_inliers inliers was found.
  bool success = false;
  /// Why the run failed (empty on success), e.g. "fewer data (1) than the minimal sample (2)".
  std::string message = "not run";

  /// The final model (after local optimisation and the final refit, when those ran).
  Model model{};
  /// Indices into the input of the data with `residual(model, datum) <= threshold`, increasing.
  std::vector<std::size_t> inliers;
  /// One entry per input datum: 1 for an inlier of `model`, 0 otherwise (empty on early failure).
  std::vector<char> inlier_mask;
  /// Score of `model` under the Scoring policy (higher is better): the inlier count for
  /// InlierCount, the sum of 1 - (r / threshold)^2 over inliers for Msac. 0 when nothing was found.
  double score = 0.0;
  /// Root mean square of the inliers' residuals, in data units; +inf when there are no inliers.
  double rms = std::numeric_limits<double>::infinity();

  /// Iterations run (minimal samples drawn, not counting degenerate redraws).
  std::size_t iterations = 0;
  /// Number of data in the input (to turn `residual_evaluations` into passes over the data).
  std::size_t num_data = 0;
  /// Models returned by the minimal solver over all iterations.
  std::size_t hypotheses_generated = 0;
  /// Hypotheses whose scoring stopped early: they provably could no longer beat the best (the exact
  /// bound), or the bail-out test or the SPRT dropped them.
  std::size_t hypotheses_stopped_early = 0;
  /// Of hypotheses_stopped_early, those the SPRT rejected (RansacOptions::sprt; 0 without it).
  std::size_t hypotheses_rejected_sprt = 0;
  /// Of hypotheses_stopped_early, those the bail-out test dropped (RansacOptions::bail_out_risk).
  std::size_t hypotheses_bailed_out = 0;
  /// Samples rejected as degenerate or giving no model (each one was redrawn or ended its
  /// iteration).
  std::size_t degenerate_samples = 0;
  /// Hypotheses that strictly beat the best so far (each one is handed to local optimisation).
  std::size_t best_updates = 0;
  /// Local optimisations that did some work (evaluated residuals); 0 with NoLocalOptimization or
  /// with Refit on an estimator without `refine`.
  std::size_t local_optimizations = 0;
  /// Local optimisations that found a strictly better model.
  std::size_t local_optimization_improvements = 0;
  /// True when the final refit on all inliers was kept.
  bool final_refit = false;
  /// Calls to Estimator::residual during the whole run (scoring, local optimisation, final refit,
  /// inlier mask). Speculative hypotheses computed by parallel workers past the stopping iteration
  /// are not counted, so the figure does not depend on the thread count.
  std::size_t residual_evaluations = 0;

  /// Whole passes over the data the run cost: residual_evaluations / num_data (0 for no data).
  double data_passes() const {
    return num_data == 0 ? 0.0
                         : static_cast<double>(residual_evaluations) / static_cast<double>(num_data);
  }
};

}  // namespace diachron
