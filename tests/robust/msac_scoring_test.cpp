#include <cstddef>
#include <limits>

#include <catch2/catch.hpp>

#include <diachron/robust/msac_scoring.hpp>
#include <diachron/robust/ransac.hpp>

#include "robust/test_estimators.hpp"

using diachron::Msac;

static_assert(diachron::is_scoring_v<Msac>, "Msac is a Scoring");

TEST_CASE("Msac: truncated quadratic gain in [0, 1]", "[robust]") {
  const Msac msac;
  CHECK(msac.early_exit);
  CHECK(msac.gain(0.0, 2.0) == 1.0);
  CHECK(msac.gain(1.0, 2.0) == Approx(0.75));
  CHECK(msac.gain(2.0, 2.0) == 0.0);
  CHECK(msac.gain(2.0001, 2.0) == 0.0);
  CHECK(msac.gain(std::numeric_limits<double>::infinity(), 2.0) == 0.0);
  CHECK(msac.gain(std::numeric_limits<double>::quiet_NaN(), 2.0) == 0.0);
}

TEST_CASE("Msac: a stopped hypothesis could never have beaten its bound", "[robust]") {
  const auto data = diachron_test::make_line_data(100, 300, 1.0, 4);
  const diachron_test::LineEstimator estimator;
  const Msac scoring;
  const diachron::RansacProblem<diachron_test::LineEstimator, Msac> problem(
      estimator, scoring, data.data(), data.size(), 3.0);
  const Msac no_exit{false};
  const diachron::RansacProblem<diachron_test::LineEstimator, Msac> full_problem(
      estimator, no_exit, data.data(), data.size(), 3.0);
  diachron::RandomStream rng(8, 0);
  std::size_t stopped = 0, evaluations = 0, full_evaluations = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const auto models = estimator.minimal(
        {data[rng.uniform_index(data.size())], data[rng.uniform_index(data.size())]});
    if (models.empty()) continue;
    const double bound = rng.uniform(0.0, 80.0);
    const auto partial = problem.score(models[0], bound, evaluations);
    const auto full = full_problem.score(models[0], bound, full_evaluations);
    REQUIRE(full.complete);
    if (partial.complete) {
      CHECK(partial.score == full.score);
      CHECK(partial.num_inliers == full.num_inliers);
    } else {
      ++stopped;
      CHECK(full.score <= bound);
    }
  }
  CHECK(stopped > 100);
  CHECK(evaluations < full_evaluations);
}

TEST_CASE("Msac: early exit never changes the winner", "[robust]") {
  using Line = diachron_test::LineEstimator;
  for (std::uint64_t seed = 0; seed < 8; ++seed) {
    const auto data = diachron_test::make_line_data(80, 20 + 60 * seed, 1.0, 100 + seed);
    diachron::RansacOptions options;
    options.threshold = 3.0;
    options.seed = seed;
    const auto with = diachron::Ransac<Line>(options, Line{}, {}, Msac{true}).run(data);
    const auto without = diachron::Ransac<Line>(options, Line{}, {}, Msac{false}).run(data);
    INFO("seed " << seed);
    REQUIRE(with.success == without.success);
    CHECK(with.model.normal == without.model.normal);
    CHECK(with.model.offset == without.model.offset);
    CHECK(with.inliers == without.inliers);
    CHECK(with.iterations == without.iterations);
    CHECK(with.score == without.score);
    CHECK(with.best_updates == without.best_updates);
    CHECK(with.local_optimizations == without.local_optimizations);
    CHECK(without.hypotheses_stopped_early == 0);
    CHECK(with.residual_evaluations <= without.residual_evaluations);
  }
}
