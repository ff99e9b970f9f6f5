// ByteBudgetCache: least-recently-used eviction against a brute-force oracle, the budget, loaders
// that throw, one load per key under 8 threads, values kept alive by their holders.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/byte_budget_cache.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>

namespace {

// A value that says its own size: an image of `bytes` bytes, tagged with its key.
struct CacheTestBlob {
  int key = 0;
  std::size_t bytes = 0;
  std::vector<unsigned char> pixels;
  CacheTestBlob(int k, std::size_t b) : key(k), bytes(b), pixels(b, static_cast<unsigned char>(k)) {}
};

using CacheTestCache = diachron::ByteBudgetCache<int, CacheTestBlob>;

CacheTestCache make_cache_test_cache(std::size_t budget) {
  diachron::ByteBudgetCacheOptions options;
  options.budget_bytes = budget;
  return CacheTestCache(options, [](const CacheTestBlob& b) { return b.bytes; });
}

// The oracle: entries in recency order (front = most recent), as plainly as it can be written.
struct CacheTestOracle {
  std::size_t budget = 0;
  std::vector<std::pair<int, std::size_t>> entries;  // key, bytes
  std::size_t hits = 0, misses = 0, evictions = 0, not_kept = 0, peak = 0;

  std::size_t resident() const {
    std::size_t sum = 0;
    for (const auto& e : entries) sum += e.second;
    return sum;
  }
  bool contains(int key) const {
    for (const auto& e : entries)
      if (e.first == key) return true;
    return false;
  }
  void get(int key, std::size_t bytes) {
    for (std::size_t i = 0; i < entries.size(); ++i) {
      if (entries[i].first == key) {
        const auto hit = entries[i];
        entries.erase(entries.begin() + static_cast<std::ptrdiff_t>(i));
        entries.insert(entries.begin(), hit);
        ++hits;
        return;
      }
    }
    ++misses;
    if (bytes > budget) {
      ++not_kept;
      return;
    }
    entries.insert(entries.begin(), {key, bytes});
    while (resident() > budget) {
      entries.pop_back();
      ++evictions;
    }
    if (resident() > peak) peak = resident();
  }
};

}  // namespace

TEST_CASE("ByteBudgetCache: Options", "[core]") {
  diachron::ByteBudgetCacheOptions options;
  CHECK(options.budget_bytes == std::size_t{1} << 30);
  CHECK_NOTHROW(options.check());
  options.budget_bytes = 0;
  CHECK_THROWS_AS(options.check(), diachron::Error);
  CHECK_THROWS_AS(CacheTestCache(options, [](const CacheTestBlob& b) { return b.bytes; }), diachron::Error);
  options.budget_bytes = 10;
  CHECK_THROWS_AS(CacheTestCache(options, CacheTestCache::SizeFunction()), diachron::Error);
}

TEST_CASE("ByteBudgetCache: Nominal, a hit returns the stored pointer without loading", "[core]") {
  auto cache = make_cache_test_cache(100);
  int loads = 0;
  const auto load7 = [&] {
    ++loads;
    return CacheTestBlob(7, 30);
  };
  const auto first = cache.get(7, load7);
  const auto second = cache.get(7, load7);
  CHECK(loads == 1);
  CHECK(first == second);
  CHECK(first->key == 7);
  CHECK(cache.peek(7) == first);
  CHECK(cache.peek(8) == nullptr);
  const auto s = cache.stats();
  CHECK(s.hits == 1);
  CHECK(s.misses == 1);
  CHECK(s.entries == 1);
  CHECK(s.resident_bytes == 30);
  CHECK(s.peak_resident_bytes == 30);
  CHECK(cache.erase(7));
  CHECK_FALSE(cache.erase(7));
  CHECK(cache.stats().resident_bytes == 0);
  cache.get(7, load7);
  CHECK(loads == 2);
  cache.clear();
  CHECK(cache.stats().entries == 0);
  CHECK(cache.stats().misses == 2);  // clear() keeps the counters
}

TEST_CASE("ByteBudgetCache: loaders may return a Value, a shared_ptr or a unique_ptr; null is an error", "[core]") {
  auto cache = make_cache_test_cache(100);
  CHECK(cache.get(1, [] { return CacheTestBlob(1, 5); })->key == 1);
  CHECK(cache.get(2, [] { return std::make_shared<CacheTestBlob>(2, 5); })->key == 2);
  CHECK(cache.get(3, [] { return std::make_shared<const CacheTestBlob>(3, 5); })->key == 3);
  CHECK(cache.get(4, [] { return std::make_unique<CacheTestBlob>(4, 5); })->key == 4);
  CHECK_THROWS_AS(cache.get(5, [] { return std::shared_ptr<CacheTestBlob>(); }), diachron::Error);
  CHECK(cache.peek(5) == nullptr);
  CHECK(cache.stats().failed_loads == 1);
  CHECK(cache.stats().resident_bytes == 20);
}

