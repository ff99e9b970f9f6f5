#include <catch2/catch.hpp>

#include <atomic>
#include <stdexcept>
#include <vector>

#include <diachron/core/parallel.hpp>
#include <diachron/core/progress.hpp>
#include <diachron/core/thread_pool.hpp>

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

TEST_CASE("parallel_for: nested calls finish and visit every pair once", "[core]") {
  // Each outer body runs an inner loop on the same shared pool: with every worker busy in an outer
  // body, the inner loops must still progress on their own threads instead of waiting for a worker.
  for (std::size_t threads : {1u, 2u, 3u, 8u}) {
    std::vector<std::atomic<int>> hits(40 * 30);
    diachron::parallel_for(40, threads, [&](std::size_t i) {
      diachron::parallel_for(30, threads, [&](std::size_t j) { hits[i * 30 + j].fetch_add(1); });
    });
    for (auto& h : hits) REQUIRE(h.load() == 1);
  }
}

TEST_CASE("parallel_for: three levels of nesting with more threads than workers", "[core]") {
  std::atomic<int> leaves{0};
  diachron::parallel_for(6, 4, [&](std::size_t) {
    diachron::parallel_for(5, 4, [&](std::size_t) {
      diachron::parallel_for(4, 4, [&](std::size_t) { leaves.fetch_add(1); });
    });
  });
  REQUIRE(leaves.load() == 6 * 5 * 4);
}

TEST_CASE("parallel_for: an exception in a nested body reaches the outer caller", "[core]") {
  for (std::size_t threads : {1u, 2u, 4u}) {
    std::atomic<int> outer_done{0};
    REQUIRE_THROWS_WITH(diachron::parallel_for(20, threads,
                                               [&](std::size_t i) {
                                                 diachron::parallel_for(10, threads, [&](std::size_t j) {
                                                   if (i == 7 && j == 3) throw std::runtime_error("inner 7/3");
                                                 });
                                                 outer_done.fetch_add(1);
                                               }),
                        "inner 7/3");
    REQUIRE(outer_done.load() < 20);
    // The pool is still usable after a failed call.
    std::atomic<int> after{0};
    diachron::parallel_for(100, threads, [&](std::size_t) { after.fetch_add(1); });
    REQUIRE(after.load() == 100);
  }
}

TEST_CASE("parallel_for: the exception thrown is the one the body threw, once per failing call", "[core]") {
  struct Custom {
    int item;
  };
  for (int round = 0; round < 50; ++round) {
    try {
      diachron::parallel_for(64, 3, [&](std::size_t i) {
        if (i % 16 == 5) throw Custom{static_cast<int>(i)};
      });
      FAIL("no exception");
    } catch (const Custom& c) {
      REQUIRE(c.item % 16 == 5);
    }
  }
}

TEST_CASE("parallel_for: many small calls reuse the pool's threads", "[core]") {
  diachron::parallel_for(4, 3, [](std::size_t) {});  // make sure the pool has its workers
  const std::size_t workers = diachron::ThreadPool::shared().size();
  REQUIRE(workers >= 2);
  std::vector<long> sums(3000);
  for (std::size_t call = 0; call < sums.size(); ++call) {
    std::vector<long> slots(5);
    diachron::parallel_for(slots.size(), 3, [&](std::size_t i) { slots[i] = static_cast<long>(call * 10 + i); });
    long s = 0;
    for (long v : slots) s += v;
    sums[call] = s;
  }
  for (std::size_t call = 0; call < sums.size(); ++call) REQUIRE(sums[call] == static_cast<long>(call * 50 + 10));
  // No thread was started per call.
  REQUIRE(diachron::ThreadPool::shared().size() == workers);
}

TEST_CASE("parallel_for: per-item results do not depend on the thread count", "[core]") {
  auto run = [](std::size_t threads) {
    std::vector<double> out(777);
    diachron::parallel_for(out.size(), threads, [&](std::size_t i) {
      double x = static_cast<double>(i);
      for (int k = 0; k < 50; ++k) x = x * 0.5 + static_cast<double>(k % 7);
      out[i] = x;
    });
    return out;
  };
  const std::vector<double> one = run(1);
  for (std::size_t threads : {2u, 3u, 0u}) REQUIRE(run(threads) == one);
}

TEST_CASE("ThreadPool: a private pool runs every task and joins on destruction", "[core]") {
  std::atomic<int> done{0};
  {
    diachron::ThreadPool pool;
    pool.reserve(2);
    REQUIRE(pool.size() == 2);
    for (int i = 0; i < 100; ++i) pool.submit([&] { done.fetch_add(1); });
  }
  REQUIRE(done.load() == 100);
}
