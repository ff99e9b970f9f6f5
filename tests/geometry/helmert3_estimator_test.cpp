// Tests for Helmert3Estimator: the Estimator concept, exact minimal solutions (rotations up to 180
// degrees, extreme scales, UTM coordinates), residuals, refine and the centred degeneracy test.

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3_estimator.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/robust/estimator.hpp>

using diachron::Helmert3;
using diachron::Helmert3Estimator;
using diachron::kPi;
using diachron::PointPair3;

static_assert(diachron::is_estimator_v<Helmert3Estimator>);
static_assert(diachron::estimator_has_refine_v<Helmert3Estimator>);
static_assert(diachron::estimator_has_residual_function_v<Helmert3Estimator>);
static_assert(diachron::estimator_has_degenerate_v<Helmert3Estimator>);
static_assert(diachron::check_estimator<Helmert3Estimator>());
static_assert(Helmert3Estimator::kSampleSize == 3 && Helmert3Estimator::kMaxModels == 1);

namespace {

using Sample = Helmert3Estimator::Sample;

Sample sample_of(const Helmert3& model, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                 const Eigen::Vector3d& c) {
  return {PointPair3{a, model(a)}, PointPair3{b, model(b)}, PointPair3{c, model(c)}};
}

Eigen::Vector3d random_point(diachron::RandomStream& random, const Eigen::Vector3d& centre,
                             const Eigen::Vector3d& extent) {
  // One draw per statement, the last coordinate (or point) first: the order of a call's arguments
  // is unspecified (core/random.hpp, "Order of draws"); this is the order the tests were written
  // with.
  const double z = random.uniform(-1, 1), y = random.uniform(-1, 1);
  return centre + Eigen::Vector3d(random.uniform(-1, 1), y, z).cwiseProduct(extent);
}

}  // namespace

TEST_CASE("Helmert3Estimator: exact recovery from a minimal sample", "[geometry]") {
  const Helmert3Estimator estimator;
  diachron::RandomStream random(1);
  for (double angle : {0.0, 0.2, 1.5, kPi - 1e-9, kPi, kPi - 1e-6}) {
    for (double scale : {0.01, 0.1, 1.0, 10.0, 100.0}) {
      for (int trial = 0; trial < 5; ++trial) {
        const double az = random.normal(), ay = random.normal();
        const Eigen::Vector3d axis = Eigen::Vector3d(random.normal(), ay, az).normalized();
        const Helmert3 epoch2_from_epoch1 = Helmert3::from_axis_angle(
            scale, axis * angle, random_point(random, {0, 0, 0}, {100, 100, 100}));
        const Eigen::Vector3d extent(500, 500, 50);
        const Eigen::Vector3d c = random_point(random, {0, 0, 0}, extent);
        const Eigen::Vector3d b = random_point(random, {0, 0, 0}, extent);
        const Eigen::Vector3d a = random_point(random, {0, 0, 0}, extent);
        const Sample sample = sample_of(epoch2_from_epoch1, a, b, c);
        REQUIRE_FALSE(estimator.degenerate(sample));
        const auto models = estimator.minimal(sample);
        REQUIRE(models.size() == 1);
        const Helmert3& model = models[0];
        CHECK(model.scale == Approx(scale).epsilon(1e-10));
        CHECK(diachron::rotation_distance(model.rotation, epoch2_from_epoch1.rotation) < 1e-10);
        const Eigen::Vector3d x = random_point(random, {0, 0, 0}, extent);
        CHECK(estimator.residual(model, {x, epoch2_from_epoch1(x)}) < 1e-9 * scale * 500);
      }
    }
  }
}

TEST_CASE("Helmert3Estimator: UTM coordinates keep sub-micrometre residuals", "[geometry]") {
  const Helmert3Estimator estimator;
  diachron::RandomStream random(2);
  const Eigen::Vector3d utm(5e5, 5e6, 1e3);
  double worst = 0.0;
  for (double angle : {1e-4, 0.02, kPi - 1e-9, kPi}) {
    const double az = random.normal(), ay = random.normal();
    const Eigen::Vector3d axis = Eigen::Vector3d(random.normal(), ay, az).normalized();
    const Eigen::Matrix3d r = diachron::rotation_from_axis_angle<double>(axis * angle);
    const double scale = 0.9995;
    // Rotate about a UTM point so that the target stays in UTM range.
    const Helmert3 epoch2_from_epoch1{scale, r,
                                      utm - scale * (r * utm) + Eigen::Vector3d(4, -9, 2)};
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Vector3d extent(2000, 2000, 200);
      const Eigen::Vector3d c = random_point(random, utm, extent);
      const Eigen::Vector3d b = random_point(random, utm, extent);
      const Eigen::Vector3d a = random_point(random, utm, extent);
      const Sample sample = sample_of(epoch2_from_epoch1, a, b, c);
      const auto models = estimator.minimal(sample);
      REQUIRE(models.size() == 1);
      for (int k = 0; k < 10; ++k) {
        const Eigen::Vector3d x = random_point(random, utm, extent);
        worst = std::max(worst, estimator.residual(models[0], {x, epoch2_from_epoch1(x)}));
      }
    }
  }
  INFO("worst residual " << worst << " m");
  CHECK(worst < 1e-6);
}