TEST_CASE("ByteBudgetCache: least-recently-used eviction equals a brute-force oracle", "[core]") {
  for (std::uint64_t seed = 0; seed < 20; ++seed) {
    diachron::RandomStream random(seed);
    const std::size_t budget = 50 + random.uniform_index(200);
    const int keys = 3 + static_cast<int>(random.uniform_index(20));
    // Each key's size, fixed; some larger than the budget.
    std::vector<std::size_t> sizes(static_cast<std::size_t>(keys));
    for (auto& s : sizes) s = random.uniform_index(10) == 0 ? budget + 1 + random.uniform_index(50) : 1 + random.uniform_index(budget / 2);
    auto cache = make_cache_test_cache(budget);
    CacheTestOracle oracle;
    oracle.budget = budget;
    for (int step = 0; step < 400; ++step) {
      const int key = static_cast<int>(random.uniform_index(static_cast<std::size_t>(keys)));
      const std::size_t bytes = sizes[static_cast<std::size_t>(key)];
      bool loaded = false;
      const auto value = cache.get(key, [&] {
        loaded = true;
        return CacheTestBlob(key, bytes);
      });
      const bool oracle_hit = oracle.contains(key);
      oracle.get(key, bytes);
      INFO("seed " << seed << ", step " << step << ", key " << key << ", " << bytes << " of " << budget << " bytes");
      REQUIRE(value->key == key);
      REQUIRE(loaded == !oracle_hit);
      const auto s = cache.stats();
      REQUIRE(s.hits == oracle.hits);
      REQUIRE(s.misses == oracle.misses);
      REQUIRE(s.evictions == oracle.evictions);
      REQUIRE(s.not_kept == oracle.not_kept);
      REQUIRE(s.entries == oracle.entries.size());
      REQUIRE(s.resident_bytes == oracle.resident());
      REQUIRE(s.peak_resident_bytes == oracle.peak);
      REQUIRE(s.resident_bytes <= budget);
      for (int k = 0; k < keys; ++k) REQUIRE((cache.peek(k) != nullptr) == oracle.contains(k));
    }
  }
}

TEST_CASE("ByteBudgetCache: a value larger than the budget is returned, not kept, and evicts nothing", "[core]") {
  auto cache = make_cache_test_cache(100);
  cache.get(1, [] { return CacheTestBlob(1, 60); });
  const auto big = cache.get(2, [] { return CacheTestBlob(2, 101); });
  REQUIRE(big != nullptr);
  CHECK(big->pixels.size() == 101);
  CHECK(cache.peek(2) == nullptr);
  CHECK(cache.peek(1) != nullptr);
  const auto s = cache.stats();
  CHECK(s.not_kept == 1);
  CHECK(s.evictions == 0);
  CHECK(s.resident_bytes == 60);
  // Exactly the budget is kept (and evicts the rest).
  cache.get(3, [] { return CacheTestBlob(3, 100); });
  CHECK(cache.peek(3) != nullptr);
  CHECK(cache.peek(1) == nullptr);
  CHECK(cache.stats().resident_bytes == 100);
}

TEST_CASE("ByteBudgetCache: a loader that throws stores nothing, and the next get loads again", "[core]") {
  auto cache = make_cache_test_cache(100);
  int calls = 0;
  CHECK_THROWS_WITH(cache.get(4,
                              [&]() -> CacheTestBlob {
                                ++calls;
                                throw std::runtime_error("unreadable image");
                              }),
                    "unreadable image");
  CHECK(cache.peek(4) == nullptr);
  auto s = cache.stats();
  CHECK(s.misses == 1);
  CHECK(s.failed_loads == 1);
  CHECK(s.entries == 0);
  CHECK(s.resident_bytes == 0);
  const auto value = cache.get(4, [&] {
    ++calls;
    return CacheTestBlob(4, 10);
  });
  CHECK(calls == 2);
  CHECK(value->key == 4);
  CHECK(cache.peek(4) == value);
  // A size function that throws counts as a failed load too.
  diachron::ByteBudgetCacheOptions options;
  options.budget_bytes = 100;
  CacheTestCache picky(options, [](const CacheTestBlob& b) -> std::size_t {
    if (b.key < 0) throw std::invalid_argument("negative key");
    return b.bytes;
  });
  CHECK_THROWS_AS(picky.get(-1, [] { return CacheTestBlob(-1, 3); }), std::invalid_argument);
  CHECK(picky.peek(-1) == nullptr);
  CHECK(picky.stats().failed_loads == 1);
}

TEST_CASE("ByteBudgetCache: 8 threads asking for one key at once share one load", "[core]") {
  auto cache = make_cache_test_cache(1000);
  std::atomic<int> calls{0};
  std::atomic<int> ready{0};
  constexpr int kThreads = 8;
  std::vector<CacheTestCache::ValuePtr> got(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      ready.fetch_add(1);
      while (ready.load() < kThreads) std::this_thread::yield();
      got[static_cast<std::size_t>(t)] = cache.get(42, [&] {
        calls.fetch_add(1);
        std::this_thread::sleep_for(std::chrono::milliseconds(100));  // slow: the others arrive meanwhile
        return CacheTestBlob(42, 64);
      });
    });
  }
  for (auto& th : threads) th.join();
  CHECK(calls.load() == 1);
  for (const auto& p : got) {
    REQUIRE(p != nullptr);
    CHECK(p == got[0]);
  }
  const auto s = cache.stats();
  CHECK(s.misses == 1);
  CHECK(s.hits == kThreads - 1);
  CHECK(s.joined + 1 <= static_cast<std::size_t>(kThreads));  // a late thread may find it stored
  CHECK(s.resident_bytes == 64);
}

