// Tests for Similarity2Estimator: the Estimator concept, exact minimal solutions (also near 180
// degrees, at extreme scales and on UTM coordinates), residuals, refine and degeneracy.

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/geometry/similarity2_estimator.hpp>
#include <diachron/robust/estimator.hpp>

using diachron::kPi;
using diachron::PointPair2;
using diachron::Similarity2;
using diachron::Similarity2Estimator;

static_assert(diachron::is_estimator_v<Similarity2Estimator>);
static_assert(diachron::estimator_has_refine_v<Similarity2Estimator>);
static_assert(diachron::estimator_has_residual_function_v<Similarity2Estimator>);
static_assert(diachron::estimator_has_degenerate_v<Similarity2Estimator>);
static_assert(diachron::check_estimator<Similarity2Estimator>());
static_assert(Similarity2Estimator::kSampleSize == 2 && Similarity2Estimator::kMaxModels == 1);

namespace {

double angle_error(double a, double b) { return std::abs(diachron::wrap_angle(a - b)); }

Similarity2Estimator::Sample sample_of(const Similarity2& model, Eigen::Vector2d a,
                                       Eigen::Vector2d b) {
  return {PointPair2{a, model(a)}, PointPair2{b, model(b)}};
}

}  // namespace

TEST_CASE("Similarity2Estimator: exact recovery from a minimal sample", "[geometry]") {
  const Similarity2Estimator estimator;
  diachron::RandomStream random(1);
  for (double angle : {0.0, 0.5, -1.5, kPi - 1e-9, kPi, -kPi + 1e-6, kPi / 2}) {
    for (double scale : {0.01, 0.1, 1.0, 10.0, 100.0}) {
      const Similarity2 truth{scale, angle, {random.uniform(-500, 500), random.uniform(-500, 500)}};
      for (int trial = 0; trial < 5; ++trial) {
        // One draw per statement, b before a and y before x: the order of a call's arguments is
        // unspecified (core/random.hpp, "Order of draws"); this is the order the tests were written
        // with.
        const Eigen::Vector2d b{random.uniform(0, 4000), random.uniform(0, 3000)};
        const Eigen::Vector2d a{random.uniform(0, 4000), random.uniform(0, 3000)};
        const auto sample = sample_of(truth, a, b);
        REQUIRE_FALSE(estimator.degenerate(sample));
        const auto models = estimator.minimal(sample);
        REQUIRE(models.size() == 1);
        const Similarity2& model = models[0];
        CHECK(model.scale == Approx(scale).epsilon(1e-11));
        CHECK(angle_error(model.angle, angle) < 1e-11);
        CHECK(model.angle > -kPi);
        CHECK(model.angle <= kPi);
        CHECK((model.translation - truth.translation).norm() < 1e-8 * (1 + scale));
        for (const auto& pair : sample)
          CHECK(estimator.residual(model, pair) < 1e-9 * scale * 4000);
        // Every other point of the same transform fits too.
        const double xy = random.uniform(0, 3000);
        const Eigen::Vector2d x(random.uniform(0, 4000), xy);
        CHECK(estimator.residual(model, {x, truth(x)}) < 1e-9 * scale * 4000);
      }
    }
  }
}

TEST_CASE("Similarity2Estimator: UTM coordinates keep sub-micrometre residuals", "[geometry]") {
  const Similarity2Estimator estimator;
  diachron::RandomStream random(2);
  const Eigen::Vector2d utm(5e5, 5e6);
  double worst = 0.0;
  for (double angle : {1e-3, kPi - 1e-9, kPi, -kPi + 1e-6}) {
    const Similarity2 rotate{1.0002, angle, {0, 0}};
    const Similarity2 truth{1.0002, angle, utm - rotate(utm) + Eigen::Vector2d(7, -3)};
    for (int trial = 0; trial < 20; ++trial) {
      const double ay = random.uniform(-2e3, 2e3);
      const Eigen::Vector2d a = utm + Eigen::Vector2d(random.uniform(-2e3, 2e3), ay);
      const double by = random.uniform(-2e3, 2e3);
      const Eigen::Vector2d b = utm + Eigen::Vector2d(random.uniform(-2e3, 2e3), by);
      const auto models = estimator.minimal(sample_of(truth, a, b));
      REQUIRE(models.size() == 1);
      for (int k = 0; k < 10; ++k) {
        const double xy = random.uniform(-2e3, 2e3);
        const Eigen::Vector2d x = utm + Eigen::Vector2d(random.uniform(-2e3, 2e3), xy);
        worst = std::max(worst, estimator.residual(models[0], {x, truth(x)}));
      }
    }
  }
  INFO("worst residual " << worst << " m");
  CHECK(worst < 1e-6);
}

