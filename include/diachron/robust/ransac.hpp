#pragma once
/// @file
/// diachron::Ransac: random sample consensus assembled from five policies (docs/concepts.md).
///
/// Policies and where their requirements are written:
/// - Estimator          robust/estimator.hpp               (the model: minimal solver, residual, ...)
/// - Sampler            robust/uniform_sampler.hpp          UniformSampler, ProsacSampler
/// - Scoring            robust/inlier_count_scoring.hpp     InlierCount, Msac
/// - Termination        robust/fixed_iterations.hpp         FixedIterations, Adaptive
/// - LocalOptimization  robust/no_local_optimization.hpp    NoLocalOptimization, Refit
///
/// The paper's configuration is Ransac<E, UniformSampler, InlierCount, FixedIterations,
/// NoLocalOptimization> with max_iterations = 1000; the defaults are LO-MSAC with the exact adaptive
/// stopping rule.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <sstream>
#include <utility>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/robust/adaptive_termination.hpp>
#include <diachron/robust/bail_out.hpp>
#include <diachron/robust/estimator.hpp>
#include <diachron/robust/fixed_iterations.hpp>
#include <diachron/robust/inlier_count_scoring.hpp>
#include <diachron/robust/msac_scoring.hpp>
#include <diachron/robust/no_local_optimization.hpp>
#include <diachron/robust/ransac_options.hpp>
#include <diachron/robust/ransac_problem.hpp>
#include <diachron/robust/ransac_report.hpp>
#include <diachron/robust/refit_local_optimization.hpp>
#include <diachron/robust/sprt.hpp>
#include <diachron/robust/uniform_sampler.hpp>

namespace diachron {

namespace detail {

// Local-optimisation policies may take a RandomStream& as a fifth argument (Refit does, for its
// random subset); Ransac then hands them RandomStream(seed, ~iteration), a stream no sample uses.
template <class L, class E, class S, class = void>
struct local_optimization_takes_stream : std::false_type {};
template <class L, class E, class S>
struct local_optimization_takes_stream<
    L, E, S,
    std::void_t<decltype(std::declval<const L&>().optimize(
        std::declval<const RansacProblem<E, S>&>(), std::declval<typename E::Model&>(),
        std::declval<Support&>(), std::declval<std::size_t&>(), std::declval<RandomStream&>()))>>
    : std::true_type {};

}  // namespace detail

/// Robust estimation of an Estimator's model from data with outliers.
///
/// Algorithm. Iteration i draws a minimal sample from RandomStream(seed, i) (redrawing, up to
/// options.max_sample_attempts times, samples that are degenerate or give no model), scores every
/// model of the sample, and the best of them becomes the best model when its score is strictly
/// higher; then local optimisation runs on it, and the Termination policy decides whether to stop.
/// Finally the best model is refit on all its inliers (options.final_refit, estimators with
/// `refine` only; one unweighted least-squares fit), the refit kept unless its truncated quadratic
/// cost sum(min(r^2, t^2)) on all data is higher, whatever the Scoring policy (so InlierCount does
/// not throw a better fit away for an inlier lost at the threshold); its final pass gives the
/// report's inliers, mask, score and rms.
///
/// Determinism. Hypotheses are processed in batches (of 1, 2, 4, ... then 64 iterations; a fixed
/// schedule). Within a batch they are generated and scored independently, on options.threads
/// threads, with early exit bounded by the best score known before the batch; the results are then
/// merged strictly in iteration order, and hypotheses past the stopping iteration are discarded. A
/// batch ends early at a new best, so the bound of every iteration is the best of all before it.
/// Since every early exit depends only on that bound and each iteration's randomness comes from its
/// own stream, the report (model, inliers, iterations, score and all counters) is identical for
/// every thread count.
/// Local optimisation of the best found at iteration i draws from RandomStream(seed, ~i).
///
/// Bail-out test (options.bail_out_risk, on by default; robust/bail_out.hpp). A hypothesis is first
/// scored on a random sample of the data, drawn once per run from RandomStream(seed,
/// kScreeningStream), and dropped when Hoeffding's inequality shows its mean gain below the best's,
/// or, on a sample of part of the data, when it scores no more on the sample than the best did (0
/// before there is a best); survivors get the full pass with its exact early exit. The bounds are
/// the batch's, so the test too is the same for every thread count. Unlike the exact exit, it may
/// drop a hypothesis that would have beaten the best: with probability at most bail_out_risk at
/// the Hoeffding checkpoints, and near-ties at the sample comparison (see bail_out.hpp).
///
/// SPRT (options.sprt). Each batch uses one test, built before the batch from the best model so
/// far (epsilon = its inlier rate) and delta (options.sprt_delta, then the inlier rate measured on
/// the hypotheses rejected in earlier batches); the test state changes only at the merge, so it
/// too is the same for every thread count. The stopping rule is lengthened for the probability
/// 1 / A of rejecting a good model (robust/sprt.hpp).
///
/// Errors. Invalid options (threshold <= 0 or non-finite, ...) throw diachron::Error from the
/// constructor; a null data pointer with a non-zero size throws from run(). "No answer" is not an
/// error: empty data, fewer data than Estimator::kSampleSize, samples that are all degenerate, or a
/// best model with fewer than options.min_inliers inliers give `success == false` and a message.
/// Non-finite data are not checked here (the Datum type is opaque): their residuals are +inf or
/// NaN, which count as outliers, so they never support a model. The convenience functions of
/// robust/robust_estimation.hpp reject them with diachron::Error instead.
///
/// The input is read in place: never copied (minimal samples copy kSampleSize data) nor reordered.
/// Thread safety: run() is const and may be called concurrently on one object.
///
/// @tparam Estimator models the Estimator concept.
/// @tparam Sampler, Scoring, Termination, LocalOptimization model their concepts (see above).
template <class Estimator, class Sampler = UniformSampler, class Scoring = Msac,
          class Termination = Adaptive, class LocalOptimization = Refit>
class Ransac {
  static_assert(check_estimator<Estimator>(),
                "Ransac's first template argument must model the Estimator concept "
                "(see diachron/robust/estimator.hpp)");
  static_assert(is_sampler_v<Sampler>,
                "Sampler must have `void prepare(std::size_t, std::size_t)` and `void "
                "draw(std::size_t, RandomStream&, std::size_t*) const` (see "
                "diachron/robust/uniform_sampler.hpp)");
  static_assert(is_scoring_v<Scoring>,
                "Scoring must have `double gain(double residual, double threshold) const` and a "
                "`bool early_exit` member (see diachron/robust/inlier_count_scoring.hpp)");
  static_assert(is_termination_v<Termination>,
                "Termination must have `std::size_t required_iterations(const RansacOptions&, "
                "std::size_t, std::size_t, std::size_t) const` or `std::size_t "
                "required_iterations(const RansacOptions&, const TerminationState&) const` (see "
                "diachron/robust/fixed_iterations.hpp)");
  static_assert(is_local_optimization_v<LocalOptimization, Estimator, Scoring>,
                "LocalOptimization must have `bool optimize(const RansacProblem<E, S>&, Model&, "
                "Support&, std::size_t&) const` (see diachron/robust/no_local_optimization.hpp)");

