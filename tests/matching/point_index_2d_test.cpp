#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/matching/point_index_2d.hpp>

using diachron::IndexedNeighbor;
using diachron::PointIndex2D;
using Eigen::Vector2d;

namespace {

std::vector<IndexedNeighbor> sorted_oracle(const std::vector<Vector2d>& pts, const Vector2d& q,
                                           bool (*keep)(const Vector2d& d, double a, double b), double a,
                                           double b) {
  std::vector<IndexedNeighbor> out;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (keep(pts[i] - q, a, b)) out.push_back({i, (pts[i] - q).norm()});
  std::sort(out.begin(), out.end(), [](const IndexedNeighbor& x, const IndexedNeighbor& y) {
    return x.distance < y.distance || (x.distance == y.distance && x.index < y.index);
  });
  return out;
}

bool in_radius(const Vector2d& d, double r, double) { return d.squaredNorm() <= r * r; }
bool in_box(const Vector2d& d, double hw, double hh) { return std::abs(d.x()) <= hw && std::abs(d.y()) <= hh; }
bool everything(const Vector2d&, double, double) { return true; }

void require_equal(const std::vector<IndexedNeighbor>& got, const std::vector<IndexedNeighbor>& want) {
  REQUIRE(got.size() == want.size());
  for (std::size_t k = 0; k < got.size(); ++k) {
    REQUIRE(got[k].index == want[k].index);
    REQUIRE(got[k].distance == want[k].distance);
  }
}

std::vector<Vector2d> random_points(diachron::RandomStream& rng, std::size_t n, double extent) {
  std::vector<Vector2d> pts(n);
  // One draw per statement, y before x: the order of a call's arguments is unspecified
  // (core/random.hpp, "Order of draws").
  for (auto& p : pts) {
    const double y = rng.uniform(0, extent);
    p = Vector2d(rng.uniform(0, extent), y);
  }
  return pts;
}

}  // namespace

TEST_CASE("PointIndex2D: radius, knn and box search equal brute force on random points", "[matching]") {
  diachron::RandomStream rng(42);
  for (std::size_t n : {1u, 7u, 100u, 3000u}) {
    const auto pts = random_points(rng, n, 1000.0);
    const PointIndex2D index(pts);
    REQUIRE(index.size() == n);
    for (int trial = 0; trial < 60; ++trial) {
      const double qy = rng.uniform(-100, 1100);  // y before x, as in random_points
      const Vector2d q(rng.uniform(-100, 1100), qy);
      const double r = rng.uniform(0, 200);
      INFO("n " << n << " trial " << trial);
      // The radius is a plain distance in pixels: a point at 150 px is found with radius 200.
      require_equal(index.radius_search(q, r), sorted_oracle(pts, q, in_radius, r, 0));
      const double hw = rng.uniform(0, 150), hh = rng.uniform(0, 150);
      require_equal(index.box_search(q, hw, hh), sorted_oracle(pts, q, in_box, hw, hh));
      const std::size_t k = 1 + rng.uniform_index(20);
      auto all = sorted_oracle(pts, q, everything, 0, 0);
      all.resize(std::min(k, all.size()));
      require_equal(index.knn_search(q, k), all);
    }
  }
}

TEST_CASE("PointIndex2D: the radius is inclusive and not squared; exact ties are ordered by index",
          "[matching]") {
  // Integer grid with duplicates: many exactly equal distances.
  std::vector<Vector2d> pts;
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 20; ++x) pts.emplace_back(x, y);
  pts.emplace_back(5, 5);  // duplicate of index 105
  const PointIndex2D index(pts);
  const auto r = index.radius_search(Vector2d(5, 5), 3.0);
  require_equal(r, sorted_oracle(pts, Vector2d(5, 5), in_radius, 3.0, 0));
  REQUIRE(r[0].index == 105);
  REQUIRE(r[1].index == 400);
  REQUIRE(r[0].distance == 0.0);
  // (8, 5) is exactly 3 px away: inclusive. With a squared-radius mix-up 3 would find 9 px.
  REQUIRE(std::any_of(r.begin(), r.end(), [](const IndexedNeighbor& n) { return n.index == 5 * 20 + 8; }));
  REQUIRE(std::none_of(r.begin(), r.end(), [](const IndexedNeighbor& n) { return n.distance > 3.0; }));
  for (std::size_t k : {1u, 2u, 3u, 6u, 10u, 13u, 30u}) {
    for (const Vector2d& q : {Vector2d(5, 5), Vector2d(0, 0), Vector2d(10.5, 3), Vector2d(-2, 7)}) {
      auto all = sorted_oracle(pts, q, everything, 0, 0);
      all.resize(k);
      require_equal(index.knn_search(q, k), all);
    }
  }
  REQUIRE(index.radius_search(Vector2d(5, 5), 0.0).size() == 2);
}

TEST_CASE("PointIndex2D: empty index, degenerate queries and bad input", "[matching]") {
  const PointIndex2D empty(std::vector<Vector2d>{});
  REQUIRE(empty.empty());
  REQUIRE(empty.radius_search(Vector2d(0, 0), 10).empty());
  REQUIRE(empty.knn_search(Vector2d(0, 0), 3).empty());
  const PointIndex2D one(std::vector<Vector2d>{Vector2d(1, 1)});
  REQUIRE(one.knn_search(Vector2d(0, 0), 5).size() == 1);
  REQUIRE(one.knn_search(Vector2d(0, 0), 0).empty());
  REQUIRE(one.radius_search(Vector2d(0, 0), -1).empty());
  REQUIRE(one.radius_search(Vector2d(0, 0), std::numeric_limits<double>::quiet_NaN()).empty());
  REQUIRE(one.radius_search(Vector2d(std::numeric_limits<double>::quiet_NaN(), 0), 5).empty());
  REQUIRE_THROWS_AS(PointIndex2D(std::vector<Vector2d>{Vector2d(0, std::numeric_limits<double>::infinity())}),
                    diachron::Error);
}

TEST_CASE("PointIndex2D: survives moves; concurrent queries agree with serial ones", "[matching]") {
  diachron::RandomStream rng(9);
  const auto pts = random_points(rng, 2000, 500.0);
  PointIndex2D first(pts);
  PointIndex2D index(std::move(first));  // the tree must still see the points
  std::vector<Vector2d> queries = random_points(rng, 400, 500.0);
  std::vector<std::vector<IndexedNeighbor>> parallel(queries.size());
  diachron::parallel_for(queries.size(), 2, [&](std::size_t i) { parallel[i] = index.radius_search(queries[i], 25.0); });
  for (std::size_t i = 0; i < queries.size(); ++i)
    require_equal(parallel[i], sorted_oracle(pts, queries[i], in_radius, 25.0, 0));
  PointIndex2D assigned(std::vector<Vector2d>{});
  assigned = std::move(index);
  require_equal(assigned.knn_search(queries[0], 4), [&] {
    auto all = sorted_oracle(pts, queries[0], everything, 0, 0);
    all.resize(4);
    return all;
  }());
}
