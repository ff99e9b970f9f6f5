// Tests for Homography2 and the normalised DLT: exact estimation on 4 and 20 pairs, application
// near the line at infinity, inverse and composition, degenerate configurations.

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/geometry/similarity2.hpp>

using diachron::Homography2;
using diachron::PointPair2;
using diachron::Vec2;

namespace {

/// A strongly projective homography, as between a tilted aerial image and a map.
Homography2 example_homography() {
  Eigen::Matrix3d h;
  h << 1.2, 0.15, 30.0,  //
      -0.1, 0.9, -12.0,  //
      2e-4, -1e-4, 1.0;
  return Homography2{h};
}

std::vector<PointPair2> make_pairs(const Homography2& h, std::size_t n,
                                   diachron::RandomStream& random, Vec2 offset = Vec2::Zero()) {
  std::vector<PointPair2> pairs;
  while (pairs.size() < n) {
    // One draw per statement, y before x: the order of a call's arguments is unspecified
    // (core/random.hpp, "Order of draws"); this is the order the tests were written with.
    const double xy = random.uniform(0, 1500);
    const Vec2 x = offset + Vec2(random.uniform(0, 2000), xy);
    const std::optional<Vec2> y = h(x);
    if (y) pairs.push_back({x, *y});
  }
  return pairs;
}

double max_transfer_error(const Homography2& h, const std::vector<PointPair2>& pairs) {
  double worst = 0.0;
  for (const auto& pair : pairs) {
    const std::optional<Vec2> y = h(pair.source);
    if (!y) return std::numeric_limits<double>::infinity();
    worst = std::max(worst, (*y - pair.target).norm());
  }
  return worst;
}

}  // namespace

TEST_CASE("Homography2: applies the projective map and refuses points at infinity", "[geometry]") {
  const Homography2 h = example_homography();
  const Vec2 x(100.0, 200.0);
  const Eigen::Vector3d expected = h.matrix * Eigen::Vector3d(100.0, 200.0, 1.0);
  const std::optional<Vec2> y = h(x);
  REQUIRE(y);
  CHECK((*y - expected.head<2>() / expected.z()).norm() < 1e-12);

  // On the vanishing line 2e-4 x - 1e-4 y + 1 = 0, e.g. (0, 10000), w is 0.
  CHECK_FALSE(h(Vec2(0.0, 10000.0)));
  CHECK(h(Vec2(0.0, 9000.0)));
  CHECK_FALSE(h(Vec2(std::nan(""), 1.0)));
  CHECK((*Homography2::identity()(x) - x).norm() == 0.0);
}

TEST_CASE("Homography2: inverse and composition", "[geometry]") {
  const Homography2 b_from_a = example_homography();
  const std::optional<Homography2> a_from_b = b_from_a.inverse();
  REQUIRE(a_from_b);
  diachron::RandomStream random(1);
  Eigen::Matrix3d other_matrix;
  other_matrix << 0.8, -0.3, 5.0, 0.25, 1.1, 7.0, -1e-4, 3e-4, 1.0;
  const Homography2 c_from_b{other_matrix};
  for (int i = 0; i < 50; ++i) {
    const double xy = random.uniform(0, 1500);
    const Vec2 x(random.uniform(0, 2000), xy);
    const std::optional<Vec2> y = b_from_a(x);
    REQUIRE(y);
    const std::optional<Vec2> back = (*a_from_b)(*y);
    REQUIRE(back);
    CHECK((*back - x).norm() < 1e-9);
    const std::optional<Vec2> composed = (c_from_b * b_from_a)(x);
    const std::optional<Vec2> chained = c_from_b(*y);
    REQUIRE(composed);
    REQUIRE(chained);
    CHECK((*composed - *chained).norm() < 1e-9);
  }
  Eigen::Matrix3d singular;
  singular << 1, 2, 3, 2, 4, 6, 0, 0, 1;
  CHECK_FALSE(Homography2{singular}.inverse());
  CHECK_FALSE(Homography2{Eigen::Matrix3d::Zero()}.inverse());
}

