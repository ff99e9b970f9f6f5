#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <diachron/camera/micmac_conversion.hpp>
#include <diachron/core/random.hpp>
#include <diachron/io/homol.hpp>

#include "support/temp_folder.hpp"

using Catch::Matchers::Contains;
using diachron::PointMatch;
using diachron::PointMatches;

namespace {

namespace fs = std::filesystem;

std::string homol_folder(const std::string& name) { return diachron::test::fresh_temp_folder("homol_" + name); }

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

PointMatches random_matches(std::size_t n, std::uint64_t seed) {
  diachron::RandomStream rng(seed);
  PointMatches out;
  for (std::size_t i = 0; i < n; ++i) {
    // One draw per statement, each y before its x: the order of a call's arguments is unspecified
    // (core/random.hpp, "Order of draws"); the braces take the first point before the second.
    const double ay = rng.uniform(-0.5, 3000), ax = rng.uniform(-0.5, 4000), by = rng.uniform(-0.5, 5000);
    out.push_back(PointMatch{Eigen::Vector2d(ax, ay), Eigen::Vector2d(rng.uniform(-0.5, 6000), by), 0.0});
  }
  // Values that print badly with a fixed number of decimals.
  out.push_back(PointMatch{Eigen::Vector2d(1.0 / 3.0, 1e-9), Eigen::Vector2d(12345.678901234567, 0.1), 0.0});
  return out;
}

}  // namespace

TEST_CASE("homol: write then read gives the same points, both directions, exactly", "[io]") {
  const std::string dir = homol_folder("roundtrip") + "/Homol-Guided";
  const PointMatches matches = random_matches(200, 1);
  diachron::write_homol(dir, "OIS-1971.tif", "IMG_2014.tif", matches);

  CHECK(diachron::homol_file_path(dir, "OIS-1971.tif", "IMG_2014.tif") == dir + "/PastisOIS-1971.tif/IMG_2014.tif.txt");
  const PointMatches forward = diachron::read_homol(dir, "OIS-1971.tif", "IMG_2014.tif");
  const PointMatches backward = diachron::read_homol(dir + "/PastisIMG_2014.tif/OIS-1971.tif.txt");
  REQUIRE(forward.size() == matches.size());
  REQUIRE(backward.size() == matches.size());
  for (std::size_t i = 0; i < matches.size(); ++i) {
    INFO("match " << i);
    CHECK(forward[i].a == matches[i].a);
    CHECK(forward[i].b == matches[i].b);
    CHECK(backward[i].a == matches[i].b);
    CHECK(backward[i].b == matches[i].a);
  }

  // One line per match, four fields, the first image first.
  std::istringstream lines(slurp(dir + "/PastisOIS-1971.tif/IMG_2014.tif.txt"));
  std::string line;
  std::getline(lines, line);
  std::istringstream fields(line);
  double x1 = 0, y1 = 0, x2 = 0, y2 = 0, extra = 0;
  REQUIRE(static_cast<bool>(fields >> x1 >> y1 >> x2 >> y2));
  CHECK_FALSE(static_cast<bool>(fields >> extra));
  CHECK(x1 == matches[0].a.x());
  CHECK(y2 == matches[0].b.y());

  // Writing again replaces, not appends.
  diachron::write_homol(dir, "OIS-1971.tif", "IMG_2014.tif", PointMatches(matches.begin(), matches.begin() + 3));
  CHECK(diachron::read_homol(dir, "IMG_2014.tif", "OIS-1971.tif").size() == 3);
}

TEST_CASE("homol: the pixel convention offset is explicit and applied both ways", "[io]") {
  // MicMac and diachron both put (0, 0) at the centre of the top-left pixel.
  CHECK(diachron::kMicmacHomolPixelShift == 0.0);
  CHECK(diachron::kMicmacHomolPixelShift == diachron::kMicmacPixelShift);

  const std::string dir = homol_folder("shift");
  const PointMatches one{PointMatch{Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 20), 0.0}};
  diachron::write_homol(dir, "a.tif", "b.tif", one);
  CHECK(slurp(dir + "/Pastisa.tif/b.tif.txt") == "0 0 10 20\n");
  CHECK(slurp(dir + "/Pastisb.tif/a.tif.txt") == "10 20 0 0\n");

  // A corner-convention tool (top-left pixel centre at (0.5, 0.5)).
  diachron::write_homol(dir, "a.tif", "b.tif", one, 0.5);
  CHECK(slurp(dir + "/Pastisa.tif/b.tif.txt") == "0.5 0.5 10.5 20.5\n");
  const PointMatches back = diachron::read_homol(dir, "a.tif", "b.tif", 0.5);
  REQUIRE(back.size() == 1);
  CHECK(back[0].a == Eigen::Vector2d(0, 0));
  CHECK(back[0].b == Eigen::Vector2d(10, 20));
  CHECK(diachron::read_homol(dir, "a.tif", "b.tif")[0].a == Eigen::Vector2d(0.5, 0.5));
}

