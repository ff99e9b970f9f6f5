#include <array>
#include <cstddef>
#include <optional>
#include <type_traits>
#include <vector>

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

// The archetype with one thing changed each (issue 12).
struct NoMaxModels {
  using Datum = double;
  using Model = double;
  static constexpr std::size_t kSampleSize = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = diachron::StaticVector<Model, 1>;
  Models minimal(const Sample&) const { return {}; }
  double residual(const Model&, const Datum&) const { return 0.0; }
};

struct VectorSample {
  using Datum = double;
  using Model = double;
  static constexpr std::size_t kSampleSize = 1;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::vector<Datum>;
  using Models = diachron::StaticVector<Model, kMaxModels>;
  Models minimal(const Sample&) const { return {}; }
  double residual(const Model&, const Datum&) const { return 0.0; }
};

struct NonConstRefine : diachron_test::MeanEstimator {
  std::optional<Model> refine(const Model& initial, const diachron::Subset<Datum>&,
                              const double*) {
    return initial;
  }
};

struct ConstWrongReturnRefine : diachron_test::MeanEstimator {
  Model refine(const Model& initial, const diachron::Subset<Datum>&, const double*) const {
    return initial;
  }
};

struct TwoArgumentRefine : diachron_test::MeanEstimator {
  std::optional<Model> refine(const Model& initial, const diachron::Subset<Datum>&) const {
    return initial;
  }
};

struct NonConstDegenerate : diachron_test::MeanEstimator {
  bool degenerate(const Sample&) { return false; }
};

struct GoodRefineAndOverload : diachron_test::MeanEstimator {
  std::optional<Model> refine(const Model& initial, const diachron::Subset<Datum>&,
                              const double*) const {
    return initial;
  }
  std::optional<Model> refine(const Model& initial) const { return initial; }
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

TEST_CASE("Estimator concept: each missing or wrong member is detected on its own", "[robust]") {
  static_assert(diachron::is_estimator_v<diachron_test::MeanEstimator>);
  // A missing kMaxModels is told apart from the other types (check_estimator names it; the
  // compile-fail test robust/compile_fail_missing_max_models checks the message).
  static_assert(!diachron::has_estimator_types_v<NoMaxModels>);
  static_assert(diachron::detail::has_datum_type<NoMaxModels>::value);
  static_assert(diachron::detail::has_sample_size<NoMaxModels>::value);
  static_assert(!diachron::detail::has_max_models<NoMaxModels>::value);
  static_assert(!diachron::is_estimator_v<NoMaxModels>);
  // A std::vector Sample compiled and crashed Ransac (sample[k] into an empty vector).
  static_assert(diachron::has_estimator_types_v<VectorSample>);
  static_assert(!diachron::detail::sample_is_array_v<VectorSample>);
  static_assert(!diachron::is_estimator_v<VectorSample>);
  SUCCEED();
}

TEST_CASE("Estimator concept: an optional member with the wrong signature is an error, not ignored",
          "[robust]") {
  static_assert(diachron::estimator_has_refine_v<diachron_test::LineEstimator>);
  static_assert(!diachron::estimator_has_mismatched_optional_v<diachron_test::LineEstimator>);
  static_assert(!diachron::estimator_has_mismatched_optional_v<diachron_test::MeanEstimator>);
  static_assert(!diachron::estimator_has_mismatched_optional_v<diachron::Similarity2Estimator>);
  static_assert(!diachron::estimator_has_mismatched_optional_v<diachron::Helmert3Estimator>);
  static_assert(!diachron::estimator_has_refine_v<NonConstRefine>);  // not const
  static_assert(diachron::estimator_has_mismatched_optional_v<NonConstRefine>);
  static_assert(!diachron::is_estimator_v<NonConstRefine>);
  static_assert(!diachron::estimator_has_refine_v<ConstWrongReturnRefine>);  // returns a Model
  static_assert(!diachron::is_estimator_v<ConstWrongReturnRefine>);
  static_assert(!diachron::estimator_has_refine_v<TwoArgumentRefine>);
  static_assert(!diachron::is_estimator_v<TwoArgumentRefine>);
  static_assert(!diachron::estimator_has_degenerate_v<NonConstDegenerate>);
  static_assert(!diachron::is_estimator_v<NonConstDegenerate>);
  // Another overload beside the right one is fine.
  static_assert(diachron::estimator_has_refine_v<GoodRefineAndOverload>);
  static_assert(diachron::is_estimator_v<GoodRefineAndOverload>);
  SUCCEED();
}
