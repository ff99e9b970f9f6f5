#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/geometry/similarity2_estimator.hpp>
#include <diachron/robust/prosac_sampler.hpp>
#include <diachron/robust/prosac_termination.hpp>
#include <diachron/robust/ransac.hpp>

#include "robust/test_estimators.hpp"

using diachron::ProsacTermination;
using diachron::RansacOptions;
using diachron::TerminationState;

static_assert(diachron::is_termination_v<ProsacTermination>, "ProsacTermination is a Termination");

namespace {

// P(Binomial(n, p) >= k) by direct summation of the pmf (small n only).
double binomial_tail(std::size_t n, double p, std::size_t k) {
  double sum = 0.0;
  for (std::size_t j = k; j <= n; ++j) {
    const double log_choose = std::lgamma(n + 1.0) - std::lgamma(j + 1.0) - std::lgamma(n - j + 1.0);
    sum += std::exp(log_choose + j * std::log(p) + (n - j) * std::log1p(-p));
  }
  return sum;
}

TerminationState state_of(const std::vector<std::size_t>& inliers, std::size_t num_data,
                          std::size_t sample_size, std::size_t iterations = 1) {
  TerminationState state;
  state.iterations = iterations;
  state.best_inliers = inliers.size();
  state.num_data = num_data;
  state.sample_size = sample_size;
  state.pool_size = num_data;
  state.best_inlier_indices = &inliers;
  return state;
}

// Similarity2 pairs (1 px noise) ranked as a matcher would rank them: the top `top` hold
// `top_inliers` inliers, the rest `rest_inliers`, each part in random order. in[i] says whether
// datum i is an inlier.
struct RankedPairs {
  std::vector<diachron::PointPair2> data;
  std::vector<bool> in;
};

RankedPairs ranked_pairs(std::size_t num_data, std::size_t top, std::size_t top_inliers,
                         std::size_t rest_inliers, std::uint64_t seed) {
  diachron::RandomStream rng(seed, 3);
  RankedPairs ranked;
  const auto part = [&](std::size_t count, std::size_t inliers) {
    std::vector<bool> flags(count, false);
    std::fill(flags.begin(), flags.begin() + static_cast<std::ptrdiff_t>(inliers), true);
    for (std::size_t i = count; i > 1; --i) {  // Fisher-Yates
      const std::size_t j = rng.uniform_index(i);
      const bool t = flags[i - 1];
      flags[i - 1] = flags[j];
      flags[j] = t;
    }
    ranked.in.insert(ranked.in.end(), flags.begin(), flags.end());
  };
  part(top, top_inliers);
  part(num_data - top, rest_inliers);
  for (const bool inlier : ranked.in) ranked.data.push_back(diachron_test::similarity_pair(rng, inlier));
  return ranked;
}

double corner_error(const diachron::Similarity2& model) {
  const diachron::Similarity2 truth{1.2, 0.3, {50.0, -20.0}};
  double worst = 0.0;
  for (double x : {0.0, 1000.0}) {
    for (double y : {0.0, 1000.0}) {
      worst = std::max(worst, (model(Eigen::Vector2d(x, y)) - truth(Eigen::Vector2d(x, y))).norm());
    }
  }
  return worst;
}

}  // namespace

TEST_CASE("ProsacTermination: I_min is the binomial bound of the paper", "[robust]") {
  for (const double beta : {0.01, 0.05, 0.2}) {
    std::size_t previous = 0;
    for (std::size_t n = 3; n <= 120; ++n) {
      const std::size_t m = 2;
      const std::size_t i_min = diachron::prosac_min_non_random_inliers(n, m, beta, 0.05);
      // Smallest I with P(Binomial(n - m, beta) >= I - m) < 0.05.
      std::size_t expected = n + 1;
      for (std::size_t i = m; i <= n; ++i) {
        if (binomial_tail(n - m, beta, i - m) < 0.05) {
          expected = i;
          break;
        }
      }
      REQUIRE(i_min == expected);
      REQUIRE(i_min >= previous);  // grows with n, which prepare() relies on for its hint
      REQUIRE(diachron::prosac_min_non_random_inliers(n, m, beta, 0.05, previous) == i_min);
      previous = i_min;
    }
  }
  // Large n: the search stays exact (checked against its own definition at the boundary).
  const std::size_t i_min = diachron::prosac_min_non_random_inliers(100000, 3, 0.05, 0.05);
  CHECK(diachron::log_binomial_tail(100000 - 3, 0.05, i_min - 3) < std::log(0.05));
  CHECK(diachron::log_binomial_tail(100000 - 3, 0.05, i_min - 4) >= std::log(0.05));
}

