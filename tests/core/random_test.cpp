#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include <diachron/core/random.hpp>

using diachron::RandomStream;

TEST_CASE("RandomStream: the same seed and stream give the same sequence", "[core]") {
  RandomStream a(42, 7), b(42, 7);
  for (int i = 0; i < 1000; ++i) {
    const auto x = a.next_u64();  // one draw per statement (core/random.hpp, "Order of draws")
    REQUIRE(x == b.next_u64());
  }
}

TEST_CASE("RandomStream: different seeds or streams give different sequences", "[core]") {
  RandomStream a(42, 7), b(43, 7), c(42, 8);
  int same_b = 0, same_c = 0;
  for (int i = 0; i < 1000; ++i) {
    const auto x = a.next_u64();
    same_b += x == b.next_u64();
    same_c += x == c.next_u64();
  }
  REQUIRE(same_b == 0);
  REQUIRE(same_c == 0);
}

TEST_CASE("RandomStream: uniform_index is in range and unbiased", "[core]") {
  RandomStream rng(1);
  const std::size_t n = 7;
  std::vector<int> counts(n, 0);
  const int draws = 70000;
  for (int i = 0; i < draws; ++i) {
    const auto k = rng.uniform_index(n);
    REQUIRE(k < n);
    ++counts[k];
  }
  // Each bin expects 10000 with sd ~ 93; 6 sd is a bound a broken generator would miss.
  for (int c : counts) REQUIRE(std::abs(c - 10000) < 560);
  REQUIRE(rng.uniform_index(1) == 0);
}

TEST_CASE("RandomStream: uniform01 and normal have the right moments", "[core]") {
  RandomStream rng(3, 1);
  const int n = 200000;
  double sum = 0, sum2 = 0, nsum = 0, nsum2 = 0;
  for (int i = 0; i < n; ++i) {
    const double u = rng.uniform01();
    REQUIRE(u >= 0.0);
    REQUIRE(u < 1.0);
    sum += u;
    sum2 += u * u;
    const double z = rng.normal();
    nsum += z;
    nsum2 += z * z;
  }
  REQUIRE(sum / n == Approx(0.5).margin(0.005));
  REQUIRE(sum2 / n - (sum / n) * (sum / n) == Approx(1.0 / 12.0).margin(0.002));
  REQUIRE(nsum / n == Approx(0.0).margin(0.01));
  REQUIRE(nsum2 / n == Approx(1.0).margin(0.01));
}
