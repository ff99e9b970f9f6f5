#pragma once
/// @file
/// Local optimisation by iterated weighted least squares on a bounded random subset of the inliers
/// (in the spirit of LO-RANSAC, Chum, Matas and Kittler, DAGM 2003, and its inner non-minimal
/// sample). Models the LocalOptimization concept of robust/no_local_optimization.hpp.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <unordered_set>
#include <utility>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/robust/estimator.hpp>
#include <diachron/robust/no_local_optimization.hpp>
#include <diachron/robust/ransac_problem.hpp>

namespace diachron {

/// Iterated weighted least squares on a random subset of the data, then one full score.
///
/// 1. Pool: a random subset of the data (without replacement, in random order) of about
///    1.5 x max_lo_data / inlier rate data, at most `max_pool`, drawn from the stream Ransac derives
///    from (seed, iteration); all data when that is at least as many.
/// 2. Up to `max_steps` steps: the current model's inliers in the pool (the first `max_lo_data` of
///    them in the pool's order) are refit with Estimator::refine (Tukey weights by default); the
///    refit replaces the current model only if its score on the pool is strictly higher.
/// 3. The last accepted refit is scored once on all data (exact early exit against the incoming
///    score) and kept only if its full score is strictly higher.
/// The final refit on all inliers of the best model stays in Ransac (RansacOptions::final_refit).
///
/// Cost per local optimisation: at most (steps + 1) x max_pool residuals, refits on at most
/// max_lo_data data, plus one pass over the data, instead of up to 3 passes and a refit on all
/// inliers per step. Without the max_pool cap, a model with a handful of inliers (a wrong early
/// best) would make every step a pass over all data.
///
/// Guards (COLMAP #4678 crashed here): a step with fewer than kSampleSize inliers in the pool, a
/// refit that fails, or one that does not strictly improve the pool score ends the iteration, so a
/// shrinking inlier set can neither reach refine nor loop.
/// Estimators without `refine` make this policy a no-op (it compiles and returns false).
struct Refit {
  /// Refit steps per local optimisation, >= 0 (0 turns the policy off). 4 rather than the 10 of
  /// full-data IRLS: on a subset the steps are cheap, but later ones seldom change the inlier set.
  std::size_t max_steps = 4;
  /// Most inliers a refit sees (>= 1; values below kSampleSize act as kSampleSize). The
  /// least-squares error of the fit shrinks as 1 / sqrt(data), so beyond a few thousand more data
  /// buy little; the final refit on all inliers restores full accuracy.
  std::size_t max_lo_data = 2000;
  /// Most data a step evaluates (>= 1). The default holds 2000 inliers down to an inlier rate of
  /// about 9 %; below that the refits see fewer inliers (about 0.3 x max_pool x rate), which still
  /// suffices for the few parameters of a geometric model.
  std::size_t max_pool = 32768;
  /// true: Tukey biweight IRLS weights (1 - (r / t)^2)^2, which let inliers near the threshold (the
  /// likeliest to be outliers in disguise) count less; false: unit weights, i.e. plain least
  /// squares on the inliers (IRLS for the truncated quadratic).
  bool tukey_weights = true;

  /// The concept's entry point without a caller-given stream: the pool comes from RandomStream(0,
  /// 0). Ransac calls the overload below with a stream of its own.
  template <class Estimator, class Scoring>
  bool optimize(const RansacProblem<Estimator, Scoring>& problem, typename Estimator::Model& model,
                Support& support, std::size_t& residual_evaluations) const {
    RandomStream rng(0, 0);
    return optimize(problem, model, support, residual_evaluations, rng);
  }

  /// As above, drawing the pool from `rng`.
  template <class Estimator, class Scoring>
  bool optimize(const RansacProblem<Estimator, Scoring>& problem, typename Estimator::Model& model,
                Support& support, std::size_t& residual_evaluations, RandomStream& rng) const {
    if constexpr (!estimator_has_refine_v<Estimator>) {
      (void)problem;
      (void)model;
      (void)support;
      (void)residual_evaluations;
      (void)rng;
      return false;
    } else {
      using Model = typename Estimator::Model;
      constexpr std::size_t kSampleSize = Estimator::kSampleSize;
      if (max_steps == 0 || !support.complete) return false;
      const std::size_t n = problem.size();
      const std::size_t cap = std::max(max_lo_data, kSampleSize);

      // The pool: all data (pool empty = identity) or a random subset in random order.
      std::vector<std::size_t> pool;
      const double rate = static_cast<double>(support.num_inliers) / static_cast<double>(n);
      const double want = std::min(std::ceil(1.5 * static_cast<double>(cap) / rate),
                                   static_cast<double>(std::max<std::size_t>(max_pool, 1)));
      const bool subset_pool = want < static_cast<double>(n);
      if (subset_pool) draw_pool(n, static_cast<std::size_t>(want), rng, pool);
      const std::size_t* pool_ptr = subset_pool ? pool.data() : nullptr;
      const std::size_t pool_size = subset_pool ? pool.size() : n;

      std::vector<std::size_t> indices;
      std::vector<double> weights;
      // Pool inliers (at most cap) and Tukey weights of `m`; returns the pool score.
      const auto collect = [&](const Model& m) {
        indices.clear();
        weights.clear();
        double score = 0.0;
        const double t2 = problem.threshold() * problem.threshold();
        problem.for_each(m, pool_ptr, pool_size, [&](std::size_t i, double gain, bool inlier,
                                                     double r2) {
          score += gain;
          if (inlier && indices.size() < cap) {
            indices.push_back(i);
            const double q = std::min(r2 / t2, 1.0);
            weights.push_back((1.0 - q) * (1.0 - q));
          }
        });
        residual_evaluations += pool_size;
        return score;
      };

      Model current = model;
      double current_score = collect(current);
      bool changed = false;
      for (std::size_t step = 0; step < max_steps; ++step) {
        if (indices.size() < kSampleSize) break;
        const Subset<typename Estimator::Datum> subset(problem.data(), indices.data(),
                                                       indices.size());
        const auto refined =
            problem.estimator().refine(current, subset, tukey_weights ? weights.data() : nullptr);
        if (!refined) break;
        const double refined_score = collect(*refined);
        if (!(refined_score > current_score)) break;
        current = *refined;
        current_score = refined_score;
        changed = true;
      }
      if (!changed) return false;
      const Support full = problem.score(current, support.score, residual_evaluations);
      if (!full.complete || !(full.score > support.score)) return false;
      model = current;
      support = full;
      return true;
    }
  }

 private:
  // m distinct indices of [0, n) in uniform random order: a partial Fisher-Yates shuffle when m is
  // a sizeable share of n, otherwise rejection of repeats through a hash set.
  static void draw_pool(std::size_t n, std::size_t m, RandomStream& rng,
                        std::vector<std::size_t>& pool) {
    pool.clear();
    m = std::min(m, n);
    if (m * 4 >= n) {
      pool.resize(n);
      for (std::size_t i = 0; i < n; ++i) pool[i] = i;
      for (std::size_t k = 0; k < m; ++k) std::swap(pool[k], pool[k + rng.uniform_index(n - k)]);
      pool.resize(m);
      return;
    }
    std::unordered_set<std::size_t> seen;
    seen.reserve(2 * m);
    pool.reserve(m);
    while (pool.size() < m) {
      const std::size_t i = rng.uniform_index(n);
      if (seen.insert(i).second) pool.push_back(i);
    }
  }
};

}  // namespace diachron