TEST_CASE("ProsacTermination: options are validated at construction", "[robust]") {
  CHECK_THROWS_AS(ProsacTermination(0.0), diachron::Error);
  CHECK_THROWS_AS(ProsacTermination(1.0), diachron::Error);
  CHECK_THROWS_AS(ProsacTermination(0.05, 0.0), diachron::Error);
  CHECK_THROWS_AS(ProsacTermination(0.05, std::nan("")), diachron::Error);
  CHECK(ProsacTermination{}.chance_inlier_rate() == 0.05);
  CHECK(ProsacTermination{}.non_randomness() == 0.05);
}

TEST_CASE("ProsacTermination: stops early on support concentrated at the top, never on chance",
          "[robust]") {
  RansacOptions options;
  options.max_iterations = 100000;
  options.confidence = 0.999;
  ProsacTermination termination;
  termination.prepare(1000, 2);
  REQUIRE(termination.lengths().front() == 3);
  REQUIRE(termination.lengths().back() == 1000);

  // No best model (no inlier indices): as many as allowed.
  TerminationState none;
  none.num_data = 1000;
  none.sample_size = 2;
  CHECK(termination.required_iterations(options, none) == options.max_iterations);

  // 80 of the top 100 and 20 of the rest: n* within the top 100, a handful of iterations, where
  // the uniform rule on all data (100 of 1000) asks for 694.
  std::vector<std::size_t> top;
  for (std::size_t i = 0; i < 100; ++i) {
    if (i % 5 != 0) top.push_back(i);
  }
  for (std::size_t i = 100; i < 1000; i += 45) top.push_back(i);
  const auto [length, k] = termination.termination_length(options, state_of(top, 1000, 2));
  CHECK(length >= 3);  // a short top with the same inlier rate may give the fewest iterations
  CHECK(length <= 110);
  CHECK(k <= 10);
  CHECK(termination.required_iterations(options, state_of(top, 1000, 2)) <= 10);
  CHECK(diachron::Adaptive{}.required_iterations(options, top.size(), 1000, 2) == 694);

  // The same count spread evenly over the ranks is what a wrong model gets by chance (beta =
  // 0.05 would give 50 of 1000): no length is non-random, so it never stops.
  std::vector<std::size_t> spread;
  for (std::size_t i = 0; i < 1000; i += 25) spread.push_back(i);  // 40 of 1000
  CHECK(termination.termination_length(options, state_of(spread, 1000, 2)).first == 0);
  CHECK(termination.required_iterations(options, state_of(spread, 1000, 2)) ==
        options.max_iterations);
  // ... while the all-data rule of Adaptive would stop.
  CHECK(diachron::Adaptive{}.required_iterations(options, spread.size(), 1000, 2) < 5000);

  // Clamps, and confidence 1 never stops early.
  options.min_iterations = 50;
  CHECK(termination.required_iterations(options, state_of(top, 1000, 2)) == 50);
  options.min_iterations = 0;
  options.confidence = 1.0;
  CHECK(termination.required_iterations(options, state_of(top, 1000, 2)) ==
        options.max_iterations);
}