TEST_CASE("Helmert3Estimator: residual is the distance in the target frame", "[geometry]") {
  const Helmert3Estimator estimator;
  const Helmert3 model{10.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 0, 0)};
  // model((1, 1, 1)) = (11, 10, 10); the target is offset by (2, 3, 6): distance 7.
  CHECK(estimator.residual(model, {{1, 1, 1}, {13, 13, 16}}) == Approx(7.0));
  CHECK(estimator.residual(model, {{1, 1, 1}, {11, 10, 10}}) == 0.0);
}

TEST_CASE("Helmert3Estimator: degenerate detects coincident and collinear triangles only",
          "[geometry]") {
  const Helmert3Estimator estimator;
  const Helmert3 h = Helmert3::from_axis_angle(2.0, {0.3, -0.2, 0.5}, {10, 20, 30});

  // Coincident source points.
  CHECK(estimator.degenerate(sample_of(h, {1, 2, 3}, {1, 2, 3}, {4, 0, 1})));
  // Collinear source points, not through the origin.
  CHECK(estimator.degenerate(sample_of(h, {1, 2, 3}, {2, 3, 4}, {4, 5, 6})));
  // Collinear at UTM coordinates.
  const Eigen::Vector3d utm(5e5, 5e6, 1e3), dir(0.6, 0.8, 0.0);
  CHECK(estimator.degenerate(sample_of(h, utm, utm + 10 * dir, utm + 250 * dir)));
  // Collinear target with a fine source.
  Sample bad_target = sample_of(h, {0, 0, 0}, {1, 0, 0}, {0, 1, 0});
  bad_target[2].target = bad_target[0].target + 3.0 * (bad_target[1].target - bad_target[0].target);
  CHECK(estimator.degenerate(bad_target));
  CHECK(estimator.minimal(bad_target).empty());
  // Non-finite.
  Sample with_nan = sample_of(h, {0, 0, 0}, {1, 0, 0}, {0, 1, 0});
  with_nan[1].source.z() = std::numeric_limits<double>::quiet_NaN();
  CHECK(estimator.degenerate(with_nan));
  CHECK(estimator.minimal(with_nan).empty());

  // Each pair collinear with the origin, and all three on a plane through the origin (flat ground
  // at z = 0): fine. An uncentred rank test (COLMAP) rejects both.
  const Sample through_origin = sample_of(h, {1, 1, 0}, {0, 2, 0}, {3, 0, 0});
  CHECK_FALSE(estimator.degenerate(through_origin));
  REQUIRE(estimator.minimal(through_origin).size() == 1);
  CHECK(diachron::rotation_distance(estimator.minimal(through_origin)[0].rotation, h.rotation) <
        1e-12);
  const Sample origin_vertex = sample_of(h, {0, 0, 0}, {1, 1, 1}, {2, 2, -3});
  CHECK_FALSE(estimator.degenerate(origin_vertex));

  // Scale invariance: the same shape is (non-)degenerate at every size.
  for (double size : {1e-3, 1.0, 1e6}) {
    CHECK_FALSE(estimator.degenerate(sample_of(h, {0, 0, 0}, {size, 0, 0}, {0, size * 1e-3, 0})));
    CHECK(
        estimator.degenerate(sample_of(h, {0, 0, 0}, {size, 0, 0}, {0.5 * size, size * 1e-8, 0})));
  }
}

