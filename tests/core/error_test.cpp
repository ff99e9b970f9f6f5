#include <catch2/catch.hpp>

#include <string>

#include <diachron/core/error.hpp>

namespace {
int error_test_checked(int n) {
  DIACHRON_CHECK(n > 0, "n must be > 0, got " << n);
  return n;
}
}  // namespace

TEST_CASE("Error: what() keeps the condition for developers, message() is for people", "[core][error]") {
  try {
    error_test_checked(-3);
    FAIL("no throw");
  } catch (const diachron::Error& e) {
    const std::string what = e.what();
    CHECK(what.find("diachron: n must be > 0, got -3") == 0);
    CHECK(what.find("n > 0]") != std::string::npos);
    CHECK(e.message() == "n must be > 0, got -3");
  }
  CHECK(diachron::Error("diachron: io: cannot create 'x'").message() == "io: cannot create 'x'");
  CHECK(diachron::Error("plain").message() == "plain");
}
