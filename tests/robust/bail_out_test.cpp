#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <numeric>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/robust/bail_out.hpp>
#include <diachron/robust/robust_estimation.hpp>

#include "robust/test_estimators.hpp"

using diachron::BailOutSample;
using diachron::PointPair2;
using diachron::RandomStream;
using diachron::RansacOptions;

namespace {

using diachron_test::similarity_pairs;

bool is_true_inlier(std::size_t index, std::size_t inliers, std::size_t outliers,
                    bool outliers_first) {
  return outliers_first ? index >= outliers : index < inliers;
}

// Population gains in [0, 1]: an inlier adds an MSAC-like gain (uniform in [0.5, 1], mean 0.75;
// with Gaussian noise and a 3-sigma threshold MSAC's mean inlier gain is 1 - 2/9 = 0.78), an
// outlier 0.
std::vector<double> population(std::size_t n, double inlier_rate, std::uint64_t seed) {
  RandomStream rng(seed, 3);
  std::vector<double> gains(n);
  for (double& g : gains) g = rng.uniform(0.0, 1.0) < inlier_rate ? rng.uniform(0.5, 1.0) : 0.0;
  return gains;
}

double mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return sum / static_cast<double>(v.size());
}

// The first checkpoint at which `sample` drops a hypothesis with these population gains against
// `mean_to_beat`, or 0 when it never does.
std::size_t bail_checkpoint(const BailOutSample& sample, const std::vector<double>& gains,
                            double mean_to_beat) {
  double partial = 0.0;
  std::size_t done = 0;
  for (const std::size_t checkpoint : sample.checkpoints) {
    for (; done < checkpoint; ++done) partial += gains[sample.indices[done]];
    if (sample.should_bail(partial, done, mean_to_beat)) return checkpoint;
  }
  return 0;
}

}  // namespace

TEST_CASE("BailOutSample: size, checkpoints and indices", "[robust]") {
  CHECK(diachron::bail_out_sample_size(255) == 0);
  CHECK(diachron::bail_out_sample_size(256) == 256);
  CHECK(diachron::bail_out_sample_size(4096) == 4096);
  CHECK(diachron::bail_out_sample_size(4097) == 4096);
  CHECK(diachron::bail_out_sample_size(100000) == 12500);
  CHECK(diachron::bail_out_sample_size(5000000) == diachron::kMaxBailOutSample);

  RandomStream rng(5, 1);
  CHECK(diachron::make_bail_out_sample(255, 1e-3, rng).empty());

  for (std::size_t n : {300u, 4000u, 10000u, 100000u, 1000000u}) {
    RandomStream a(7, 1), b(7, 1);
    const BailOutSample sample = diachron::make_bail_out_sample(n, 1e-3, a);
    INFO("n " << n);
    REQUIRE(sample.indices.size() == diachron::bail_out_sample_size(n));
    REQUIRE(sample.bails_out());
    CHECK(sample.complete == (n <= diachron::kMaxCompleteBailOutSample));
    if (sample.complete) {
      // A permutation of all data, not the identity.
      std::vector<std::size_t> sorted = sample.indices;
      std::sort(sorted.begin(), sorted.end());
      std::vector<std::size_t> all(n);
      std::iota(all.begin(), all.end(), std::size_t{0});
      CHECK(sorted == all);
      CHECK(sample.indices != all);
    }
    if (!sample.complete) {
      // Each stretch between checkpoints: one index per stratum of the whole input, increasing.
      std::size_t begin = 0;
      bool in_strata = true;
      for (const std::size_t end : sample.checkpoints) {
        const double width = static_cast<double>(n) / static_cast<double>(end - begin);
        for (std::size_t k = begin; k < end; ++k) {
          const double index = static_cast<double>(sample.indices[k]);
          const double low = static_cast<double>(k - begin) * width;
          in_strata = in_strata && index >= std::floor(low) && index < low + width;
        }
        CHECK(std::is_sorted(sample.indices.begin() + static_cast<std::ptrdiff_t>(begin),
                             sample.indices.begin() + static_cast<std::ptrdiff_t>(end)));
        begin = end;
      }
      CHECK(in_strata);
    }
    CHECK(sample.checkpoints.front() == diachron::kFirstBailOutCheckpoint);
    CHECK(sample.checkpoints.back() == sample.indices.size());
    CHECK(std::is_sorted(sample.checkpoints.begin(), sample.checkpoints.end()));
    CHECK(std::adjacent_find(sample.checkpoints.begin(), sample.checkpoints.end()) ==
          sample.checkpoints.end());
    CHECK(*std::max_element(sample.indices.begin(), sample.indices.end()) < n);
    // Spread over the whole input, not bunched at its head, from the very first checkpoint on.
    const std::size_t head = std::min<std::size_t>(sample.indices.size(), 1024);
    const double mean_index =
        std::accumulate(sample.indices.begin(), sample.indices.begin() + head, 0.0) /
        static_cast<double>(head);
    CHECK(std::abs(mean_index / static_cast<double>(n) - 0.5) < 0.05);
    // Same stream, same sample.
    CHECK(diachron::make_bail_out_sample(n, 1e-3, b).indices == sample.indices);
    CHECK(sample.log_term ==
          Approx(0.5 * std::log(static_cast<double>(sample.checkpoints.size()) / 1e-3)));
  }

  RandomStream c(7, 1);
  const BailOutSample no_test = diachron::make_bail_out_sample(100000, 0.0, c);
  CHECK_FALSE(no_test.empty());
  CHECK_FALSE(no_test.bails_out());
  CHECK_FALSE(no_test.should_bail(0.0, 1000, 0.9));  // risk 0: never
}

