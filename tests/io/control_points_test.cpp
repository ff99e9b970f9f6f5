// read_control_points: the records, any order of points and observations, comments, and every
// malformed file named with its line.

#include <catch2/catch.hpp>

#include <fstream>
#include <string>

#include <diachron/core/error.hpp>
#include <diachron/io/control_points.hpp>

#include "support/temp_folder.hpp"

using Catch::Matchers::Contains;

namespace {

// A control-point file with `text` in a fresh folder; its path.
std::string control_file(const std::string& name, const std::string& text) {
  const std::string path = diachron::test::fresh_temp_folder("control_points_" + name) + "/gcps.txt";
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

}  // namespace

TEST_CASE("read_control_points: points and their observations, in any order", "[io]") {
  const std::string path = control_file("good",
                                        "# a comment\n"
                                        "obs B 1954_002.tif 10.5 20.25\n"
                                        "point A 100 200.5 -3 0.25\n"
                                        "\n"
                                        "obs A 1954_001.tif 1 2\r\n"
                                        "point B 1e3 2e3 3e3 1\n"
                                        "  obs   A\t2019_007.tif   -0.5 1e2\n");
  const std::vector<diachron::ControlPointRecord> points = diachron::read_control_points(path);
  REQUIRE(points.size() == 2);
  CHECK(points[0].name == "A");
  CHECK(points[0].position == Eigen::Vector3d(100, 200.5, -3));
  CHECK(points[0].sigma == 0.25);
  REQUIRE(points[0].observations.size() == 2);
  CHECK(points[0].observations[0].first == "1954_001.tif");
  CHECK(points[0].observations[0].second == Eigen::Vector2d(1, 2));
  CHECK(points[0].observations[1].first == "2019_007.tif");
  CHECK(points[0].observations[1].second == Eigen::Vector2d(-0.5, 100));
  CHECK(points[1].name == "B");
  CHECK(points[1].position == Eigen::Vector3d(1000, 2000, 3000));
  REQUIRE(points[1].observations.size() == 1);
  CHECK(points[1].observations[0].second == Eigen::Vector2d(10.5, 20.25));
  // A point without observations is kept: the adjustment reports it unused.
  CHECK(diachron::read_control_points(control_file("alone", "point C 1 2 3 4\n")).front().observations.empty());
  CHECK(diachron::read_control_points(control_file("empty", "# nothing\n")).empty());
}

TEST_CASE("read_control_points: malformed files are named with their line", "[io]") {
  const auto refused = [](const std::string& name, const std::string& text, const std::string& what) {
    INFO(name);
    const std::string path = control_file(name, text);
    CHECK_THROWS_WITH(diachron::read_control_points(path), Contains(path) && Contains(what));
  };
  refused("kind", "point A 1 2 3 1\nvertex A 1 2 3\n", "line 2: unknown record 'vertex'");
  refused("short point", "point A 1 2 3\n", "line 1: a point line is 'point NAME X Y Z SIGMA'");
  refused("long obs", "point A 1 2 3 1\nobs A img 1 2 3\n", "line 2: an observation line is 'obs NAME IMAGE X Y'");
  refused("number", "point A 1 2 z 1\n", "line 1: cannot read Z: 'z' is not a finite number");
  refused("nan", "point A 1 2 nan 1\n", "line 1: cannot read Z");
  refused("sigma", "point A 1 2 3 0\n", "line 1: point A: SIGMA must be > 0");
  refused("twice", "point A 1 2 3 1\n# again\npoint A 4 5 6 1\n", "line 3: point A is defined twice");
  refused("undefined", "point A 1 2 3 1\nobs B img 1 2\n", "line 2: observation of point B, which the file does not define");
  refused("same image", "point A 1 2 3 1\nobs A img 1 2\nobs A img 3 4\n", "line 3: point A is observed twice in img");
  CHECK_THROWS_WITH(diachron::read_control_points("/nonexistent/gcps.txt"), Contains("cannot be opened"));
}
