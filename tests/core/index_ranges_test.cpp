// Index ranges: parsing (strict), grouping sorted indices, text, chunks; against brute force.
#include <catch2/catch.hpp>

#include <cstddef>
#include <string>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/index_ranges.hpp>
#include <diachron/core/random.hpp>

using namespace diachron;

TEST_CASE("parse_index_range: I and A-B, nothing else", "[core]") {
  CHECK(parse_index_range("17") == IndexRange{17, 17});
  CHECK(parse_index_range("0-99") == IndexRange{0, 99});
  CHECK(parse_index_range("5-5").size() == 1);
  for (const char* bad : {"", "-1", "1-", "a", "1 - 2", " 3", "3-2", "1-2-3", "+4", "1.5", "99999999999999999999"})
    CHECK_THROWS_AS(parse_index_range(bad), Error);
}

TEST_CASE("index_ranges: consecutive runs, and their text", "[core]") {
  CHECK(index_ranges({}).empty());
  const std::vector<IndexRange> r = index_ranges({0, 1, 2, 3, 7, 9, 10, 11, 12});
  REQUIRE(r.size() == 3);
  CHECK(index_ranges_text(r) == "0-3,7,9-12");
  CHECK(index_ranges_text(r, 2) == "0-3,7,...");
  // Brute force: every index of the input is in exactly one range, ranges are maximal.
  RandomStream rng(3);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<std::size_t> sorted;
    for (std::size_t i = 0; i < 200; ++i)
      if (rng.uniform(0.0, 1.0) < 0.6) sorted.push_back(i);
    const std::vector<IndexRange> ranges = index_ranges(sorted);
    std::vector<std::size_t> back;
    for (std::size_t k = 0; k < ranges.size(); ++k) {
      if (k > 0) CHECK(ranges[k].first > ranges[k - 1].last + 1);
      for (std::size_t i = ranges[k].first; i <= ranges[k].last; ++i) back.push_back(i);
    }
    CHECK(back == sorted);
  }
}

TEST_CASE("index_chunks: [0, n) in chunks of at most c", "[core]") {
  CHECK(index_chunks(0, 10).empty());
  const std::vector<IndexRange> c = index_chunks(2501, 1000);
  REQUIRE(c.size() == 3);
  CHECK(c[0] == IndexRange{0, 999});
  CHECK(c[2] == IndexRange{2000, 2500});
  CHECK(index_chunks(3, 1).size() == 3);
  CHECK_THROWS_AS(index_chunks(3, 0), Error);
}