TEST_CASE("BailOutSample: a hypothesis as good as the best is dropped at most `risk` of the time",
          "[robust]") {
  // A generous risk so that the rate is measurable in a few thousand trials: the Hoeffding bound
  // holds whatever the gains' distribution, so the observed rate must stay below it.
  const double risk = 0.1;
  // A permutation sample (4000 data), and a partial stratified one (200k data) on gains in input
  // order: every inlier in the first half, as a sorted match list would have them.
  for (const bool ordered : {false, true}) {
    std::vector<double> gains = population(ordered ? 200000 : 4000, 0.5, 1);
    if (ordered) std::sort(gains.begin(), gains.end(), std::greater<double>());
    const double mu = mean(gains);
    const int trials = ordered ? 300 : 2000;
    // A hypothesis 10 % worse everywhere, to show the test has power.
    std::vector<double> worse = gains;
    for (double& g : worse) g *= 0.9;
    int dropped = 0;
    int dropped_loose = 0;
    int dropped_worse = 0;
    double first_stretch = 0.0;  // mean gain of the first 64 sampled data, over the trials
    for (int t = 0; t < trials; ++t) {
      RandomStream rng(100 + static_cast<std::uint64_t>(t), 1);
      BailOutSample sample = diachron::make_bail_out_sample(gains.size(), risk, rng);
      REQUIRE(sample.complete == !ordered);
      for (std::size_t k = 0; k < 64; ++k) first_stretch += gains[sample.indices[k]] / 64.0;
      if (bail_checkpoint(sample, gains, mu) != 0) ++dropped;
      if (bail_checkpoint(sample, worse, mu) != 0) ++dropped_worse;
      // With a hundredth of the margin's square, the test would break its promise.
      sample.log_term /= 100.0;
      if (bail_checkpoint(sample, gains, mu) != 0) ++dropped_loose;
    }
    INFO("ordered " << ordered << " dropped " << dropped << " loose " << dropped_loose
                    << " worse " << dropped_worse << " of " << trials);
    CHECK(static_cast<double>(dropped) / trials <= risk);
    CHECK(dropped_worse >= 0.9 * trials);
    // Stratified draws on ordered data vary far less than the bound allows; the permutation
    // shows the bound is not vacuous.
    if (!ordered) CHECK(dropped_loose > trials / 10);
    // Unbiased even on ordered data: the sampled mean matches the population's.
    CHECK(first_stretch / trials == Approx(mu).margin(0.02));
  }
}

TEST_CASE("BailOutSample: clearly worse hypotheses go within a few hundred data", "[robust]") {
  const std::vector<double> best = population(200000, 0.5, 2);
  const double mu = mean(best);
  RandomStream rng(9, 1);
  const BailOutSample sample = diachron::make_bail_out_sample(best.size(), 1e-3, rng);
  // A wrong model: a few percent of chance inliers.
  CHECK(bail_checkpoint(sample, population(200000, 0.03, 3), mu) == 64);
  // A model with a quarter less mean gain.
  const std::size_t at = bail_checkpoint(sample, population(200000, 0.375, 4), mu);
  CHECK(at > 0);
  CHECK(at <= 2048);
  // A better one is never dropped here.
  CHECK(bail_checkpoint(sample, population(200000, 0.6, 5), mu) == 0);
}

