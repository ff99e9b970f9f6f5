#include <catch2/catch.hpp>

#include <diachron/robust/fixed_iterations.hpp>
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
