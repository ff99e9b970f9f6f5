// ErrorStatistics against values worked out by hand and against a brute-force recomputation.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/eval/error_statistics.hpp>

using namespace diachron;

TEST_CASE("error_statistics: hand-worked values", "[eval]") {
  // e = -1, 1, 2, 6: mean 2, |e| mean 2.5, e^2 mean 42/4, deviations -3 -1 0 4 -> variance 26/4.
  const ErrorStatistics s = error_statistics({-1.0, 1.0, 2.0, 6.0});
  CHECK(s.count == 4);
  CHECK(s.mean == Approx(2.0));
  CHECK(s.mean_abs == Approx(2.5));
  CHECK(s.abs_mean() == Approx(2.0));
  CHECK(s.rms == Approx(std::sqrt(42.0 / 4.0)));
  CHECK(s.sigma == Approx(std::sqrt(26.0 / 4.0)));
  CHECK(s.median == Approx(1.5));
  // |e - 1.5| = 2.5 0.5 0.5 4.5 -> median 1.5.
  CHECK(s.nmad == Approx(kNmadFactor * 1.5));
  CHECK(s.min == -1.0);
  CHECK(s.max == 6.0);
  // The paper's |mu| differs from |mean| as soon as signs mix.
  CHECK(s.mean_abs > s.abs_mean());
}

TEST_CASE("error_statistics: rms^2 = mean^2 + sigma^2 and odd-count median", "[eval]") {
  std::vector<double> e;
  RandomStream rng(3, 0);
  for (int i = 0; i < 101; ++i) e.push_back(5.0 + 2.0 * rng.normal());
  const ErrorStatistics s = error_statistics(e);
  CHECK(s.rms * s.rms == Approx(s.mean * s.mean + s.sigma * s.sigma).epsilon(1e-12));
  std::vector<double> sorted = e;
  std::sort(sorted.begin(), sorted.end());
  CHECK(s.median == sorted[50]);
  CHECK(s.nmad == Approx(2.0).epsilon(0.3));
}

TEST_CASE("error_statistics: empty gives NaN, non-finite throws, scaled", "[eval]") {
  const ErrorStatistics empty = error_statistics({});
  CHECK(empty.count == 0);
  CHECK(std::isnan(empty.mean));
  CHECK(std::isnan(empty.nmad));
  CHECK_THROWS_AS(error_statistics({1.0, std::numeric_limits<double>::quiet_NaN()}), Error);
  CHECK_THROWS_WITH(error_statistics({1.0, std::numeric_limits<double>::infinity()}), Catch::Contains("error 1"));
  const ErrorStatistics s = error_statistics({-2.0, 4.0}).scaled(0.5);
  CHECK(s.mean == Approx(0.5));
  CHECK(s.mean_abs == Approx(1.5));
  CHECK(s.min == Approx(-1.0));
  CHECK(s.count == 2);
  CHECK_THROWS_AS(s.scaled(0.0), Error);
}
