// Tests for the weighted Procrustes fit (fit_similarity, fit_similarity2, fit_helmert3): exact
// recovery, UTM numerics, weights, symmetric scale, reflections and degenerate input.

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/procrustes.hpp>
#include <diachron/geometry/rotation.hpp>

using diachron::Helmert3;
using diachron::kPi;
using diachron::PointPair2;
using diachron::PointPair3;
using diachron::ProcrustesOptions;
using diachron::Similarity2;

namespace {

const std::vector<double> kAngles = {0.0, 0.3, -2.0, kPi / 2, kPi - 1e-9, kPi, -kPi + 1e-6};
const std::vector<double> kScales = {0.01, 0.3, 1.0, 7.0, 100.0};

std::vector<PointPair2> make_pairs2(const Similarity2& b_from_a, std::size_t n,
                                    Eigen::Vector2d centre, double extent,
                                    diachron::RandomStream& random, double noise = 0.0) {
  std::vector<PointPair2> pairs;
  for (std::size_t i = 0; i < n; ++i) {
    // One draw per statement, the last coordinate first: the order of a call's arguments is
    // unspecified (core/random.hpp, "Order of draws"); this is the order the tests were written
    // with.
    const double xy = random.uniform(-extent, extent);
    const Eigen::Vector2d x = centre + Eigen::Vector2d(random.uniform(-extent, extent), xy);
    const double ny = random.normal();
    pairs.push_back({x, b_from_a(x) + noise * Eigen::Vector2d(random.normal(), ny)});
  }
  return pairs;
}

std::vector<PointPair3> make_pairs3(const Helmert3& epoch2_from_epoch1, std::size_t n,
                                    Eigen::Vector3d centre, Eigen::Vector3d extent,
                                    diachron::RandomStream& random, double noise = 0.0) {
  std::vector<PointPair3> pairs;
  for (std::size_t i = 0; i < n; ++i) {
    const double xz = random.uniform(-1, 1), xy = random.uniform(-1, 1);
    const Eigen::Vector3d x =
        centre + Eigen::Vector3d(random.uniform(-1, 1), xy, xz).cwiseProduct(extent);
    const double nz = random.normal(), ny = random.normal();
    pairs.push_back({x, epoch2_from_epoch1(x) + noise * Eigen::Vector3d(random.normal(), ny, nz)});
  }
  return pairs;
}

double angle_difference(double a, double b) { return std::abs(diachron::wrap_angle(a - b)); }

template <class Pairs, class Model>
double max_residual(const Pairs& pairs, const Model& model) {
  double worst = 0.0;
  for (const auto& pair : pairs) worst = std::max(worst, (model(pair.source) - pair.target).norm());
  return worst;
}

template <class Pairs>
std::vector<std::decay_t<decltype(std::declval<Pairs>()[0])>> swapped(const Pairs& pairs) {
  std::vector<std::decay_t<decltype(std::declval<Pairs>()[0])>> out;
  for (const auto& pair : pairs) out.push_back({pair.target, pair.source});
  return out;
}

}  // namespace

TEST_CASE("Procrustes: exact 2D recovery for all angles and scales", "[geometry]") {
  diachron::RandomStream random(1);
  for (double angle : kAngles) {
    for (double scale : kScales) {
      const Similarity2 truth{scale, angle, {random.uniform(-50, 50), random.uniform(-50, 50)}};
      for (std::size_t n : {2u, 3u, 30u}) {
        const auto pairs = make_pairs2(truth, n, {0, 0}, 100.0, random);
        const std::optional<Similarity2> fit = diachron::fit_similarity2(pairs);
        REQUIRE(fit);
        CHECK(fit->scale == Approx(scale).epsilon(1e-12));
        CHECK(angle_difference(fit->angle, angle) < 1e-12);
        CHECK(fit->angle > -kPi);
        CHECK(fit->angle <= kPi);
        CHECK(max_residual(pairs, *fit) < 1e-9 * scale * 100.0);
      }
    }
  }
}

