#include <algorithm>
#include <cstddef>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/robust/fixed_iterations.hpp>
#include <diachron/robust/prosac_sampler.hpp>
#include <diachron/robust/ransac.hpp>

#include "robust/test_estimators.hpp"

static_assert(diachron::is_termination_v<diachron::FixedIterations>,
              "FixedIterations is a Termination");
static_assert(!diachron::is_termination_v<int>, "int is not a Termination");

TEST_CASE("FixedIterations: always max_iterations, whatever the support", "[robust]") {
  diachron::RansacOptions options;
  options.max_iterations = 1000;
  options.min_iterations = 10;
  options.confidence = 0.5;
  const diachron::FixedIterations fixed;
  CHECK(fixed.required_iterations(options, 0, 100, 2) == 1000);
  CHECK(fixed.required_iterations(options, 100, 100, 2) == 1000);
  options.max_iterations = 7;
  options.min_iterations = 0;
  CHECK(fixed.required_iterations(options, 100, 100, 2) == 7);
}

TEST_CASE("FixedIterations: a Ransac run on exact data still runs every iteration", "[robust]") {
  const auto data = diachron_test::make_line_data(40, 0, 0.0, 3);
  diachron::RansacOptions options;
  options.max_iterations = 250;
  const auto report =
      diachron::Ransac<diachron_test::LineEstimator, diachron::UniformSampler, diachron::Msac,
                       diachron::FixedIterations>(options)
          .run(data);
  REQUIRE(report.success);
  CHECK(report.iterations == 250);
  CHECK(report.hypotheses_generated == 250);
}

namespace {

// A Termination of the TerminationState form that records what Ransac tells it (the log is the
// caller's: the policy is copied into the run).
struct RecordingTermination {
  static constexpr bool kNeedsBestInliers = true;
  std::vector<diachron::TerminationState>* log = nullptr;
  std::vector<std::vector<std::size_t>>* inliers = nullptr;
  std::size_t* prepared = nullptr;
  std::size_t stop_after = 12;

  void prepare(std::size_t num_data, std::size_t sample_size) {
    *prepared = num_data * 10 + sample_size;
  }
  std::size_t required_iterations(const diachron::RansacOptions&,
                                  const diachron::TerminationState& state) const {
    log->push_back(state);
    inliers->push_back(state.best_inlier_indices ? *state.best_inlier_indices
                                                 : std::vector<std::size_t>{});
    return stop_after;
  }
};

}  // namespace

TEST_CASE("Termination: the TerminationState form sees iterations, pool and best inliers",
          "[robust]") {
  static_assert(diachron::is_termination_v<RecordingTermination>);
  static_assert(diachron::detail::termination_needs_best_inliers<RecordingTermination>::value);
  static_assert(!diachron::detail::termination_needs_best_inliers<diachron::Adaptive>::value);
  const auto data = diachron_test::make_line_data(60, 40, 1.0, 5);
  std::vector<diachron::TerminationState> log;
  std::vector<std::vector<std::size_t>> inliers;
  std::size_t prepared = 0;
  RecordingTermination termination;
  termination.log = &log;
  termination.inliers = &inliers;
  termination.prepared = &prepared;
  diachron::RansacOptions options;
  options.threshold = 3.0;
  const auto report =
      diachron::Ransac<diachron_test::LineEstimator, diachron::ProsacSampler, diachron::Msac,
                       RecordingTermination>(options, {}, diachron::ProsacSampler(50.0), {},
                                             termination)
          .run(data);
  REQUIRE(report.success);
  CHECK(report.iterations == 12);
  CHECK(prepared == 100 * 10 + 2);
  REQUIRE(log.size() == 13);  // before the first iteration and after each
  diachron::ProsacSampler sampler(50.0);
  sampler.prepare(100, 2);
  for (std::size_t k = 0; k < log.size(); ++k) {
    const auto& state = log[k];
    CHECK(state.iterations == k);
    CHECK(state.num_data == 100);
    CHECK(state.sample_size == 2);
    CHECK(state.pool_size == sampler.pool_size(k));
    if (state.best_inliers == 0) {
      CHECK(state.best_inlier_indices == nullptr);
    } else {
      // The best model's inliers, increasing, as many as its support counts.
      CHECK(state.best_inlier_indices != nullptr);
      CHECK(inliers[k].size() == state.best_inliers);
      CHECK(std::is_sorted(inliers[k].begin(), inliers[k].end()));
    }
  }
  CHECK(log.back().best_inliers > 0);
  // The classic form goes through the same dispatch.
  diachron::TerminationState state;
  state.best_inliers = 50;
  state.num_data = 100;
  state.sample_size = 2;
  options.confidence = 0.99;
  CHECK(diachron::required_iterations(diachron::Adaptive{}, options, state) == 17);
  CHECK(diachron::required_iterations(diachron::FixedIterations{}, options, state) == 1000);
}
