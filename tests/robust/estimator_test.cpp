#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/geometry/helmert3_estimator.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/geometry/similarity2_estimator.hpp>
#include <diachron/robust/estimator.hpp>

#include "robust/test_estimators.hpp"

namespace {
struct NotAnEstimator {
  using Datum = double;
};
}  // namespace

TEST_CASE("Estimator concept: traits tell required from optional members", "[robust]") {
  static_assert(!diachron::is_estimator_v<NotAnEstimator>);
  static_assert(!diachron::is_estimator_v<int>);
  static_assert(diachron::is_estimator_v<diachron::Similarity2Estimator>);
  static_assert(diachron::is_estimator_v<diachron::Helmert3Estimator>);
  static_assert(diachron::check_estimator<diachron::Helmert3Estimator>());
  static_assert(!diachron::estimator_has_residual_function_v<NotAnEstimator>);
  SUCCEED();
}

TEST_CASE("make_residual_function: equals residual() for the estimators that provide one", "[robust]") {
  diachron::RandomStream rng(3);
  const diachron::Similarity2Estimator e2;
  const diachron::Similarity2 s{1.7, 2.9, {1000.0, -5.0}};
  const diachron::Helmert3Estimator e3;
  const diachron::Helmert3 h{0.8, diachron::random_rotation(rng), {5e5, 5e6, 1e3}};
  const auto f2 = diachron::make_residual_function(e2, s);
  const auto f3 = diachron::make_residual_function(e3, h);
  for (int i = 0; i < 100; ++i) {
    const diachron::PointPair2 p2{{rng.uniform(-1e3, 1e3), rng.uniform(-1e3, 1e3)},
                                  {rng.uniform(-1e3, 1e3), rng.uniform(-1e3, 1e3)}};
    REQUIRE(f2(p2) == Approx(e2.residual(s, p2)).epsilon(1e-14));
    const diachron::PointPair3 p3{{rng.uniform(-1e3, 1e3), rng.uniform(-1e3, 1e3), rng.uniform(0, 1e3)},
                                  {rng.uniform(-1e3, 1e3), rng.uniform(-1e3, 1e3), rng.uniform(0, 1e3)}};
    REQUIRE(f3(p3) == Approx(e3.residual(h, p3)).epsilon(1e-12));
  }
}

TEST_CASE("make_residual_function: falls back to residual() when the estimator has none", "[robust]") {
  static_assert(!diachron::estimator_has_residual_function_v<diachron_test::MeanEstimator>);
  const diachron_test::MeanEstimator e;
  const diachron_test::MeanEstimator::Model m = 2.5;
  const auto f = diachron::make_residual_function(e, m);
  REQUIRE(f(4.0) == e.residual(m, 4.0));
}