TEST_CASE("Procrustes: exact 3D recovery for rotations up to 180 degrees and scales",
          "[geometry]") {
  diachron::RandomStream random(2);
  for (double angle : {0.0, 0.3, 2.0, kPi - 1e-9, kPi, kPi - 1e-6}) {
    for (double scale : kScales) {
      const double az = random.normal(), ay = random.normal();
      const Eigen::Vector3d axis = Eigen::Vector3d(random.normal(), ay, az).normalized();
      const Helmert3 truth = Helmert3::from_axis_angle(
          scale, axis * angle,
          {random.uniform(-50, 50), random.uniform(-50, 50), random.uniform(-50, 50)});
      for (std::size_t n : {3u, 4u, 50u}) {
        const auto pairs = make_pairs3(truth, n, {0, 0, 0}, {100, 100, 100}, random);
        const std::optional<Helmert3> fit = diachron::fit_helmert3(pairs);
        REQUIRE(fit);
        CHECK(fit->scale == Approx(scale).epsilon(1e-12));
        CHECK(diachron::rotation_distance(fit->rotation, truth.rotation) < 1e-11);
        CHECK(fit->rotation.determinant() == Approx(1.0));
        CHECK(max_residual(pairs, *fit) < 1e-9 * scale * 100.0);
      }
    }
  }
}

TEST_CASE("Procrustes: UTM-sized coordinates give sub-micrometre residuals", "[geometry]") {
  diachron::RandomStream random(3);
  const Eigen::Vector3d utm(5e5, 5e6, 1e3);
  double worst = 0.0;
  for (double angle : {1e-4, 0.05, kPi - 1e-9, kPi}) {
    const double az = random.normal(), ay = random.normal();
    const Eigen::Vector3d axis = Eigen::Vector3d(random.normal(), ay, az).normalized();
    const Helmert3 epoch2_from_epoch1 =
        Helmert3::from_axis_angle(1.0003, axis * angle, {12.0, -31.0, 4.5});
    // Source and target both far from the origin: subtracting the truth's translation would hide
    // the problem, so build the target around UTM coordinates too.
    const Helmert3 shifted{epoch2_from_epoch1.scale, epoch2_from_epoch1.rotation,
                           epoch2_from_epoch1.translation + utm -
                               epoch2_from_epoch1.scale * (epoch2_from_epoch1.rotation * utm)};
    for (std::size_t n : {3u, 200u}) {
      const auto pairs = make_pairs3(shifted, n, utm, {2000, 2000, 200}, random);
      const std::optional<Helmert3> fit = diachron::fit_helmert3(pairs);
      REQUIRE(fit);
      const double residual = max_residual(pairs, *fit);
      worst = std::max(worst, residual);
      CHECK(residual < 1e-6);
      CHECK(fit->scale == Approx(1.0003).epsilon(1e-12));
    }
  }
  // 2D: easting/northing of a DSM in map units.
  for (double angle : {0.01, kPi - 1e-9, -kPi + 1e-6}) {
    const Similarity2 rotated{0.9997, angle, {0.0, 0.0}};
    const Eigen::Vector2d e(5e5, 5e6);
    const Similarity2 b_from_a{0.9997, angle, e - rotated(e) + Eigen::Vector2d(3.0, -8.0)};
    const auto pairs = make_pairs2(b_from_a, 100, e, 3000.0, random);
    const std::optional<Similarity2> fit = diachron::fit_similarity2(pairs);
    REQUIRE(fit);
    const double residual = max_residual(pairs, *fit);
    worst = std::max(worst, residual);
    CHECK(residual < 1e-6);
  }
  INFO("worst UTM residual " << worst << " m");
  CHECK(worst < 1e-6);
}

