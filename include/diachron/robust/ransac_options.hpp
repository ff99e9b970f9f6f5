#pragma once
/// @file
/// Options shared by every diachron::Ransac composition, whatever its policies. Policy-specific
/// knobs (the Adaptive multiplier, the Refit iteration count, ...) live in the policy objects.

#include <cmath>
#include <cstddef>
#include <cstdint>

#include <diachron/core/error.hpp>

namespace diachron {

/// Options of diachron::Ransac. Defaults follow the paper (Zhang et al., 1000 iterations) where it
/// says something, and the estimator literature otherwise. `check()` validates them; Ransac's
/// constructor calls it, so an invalid value throws diachron::Error before any work is done.
struct RansacOptions {
  /// Inlier threshold on the estimator's residual, in data units (not squared): pixels for 2D
  /// correspondences, target-frame metres for 3D ones. A datum is an inlier when
  /// `residual <= threshold`. Must be finite and > 0. The paper uses 10 px for the rough
  /// co-registration and 10 x GSD for the 3D Helmert; there is no meaningful universal default, so
  /// the default (1.0) only keeps a default-constructed object valid.
  double threshold = 1.0;

  /// Hard cap on the number of iterations (minimal samples drawn), >= 1. The paper runs exactly
  /// 1000; with Adaptive termination this is the most that is run, with FixedIterations it is
  /// exactly what is run.
  std::size_t max_iterations = 1000;

  /// Iterations always run before Adaptive termination may stop, in [0, max_iterations].
  /// 0 lets the stopping rule alone decide. Ignored by FixedIterations.
  std::size_t min_iterations = 0;

  /// Probability, in (0, 1], that Adaptive termination has drawn at least one all-inlier sample
  /// before it stops (exact without-replacement rule). 1 means "never stop early": every run then
  /// uses exactly max_iterations, which is the paper's fixed-count behaviour. Ignored by
  /// FixedIterations.
  double confidence = 0.999;

  /// Seed of the random streams. The sample of iteration i comes from RandomStream(seed, i), so the
  /// same seed gives the same report whatever `threads`.
  std::uint64_t seed = 0;

  /// Worker threads for generating and scoring hypotheses; 0 means all cores. The report does not
  /// depend on it. Threads only pay off when scoring one hypothesis is expensive (many data).
  std::size_t threads = 1;

  /// Fewest inliers a final model needs for `success`. 0 (default) means kSampleSize + 1: a model
  /// supported only by the sample it was computed from is not evidence of anything.
  std::size_t min_inliers = 0;

  /// Samples drawn per iteration before the iteration is given up, >= 1: a sample is redrawn (from
  /// the same iteration's stream) when the estimator calls it degenerate or its minimal solver
  /// returns no model. The cap keeps an all-degenerate data set from looping forever.
  std::size_t max_sample_attempts = 100;

  /// After the main loop, refit the best model on all its inliers with Estimator::refine (when the
  /// estimator has one, one unweighted fit) and keep the refit unless its truncated quadratic cost
  /// sum(min(r^2, threshold^2)) over all data is higher than the unrefined model's, whatever the
  /// Scoring policy: an inlier count would reject a better fit that loses an inlier or two at the
  /// threshold. The report's score is the kept model's (it may then be below the loop's best).
  bool final_refit = true;

  /// Risk, in [0, 1), of the bail-out test (Capel 2005; robust/bail_out.hpp): before its full pass,
  /// a hypothesis is scored on a random sample of the data (all of them in random order up to 4096,
  /// else an eighth of them, 4096 to 65536, drawn once per run so input order cannot bias it) and
  /// dropped once its partial score shows, by Hoeffding's inequality, that it is below the best
  /// so far. A hypothesis at least as good as the best is dropped with probability at most this
  /// risk; those it most often concerns are near ties with the best, which local optimisation and
  /// the final refit have already improved on. 0 turns the test off (every hypothesis then gets
  /// the exact treatment alone). Applies only when the Scoring policy's early_exit is on, and only
  /// to 256 data or more.
  double bail_out_risk = 1e-3;

  /// Reject hypotheses early with the sequential probability ratio test of randomized RANSAC
  /// (Matas and Chum 2005; robust/sprt.hpp): at the checkpoints of the bail-out sample (random
  /// order; after every block of 64 data in input order for fewer than 256 data), a hypothesis whose
  /// inliers so far are much likelier under "bad model" (inlier rate sprt_delta, re-estimated from
  /// the rejected models) than under "as good as the best so far" is dropped. A good model is
  /// dropped with probability at most 1 / A (typically 1e-2 to 1e-3); the adaptive stopping rule is
  /// lengthened to make up for it. The exact early exit still applies. Off by default: it trades a
  /// small chance of missing the best hypothesis for far fewer residual evaluations per losing
  /// hypothesis (see docs/benchmarks.md).
  bool sprt = false;
  /// Initial inlier rate of bad models, in (0, 1); replaced by the rate measured on rejected
  /// hypotheses once they have been evaluated on at least 10 * 64 data in total.
  double sprt_delta = 0.05;
  /// Cost of making one hypothesis (sampling, minimal solver), in residual evaluations, > 0: the
  /// paper's t_M, which sets the test's threshold A. Larger values make A larger (fewer false
  /// rejections, later rejection of bad models).
  double sprt_model_cost = 200.0;

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    DIACHRON_CHECK(std::isfinite(threshold) && threshold > 0.0,
                   "RansacOptions::threshold must be finite and > 0, got " << threshold);
    DIACHRON_CHECK(max_iterations >= 1, "RansacOptions::max_iterations must be >= 1");
    DIACHRON_CHECK(min_iterations <= max_iterations,
                   "RansacOptions::min_iterations (" << min_iterations
                                                     << ") exceeds max_iterations ("
                                                     << max_iterations << ")");
    DIACHRON_CHECK(confidence > 0.0 && confidence <= 1.0,
                   "RansacOptions::confidence must be in (0, 1], got " << confidence);
    DIACHRON_CHECK(max_sample_attempts >= 1, "RansacOptions::max_sample_attempts must be >= 1");
    DIACHRON_CHECK(bail_out_risk >= 0.0 && bail_out_risk < 1.0,
                   "RansacOptions::bail_out_risk must be in [0, 1), got " << bail_out_risk);
    DIACHRON_CHECK(sprt_delta > 0.0 && sprt_delta < 1.0,
                   "RansacOptions::sprt_delta must be in (0, 1), got " << sprt_delta);
    DIACHRON_CHECK(std::isfinite(sprt_model_cost) && sprt_model_cost > 0.0,
                   "RansacOptions::sprt_model_cost must be finite and > 0, got "
                       << sprt_model_cost);
  }
};

}  // namespace diachron