TEST_CASE("Ransac with the bail-out test: same answer as exact scoring, fewer evaluations",
          "[robust]") {
  const std::size_t inliers = 10000;
  for (double ratio : {0.1, 0.5, 0.9}) {
    const auto outliers = static_cast<std::size_t>(std::lround(inliers * ratio / (1.0 - ratio)));
    for (bool outliers_first : {false, true}) {
      for (std::uint64_t seed : {1u, 2u, 3u}) {
        const auto data = similarity_pairs(inliers, outliers, seed, outliers_first);
        RansacOptions options;
        options.threshold = 3.0;
        options.seed = seed;
        options.max_iterations = 5000;
        options.bail_out_risk = 0.0;
        const auto exact = diachron::ransac_similarity2(data, options);
        options.bail_out_risk = 1e-3;
        const auto fast = diachron::ransac_similarity2(data, options);
        INFO("outliers " << ratio << " outliers first " << outliers_first << " seed " << seed
                         << " passes " << exact.data_passes() << " vs " << fast.data_passes());
        REQUIRE(exact.success);
        REQUIRE(fast.success);
        std::size_t found = 0;
        for (std::size_t i : fast.inliers) found += is_true_inlier(i, inliers, outliers, outliers_first);
        CHECK(found >= 0.95 * inliers);
        CHECK(std::abs(fast.model.angle - 0.3) < 1e-3);
        CHECK(std::abs(fast.model.scale - 1.2) < 1e-3);
        CHECK(std::abs(fast.model.angle - exact.model.angle) < 2e-4);
        CHECK(fast.hypotheses_bailed_out > 0);
        CHECK(fast.hypotheses_bailed_out <= fast.hypotheses_stopped_early);
        CHECK(exact.hypotheses_bailed_out == 0);
        // Savings where losing hypotheses abound; at 10 % outliers most hypotheses are near-ties
        // that pay for the sample and then the full pass, a bounded overhead.
        if (ratio >= 0.5) CHECK(fast.residual_evaluations < exact.residual_evaluations);
        CHECK(fast.data_passes() <= 1.25 * exact.data_passes());
      }
    }
  }
}

TEST_CASE("Ransac with the bail-out test on a partial sample (200k data): a fraction of the passes",
          "[robust]") {
  // Above kMaxCompleteBailOutSample data the sample is partial: hypotheses that do not beat the best on it
  // never cost a full pass, even before a good model is known.
  for (bool outliers_first : {false, true}) {
    const auto data = similarity_pairs(100000, 100000, 8, outliers_first);
    RansacOptions options;
    options.threshold = 3.0;
    options.seed = 8;
    options.bail_out_risk = 0.0;
    const auto exact = diachron::ransac_similarity2(data, options);
    options.bail_out_risk = 1e-3;
    const auto fast = diachron::ransac_similarity2(data, options);
    INFO("outliers first " << outliers_first << " passes " << exact.data_passes() << " vs "
                           << fast.data_passes());
    REQUIRE(exact.success);
    REQUIRE(fast.success);
    CHECK(std::abs(fast.model.angle - exact.model.angle) < 1e-4);
    CHECK(std::abs(fast.model.scale - exact.model.scale) < 1e-4);
    CHECK(fast.inliers.size() >= 0.999 * exact.inliers.size());
    CHECK(fast.data_passes() < 0.6 * exact.data_passes());  // 0.29 and 0.24 when written
  }
}

TEST_CASE("Ransac: the bail-out test needs early exit and enough data", "[robust]") {
  RansacOptions options;
  options.threshold = 3.0;
  options.seed = 4;
  // Fewer than 256 data: no sample, nothing bailed.
  const auto small = similarity_pairs(120, 120, 4, false);
  CHECK(diachron::ransac_similarity2(small, options).hypotheses_bailed_out == 0);
  // Scoring without early exit scores every hypothesis in full.
  const auto data = similarity_pairs(4000, 4000, 4, false);
  diachron::Msac exhaustive;
  exhaustive.early_exit = false;
  const auto report = diachron::DefaultRansac<diachron::Similarity2Estimator>(
                          options, {}, {}, exhaustive)
                          .run(data);
  REQUIRE(report.success);
  CHECK(report.hypotheses_bailed_out == 0);
  CHECK(report.hypotheses_stopped_early == 0);
  CHECK(diachron::ransac_similarity2(data, options).hypotheses_bailed_out > 0);
}
