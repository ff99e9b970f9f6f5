#include <cstddef>

#include <catch2/catch.hpp>

#include <diachron/robust/msac_scoring.hpp>
#include <diachron/robust/no_local_optimization.hpp>

#include "robust/test_estimators.hpp"

using diachron_test::LineEstimator;

static_assert(diachron::is_local_optimization_v<diachron::NoLocalOptimization, LineEstimator,
                                                diachron::Msac>,
              "NoLocalOptimization is a LocalOptimization");
static_assert(!diachron::is_local_optimization_v<int, LineEstimator, diachron::Msac>,
              "int is not a LocalOptimization");

TEST_CASE("NoLocalOptimization: leaves model and support untouched", "[robust]") {
  const auto data = diachron_test::make_line_data(50, 10, 1.0, 2);
  const LineEstimator estimator;
  const diachron::Msac scoring;
  const diachron::RansacProblem<LineEstimator, diachron::Msac> problem(estimator, scoring,
                                                                       data.data(), data.size(), 3.0);
  diachron_test::Line model;
  model.normal = Eigen::Vector2d(-0.5, 1.0).normalized();
  model.offset = model.normal.y() * 21.0;
  std::size_t evaluations = 0;
  diachron::Support support = problem.score(model, 0.0, evaluations);
  const diachron::Support before = support;
  const diachron_test::Line model_before = model;
  CHECK_FALSE(diachron::NoLocalOptimization{}.optimize(problem, model, support, evaluations));
  CHECK(model.normal == model_before.normal);
  CHECK(model.offset == model_before.offset);
  CHECK(support.score == before.score);
  CHECK(evaluations == data.size());
}