TEST_CASE("Procrustes: a tight cluster plus a far point, at UTM coordinates, stays exact",
          "[geometry]") {
  // The one-pass sums are taken about a point near the centroid; the worst case for such sums is a
  // spread dominated by one far point, where "mean of products minus product of means" cancels
  // most. Exact data must still fit to well below a micrometre.
  diachron::RandomStream random(21);
  const Eigen::Vector3d utm(5e5, 5e6, 1e3);
  const Helmert3 rotated = Helmert3::from_axis_angle(1.0002, Eigen::Vector3d(0.1, -0.2, 0.9),
                                                     Eigen::Vector3d::Zero());
  const Helmert3 truth{rotated.scale, rotated.rotation,
                       utm - rotated.scale * (rotated.rotation * utm) + Eigen::Vector3d(4, -2, 1)};
  for (std::size_t n : {50u, 2000u}) {
    std::vector<PointPair3> pairs;
    for (std::size_t i = 0; i < n; ++i) {
      const double xz = random.uniform(-0.5, 0.5), xy = random.uniform(-0.5, 0.5);
      const Eigen::Vector3d x = utm + Eigen::Vector3d(random.uniform(-0.5, 0.5), xy, xz);
      pairs.push_back({x, truth(x)});
    }
    const Eigen::Vector3d far = utm + Eigen::Vector3d(20000.0, -15000.0, 300.0);
    pairs.push_back({far, truth(far)});
    const std::optional<Helmert3> fit = diachron::fit_helmert3(pairs);
    REQUIRE(fit);
    INFO("n " << n << " max residual " << max_residual(pairs, *fit));
    CHECK(max_residual(pairs, *fit) < 1e-6);
  }
}

TEST_CASE(
    "Procrustes: equal weights reproduce the unweighted fit, integer weights duplicate points",
    "[geometry]") {
  diachron::RandomStream random(4);
  const Helmert3 truth = Helmert3::from_axis_angle(1.5, {0.2, -0.4, 1.0}, {1, 2, 3});
  const auto pairs = make_pairs3(truth, 40, {0, 0, 0}, {50, 50, 10}, random, /*noise=*/0.5);
  const std::vector<double> equal(pairs.size(), 3.7);
  const auto plain = diachron::fit_helmert3(pairs);
  const auto weighted = diachron::fit_helmert3(pairs, equal.data());
  REQUIRE(plain);
  REQUIRE(weighted);
  CHECK(weighted->scale == Approx(plain->scale).epsilon(1e-13));
  CHECK((weighted->rotation - plain->rotation).norm() < 1e-13);
  CHECK((weighted->translation - plain->translation).norm() < 1e-11);

  // Weight 2 on a pair == that pair listed twice.
  std::vector<double> weights(pairs.size(), 1.0);
  auto duplicated = pairs;
  for (std::size_t i = 0; i < pairs.size(); i += 3) {
    weights[i] = 2.0;
    duplicated.push_back(pairs[i]);
  }
  const auto by_weight = diachron::fit_helmert3(pairs, weights.data());
  const auto by_copy = diachron::fit_helmert3(duplicated);
  REQUIRE(by_weight);
  REQUIRE(by_copy);
  CHECK(by_weight->scale == Approx(by_copy->scale).epsilon(1e-12));
  CHECK((by_weight->rotation - by_copy->rotation).norm() < 1e-12);
  CHECK((by_weight->translation - by_copy->translation).norm() < 1e-10);
  // ... and weights do change the answer on noisy data.
  CHECK((by_weight->translation - plain->translation).norm() > 1e-6);
}