TEST_CASE("Helmert3Estimator: refine is weighted least squares", "[geometry]") {
  diachron::RandomStream random(3);
  const Helmert3 truth = Helmert3::from_axis_angle(1.05, {0.01, -0.02, 3.0}, {100, -50, 20});
  std::vector<PointPair3> data;
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector3d x = random_point(random, {0, 0, 0}, {1000, 1000, 100});
    const double nz = random.normal(), ny = random.normal();
    data.push_back({x, truth(x) + 0.5 * Eigen::Vector3d(random.normal(), ny, nz)});
  }
  const Helmert3Estimator estimator;
  const diachron::Subset<PointPair3> all(data.data(), data.size());
  const std::vector<double> equal(data.size(), 2.0);
  const auto plain = estimator.refine(Helmert3::identity(), all, nullptr);
  const auto weighted = estimator.refine(Helmert3::identity(), all, equal.data());
  REQUIRE(plain);
  REQUIRE(weighted);
  CHECK(weighted->scale == Approx(plain->scale).epsilon(1e-13));
  CHECK((weighted->rotation - plain->rotation).norm() < 1e-13);
  CHECK((weighted->translation - plain->translation).norm() < 1e-9);
  CHECK(diachron::rotation_distance(plain->rotation, truth.rotation) < 1e-3);

  auto with_outliers = data;
  std::vector<double> weights(data.size(), 1.0);
  for (int k = 0; k < 20; ++k) {
    with_outliers.push_back({random_point(random, {0, 0, 0}, {1000, 1000, 100}),
                             random_point(random, {0, 0, 0}, {1000, 1000, 100})});
    weights.push_back(0.0);
  }
  const diachron::Subset<PointPair3> all_with(with_outliers.data(), with_outliers.size());
  const auto ignoring = estimator.refine(*plain, all_with, weights.data());
  REQUIRE(ignoring);
  CHECK(ignoring->scale == Approx(plain->scale).epsilon(1e-13));
  CHECK((ignoring->translation - plain->translation).norm() < 1e-9);
  const auto spoiled = estimator.refine(*plain, all_with, nullptr);
  REQUIRE(spoiled);
  CHECK(std::abs(spoiled->scale - plain->scale) > 1e-3);

  // A subset through indices: only the listed data count.
  const std::vector<std::size_t> indices = {0, 1, 2, 3, 4, 5, 6, 7};
  const diachron::Subset<PointPair3> some(with_outliers.data(), indices.data(), indices.size());
  REQUIRE(estimator.refine(*plain, some, nullptr));
  const diachron::Subset<PointPair3> two(data.data(), 2);
  CHECK_FALSE(estimator.refine(*plain, two, nullptr));
}

TEST_CASE("Helmert3Estimator: options (symmetric scale, rigid, check())", "[geometry]") {
  diachron::RandomStream random(4);
  const Helmert3 truth = Helmert3::from_axis_angle(0.5, {0.5, 0.5, 0.5}, {1, 2, 3});
  std::vector<PointPair3> forward, backward;
  for (int i = 0; i < 30; ++i) {
    const Eigen::Vector3d x = random_point(random, {0, 0, 0}, {50, 50, 50});
    const double nz = random.normal(), ny = random.normal();
    const Eigen::Vector3d y = truth(x) + Eigen::Vector3d(random.normal(), ny, nz);
    forward.push_back({x, y});
    backward.push_back({y, x});
  }
  Helmert3Estimator::Options options;
  options.symmetric_scale = true;
  const Helmert3Estimator symmetric(options);
  const auto ab = symmetric.refine({}, {forward.data(), forward.size()}, nullptr);
  const auto ba = symmetric.refine({}, {backward.data(), backward.size()}, nullptr);
  REQUIRE(ab);
  REQUIRE(ba);
  CHECK(ab->scale * ba->scale == Approx(1.0).epsilon(1e-13));
  // Symmetric scale is exact on a noise-free minimal sample as well.
  const auto exact = symmetric.minimal(sample_of(truth, {0, 0, 0}, {10, 0, 1}, {3, 7, -2}));
  REQUIRE(exact.size() == 1);
  CHECK(exact[0].scale == Approx(0.5).epsilon(1e-13));

  const Helmert3Estimator umeyama;
  const auto uab = umeyama.refine({}, {forward.data(), forward.size()}, nullptr);
  const auto uba = umeyama.refine({}, {backward.data(), backward.size()}, nullptr);
  CHECK(uab->scale * uba->scale < 1.0 - 1e-5);

  Helmert3Estimator::Options rigid_options;
  rigid_options.estimate_scale = false;
  const Helmert3Estimator rigid(rigid_options);
  const Helmert3 euclidean = Helmert3::from_yaw_pitch_roll(1.0, 2.0, 0.3, -0.1, {5, 6, 7});
  const auto models = rigid.minimal(sample_of(euclidean, {0, 0, 0}, {10, 0, 1}, {3, 7, -2}));
  REQUIRE(models.size() == 1);
  CHECK(models[0].scale == 1.0);
  CHECK(diachron::rotation_distance(models[0].rotation, euclidean.rotation) < 1e-12);

  CHECK_NOTHROW(Helmert3Estimator::Options{}.check());
  Helmert3Estimator::Options bad;
  bad.collinearity_tolerance = 1.5;
  CHECK_THROWS_AS(bad.check(), diachron::Error);  // check(), as RansacOptions::check()
  CHECK_THROWS_AS(Helmert3Estimator(bad), diachron::Error);
  bad = {};
  bad.coincidence_tolerance = -1e-3;
  CHECK_THROWS_AS(Helmert3Estimator(bad), diachron::Error);
}