TEST_CASE("Ransac: PROSAC with its termination needs far fewer iterations on quality-sorted data",
          "[robust]") {
  // 1000 matches, 100 inliers: 80 of them among the 100 best-ranked. Uniform + Adaptive needs
  // about 690 iterations (10 % inliers, 2-point samples); PROSAC + ProsacTermination stops once the
  // top ~100 are explained, after a handful, with the same model (both refit on all inliers).
  RansacOptions options;
  options.threshold = 3.0;
  options.max_iterations = 5000;
  std::size_t prosac_total = 0, uniform_total = 0;
  double prosac_error = 0.0, uniform_error = 0.0;
  for (std::uint64_t seed = 0; seed < 10; ++seed) {
    const RankedPairs ranked = ranked_pairs(1000, 100, 80, 20, seed);
    options.seed = seed;
    const auto prosac = diachron::Ransac<diachron::Similarity2Estimator, diachron::ProsacSampler,
                                         diachron::Msac, ProsacTermination>(options)
                            .run(ranked.data);
    const auto uniform = diachron::Ransac<diachron::Similarity2Estimator>(options).run(ranked.data);
    REQUIRE(prosac.success);
    REQUIRE(uniform.success);
    CHECK(prosac.iterations * 20 < uniform.iterations);
    prosac_total += prosac.iterations;
    uniform_total += uniform.iterations;
    // Same quality: (nearly) the same inliers and model.
    std::size_t true_found = 0;
    for (const std::size_t i : prosac.inliers) true_found += ranked.in[i] ? 1 : 0;
    CHECK(true_found >= 98);
    CHECK(prosac.inliers.size() + 2 >= uniform.inliers.size());
    CHECK(corner_error(prosac.model) < 1.0);
    prosac_error += corner_error(prosac.model);
    uniform_error += corner_error(uniform.model);
  }
  INFO("over 10 seeds: iterations PROSAC " << prosac_total << ", uniform " << uniform_total
                                          << "; mean corner error PROSAC " << prosac_error / 10
                                          << " px, uniform " << uniform_error / 10 << " px");
  CHECK(prosac_total * 50 < uniform_total);
  CHECK(prosac_error <= 1.1 * uniform_error);
}

TEST_CASE("Ransac: PROSAC termination never stops on a model whose support is chance",
          "[robust]") {
  // Pure outliers: every model's support is chance, so the run goes to max_iterations.
  RansacOptions options;
  options.threshold = 3.0;
  options.max_iterations = 300;
  const auto outliers = diachron_test::similarity_pairs(0, 500, 5);
  const auto report = diachron::Ransac<diachron::Similarity2Estimator, diachron::ProsacSampler,
                                       diachron::Msac, ProsacTermination>(options)
                          .run(outliers);
  CHECK(report.iterations == 300);

  // Evenly spaced values, threshold 1.5: every 1D location has 3 inliers of 60, in shuffled ranks.
  // Adaptive takes 3 of 60 for a real inlier rate and stops after about 135 iterations;
  // ProsacTermination sees no length where 3 inliers beat chance (beta = 0.05) and runs on.
  std::vector<double> values(60);
  std::iota(values.begin(), values.end(), 0.0);
  diachron::RandomStream rng(9, 0);
  for (std::size_t i = values.size(); i > 1; --i) std::swap(values[i - 1], values[rng.uniform_index(i)]);
  options.threshold = 1.5;
  options.max_iterations = 1000;
  using Mean = diachron_test::MeanEstimator;
  const auto adaptive = diachron::Ransac<Mean>(options).run(values);
  const auto prosac =
      diachron::Ransac<Mean, diachron::ProsacSampler, diachron::Msac, ProsacTermination>(options)
          .run(values);
  CHECK(adaptive.iterations < 200);
  CHECK(prosac.iterations == 1000);
}

TEST_CASE("Ransac: PROSAC with its termination is identical for 1, 2 and 4 threads", "[robust]") {
  const RankedPairs ranked = ranked_pairs(3000, 300, 200, 100, 21);
  RansacOptions options;
  options.threshold = 3.0;
  using Prosac = diachron::Ransac<diachron::Similarity2Estimator, diachron::ProsacSampler,
                                  diachron::Msac, ProsacTermination>;
  options.threads = 1;
  const auto one = Prosac(options).run(ranked.data);
  for (const std::size_t threads : {2, 4}) {
    options.threads = threads;
    const auto many = Prosac(options).run(ranked.data);
    CHECK(many.iterations == one.iterations);
    CHECK(many.inliers == one.inliers);
    CHECK(many.model.translation == one.model.translation);
    CHECK(many.model.angle == one.model.angle);
    CHECK(many.model.scale == one.model.scale);
    CHECK(many.residual_evaluations == one.residual_evaluations);
    CHECK(many.best_updates == one.best_updates);
  }
  CHECK(one.success);
}
