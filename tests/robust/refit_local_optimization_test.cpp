#include <cstddef>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/robust/msac_scoring.hpp>
#include <diachron/robust/ransac.hpp>
#include <diachron/robust/refit_local_optimization.hpp>

#include "robust/test_estimators.hpp"

using diachron::Msac;
using diachron::Refit;
using diachron::Support;
using diachron_test::LineEstimator;

static_assert(diachron::is_local_optimization_v<Refit, LineEstimator, Msac>,
              "Refit is a LocalOptimization");
static_assert(diachron::is_local_optimization_v<Refit, diachron_test::MeanEstimator, Msac>,
              "Refit accepts estimators without refine (and does nothing)");

TEST_CASE("Refit: improves a rough line to the least-squares fit", "[robust]") {
  const auto data = diachron_test::make_line_data(200, 100, 1.0, 6);
  const LineEstimator estimator;
  const Msac scoring;
  const diachron::RansacProblem<LineEstimator, Msac> problem(estimator, scoring, data.data(),
                                                             data.size(), 3.0);
  // A line through two inliers: roughly right.
  auto model = estimator.minimal({data[0], data[1]})[0];
  std::size_t evaluations = 0;
  Support support = problem.score(model, 0.0, evaluations);
  const double rough_score = support.score;
  const double rough_error = diachron_test::line_error(model);
  for (const bool tukey : {true, false}) {
    auto refined = model;
    Support refined_support = support;
    Refit refit;
    refit.tukey_weights = tukey;
    REQUIRE(refit.optimize(problem, refined, refined_support, evaluations));
    CHECK(refined_support.complete);
    CHECK(refined_support.score > rough_score);
    CHECK(diachron_test::line_error(refined) < 0.6);
    CHECK(diachron_test::line_error(refined) < rough_error);
  }
  Refit off;
  off.max_steps = 0;
  CHECK_FALSE(off.optimize(problem, model, support, evaluations));
}

TEST_CASE("Refit: estimators without refine make it a no-op", "[robust]") {
  const std::vector<double> data{1.0, 1.1, 0.9, 5.0};
  const diachron_test::MeanEstimator estimator;
  const Msac scoring;
  const diachron::RansacProblem<diachron_test::MeanEstimator, Msac> problem(
      estimator, scoring, data.data(), data.size(), 0.5);
  double model = 1.1;
  std::size_t evaluations = 0;
  Support support = problem.score(model, 0.0, evaluations);
  CHECK_FALSE(Refit{}.optimize(problem, model, support, evaluations));
  CHECK(model == 1.1);
}

TEST_CASE("Refit: a shrinking or too small inlier set never reaches refine (COLMAP #4678)",
          "[robust]") {
  // Well-separated values: every hypothesis has one inlier, fewer than kSampleSize = 2, so LO runs
  // on sets smaller than a sample; refine throws if it is ever called with them.
  std::vector<double> spread;
  for (int i = 0; i < 50; ++i) spread.push_back(10.0 * i);
  diachron::RansacOptions options;
  options.threshold = 1.0;
  options.max_iterations = 200;
  using Shrinking = diachron_test::ShrinkingEstimator;
  diachron::RansacReport<double> report;
  REQUIRE_NOTHROW(report = diachron::Ransac<Shrinking>(options).run(spread));
  CHECK(report.local_optimizations >= 1);
  CHECK_FALSE(report.success);  // one inlier is below min_inliers

  // Clusters: refine is called, but its refit drifts off the data (the inlier set shrinks at every
  // step); LO must reject it rather than follow it, and stop.
  std::vector<double> clusters;
  diachron::RandomStream rng(12, 0);
  for (int i = 0; i < 60; ++i) clusters.push_back(rng.normal(0.0, 0.2));
  for (int i = 0; i < 40; ++i) clusters.push_back(rng.uniform(5.0, 100.0));
  Shrinking drifting;
  drifting.drift = 0.7;
  REQUIRE_NOTHROW(report = diachron::Ransac<Shrinking>(options, drifting).run(clusters));
  REQUIRE(report.success);
  CHECK(report.local_optimizations >= 1);
  CHECK(report.local_optimization_improvements == 0);
  CHECK_FALSE(report.final_refit);  // the drifting refit loses inliers, so it is not kept
  CHECK(std::abs(report.model) < 0.5);
}