TEST_CASE("ByteBudgetCache: when the shared load throws, every waiter gets the exception", "[core]") {
  auto cache = make_cache_test_cache(1000);
  std::atomic<int> calls{0};
  std::atomic<int> ready{0};
  std::atomic<int> thrown{0};
  constexpr int kThreads = 8;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&] {
      ready.fetch_add(1);
      while (ready.load() < kThreads) std::this_thread::yield();
      try {
        cache.get(9, [&]() -> CacheTestBlob {
          calls.fetch_add(1);
          std::this_thread::sleep_for(std::chrono::milliseconds(200));
          throw std::runtime_error("disk gone");
        });
      } catch (const std::runtime_error& e) {
        if (std::string(e.what()) == "disk gone") thrown.fetch_add(1);
      }
    });
  }
  for (auto& th : threads) th.join();
  // One load normally; a thread that arrives after the failure loads (and fails) again.
  CHECK(calls.load() >= 1);
  CHECK(thrown.load() == kThreads);
  CHECK(cache.stats().failed_loads == static_cast<std::size_t>(calls.load()));
  CHECK(cache.stats().misses == static_cast<std::size_t>(calls.load()));
  CHECK(cache.peek(9) == nullptr);
  CHECK(cache.stats().resident_bytes == 0);
}

TEST_CASE("ByteBudgetCache: many threads on many keys keep the budget and the counts", "[core]") {
  auto cache = make_cache_test_cache(300);
  std::atomic<int> loads{0};
  std::atomic<bool> wrong{false};
  constexpr int kThreads = 8;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      diachron::RandomStream random(7, static_cast<std::uint64_t>(t));
      for (int i = 0; i < 2000; ++i) {
        const int key = static_cast<int>(random.uniform_index(16));
        const auto v = cache.get(key, [&] {
          loads.fetch_add(1);
          return CacheTestBlob(key, 10 + static_cast<std::size_t>(key) * 5);
        });
        if (v->key != key || v->pixels.size() != v->bytes) wrong = true;
      }
    });
  }
  for (auto& th : threads) th.join();
  CHECK_FALSE(wrong.load());
  const auto s = cache.stats();
  CHECK(s.misses == static_cast<std::size_t>(loads.load()));
  CHECK(s.hits + s.misses == static_cast<std::size_t>(kThreads) * 2000);
  CHECK(s.peak_resident_bytes <= 300);
  CHECK(s.resident_bytes <= 300);
}

TEST_CASE("ByteBudgetCache: a value evicted while held stays alive through its holder", "[core]") {
  auto cache = make_cache_test_cache(100);
  const auto held = cache.get(1, [] { return CacheTestBlob(1, 80); });
  std::weak_ptr<const CacheTestBlob> watch = held;
  cache.get(2, [] { return CacheTestBlob(2, 80); });  // evicts 1
  CHECK(cache.peek(1) == nullptr);
  CHECK(cache.stats().evictions == 1);
  CHECK(cache.stats().resident_bytes == 80);  // the budget counts what the cache keeps, not `held`
  REQUIRE_FALSE(watch.expired());
  CHECK(held->key == 1);
  CHECK(held->pixels.size() == 80);
  CHECK(held->pixels[79] == 1);
  // Asked again, it is loaded again: the cache does not know about holders.
  int loads = 0;
  const auto again = cache.get(1, [&] {
    ++loads;
    return CacheTestBlob(1, 80);
  });
  CHECK(loads == 1);
  CHECK(again != held);
  // Once neither the cache nor a holder has it, it is freed.
  std::weak_ptr<const CacheTestBlob> watch_again = again;
  const auto other = cache.get(3, [] { return CacheTestBlob(3, 80); });  // evicts the reloaded 1
  CHECK_FALSE(watch_again.expired());  // `again` still holds it
  CHECK_FALSE(watch.expired());
}

TEST_CASE("ByteBudgetCache: string keys and a custom hash", "[core]") {
  struct FirstCharHash {  // a poor hash (collisions) must still give right answers
    std::size_t operator()(const std::string& s) const { return s.empty() ? 0 : static_cast<std::size_t>(s[0]); }
  };
  diachron::ByteBudgetCacheOptions options;
  options.budget_bytes = 1 << 20;
  diachron::ByteBudgetCache<std::string, std::string, FirstCharHash> cache(
      options, [](const std::string& s) { return s.size(); });
  CHECK(*cache.get("image_a.tif", [] { return std::string("aaaa"); }) == "aaaa");
  CHECK(*cache.get("image_b.tif", [] { return std::string("bb"); }) == "bb");
  CHECK(*cache.get("image_a.tif", [] { return std::string("wrong"); }) == "aaaa");
  CHECK(cache.stats().resident_bytes == 6);
}
