#include <algorithm>
#include <cstddef>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/robust/uniform_sampler.hpp>

using diachron::RandomStream;
using diachron::UniformSampler;

static_assert(diachron::is_sampler_v<UniformSampler>, "UniformSampler is a Sampler");
static_assert(!diachron::is_sampler_v<int>, "int is not a Sampler");

TEST_CASE("UniformSampler: draws distinct indices in range", "[robust]") {
  for (std::size_t n : {3u, 4u, 10u, 1000u}) {
    for (std::size_t m : {1u, 2u, 3u}) {
      UniformSampler sampler;
      sampler.prepare(n, m);
      for (std::size_t it = 0; it < 2000; ++it) {
        RandomStream rng(7, it);
        std::vector<std::size_t> sample(m);
        sampler.draw(it, rng, sample.data());
        for (std::size_t k = 0; k < m; ++k) REQUIRE(sample[k] < n);
        std::sort(sample.begin(), sample.end());
        REQUIRE(std::adjacent_find(sample.begin(), sample.end()) == sample.end());
      }
    }
  }
}

TEST_CASE("UniformSampler: a full-size sample is a permutation", "[robust]") {
  UniformSampler sampler;
  sampler.prepare(5, 5);
  RandomStream rng(1, 0);
  std::vector<std::size_t> sample(5);
  sampler.draw(0, rng, sample.data());
  std::sort(sample.begin(), sample.end());
  CHECK(sample == std::vector<std::size_t>{0, 1, 2, 3, 4});
}

TEST_CASE("UniformSampler: deterministic per stream and close to uniform", "[robust]") {
  UniformSampler sampler;
  sampler.prepare(10, 3);
  std::vector<std::size_t> counts(10, 0);
  const std::size_t draws = 20000;
  for (std::size_t it = 0; it < draws; ++it) {
    std::size_t a[3], b[3];
    RandomStream rng_a(3, it), rng_b(3, it);
    sampler.draw(it, rng_a, a);
    sampler.draw(it, rng_b, b);
    REQUIRE(std::equal(a, a + 3, b));
    for (std::size_t k : a) ++counts[k];
  }
  // Each index is in a sample with probability 3/10: expected 6000, sd ~65.
  for (std::size_t c : counts) CHECK(std::abs(static_cast<double>(c) - 6000.0) < 400.0);
}
