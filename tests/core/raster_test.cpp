#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/static_vector.hpp>

TEST_CASE("Raster: row-major layout with x the column and y the row", "[core]") {
  diachron::Raster<int> r(4, 3, -1);
  REQUIRE(r.width() == 4);
  REQUIRE(r.height() == 3);
  REQUIRE(r.size() == 12);
  r(3, 1) = 7;
  REQUIRE(r.data()[1 * 4 + 3] == 7);
  REQUIRE(r.row(1)[3] == 7);
  REQUIRE(r.at(3, 1) == 7);
  REQUIRE(r(0, 0) == -1);
}

TEST_CASE("Raster: checked access and bad sizes throw diachron::Error", "[core]") {
  diachron::Raster<float> r(2, 2);
  REQUIRE_THROWS_AS(r.at(2, 0), diachron::Error);
  REQUIRE_THROWS_AS(r.at(0, -1), diachron::Error);
  REQUIRE_THROWS_AS(diachron::Raster<float>(-1, 3), diachron::Error);
  REQUIRE(diachron::Raster<float>(0, 0).empty());
}

TEST_CASE("Error: the message names what failed and where", "[core]") {
  try {
    diachron::Raster<float> r(2, 2);
    (void)r.at(5, 1);
    FAIL("no exception");
  } catch (const diachron::Error& e) {
    const std::string what = e.what();
    REQUIRE(what.find("(5, 1)") != std::string::npos);
    REQUIRE(what.find("at") != std::string::npos);
  }
}

TEST_CASE("StaticVector: holds up to its capacity and refuses more", "[core]") {
  diachron::StaticVector<int, 2> v;
  REQUIRE(v.empty());
  v.push_back(1);
  v.push_back(2);
  REQUIRE(v.size() == 2);
  REQUIRE(v[1] == 2);
  int sum = 0;
  for (int x : v) sum += x;
  REQUIRE(sum == 3);
  REQUIRE_THROWS_AS(v.push_back(3), diachron::Error);
  v.clear();
  REQUIRE(v.empty());
}