TEST_CASE("homol: empty lists, blank lines, and what MicMac writes", "[io]") {
  const std::string dir = homol_folder("empty");
  diachron::write_homol(dir, "a.tif", "b.tif", {});
  CHECK(fs::exists(dir + "/Pastisa.tif/b.tif.txt"));
  CHECK(fs::exists(dir + "/Pastisb.tif/a.tif.txt"));
  CHECK(diachron::read_homol(dir, "a.tif", "b.tif").empty());
  CHECK(diachron::read_homol(dir, "b.tif", "a.tif").empty());

  // TiePHistorical's printf("%lf %lf %lf %lf\n"), tabs, CRLF and a trailing blank line.
  write_text(dir + "/Pastisc.tif/d.tif.txt", "12.500000 7.250000 1001.000000 -3.000000\n\n4\t5 6 7\r\n  \n");
  const PointMatches m = diachron::read_homol(dir, "c.tif", "d.tif");
  REQUIRE(m.size() == 2);
  CHECK(m[0].a == Eigen::Vector2d(12.5, 7.25));
  CHECK(m[0].b == Eigen::Vector2d(1001.0, -3.0));
  CHECK(m[1].b == Eigen::Vector2d(6, 7));
}

TEST_CASE("homol: malformed files name the file and the line", "[io]") {
  const std::string dir = homol_folder("malformed");
  const std::string good = "1 2 3 4\n";
  const std::vector<std::pair<std::string, std::string>> cases{
      {"1 2 3\n", ":2: 3 fields"},
      {"1 2 3 4 2\n", ":2: more than 4 fields"},
      {"1 2 x 4\n", ":2: 'x' is not a finite number"},
      {"1 2 nan 4\n", ":2: 'nan' is not a finite number"},
      {"1 2 inf 4\n", ":2: 'inf' is not a finite number"},
      {"1 2 3 4e999\n", ":2: '4e999' is not a finite number"},
      {"1,5 2 3 4\n", ":2: '1,5' is not a finite number"},
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const std::string path = dir + "/Pastisa/b" + std::to_string(k) + ".txt";
    write_text(path, good + cases[k].first);
    INFO(cases[k].first);
    CHECK_THROWS_WITH(diachron::read_homol(path), Contains(path + cases[k].second));
  }
  CHECK_THROWS_WITH(diachron::read_homol(dir + "/Pastisa/missing.txt"), Contains(dir + "/Pastisa/missing.txt"));
  CHECK_THROWS_AS(diachron::read_homol(dir + "/Pastisa/missing.txt"), diachron::Error);

  CHECK_THROWS_WITH(diachron::homol_file_path(dir, "", "b"), Contains("non-empty"));
  CHECK_THROWS_WITH(diachron::homol_file_path(dir, "x/y", "b"), Contains("'x/y'"));
  const PointMatches bad{PointMatch{Eigen::Vector2d(0, 0), Eigen::Vector2d(std::nan(""), 1), 0.0}};
  CHECK_THROWS_WITH(diachron::write_homol(dir + "/H", "a", "b", bad), Contains("match 0"));
  CHECK_FALSE(fs::exists(dir + "/H"));
}

TEST_CASE("homol: list_homol_pairs finds every text pair", "[io]") {
  const std::string dir = homol_folder("list");
  diachron::write_homol(dir, "b.tif", "a.tif", random_matches(3, 2));
  diachron::write_homol(dir, "a.tif", "c.tif", random_matches(3, 3));
  write_text(dir + "/Pastisa.tif/z.tif.dat", "binary");  // MicMac's binary form: not listed
  write_text(dir + "/notes.txt", "not a pair");
  fs::create_directories(dir + "/Pastis");
  const std::vector<diachron::HomolPair> pairs = diachron::list_homol_pairs(dir);
  REQUIRE(pairs.size() == 4);
  CHECK(pairs[0].image1 == "a.tif");
  CHECK(pairs[0].image2 == "b.tif");
  CHECK(pairs[1].image2 == "c.tif");
  CHECK(pairs[2].image1 == "b.tif");
  CHECK(pairs[3].image1 == "c.tif");
  CHECK(pairs[3].path == diachron::homol_file_path(dir, "c.tif", "a.tif"));
  CHECK(diachron::read_homol(pairs[1].path).size() == 4);
  CHECK_THROWS_WITH(diachron::list_homol_pairs(dir + "/nowhere"), Contains("is not a folder"));
}
