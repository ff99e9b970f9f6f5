#include <cstddef>
#include <limits>

#include <catch2/catch.hpp>

#include <diachron/robust/inlier_count_scoring.hpp>
#include <diachron/robust/ransac.hpp>

#include "robust/test_estimators.hpp"

using diachron::InlierCount;

static_assert(diachron::is_scoring_v<InlierCount>, "InlierCount is a Scoring");
static_assert(!diachron::is_scoring_v<int>, "int is not a Scoring");

TEST_CASE("InlierCount: one per inlier, threshold inclusive", "[robust]") {
  const InlierCount count;
  CHECK(count.early_exit);
  CHECK(count.gain(0.0, 1.0) == 1.0);
  CHECK(count.gain(1.0, 1.0) == 1.0);
  CHECK(count.gain(1.0000001, 1.0) == 0.0);
  CHECK(count.gain(std::numeric_limits<double>::quiet_NaN(), 1.0) == 0.0);
  CHECK(count.gain(std::numeric_limits<double>::infinity(), 1.0) == 0.0);
}

TEST_CASE("InlierCount: early exit never changes the winner", "[robust]") {
  using Line = diachron_test::LineEstimator;
  using Paper = diachron::Ransac<Line, diachron::UniformSampler, InlierCount,
                                 diachron::FixedIterations, diachron::NoLocalOptimization>;
  std::size_t saved = 0;
  for (std::uint64_t seed = 0; seed < 8; ++seed) {
    const auto data = diachron_test::make_line_data(60, 40 + 80 * seed, 1.0, 200 + seed);
    diachron::RansacOptions options;
    options.threshold = 3.0;
    options.seed = seed;
    options.max_iterations = 300;
    const auto with = Paper(options, Line{}, {}, InlierCount{true}).run(data);
    const auto without = Paper(options, Line{}, {}, InlierCount{false}).run(data);
    INFO("seed " << seed);
    REQUIRE(with.success == without.success);
    CHECK(with.model.normal == without.model.normal);
    CHECK(with.model.offset == without.model.offset);
    CHECK(with.inliers == without.inliers);
    CHECK(with.score == without.score);
    CHECK(with.best_updates == without.best_updates);
    CHECK(with.local_optimizations == without.local_optimizations);
    CHECK(with.hypotheses_stopped_early > 0);
    CHECK(with.residual_evaluations < without.residual_evaluations);
    saved += without.residual_evaluations - with.residual_evaluations;
  }
  CHECK(saved > 0);
}
