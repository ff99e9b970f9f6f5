#include <catch2/catch.hpp>

#include <cmath>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/robust/chance_inliers.hpp>

TEST_CASE("log_binomial_tail: matches direct summation", "[robust]") {
  // n = 20, p = 0.3: P(X >= 10) = 0.047962... (summed directly below).
  const std::size_t n = 20;
  const double p = 0.3;
  for (std::size_t k : {0u, 1u, 5u, 10u, 15u, 20u}) {
    double direct = 0.0;
    for (std::size_t j = k; j <= n; ++j)
      direct += std::exp(std::lgamma(n + 1.0) - std::lgamma(j + 1.0) - std::lgamma(n - j + 1.0)) *
                std::pow(p, double(j)) * std::pow(1 - p, double(n - j));
    REQUIRE(std::exp(diachron::log_binomial_tail(n, p, k)) == Approx(direct).epsilon(1e-9));
  }
  REQUIRE(std::isinf(diachron::log_binomial_tail(10, 0.5, 11)));
  REQUIRE(diachron::log_binomial_tail(10, 1.0, 10) == 0.0);
}

TEST_CASE("min_significant_inliers: random data rarely reach the bound, and the bound is tight", "[robust]") {
  // Simulate the maximum inlier count of `trials` random hypotheses over uniform data.
  const std::size_t n = 2000;
  const double p = 0.002;
  const std::size_t trials = 200;
  const std::size_t bound = diachron::min_significant_inliers(n, p, double(trials), 0.05, 0);
  diachron::RandomStream rng(5);
  int exceed = 0, reach_minus_two = 0;
  const int runs = 200;
  for (int r = 0; r < runs; ++r) {
    std::size_t best = 0;
    for (std::size_t t = 0; t < trials; ++t) {
      std::size_t count = 0;
      for (std::size_t i = 0; i < n; ++i) count += rng.uniform01() < p;
      best = std::max(best, count);
    }
    exceed += best >= bound;
    reach_minus_two += best >= bound - 2;
  }
  // alpha = 5 % bounds the chance of any hypothesis reaching it; a bound two lower is often reached.
  REQUIRE(exceed <= runs * 0.08);
  REQUIRE(reach_minus_two >= runs * 0.2);
}

TEST_CASE("min_significant_inliers: grows with trials and data, counts the sample", "[robust]") {
  const auto a = diachron::min_significant_inliers(1000, 1e-3, 1.0, 0.01, 2);
  const auto b = diachron::min_significant_inliers(1000, 1e-3, 4000.0, 0.01, 2);
  const auto c = diachron::min_significant_inliers(10000, 1e-3, 4000.0, 0.01, 2);
  REQUIRE(a >= 3);
  REQUIRE(b > a);
  REQUIRE(c > b);
  REQUIRE(diachron::min_significant_inliers(2, 0.5, 1.0, 0.01, 2) == 3);
  REQUIRE_THROWS_AS(diachron::min_significant_inliers(10, 0.1, 1.0, 0.0, 2), diachron::Error);
}

TEST_CASE("wilson_upper_bound: the rate whose z-sigma interval just reaches the observed share", "[robust]") {
  // Brute force: the Wilson bound p solves (p - share)^2 = z^2 p (1 - p) / n for p >= share; find it
  // by bisection on that equation.
  for (const double share : {0.0, 0.01, 0.05, 0.3, 0.9, 1.0})
    for (const double n : {20.0, 256.0, 5000.0}) {
      CAPTURE(share, n);
      const double z = 3.09;
      double lo = share, hi = 1.0;
      for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        ((mid - share) * (mid - share) < z * z * mid * (1.0 - mid) / n ? lo : hi) = mid;
      }
      const double bound = diachron::wilson_upper_bound(share, n, z);
      CHECK(bound == Approx(lo).margin(1e-12));
      CHECK(bound >= share);
      CHECK(bound <= 1.0);
    }
  // Nothing seen in 256 trials still allows a rate of a few percent; more trials, less.
  CHECK(diachron::wilson_upper_bound(0.0, 256.0, 3.09) > 0.03);
  CHECK(diachron::wilson_upper_bound(0.0, 2560.0, 3.09) < 0.004);
  CHECK(diachron::wilson_upper_bound(0.2, 100.0, 0.0) == Approx(0.2));
  CHECK_THROWS_AS(diachron::wilson_upper_bound(0.2, 0.0, 3.09), diachron::Error);
  CHECK_THROWS_AS(diachron::wilson_upper_bound(1.2, 10.0, 3.09), diachron::Error);
}