TEST_CASE("Procrustes: zero-weighted outliers are ignored, even non-finite ones", "[geometry]") {
  diachron::RandomStream random(5);
  const Similarity2 truth{2.5, -1.0, {4.0, -7.0}};
  auto pairs = make_pairs2(truth, 20, {100, 100}, 50.0, random);
  std::vector<double> weights(pairs.size(), 1.0);
  for (int k = 0; k < 10; ++k) {
    pairs.push_back({{random.uniform(0, 200), random.uniform(0, 200)},
                     {random.uniform(0, 200), random.uniform(0, 200)}});
    weights.push_back(0.0);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  pairs.insert(pairs.begin(), PointPair2{{nan, 1.0}, {2.0, nan}});
  weights.insert(weights.begin(), 0.0);
  const auto fit = diachron::fit_similarity2(pairs, weights.data());
  REQUIRE(fit);
  CHECK(fit->scale == Approx(2.5).epsilon(1e-12));
  CHECK(angle_difference(fit->angle, -1.0) < 1e-12);
  CHECK((fit->translation - truth.translation).norm() < 1e-9);
  // Unweighted, the outliers spoil it (and the NaN makes it fail).
  CHECK_FALSE(diachron::fit_similarity2(pairs));
}

TEST_CASE("Procrustes: symmetric scale inverts exactly, Umeyama scale does not", "[geometry]") {
  diachron::RandomStream random(6);
  const Helmert3 truth = Helmert3::from_axis_angle(1.2, {0.3, 0.1, -0.2}, {5, 5, 5});
  const auto forward = make_pairs3(truth, 30, {0, 0, 0}, {10, 10, 10}, random, /*noise=*/1.0);
  const auto backward = swapped(forward);

  ProcrustesOptions symmetric;
  symmetric.symmetric_scale = true;
  const auto ab = diachron::fit_helmert3(forward, nullptr, symmetric);
  const auto ba = diachron::fit_helmert3(backward, nullptr, symmetric);
  REQUIRE(ab);
  REQUIRE(ba);
  CHECK(ab->scale * ba->scale == Approx(1.0).epsilon(1e-13));
  // The rotation does not depend on the scale choice and is inverted too.
  CHECK((ab->rotation * ba->rotation - Eigen::Matrix3d::Identity()).norm() < 1e-12);

  const auto umeyama_ab = diachron::fit_helmert3(forward);
  const auto umeyama_ba = diachron::fit_helmert3(backward);
  REQUIRE(umeyama_ab);
  REQUIRE(umeyama_ba);
  // Cauchy-Schwarz: the product is rho^2 < 1 under noise.
  CHECK(umeyama_ab->scale * umeyama_ba->scale < 1.0 - 1e-4);

  // 2D as well.
  const auto forward2 = make_pairs2(Similarity2{0.8, 2.0, {1, 1}}, 25, {0, 0}, 10.0, random, 0.7);
  const auto s_ab = diachron::fit_similarity2(forward2, nullptr, symmetric);
  const auto s_ba = diachron::fit_similarity2(swapped(forward2), nullptr, symmetric);
  REQUIRE(s_ab);
  REQUIRE(s_ba);
  CHECK(s_ab->scale * s_ba->scale == Approx(1.0).epsilon(1e-13));
  CHECK(angle_difference(s_ab->angle, -s_ba->angle) < 1e-13);
  const auto u_ab = diachron::fit_similarity2(forward2);
  const auto u_ba = diachron::fit_similarity2(swapped(forward2));
  CHECK(u_ab->scale * u_ba->scale < 1.0 - 1e-4);
}

TEST_CASE("Procrustes: the Umeyama fit is a least-squares minimum", "[geometry]") {
  diachron::RandomStream random(7);
  const Helmert3 truth = Helmert3::from_axis_angle(0.7, {1.0, 0.5, 0.2}, {3, -1, 2});
  const auto pairs = make_pairs3(truth, 25, {0, 0, 0}, {10, 10, 10}, random, /*noise=*/0.5);
  std::vector<double> weights;
  for (std::size_t i = 0; i < pairs.size(); ++i) weights.push_back(random.uniform(0.1, 3.0));
  const auto fit = diachron::fit_helmert3(pairs, weights.data());
  REQUIRE(fit);
  auto cost = [&](const Helmert3& h) {
    double sum = 0.0;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      sum += weights[i] * (h(pairs[i].source) - pairs[i].target).squaredNorm();
    }
    return sum;
  };
  const double best = cost(*fit);
  const double step = 1e-4;
  for (int k = 0; k < 7; ++k) {
    for (double sign : {-1.0, 1.0}) {
      Helmert3 moved = *fit;
      if (k == 0) moved.scale += sign * step;
      if (k >= 1 && k <= 3) {
        Eigen::Vector3d w = Eigen::Vector3d::Zero();
        w(k - 1) = sign * step;
        moved.rotation = diachron::rotation_from_axis_angle<double>(w) * moved.rotation;
      }
      if (k >= 4) moved.translation(k - 4) += sign * step;
      CHECK(cost(moved) > best);
    }
  }
}

