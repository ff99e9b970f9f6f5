#include <catch2/catch.hpp>

#include <atomic>
#include <stdexcept>
#include <vector>

#include <diachron/core/parallel.hpp>
#include <diachron/core/progress.hpp>

TEST_CASE("parallel_for: every index is visited exactly once", "[core]") {
  for (std::size_t threads : {1u, 2u, 4u, 0u}) {
    std::vector<std::atomic<int>> hits(1000);
    diachron::parallel_for(hits.size(), threads, [&](std::size_t i) { hits[i].fetch_add(1); });
    for (auto& h : hits) REQUIRE(h.load() == 1);
  }
}

TEST_CASE("parallel_for: zero items is a no-op", "[core]") {
  int calls = 0;
  diachron::parallel_for(0, 4, [&](std::size_t) { ++calls; });
  REQUIRE(calls == 0);
}

TEST_CASE("parallel_for: an exception in a worker reaches the caller", "[core]") {
  for (std::size_t threads : {1u, 3u}) {
    REQUIRE_THROWS_AS(diachron::parallel_for(100, threads,
                                             [](std::size_t i) {
                                               if (i == 37) throw std::runtime_error("item 37");
                                             }),
                      std::runtime_error);
  }
}

TEST_CASE("ProgressReporter: reports start and every unit, serialised", "[core]") {
  std::vector<std::size_t> seen;
  diachron::ProgressReporter reporter([&](const diachron::ProgressEvent& e) { seen.push_back(e.done); },
                                      "stage", 50);
  diachron::parallel_for(50, 4, [&](std::size_t) { reporter.advance(); });
  REQUIRE(seen.size() == 51);
  REQUIRE(seen.front() == 0);
  REQUIRE(seen.back() == 50);
  for (std::size_t i = 1; i < seen.size(); ++i) REQUIRE(seen[i] == seen[i - 1] + 1);
}