TEST_CASE("Similarity2Estimator: residual is the Euclidean distance in the target frame",
          "[geometry]") {
  const Similarity2Estimator estimator;
  const Similarity2 model{2.0, kPi / 2, {1.0, 1.0}};
  // model((1, 0)) = (1, 3); the target is 3 right and 4 up of it.
  CHECK(estimator.residual(model, {{1.0, 0.0}, {4.0, 7.0}}) == Approx(5.0));
  CHECK(estimator.residual(model, {{1.0, 0.0}, {1.0, 3.0}}) == Approx(0.0).margin(1e-15));
  // Residuals are not symmetric: they live in the target frame, so scaling the model scales them.
  const Similarity2 bigger{20.0, 0.0, {0.0, 0.0}};
  CHECK(estimator.residual(bigger, {{1.0, 0.0}, {21.0, 0.0}}) == Approx(1.0));
}

TEST_CASE("Similarity2Estimator: minimal never returns non-finite or degenerate models",
          "[geometry]") {
  const Similarity2Estimator estimator;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  using Sample = Similarity2Estimator::Sample;
  CHECK(estimator.minimal(Sample{PointPair2{{1, 2}, {3, 4}}, PointPair2{{1, 2}, {5, 6}}}).empty());
  CHECK(estimator.minimal(Sample{PointPair2{{1, 2}, {3, 4}}, PointPair2{{5, 2}, {3, 4}}}).empty());
  CHECK(
      estimator.minimal(Sample{PointPair2{{nan, 2}, {3, 4}}, PointPair2{{5, 2}, {3, 7}}}).empty());
  CHECK(
      estimator.minimal(Sample{PointPair2{{1, 2}, {3, inf}}, PointPair2{{5, 2}, {3, 7}}}).empty());
  CHECK(estimator.minimal(Sample{PointPair2{{1e300, 2}, {3, 4}}, PointPair2{{-1e300, 2}, {3, 7}}})
            .empty());
}

TEST_CASE("Similarity2Estimator: degenerate detects coincident points only", "[geometry]") {
  const Similarity2Estimator estimator;
  using Sample = Similarity2Estimator::Sample;
  // Coincident sources, coincident targets.
  CHECK(estimator.degenerate(Sample{PointPair2{{1, 2}, {3, 4}}, PointPair2{{1, 2}, {5, 6}}}));
  CHECK(estimator.degenerate(Sample{PointPair2{{1, 2}, {3, 4}}, PointPair2{{7, 2}, {3, 4}}}));
  // Coincident up to rounding at UTM scale: relative tolerance.
  CHECK(estimator.degenerate(
      Sample{PointPair2{{5e5, 5e6}, {0, 0}}, PointPair2{{5e5 + 1e-5, 5e6}, {10, 0}}}));
  // 1 mm apart at UTM scale is still a usable baseline.
  CHECK_FALSE(estimator.degenerate(
      Sample{PointPair2{{5e5, 5e6}, {0, 0}}, PointPair2{{5e5 + 1e-3, 5e6}, {10, 0}}}));
  // Collinear with the origin is not degenerate (COLMAP's uncentred rank test rejects it).
  const Sample through_origin{PointPair2{{1, 1}, {2, 2}}, PointPair2{{2, 2}, {4, 4}}};
  CHECK_FALSE(estimator.degenerate(through_origin));
  const auto models = estimator.minimal(through_origin);
  REQUIRE(models.size() == 1);
  CHECK(models[0].scale == Approx(2.0));
  // Tiny coordinates are fine: the test is relative.
  CHECK_FALSE(estimator.degenerate(
      Sample{PointPair2{{1e-9, 0}, {0, 0}}, PointPair2{{2e-9, 0}, {0, 1e-9}}}));
  // Non-finite counts as degenerate.
  CHECK(estimator.degenerate(
      Sample{PointPair2{{std::nan(""), 0}, {0, 0}}, PointPair2{{1, 0}, {0, 1}}}));
}