TEST_CASE("Procrustes: rigid fit keeps scale 1", "[geometry]") {
  diachron::RandomStream random(8);
  const Helmert3 truth = Helmert3::from_axis_angle(1.0, {0.0, 0.0, 2.5}, {1, 2, 3});
  const auto pairs = make_pairs3(truth, 10, {0, 0, 0}, {10, 10, 10}, random);
  ProcrustesOptions rigid;
  rigid.estimate_scale = false;
  const auto fit = diachron::fit_helmert3(pairs, nullptr, rigid);
  REQUIRE(fit);
  CHECK(fit->scale == 1.0);
  CHECK(max_residual(pairs, *fit) < 1e-10);
  // On scaled data the rigid fit still returns scale 1 (and so cannot be exact).
  const Helmert3 scaled{2.0, truth.rotation, truth.translation};
  const auto scaled_pairs = make_pairs3(scaled, 10, {0, 0, 0}, {10, 10, 10}, random);
  const auto rigid_fit = diachron::fit_helmert3(scaled_pairs, nullptr, rigid);
  REQUIRE(rigid_fit);
  CHECK(rigid_fit->scale == 1.0);
  CHECK(diachron::rotation_distance(rigid_fit->rotation, truth.rotation) < 1e-10);
}

TEST_CASE("Procrustes: reflected data still give a proper rotation", "[geometry]") {
  // The corners of a 20 x 10 x 2 box, mirrored in z (det -1): the centred covariance is
  // diag(100, 25, -1), so the best proper rotation keeps x and y and is the identity.
  std::vector<PointPair3> pairs;
  for (double sx : {-1.0, 1.0}) {
    for (double sy : {-1.0, 1.0}) {
      for (double sz : {-1.0, 1.0}) {
        const Eigen::Vector3d x(10.0 * sx + 3.0, 5.0 * sy - 2.0, sz + 7.0);
        pairs.push_back({x, Eigen::Vector3d(x.x(), x.y(), -x.z())});
      }
    }
  }
  const auto fit = diachron::fit_helmert3(pairs);
  REQUIRE(fit);
  CHECK(fit->rotation.determinant() == Approx(1.0));
  CHECK((fit->rotation.transpose() * fit->rotation - Eigen::Matrix3d::Identity()).norm() < 1e-12);
  CHECK(diachron::rotation_angle(fit->rotation) < 1e-12);
  // Umeyama's scale uses trace(D S) = 100 + 25 - 1 over the variance 126.
  CHECK(fit->scale == Approx(124.0 / 126.0));

  // Random thin slab: still proper, and no worse than the identity.
  diachron::RandomStream random(9);
  std::vector<PointPair3> slab;
  for (int i = 0; i < 20; ++i) {
    const double xz = random.uniform(-1, 1), xy = random.uniform(-10, 10);
    const Eigen::Vector3d x(random.uniform(-10, 10), xy, xz);
    slab.push_back({x, Eigen::Vector3d(x.x(), x.y(), -x.z())});
  }
  const auto slab_fit = diachron::fit_helmert3(slab);
  REQUIRE(slab_fit);
  CHECK(slab_fit->rotation.determinant() == Approx(1.0));
}

TEST_CASE("Procrustes: planar 3D data and collinear 2D data are fine", "[geometry]") {
  diachron::RandomStream random(10);
  const Helmert3 truth = Helmert3::from_axis_angle(3.0, {0.1, 2.0, -0.5}, {1, 2, 3});
  std::vector<PointPair3> flat;
  for (int i = 0; i < 10; ++i) {
    const double xy = random.uniform(-10, 10);
    const Eigen::Vector3d x(random.uniform(-10, 10), xy, 0.0);  // z = 0
    flat.push_back({x, truth(x)});
  }
  const auto fit = diachron::fit_helmert3(flat);
  REQUIRE(fit);
  CHECK(diachron::rotation_distance(fit->rotation, truth.rotation) < 1e-12);

  // Two distinct points fix a 2D similarity, and 2D points on a line through the origin too.
  const Similarity2 s{2.0, 1.0, {0.5, 0.5}};
  std::vector<PointPair2> line;
  for (double t : {1.0, 2.0, 5.0}) line.push_back({{t, t}, s(Eigen::Vector2d(t, t))});
  const auto fit2 = diachron::fit_similarity2(line);
  REQUIRE(fit2);
  CHECK(angle_difference(fit2->angle, 1.0) < 1e-13);
}

