#pragma once
/// @file
/// The sequential probability ratio test of randomized RANSAC (Matas and Chum, "Randomized RANSAC
/// with sequential probability ratio test", ICCV 2005; Chum and Matas, "Optimal randomized
/// RANSAC", PAMI 30(8) 2008), as Ransac uses it when RansacOptions::sprt is set.
///
/// A hypothesis is "good" when its inlier rate is at least epsilon (here: that of the best model so
/// far) and "bad" when it is delta (the inlier rate of bad models, estimated from the models the
/// test rejected). While scoring, the likelihood ratio
///   lambda_j = prod_{i <= j} p(x_i | bad) / p(x_i | good),
/// with p(inlier | bad) = delta, p(inlier | good) = epsilon, grows for bad models and shrinks for
/// good ones; the model is rejected once lambda_j > A. By Wald's (and Ville's) inequality a good
/// model is rejected with probability at most 1 / A, also when lambda is only checked every few
/// data, as Ransac does (every kScoreBlock data). A is the paper's optimum (eq. 10 of the PAMI
/// paper): the fixed point of A = t_M C / m_S + 1 + ln A, with
///   C = (1 - delta) ln((1 - delta) / (1 - epsilon)) + delta ln(delta / epsilon),
/// t_M the cost of making a hypothesis in residual evaluations and m_S the models per sample.

#include <algorithm>
#include <cmath>

namespace diachron {

/// One SPRT, fixed for a batch of hypotheses. Inactive unless 0 < delta < epsilon < 1.
struct SprtTest {
  bool active = false;
  double epsilon = 0.0;
  double delta = 0.0;
  /// The decision threshold A (> 1) and its logarithm.
  double threshold = 1.0;
  double log_threshold = 0.0;
  /// ln(delta / epsilon) added per inlier, ln((1 - delta) / (1 - epsilon)) per outlier.
  double log_inlier = 0.0;
  double log_outlier = 0.0;

  /// Upper bound on the probability of rejecting a good model, 1 / A (0 when inactive).
  double false_rejection() const { return active ? 1.0 / threshold : 0.0; }
};

/// The SPRT for models better than `epsilon` against bad models at `delta`, with hypotheses
/// costing `model_cost` residual evaluations and `models_per_sample` models per sample.
inline SprtTest make_sprt_test(double epsilon, double delta, double model_cost,
                               double models_per_sample) {
  SprtTest test;
  if (!(delta > 0.0 && delta < epsilon && epsilon < 1.0)) return test;
  test.active = true;
  test.epsilon = epsilon;
  test.delta = delta;
  test.log_inlier = std::log(delta / epsilon);
  test.log_outlier = std::log((1.0 - delta) / (1.0 - epsilon));
  const double c = (1.0 - delta) * test.log_outlier + delta * test.log_inlier;
  const double k = model_cost * c / std::max(models_per_sample, 1.0) + 1.0;
  double a = k;
  for (int step = 0; step < 100; ++step) {
    const double next = k + std::log(a);
    if (std::abs(next - a) <= 1e-10 * next) {
      a = next;
      break;
    }
    a = next;
  }
  test.threshold = std::max(a, 1.0 + 1e-9);
  test.log_threshold = std::log(test.threshold);
  return test;
}

/// Iterations needed when a good model is accepted only with probability 1 - alpha (the paper's
/// adjustment of the stopping rule): k iterations that reach confidence `confidence` with an
/// all-inlier sample probability p reach it with (1 - p (1 - alpha)) per iteration after
/// k ln(1 - p) / ln(1 - p (1 - alpha)) iterations. Returns at least k (k unchanged when alpha <= 0).
inline double sprt_adjusted_iterations(double k, double p, double alpha) {
  if (!(alpha > 0.0) || !(k > 0.0)) return k;
  const double a = std::min(alpha, 0.5);
  double factor = 1.0 / (1.0 - a);
  if (p > 0.0 && p < 1.0) {
    const double ratio = std::log1p(-p) / std::log1p(-p * (1.0 - a));
    if (std::isfinite(ratio)) factor = std::max(factor, ratio);
  }
  return std::ceil(k * factor);
}

}  // namespace diachron