TEST_CASE("Similarity2Estimator: refine is weighted least squares", "[geometry]") {
  diachron::RandomStream random(3);
  const Similarity2 truth{1.7, 2.8, {-30, 40}};
  std::vector<PointPair2> data;
  for (int i = 0; i < 30; ++i) {
    const double xy = random.uniform(0, 1000);
    const Eigen::Vector2d x(random.uniform(0, 1000), xy);
    const double ny = random.normal();
    data.push_back({x, truth(x) + Eigen::Vector2d(random.normal(), ny)});
  }
  const Similarity2Estimator estimator;
  const diachron::Subset<PointPair2> all(data.data(), data.size());
  const std::vector<double> equal(data.size(), 0.25);
  const auto plain = estimator.refine(Similarity2::identity(), all, nullptr);
  const auto weighted = estimator.refine(Similarity2::identity(), all, equal.data());
  REQUIRE(plain);
  REQUIRE(weighted);
  CHECK(weighted->scale == Approx(plain->scale).epsilon(1e-13));
  CHECK(angle_error(weighted->angle, plain->angle) < 1e-13);
  CHECK((weighted->translation - plain->translation).norm() < 1e-9);
  CHECK(plain->scale == Approx(1.7).epsilon(1e-3));

  // Zero-weighted outliers do not move the fit.
  auto with_outliers = data;
  std::vector<double> weights(data.size(), 1.0);
  for (int k = 0; k < 15; ++k) {
    with_outliers.push_back({{random.uniform(0, 1000), random.uniform(0, 1000)},
                             {random.uniform(-3000, 3000), random.uniform(-3000, 3000)}});
    weights.push_back(0.0);
  }
  const diachron::Subset<PointPair2> all_with(with_outliers.data(), with_outliers.size());
  const auto ignoring = estimator.refine(*plain, all_with, weights.data());
  REQUIRE(ignoring);
  CHECK(ignoring->scale == Approx(plain->scale).epsilon(1e-13));
  CHECK((ignoring->translation - plain->translation).norm() < 1e-9);
  const auto spoiled = estimator.refine(*plain, all_with, nullptr);
  REQUIRE(spoiled);
  CHECK(std::abs(spoiled->scale - plain->scale) > 1e-3);

  // Too little data: nullopt.
  const diachron::Subset<PointPair2> one(data.data(), 1);
  CHECK_FALSE(estimator.refine(*plain, one, nullptr));
}

TEST_CASE("Similarity2Estimator: options (symmetric scale, rigid, check())", "[geometry]") {
  diachron::RandomStream random(4);
  const Similarity2 truth{3.0, -0.4, {5, 5}};
  std::vector<PointPair2> forward, backward;
  for (int i = 0; i < 30; ++i) {
    const double xy = random.uniform(0, 100);
    const Eigen::Vector2d x(random.uniform(0, 100), xy);
    const double ny = random.normal();
    const Eigen::Vector2d y = truth(x) + 2.0 * Eigen::Vector2d(random.normal(), ny);
    forward.push_back({x, y});
    backward.push_back({y, x});
  }
  Similarity2Estimator::Options options;
  options.symmetric_scale = true;
  const Similarity2Estimator symmetric(options);
  const auto ab = symmetric.refine({}, {forward.data(), forward.size()}, nullptr);
  const auto ba = symmetric.refine({}, {backward.data(), backward.size()}, nullptr);
  REQUIRE(ab);
  REQUIRE(ba);
  CHECK(ab->scale * ba->scale == Approx(1.0).epsilon(1e-13));
  const Similarity2Estimator umeyama;
  const auto uab = umeyama.refine({}, {forward.data(), forward.size()}, nullptr);
  const auto uba = umeyama.refine({}, {backward.data(), backward.size()}, nullptr);
  CHECK(uab->scale * uba->scale < 1.0 - 1e-5);

  Similarity2Estimator::Options rigid_options;
  rigid_options.estimate_scale = false;
  const Similarity2Estimator rigid(rigid_options);
  const Similarity2 euclidean{1.0, 2.0, {3, 4}};
  const auto models = rigid.minimal(sample_of(euclidean, {0, 0}, {10, 5}));
  REQUIRE(models.size() == 1);
  CHECK(models[0].scale == 1.0);
  CHECK(angle_error(models[0].angle, 2.0) < 1e-13);
  CHECK((models[0].translation - euclidean.translation).norm() < 1e-12);

  CHECK_NOTHROW(Similarity2Estimator::Options{}.check());
  Similarity2Estimator::Options bad;
  bad.coincidence_tolerance = -1.0;
  CHECK_THROWS_AS(bad.check(), diachron::Error);  // check(), as RansacOptions::check()
  CHECK_THROWS_AS(Similarity2Estimator(bad), diachron::Error);
  bad.coincidence_tolerance = std::nan("");
  CHECK_THROWS_AS(Similarity2Estimator(bad), diachron::Error);
}