TEST_CASE("Procrustes: degenerate input gives nullopt, bad weights throw", "[geometry]") {
  const Eigen::Vector3d p(1.0, 2.0, 3.0);
  const Helmert3 truth = Helmert3::from_axis_angle(2.0, {0.1, 0.2, 0.3}, {1, 1, 1});
  std::vector<PointPair3> empty;
  CHECK_FALSE(diachron::fit_helmert3(empty));

  std::vector<PointPair3> coincident(5, PointPair3{p, truth(p)});
  CHECK_FALSE(diachron::fit_helmert3(coincident));

  std::vector<PointPair3> two = {{p, truth(p)}, {2 * p, truth(2 * p)}};
  CHECK_FALSE(diachron::fit_helmert3(two));

  std::vector<PointPair3> collinear;
  for (double t : {0.0, 1.0, 2.5, 7.0}) {
    const Eigen::Vector3d x = Eigen::Vector3d(5e5, 5e6, 1e3) + t * Eigen::Vector3d(1.0, 1.0, 1.0);
    collinear.push_back({x, truth(x)});
  }
  CHECK_FALSE(diachron::fit_helmert3(collinear));

  // Non-collinear source onto a collinear target: no rotation fits.
  std::vector<PointPair3> onto_line = {
      {{0, 0, 0}, {0, 0, 0}}, {{1, 0, 0}, {1, 0, 0}}, {{0, 1, 0}, {2, 0, 0}}};
  CHECK_FALSE(diachron::fit_helmert3(onto_line));

  std::vector<PointPair3> good = {
      {{0, 0, 0}, truth({0, 0, 0})}, {{1, 0, 0}, truth({1, 0, 0})}, {{0, 1, 0}, truth({0, 1, 0})}};
  const std::vector<double> zeros(3, 0.0);
  CHECK_FALSE(diachron::fit_helmert3(good, zeros.data()));
  const std::vector<double> one_nonzero = {0.0, 1.0, 0.0};
  CHECK_FALSE(diachron::fit_helmert3(good, one_nonzero.data()));
  const std::vector<double> negative = {1.0, -1.0, 1.0};
  CHECK_THROWS_AS(diachron::fit_helmert3(good, negative.data()), diachron::Error);
  const std::vector<double> nan_weight = {1.0, std::nan(""), 1.0};
  CHECK_THROWS_AS(diachron::fit_helmert3(good, nan_weight.data()), diachron::Error);
  CHECK(diachron::fit_helmert3(good));

  auto with_inf = good;
  with_inf[1].target.x() = std::numeric_limits<double>::infinity();
  CHECK_FALSE(diachron::fit_helmert3(with_inf));

  // 2D: one point, coincident points, a mirrored target.
  std::vector<PointPair2> one = {{{1, 2}, {3, 4}}};
  CHECK_FALSE(diachron::fit_similarity2(one));
  std::vector<PointPair2> same = {{{1, 2}, {3, 4}}, {{1, 2}, {5, 6}}};
  CHECK_FALSE(diachron::fit_similarity2(same));
  std::vector<PointPair2> target_same = {{{1, 2}, {3, 4}}, {{5, 2}, {3, 4}}};
  CHECK_FALSE(diachron::fit_similarity2(target_same));
  std::vector<PointPair2> mirrored = {
      {{1, 0}, {1, 0}}, {{-1, 0}, {-1, 0}}, {{0, 1}, {0, -1}}, {{0, -1}, {0, 1}}};
  CHECK_FALSE(diachron::fit_similarity2(mirrored));
}

TEST_CASE("Procrustes: works on a Subset view", "[geometry]") {
  diachron::RandomStream random(12);
  const Similarity2 truth{1.1, 0.4, {2, 3}};
  auto pairs = make_pairs2(truth, 10, {0, 0}, 5.0, random);
  pairs[3].target += Eigen::Vector2d(100, 0);  // an outlier the subset leaves out
  const std::vector<std::size_t> indices = {0, 1, 2, 4, 5, 6};
  const diachron::Subset<PointPair2> subset(pairs.data(), indices.data(), indices.size());
  const auto fit = diachron::fit_similarity2(subset);
  REQUIRE(fit);
  CHECK(fit->scale == Approx(1.1).epsilon(1e-12));
  // Through the matrix interface of fit_similarity.
  const auto generic = diachron::fit_similarity<2>(subset);
  REQUIRE(generic);
  CHECK(generic->scale == Approx(fit->scale));
}