 public:
  using Datum = typename Estimator::Datum;
  using Model = typename Estimator::Model;
  using Report = RansacReport<Model>;
  static constexpr std::size_t kSampleSize = Estimator::kSampleSize;

  /// Hypotheses per batch once the schedule 1, 2, 4, ... has grown (see the class comment).
  static constexpr std::size_t kMaxBatch = 64;
  /// Random stream of the screening sample (bail-out test, SPRT): RandomStream(seed, this).
  static constexpr std::uint64_t kScreeningStream = std::uint64_t{1} << 62;

  /// @throws diachron::Error when `options.check()` fails.
  explicit Ransac(const RansacOptions& options = {}, Estimator estimator = {},
                  Sampler sampler = {}, Scoring scoring = {}, Termination termination = {},
                  LocalOptimization local_optimization = {})
      : options_(options),
        estimator_(std::move(estimator)),
        sampler_(std::move(sampler)),
        scoring_(std::move(scoring)),
        termination_(std::move(termination)),
        local_optimization_(std::move(local_optimization)) {
    options_.check();
  }

  const RansacOptions& options() const { return options_; }
  const Estimator& estimator() const { return estimator_; }

  /// Runs RANSAC on `data` (not modified, not copied).
  Report run(const std::vector<Datum>& data) const { return run(data.data(), data.size()); }

  /// Runs RANSAC on the `size` data at `data` (not modified, not copied; must outlive the call).
  /// @throws diachron::Error when `data` is null and `size` > 0.
  Report run(const Datum* data, std::size_t size) const;

 private:
  // What one iteration produced, computed independently of every other iteration.
  struct Slot {
    Model model{};
    Support support;
    bool has_model = false;
    std::size_t generated = 0;
    std::size_t stopped_early = 0;
    std::size_t rejected_sprt = 0;
    std::size_t bailed_out = 0;
    std::size_t rejected_evaluated = 0;
    std::size_t rejected_inliers = 0;
    std::size_t degenerate = 0;
    std::size_t residual_evaluations = 0;
  };

