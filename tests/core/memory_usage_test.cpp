// Resident set size of the process, and byte sizes read (strictly) and written for people.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/memory_usage.hpp>
#include <diachron/core/random.hpp>

TEST_CASE("parse_byte_size: numbers and units", "[core]") {
  using diachron::parse_byte_size;
  CHECK(parse_byte_size("0") == 0);
  CHECK(parse_byte_size("1000000") == 1000000);
  CHECK(parse_byte_size("17B") == 17);
  CHECK(parse_byte_size("1K") == 1024);
  CHECK(parse_byte_size("1KiB") == 1024);
  CHECK(parse_byte_size("1kB") == 1000);
  CHECK(parse_byte_size("1KB") == 1000);
  CHECK(parse_byte_size("512M") == 512ull << 20);
  CHECK(parse_byte_size("512MB") == 512000000ull);
  CHECK(parse_byte_size("8G") == 8ull << 30);
  CHECK(parse_byte_size("8GiB") == 8ull << 30);
  CHECK(parse_byte_size("8GB") == 8000000000ull);
  CHECK(parse_byte_size("2T") == 2ull << 40);
  CHECK(parse_byte_size("2TB") == 2000000000000ull);
  CHECK(parse_byte_size("3P") == 3ull << 50);
  CHECK(parse_byte_size("3PB") == 3000000000000000ull);
  CHECK(parse_byte_size("15E") == 15ull << 60);
  CHECK(parse_byte_size("18.4 EB") == 18400000000000000000ull);
  CHECK(parse_byte_size("1.5GiB") == 1610612736ull);
  CHECK(parse_byte_size("1.76 GB") == 1760000000ull);
  CHECK(parse_byte_size("  64 MiB  ") == 64ull << 20);
  CHECK(parse_byte_size("0.1K") == 102);  // 102.4, rounded
  CHECK(parse_byte_size("0.5B") == 1);    // half a byte rounds up
  CHECK(parse_byte_size("1.000000001G") == (1ull << 30) + 1);
  CHECK(parse_byte_size("007") == 7);
  CHECK(parse_byte_size("18446744073709551615") == std::numeric_limits<std::size_t>::max());
}

TEST_CASE("parse_byte_size: strict errors name the text", "[core]") {
  using diachron::parse_byte_size;
  for (const char* bad : {"", "   ", "G", "-1", "-1G", "+5", "1e9", "0x10", ".5G", "5.", "5.G", "8 GiBs", "8g", "8gb",
                          "8 G B", "8GG", "1,5G", "1.0000000001G", "8 ZB", "8 pB", "nan", "inf"}) {
    INFO("'" << bad << "'");
    CHECK_THROWS_AS(parse_byte_size(bad), diachron::Error);
  }
  CHECK_THROWS_WITH(parse_byte_size("12 parsecs"), Catch::Contains("unknown unit 'parsecs'"));
  CHECK_THROWS_WITH(parse_byte_size("18446744073709551616"), Catch::Contains("too large"));
  CHECK_THROWS_WITH(parse_byte_size("16777216T"), Catch::Contains("too large"));
  CHECK_THROWS_WITH(parse_byte_size("17179869184G"), Catch::Contains("too large"));
  CHECK(parse_byte_size("17179869183.99999999G") == std::numeric_limits<std::size_t>::max() - 10);
}

TEST_CASE("format_bytes: three significant digits in decimal units", "[core]") {
  using diachron::format_bytes;
  CHECK(format_bytes(0) == "0 B");
  CHECK(format_bytes(999) == "999 B");
  CHECK(format_bytes(1000) == "1.00 kB");
  CHECK(format_bytes(1760000000ull) == "1.76 GB");
  CHECK(format_bytes(17600000000ull) == "17.6 GB");
  CHECK(format_bytes(176000000000ull) == "176 GB");
  CHECK(format_bytes(999499) == "999 kB");
  CHECK(format_bytes(999500) == "1.00 MB");  // not "1000 kB"
  CHECK(format_bytes(9995) == "10.0 kB");
  CHECK(format_bytes(std::numeric_limits<std::uint64_t>::max()) == "18.4 EB");
}

TEST_CASE("format_bytes and parse_byte_size: a round trip within 0.5 %", "[core]") {
  diachron::RandomStream random(3);
  for (int i = 0; i < 2000; ++i) {
    const int digits = 1 + static_cast<int>(random.uniform_index(18));
    std::uint64_t n = 1;
    for (int d = 0; d < digits; ++d) n = n * 10 + random.uniform_index(10);
    const std::string text = diachron::format_bytes(static_cast<std::size_t>(n));
    const double back = static_cast<double>(diachron::parse_byte_size(text));
    INFO(n << " -> " << text);
    CHECK(back == Approx(static_cast<double>(n)).epsilon(0.005));
  }
}

TEST_CASE("current_resident_bytes and peak_resident_bytes: /proc/self/status", "[core]") {
  using diachron::detail::proc_status_bytes;
  const std::string status = "Name:\ttest_core\nVmHWM:\t  204800 kB\nVmRSS:\t  102400 kB\nThreads:\t1\nVmOdd:\t12 pages\n";
  CHECK(proc_status_bytes(status, "VmRSS") == std::size_t{102400} * 1024);
  CHECK(proc_status_bytes(status, "VmHWM") == std::size_t{204800} * 1024);
  CHECK_FALSE(proc_status_bytes(status, "VmSwap").has_value());
  CHECK_FALSE(proc_status_bytes(status, "VmOdd").has_value());  // not in kB
  CHECK_FALSE(proc_status_bytes(status, "Vm").has_value());     // a prefix of a name is not the name

  const auto rss = diachron::current_resident_bytes();
  const auto peak = diachron::peak_resident_bytes();
#ifdef __linux__
  REQUIRE(rss.has_value());
  REQUIRE(peak.has_value());
  CHECK(*rss > 0);
  CHECK(*peak >= *rss);
  // 64 MiB written page by page is resident: the current and the peak size grow by most of it.
  constexpr std::size_t kBlock = std::size_t{64} << 20;
  std::vector<unsigned char> block(kBlock);
  for (std::size_t i = 0; i < kBlock; i += 4096) block[i] = static_cast<unsigned char>(i >> 12);
  const auto rss_after = diachron::current_resident_bytes();
  const auto peak_after = diachron::peak_resident_bytes();
  REQUIRE(rss_after.has_value());
  REQUIRE(peak_after.has_value());
  CHECK(*rss_after >= *rss + kBlock / 2);
  CHECK(*peak_after >= *rss_after);
  CHECK(block[4096] == 1);
#else
  CHECK_FALSE(rss.has_value());
  CHECK_FALSE(peak.has_value());
#endif
}
