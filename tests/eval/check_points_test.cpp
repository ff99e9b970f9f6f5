// Check-point statistics against a brute-force recomputation, with failed check points, the GSD
// columns, the triangulator plug-in and bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/eval/check_points.hpp>

using namespace diachron;

namespace {

struct Case {
  std::vector<std::optional<Vec3>> estimated;
  std::vector<Vec3> truth;
};

// 30 check points, every 7th failed, errors with a bias per axis.
Case make_case() {
  Case c;
  RandomStream rng(11, 0);
  for (int i = 0; i < 30; ++i) {
    // One draw per statement, z before y before x: the order of a call's arguments is unspecified
    // (core/random.hpp, "Order of draws"); the case was made so.
    const double z = rng.uniform(100.0, 300.0), y = rng.uniform(-500.0, 500.0);
    const Vec3 t(rng.uniform(-500.0, 500.0), y, z);
    c.truth.push_back(t);
    if (i % 7 == 3) {
      c.estimated.push_back(std::nullopt);
    } else {
      const double ez = 0.3 * rng.normal(), ey = -0.5 + 2.0 * rng.normal();
      c.estimated.push_back(t + Vec3(1.0 + rng.normal(), ey, ez));
    }
  }
  return c;
}

}  // namespace

TEST_CASE("evaluate_check_points: per-axis and 3D statistics equal a brute-force recomputation", "[eval]") {
  const Case c = make_case();
  const double gsd = 0.5;
  const CheckPointReport r = evaluate_check_points(c.estimated, c.truth, gsd);
  REQUIRE(r.success);
  CHECK(r.num_failed == 4);  // 3, 10, 17, 24
  CHECK(r.num_used == 26);
  CHECK(r.failed == std::vector<std::size_t>{3, 10, 17, 24});
  for (int a = 0; a < 3; ++a) {
    double sum = 0.0, sum_abs = 0.0, sum_sq = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < c.truth.size(); ++i) {
      if (!c.estimated[i]) continue;
      const double e = (*c.estimated[i])[a] - c.truth[i][a];
      sum += e;
      sum_abs += std::abs(e);
      sum_sq += e * e;
      ++n;
    }
    const double mean = sum / static_cast<double>(n);
    const ErrorStatistics& s = r.axes_m[static_cast<std::size_t>(a)];
    CHECK(s.count == n);
    CHECK(s.mean == Approx(mean).epsilon(1e-12));
    CHECK(s.mean_abs == Approx(sum_abs / static_cast<double>(n)).epsilon(1e-12));
    CHECK(s.rms == Approx(std::sqrt(sum_sq / static_cast<double>(n))).epsilon(1e-12));
    CHECK(s.sigma == Approx(std::sqrt(sum_sq / static_cast<double>(n) - mean * mean)).epsilon(1e-9));
    const ErrorStatistics& g = r.axes_gsd[static_cast<std::size_t>(a)];
    CHECK(g.mean == Approx(s.mean / gsd).epsilon(1e-12));
    CHECK(g.rms == Approx(s.rms / gsd).epsilon(1e-12));
  }
  double sum_sq = 0.0;
  for (const Vec3& e : r.errors_m) sum_sq += e.squaredNorm();
  CHECK(r.rms_3d_m == Approx(std::sqrt(sum_sq / 26.0)).epsilon(1e-12));
  CHECK(r.rms_3d_m * r.rms_3d_m ==
        Approx(r.axes_m[0].rms * r.axes_m[0].rms + r.axes_m[1].rms * r.axes_m[1].rms + r.axes_m[2].rms * r.axes_m[2].rms)
            .epsilon(1e-12));
  CHECK(r.rms_3d_gsd == Approx(r.rms_3d_m / gsd).epsilon(1e-12));
  CHECK(r.gsd_m == gsd);
  // The biases are found (1, -0.5, 0 m within the noise of 25 draws).
  CHECK(r.axes_m[0].mean == Approx(1.0).margin(0.6));
  CHECK(r.axes_m[1].mean == Approx(-0.5).margin(1.2));
}

TEST_CASE("evaluate_check_points: exact estimates give zero errors; no GSD gives NaN GSD columns", "[eval]") {
  const Case c = make_case();
  std::vector<std::optional<Vec3>> exact(c.truth.begin(), c.truth.end());
  const CheckPointReport r = evaluate_check_points(exact, c.truth);
  REQUIRE(r.success);
  CHECK(r.num_failed == 0);
  CHECK(r.rms_3d_m == 0.0);
  for (const ErrorStatistics& s : r.axes_m) {
    CHECK(s.mean == 0.0);
    CHECK(s.sigma == 0.0);
  }
  CHECK(std::isnan(r.gsd_m));
  CHECK(std::isnan(r.axes_gsd[0].mean));
  CHECK(std::isnan(r.rms_3d_gsd));
}

TEST_CASE("evaluate_check_points: all failed or none is success == false with a reason", "[eval]") {
  const std::vector<Vec3> truth{Vec3(0, 0, 0), Vec3(1, 1, 1)};
  const CheckPointReport r = evaluate_check_points({std::nullopt, std::nullopt}, truth, 1.0);
  CHECK_FALSE(r.success);
  CHECK(r.num_failed == 2);
  CHECK_THAT(r.reason, Catch::Contains("2 failed"));
  CHECK(std::isnan(r.rms_3d_m));
  const CheckPointReport none = evaluate_check_points({}, {});
  CHECK_FALSE(none.success);
  CHECK_THAT(none.reason, Catch::Contains("no check points"));
}

TEST_CASE("evaluate_check_points: bad input throws naming the index", "[eval]") {
  const std::vector<Vec3> truth{Vec3(0, 0, 0), Vec3(1, 1, 1)};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(evaluate_check_points({Vec3(0, 0, 0)}, truth), Error);
  CHECK_THROWS_WITH(evaluate_check_points({Vec3(0, 0, 0), Vec3(nan, 0, 0)}, truth), Catch::Contains("estimate 1"));
  CHECK_THROWS_WITH(evaluate_check_points({Vec3(0, 0, 0), std::nullopt}, {Vec3(0, 0, 0), Vec3(0, nan, 0)}),
                    Catch::Contains("true position 1"));
  CHECK_THROWS_AS(evaluate_check_points({Vec3(0, 0, 0), Vec3(0, 0, 0)}, truth, -1.0), Error);
}

TEST_CASE("evaluate_check_points: the triangulator plug-in is called once per point, in order", "[eval]") {
  std::vector<ObservedCheckPoint> points(4);
  for (std::size_t i = 0; i < points.size(); ++i) {
    points[i].truth = Vec3(static_cast<double>(i), 0.0, 0.0);
    // The observation count encodes what the fake triangulator returns.
    points[i].observations.resize(i);
  }
  std::vector<std::size_t> calls;
  const auto triangulate = [&calls](const std::vector<CheckPointObservation>& obs) -> std::optional<Vec3> {
    calls.push_back(obs.size());
    if (obs.size() < 2) return std::nullopt;
    return Vec3(static_cast<double>(obs.size()) + 0.25, 0.0, 0.0);
  };
  const CheckPointReport r = evaluate_check_points(points, triangulate, 0.25);
  CHECK(calls == std::vector<std::size_t>{0, 1, 2, 3});
  REQUIRE(r.success);
  CHECK(r.failed == std::vector<std::size_t>{0, 1});
  CHECK(r.used == std::vector<std::size_t>{2, 3});
  CHECK(r.axes_m[0].mean == Approx(0.25));
  CHECK(r.axes_gsd[0].mean == Approx(1.0));
  CHECK(r.axes_m[1].rms == 0.0);
}