  using Problem = RansacProblem<Estimator, Scoring>;

  void run_iteration(const Problem& problem, const Sampler& sampler, std::size_t iteration,
                     double bound, double sample_bound, const SprtTest* sprt, Slot& slot) const;

  std::size_t needed_iterations(const Termination& termination, const TerminationState& state,
                                double false_rejection = 0.0) const {
    std::size_t k = required_iterations(termination, options_, state);
    if (false_rejection > 0.0 && k < options_.max_iterations) {
      const double p = std::pow(
          static_cast<double>(state.best_inliers) / static_cast<double>(state.num_data),
          static_cast<double>(kSampleSize));
      const double adjusted =
          sprt_adjusted_iterations(static_cast<double>(k), p, false_rejection);
      k = adjusted >= static_cast<double>(options_.max_iterations)
              ? options_.max_iterations
              : static_cast<std::size_t>(adjusted);
    }
    return std::min(std::max<std::size_t>(k, 1), options_.max_iterations);
  }

  RansacOptions options_;
  Estimator estimator_;
  Sampler sampler_;
  Scoring scoring_;
  Termination termination_;
  LocalOptimization local_optimization_;
};

// Implementation -----------------------------------------------------------------------------------

template <class E, class Sa, class Sc, class T, class L>
void Ransac<E, Sa, Sc, T, L>::run_iteration(const Problem& problem, const Sa& sampler,
                                            std::size_t iteration, double bound,
                                            double sample_bound, const SprtTest* sprt,
                                            Slot& slot) const {
  // Fields reset one by one: the model is overwritten before it is read, and assigning a
  // value-initialised Eigen model would copy uninitialised storage.
  slot.has_model = false;
  slot.support = Support{};
  slot.generated = 0;
  slot.stopped_early = 0;
  slot.rejected_sprt = 0;
  slot.bailed_out = 0;
  slot.rejected_evaluated = 0;
  slot.rejected_inliers = 0;
  slot.degenerate = 0;
  slot.residual_evaluations = 0;
  RandomStream rng(options_.seed, iteration);
  std::array<std::size_t, kSampleSize> indices{};
  typename E::Sample sample;
  for (std::size_t attempt = 0; attempt < options_.max_sample_attempts; ++attempt) {
    sampler.draw(iteration, rng, indices.data());
    for (std::size_t k = 0; k < kSampleSize; ++k) sample[k] = problem.data()[indices[k]];
    if constexpr (estimator_has_degenerate_v<E>) {
      if (estimator_.degenerate(sample)) {
        ++slot.degenerate;
        continue;
      }
    }
    const auto models = estimator_.minimal(sample);
    if (models.empty()) {
      ++slot.degenerate;
      continue;
    }
    slot.generated += models.size();
    for (const auto& model : models) {
      // Only a model strictly better than both the batch's bound and this sample's best so far
      // can matter, so that is the bar for early exit.
      const double bar = slot.has_model ? std::max(bound, slot.support.score) : bound;
      const Support support =
          problem.score(model, bar, slot.residual_evaluations, sprt, sample_bound);
      if (!support.complete) {
        ++slot.stopped_early;
        if (support.bailed_out) ++slot.bailed_out;
        if (support.rejected_by_sprt) {
          ++slot.rejected_sprt;
          slot.rejected_evaluated += support.evaluated;
          slot.rejected_inliers += support.inliers_seen;
        }
        continue;
      }
      if (!slot.has_model || support.score > slot.support.score) {
        slot.model = model;
        slot.support = support;
        slot.has_model = true;
      }
    }
    return;
  }
}

template <class E, class Sa, class Sc, class T, class L>
typename Ransac<E, Sa, Sc, T, L>::Report Ransac<E, Sa, Sc, T, L>::run(const Datum* data,
                                                                      std::size_t size) const {
  DIACHRON_CHECK(data != nullptr || size == 0, "Ransac::run: null data pointer with size " << size);
  Report report;
  report.num_data = size;
  if (size == 0) {
    report.message = "no data";
    return report;
  }
  if (size < kSampleSize) {
    std::ostringstream out;
    out << "fewer data (" << size << ") than the minimal sample (" << kSampleSize << ")";
    report.message = out.str();
    return report;
  }

  // The random sample of the bail-out test and of the SPRT, from a stream no iteration (i) and no
  // local optimisation (~i) uses while iterations stay below 2^62.
  BailOutSample screening;
  if ((options_.bail_out_risk > 0.0 && scoring_.early_exit) || options_.sprt) {
    RandomStream screening_rng(options_.seed, kScreeningStream);
    screening = make_bail_out_sample(size, scoring_.early_exit ? options_.bail_out_risk : 0.0,
                                     screening_rng);
  }
  const Problem problem(estimator_, scoring_, data, size, options_.threshold, &screening);
  Sa sampler = sampler_;
  sampler.prepare(size, kSampleSize);
  T termination = termination_;
  if constexpr (detail::termination_has_prepare<T>::value) termination.prepare(size, kSampleSize);
  // The best model's inlier indices, kept only for a Termination policy that asks for them.
  constexpr bool kTrackInliers = detail::termination_needs_best_inliers<T>::value;
  std::vector<std::size_t> best_inlier_indices;
  const std::size_t threads = resolve_threads(options_.threads);

  Model best_model{};
  Support best;  // score 0: a hypothesis must have some positive gain to become the best
  // The best model's score on the screening sample: 0 before there is one (a hypothesis must show
  // some support on the sample to earn a full pass), -inf without the bail-out test.
  const bool bail_out = screening.bails_out() && scoring_.early_exit;
  double best_sample_score = bail_out ? 0.0 : -std::numeric_limits<double>::infinity();
  bool has_best = false;
  std::vector<Slot> slots(kMaxBatch);
  std::size_t iteration = 0;
  // SPRT state: changed only at the merge, in iteration order.
  std::size_t rejected_evaluated = 0;
  std::size_t rejected_inliers = 0;
  const auto current_sprt = [&]() {
    if (!options_.sprt || !has_best) return SprtTest{};
    double delta = options_.sprt_delta;
    if (rejected_evaluated >= 10 * kScoreBlock) {
      delta = std::max(static_cast<double>(rejected_inliers), 1.0) /
              static_cast<double>(rejected_evaluated);
    }
    const double epsilon = static_cast<double>(best.num_inliers) / static_cast<double>(size);
    // Models per sample, m_S of the paper: measured over the iterations merged so far.
    const double models_per_sample =
        static_cast<double>(report.hypotheses_generated) /
        static_cast<double>(std::max<std::size_t>(iteration, 1));
    return make_sprt_test(epsilon, delta, options_.sprt_model_cost, models_per_sample);
  };
  const auto termination_state = [&](std::size_t done) {
    TerminationState state;
    state.iterations = done;
    state.best_inliers = best.num_inliers;
    state.num_data = size;
    state.sample_size = kSampleSize;
    if constexpr (detail::sampler_has_pool_size<Sa>::value) {
      state.pool_size = sampler.pool_size(done);
    } else {
      state.pool_size = size;
    }
    if (kTrackInliers && has_best) state.best_inlier_indices = &best_inlier_indices;
    return state;
  };
  std::size_t needed = needed_iterations(termination, termination_state(0));
  std::size_t batch = 1;
  while (iteration < needed) {
    const std::size_t begin = iteration;
    const std::size_t count = std::min(batch, needed - begin);
    batch = std::min(batch * 2, kMaxBatch);
    const double bound = best.score;
    const double sample_bound = best_sample_score;
    const SprtTest sprt = current_sprt();
    const SprtTest* sprt_ptr = sprt.active ? &sprt : nullptr;
    if (threads > 1 && count > 1) {
      parallel_for(count, threads, [&](std::size_t j) {
        run_iteration(problem, sampler, begin + j, bound, sample_bound, sprt_ptr, slots[j]);
      });
    }
    for (std::size_t j = 0; j < count; ++j) {
      Slot& slot = slots[j];
      // One thread computes each iteration only when the merge reaches it, so no hypothesis past
      // the stopping iteration is ever built; the bound is the same as with many threads.
      if (threads <= 1 || count == 1) {
        run_iteration(problem, sampler, begin + j, bound, sample_bound, sprt_ptr, slot);
      }
      report.hypotheses_generated += slot.generated;
      report.hypotheses_stopped_early += slot.stopped_early;
      report.hypotheses_rejected_sprt += slot.rejected_sprt;
      report.hypotheses_bailed_out += slot.bailed_out;
      rejected_evaluated += slot.rejected_evaluated;
      rejected_inliers += slot.rejected_inliers;
      report.degenerate_samples += slot.degenerate;
      report.residual_evaluations += slot.residual_evaluations;
      const bool updated = slot.has_model && slot.support.score > best.score;
      if (updated) {
        best_model = slot.model;
        best = slot.support;
        has_best = true;
        ++report.best_updates;
        const std::size_t evaluations_before = report.residual_evaluations;
        bool improved = false;
        if constexpr (detail::local_optimization_takes_stream<L, E, Sc>::value) {
          RandomStream lo_rng(options_.seed, ~static_cast<std::uint64_t>(begin + j));
          improved = local_optimization_.optimize(problem, best_model, best,
                                                  report.residual_evaluations, lo_rng);
        } else {
          improved = local_optimization_.optimize(problem, best_model, best,
                                                  report.residual_evaluations);
        }
        if (improved) ++report.local_optimization_improvements;
        if (report.residual_evaluations != evaluations_before) ++report.local_optimizations;
        if (bail_out) {
          // On a complete sample the best's score is its sample score, summed in the same order.
          best_sample_score = screening.complete
                                  ? best.score
                                  : problem.sample_score(best_model, report.residual_evaluations);
        }
        if constexpr (kTrackInliers) {
          problem.inliers(best_model, best_inlier_indices, nullptr, report.residual_evaluations);
        }
      }
      iteration = begin + j + 1;
      needed = needed_iterations(termination, termination_state(iteration),
                                 options_.sprt ? current_sprt().false_rejection() : 0.0);
      // The batch ends at a new best: later slots were scored against the old bound (and are
      // dropped, uncounted, when workers computed them), so every iteration is scored against the
      // best of all iterations before it, whatever the thread count and batch sizes.
      if (iteration >= needed || updated) break;
    }
  }
  report.iterations = iteration;

  if (!has_best) {
    std::ostringstream out;
    if (report.hypotheses_generated == 0) {
      out << "every sample was degenerate (" << iteration << " iterations of up to "
          << options_.max_sample_attempts << " draws)";
    } else {
      out << "no hypothesis had a single inlier (" << report.hypotheses_generated
          << " hypotheses)";
    }
    report.message = out.str();
    return report;
  }

  // The final model: one unweighted refit on all inliers of the best model (when the estimator can
  // refine), kept unless its truncated quadratic (MSAC) cost on all data is higher. Not the Scoring
  // policy's score: under InlierCount a least-squares refit that moves one or two inliers across
  // the threshold would lose to the raw minimal-sample model, whose error can be 40 times larger
  // (issue 12); the least-squares fit never raises the truncated cost over the inliers it was fit
  // on, so a refit is rejected only when it really explains the data worse. Its final pass is also
  // the report's, so the refit costs an inlier pass, one least-squares fit and nothing more.
  // Room for the inliers up front: growing a vector of half a million indices costs about as much
  // as the pass that fills it.
  const std::size_t expected_inliers = best.num_inliers + best.num_inliers / 16 + kScoreBlock;
  std::vector<std::size_t> inliers;
  inliers.reserve(expected_inliers);
  double score = 0.0;
  double sum_squares = 0.0;
  bool final_pass_done = false;
  if constexpr (estimator_has_refine_v<E>) {
    if (options_.final_refit) {
      double best_squares = 0.0;
      problem.inliers(best_model, inliers, nullptr, report.residual_evaluations, &best_squares);
      if (inliers.size() >= kSampleSize) {
        const Subset<Datum> subset(data, inliers.data(), inliers.size());
        const auto refined = estimator_.refine(best_model, subset, nullptr);
        if (refined) {
          std::vector<char> mask;
          std::vector<std::size_t> refined_inliers;
          refined_inliers.reserve(expected_inliers);
          double refined_score = 0.0, refined_squares = 0.0;
          problem.final_pass(*refined, mask, refined_inliers, refined_score, refined_squares);
          report.residual_evaluations += size;
          if (problem.truncated_cost(refined_inliers.size(), refined_squares) <=
              problem.truncated_cost(inliers.size(), best_squares)) {
            best_model = *refined;
            report.inlier_mask = std::move(mask);
            inliers = std::move(refined_inliers);
            score = refined_score;
            sum_squares = refined_squares;
            report.final_refit = true;
            final_pass_done = true;
          }
        }
      }
    }
  }
  if (!final_pass_done) {
    problem.final_pass(best_model, report.inlier_mask, inliers, score, sum_squares);
    report.residual_evaluations += size;
  }

  const std::size_t min_inliers =
      options_.min_inliers == 0 ? kSampleSize + 1 : options_.min_inliers;
  if (inliers.size() < min_inliers) {
    std::ostringstream out;
    out << "best model has " << inliers.size() << " inliers, fewer than the " << min_inliers
        << " required (RansacOptions::min_inliers)";
    report.message = out.str();
    report.inlier_mask.clear();
    return report;
  }
  report.success = true;
  report.message.clear();
  report.model = best_model;
  report.score = score;
  report.rms = std::sqrt(sum_squares / static_cast<double>(inliers.size()));
  report.inliers = std::move(inliers);
  return report;
}

}  // namespace diachron
