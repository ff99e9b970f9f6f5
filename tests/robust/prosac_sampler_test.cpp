#include <algorithm>
#include <cstddef>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/robust/prosac_sampler.hpp>

using diachron::ProsacSampler;
using diachron::RandomStream;

static_assert(diachron::is_sampler_v<ProsacSampler>, "ProsacSampler is a Sampler");

TEST_CASE("ProsacSampler: the first sample is the top-ranked data", "[robust]") {
  for (std::size_t m : {1u, 2u, 3u}) {
    ProsacSampler sampler;
    sampler.prepare(500, m);
    RandomStream rng(0, 0);
    std::vector<std::size_t> sample(m);
    sampler.draw(0, rng, sample.data());
    std::sort(sample.begin(), sample.end());
    for (std::size_t k = 0; k < m; ++k) CHECK(sample[k] == k);
  }
}

TEST_CASE("ProsacSampler: samples are distinct, in range, and hold the newest pool member",
          "[robust]") {
  const std::size_t n = 300, m = 3;
  ProsacSampler sampler(2000.0);
  sampler.prepare(n, m);
  std::size_t previous_pool = m;
  for (std::size_t it = 0; it < 5000; ++it) {
    const std::size_t pool = sampler.pool_size(it);
    REQUIRE(pool >= previous_pool);  // the pool only grows
    REQUIRE(pool <= n);
    previous_pool = pool;
    RandomStream rng(9, it);
    std::vector<std::size_t> sample(m);
    sampler.draw(it, rng, sample.data());
    for (std::size_t k : sample) REQUIRE(k < pool);
    if (pool < n) REQUIRE(std::count(sample.begin(), sample.end(), pool - 1) == 1);
    std::sort(sample.begin(), sample.end());
    REQUIRE(std::adjacent_find(sample.begin(), sample.end()) == sample.end());
  }
  CHECK(sampler.pool_size(4999) == n);  // T_N = 2000 samples: growth is over
}

TEST_CASE("ProsacSampler: early samples favour the top-ranked, deterministically", "[robust]") {
  const std::size_t n = 1000, m = 2;
  ProsacSampler sampler;
  sampler.prepare(n, m);
  double mean_index = 0.0;
  for (std::size_t it = 0; it < 100; ++it) {
    std::size_t a[2], b[2];
    RandomStream rng_a(5, it), rng_b(5, it);
    sampler.draw(it, rng_a, a);
    sampler.draw(it, rng_b, b);
    REQUIRE(std::equal(a, a + 2, b));
    mean_index += static_cast<double>(a[0] + a[1]) / 200.0;
  }
  // Uniform sampling would average 499.5.
  CHECK(mean_index < 50.0);
  CHECK(sampler.pool_size(0) == 2);
  CHECK(sampler.pool_size(1) == 3);
}

TEST_CASE("ProsacSampler: invalid growth is rejected", "[robust]") {
  CHECK_THROWS_AS(ProsacSampler(0.5), diachron::Error);
  CHECK_NOTHROW(ProsacSampler(1.0));
}