TEST_CASE("Homography2: normalised DLT is exact on 4 pairs and on 20 pairs", "[geometry]") {
  diachron::RandomStream random(2);
  const Homography2 truth = example_homography();
  for (std::size_t n : {4u, 5u, 20u}) {
    for (int trial = 0; trial < 20; ++trial) {
      const auto pairs = make_pairs(truth, n, random);
      const std::optional<Homography2> fit = diachron::estimate_homography(pairs);
      REQUIRE(fit);
      CHECK(fit->matrix.norm() == Approx(1.0));
      // Equal up to scale to the truth.
      const Eigen::Matrix3d a = fit->matrix / fit->matrix(2, 2);
      CHECK((a - truth.matrix).norm() < 1e-9 * truth.matrix.norm());
      CHECK(max_transfer_error(*fit, pairs) < 1e-8);
      // And off the data as well.
      CHECK(max_transfer_error(*fit, make_pairs(truth, 20, random)) < 1e-7);
    }
  }
}

TEST_CASE("Homography2: DLT on UTM-sized coordinates stays exact", "[geometry]") {
  diachron::RandomStream random(3);
  // A similarity between map coordinates is a homography too.
  const diachron::Similarity2 map_from_image{0.5, 0.3, {5e5, 5e6}};
  std::vector<PointPair2> pairs;
  for (int i = 0; i < 20; ++i) {
    const double xy = random.uniform(0, 3000);
    const Vec2 x(random.uniform(0, 4000), xy);
    pairs.push_back({x, map_from_image(x)});
  }
  const std::optional<Homography2> fit = diachron::estimate_homography(pairs);
  REQUIRE(fit);
  CHECK(max_transfer_error(*fit, pairs) < 1e-6);
}

TEST_CASE("Homography2: DLT least squares under noise stays close", "[geometry]") {
  diachron::RandomStream random(4);
  const Homography2 truth = example_homography();
  auto pairs = make_pairs(truth, 200, random);
  for (auto& pair : pairs) {
    const double ny = random.normal();
    pair.target += 0.5 * Vec2(random.normal(), ny);
  }
  const std::optional<Homography2> fit = diachron::estimate_homography(pairs);
  REQUIRE(fit);
  const auto clean = make_pairs(truth, 50, random);
  CHECK(max_transfer_error(*fit, clean) < 1.0);
}

TEST_CASE("Homography2: degenerate configurations give nullopt", "[geometry]") {
  const Homography2 truth = example_homography();
  auto pair_at = [&](double x, double y) { return PointPair2{Vec2(x, y), *truth(Vec2(x, y))}; };
  // Fewer than 4 pairs.
  std::vector<PointPair2> three = {pair_at(0, 0), pair_at(100, 0), pair_at(0, 100)};
  CHECK_FALSE(diachron::estimate_homography(three));
  // All collinear.
  std::vector<PointPair2> line;
  for (int i = 0; i < 10; ++i) line.push_back(pair_at(10.0 * i, 5.0 * i + 3.0));
  CHECK_FALSE(diachron::estimate_homography(line));
  // Three of four collinear.
  std::vector<PointPair2> three_collinear = {pair_at(0, 0), pair_at(100, 100), pair_at(200, 200),
                                             pair_at(0, 300)};
  CHECK_FALSE(diachron::estimate_homography(three_collinear));
  // Coincident.
  std::vector<PointPair2> same(6, pair_at(50, 50));
  CHECK_FALSE(diachron::estimate_homography(same));
  // Non-finite.
  std::vector<PointPair2> with_nan = {pair_at(0, 0), pair_at(100, 0), pair_at(0, 100),
                                      pair_at(100, 100)};
  with_nan[2].target.y() = std::nan("");
  CHECK_FALSE(diachron::estimate_homography(with_nan));
  with_nan[2].target.y() = 100.0;
  // A general-position square is fine, also through a Subset view.
  with_nan[2] = pair_at(0, 100);
  const diachron::Subset<PointPair2> view(with_nan.data(), with_nan.size());
  CHECK(diachron::estimate_homography(view));
}
