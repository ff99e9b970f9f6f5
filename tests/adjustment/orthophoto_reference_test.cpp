// Tests for pipeline/orthophoto_reference.hpp: matches to an orthophoto as control points of the
// combined adjustment, and the sigma they are given.

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/camera/frame.hpp>
#include <diachron/camera/ortho_frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/pipeline/orthophoto_reference.hpp>
#include <diachron/terrain/dsm.hpp>

using diachron::Camera;
using diachron::FraserAffine;
using diachron::Frame;

namespace {

// A pair report as orthophoto_control_points reads it.
struct OrPair {
  std::size_t master = 0, secondary = 0;
  diachron::PointMatches matches;
};

// A 100 x 80 DSM of 2 m cells from (1000, 2000) at 50 m, with a hole over cells 33-37 x 8-12.
diachron::Dsm or_dsm() {
  diachron::Raster<float> h(100, 80, 50.0f);
  for (int y = 8; y <= 12; ++y)
    for (int x = 33; x <= 37; ++x) h(x, y) = std::numeric_limits<float>::quiet_NaN();
  return diachron::Dsm(std::move(h), diachron::GeoTransform::north_up(1000.0, 2000.0, 2.0));
}

// A nadir frame camera of focal f px at (x, y, height), 400 x 300 px.
Frame<FraserAffine> or_nadir(double f, double x, double y, double height) {
  const Camera<FraserAffine> camera(f, 199.5, 149.5, 400, 300);
  return Frame<FraserAffine>(camera, diachron::Pose::look_at(Eigen::Vector3d(x, y, height), Eigen::Vector3d(x, y, 0.0)));
}

}  // namespace

TEST_CASE("orthophoto_control_points: the ground under each tile pixel, observed in the photo", "[adjustment]") {
  const diachron::Dsm dsm = or_dsm();
  // Two tiles of a 0.5 m orthophoto from (1000, 2000): the second starts 100 px to the right.
  const diachron::OrthoFrame ortho(diachron::GeoTransform::north_up(1000.0, 2000.0, 0.5), 400, 300);
  const std::vector<diachron::OrthoFrame> tiles = {ortho.tile(0, 0, 200, 300), ortho.tile(100, 0, 200, 300)};
  OrPair a{3, 1, {{Eigen::Vector2d(5.0, 6.0), Eigen::Vector2d(10.0, 20.0), 0.5},
                  {Eigen::Vector2d(7.0, 8.0), Eigen::Vector2d(41.0, 41.0), 0.4}}};  // in the hole: X 1070.75, Y 1979.25
  OrPair b{0, 0, {{Eigen::Vector2d(1.0, 2.0), Eigen::Vector2d(4.0, 4.0), 0.3}}};
  const diachron::OrthophotoControlPoints out =
      diachron::orthophoto_control_points(std::vector<OrPair>{a, b}, tiles, dsm, 6.0);
  CHECK(out.matches == 3);
  CHECK(out.off_dsm == 1);
  REQUIRE(out.points.size() == 2);
  // Tile 1's pixel (10, 20) is orthophoto pixel (110, 20): centre at X 1000 + 110.5 * 0.5, Y 2000 - 20.5 * 0.5.
  CHECK(out.points[0].position.x() == Approx(1055.25));
  CHECK(out.points[0].position.y() == Approx(1989.75));
  CHECK(out.points[0].position.z() == Approx(50.0));
  CHECK(out.points[0].sigma == 6.0);
  REQUIRE(out.points[0].epoch1.size() == 1);
  CHECK(out.points[0].epoch1[0].image == 3);
  CHECK(out.points[0].epoch1[0].pixel == Eigen::Vector2d(5.0, 6.0));
  CHECK(out.points[1].position.x() == Approx(1002.25));
  CHECK(out.points[1].position.y() == Approx(1997.75));
  CHECK(out.points[1].epoch1[0].image == 0);

  CHECK_THROWS_AS(diachron::orthophoto_control_points(std::vector<OrPair>{a}, tiles, dsm, 0.0), diachron::Error);
  OrPair bad = a;
  bad.secondary = 2;
  CHECK_THROWS_WITH(diachron::orthophoto_control_points(std::vector<OrPair>{bad}, tiles, dsm, 1.0),
                    Catch::Contains("tile 2"));
}

TEST_CASE("orthophoto_control_sigma: sigma_px of epoch 1's GSD on the reference's ground", "[adjustment]") {
  // Nadir frames 1000 m above the ground at 50 m: GSD 950 / f.
  const std::vector<Frame<FraserAffine>> frames = {or_nadir(1000.0, 0.0, 0.0, 1000.0),
                                                   or_nadir(500.0, 100.0, 0.0, 1000.0),
                                                   or_nadir(2000.0, 200.0, 0.0, 1000.0)};
  const diachron::Helmert3 identity{};
  // The median of 0.95, 1.9 and 0.475 m.
  CHECK(diachron::orthophoto_control_sigma(frames, identity, 50.0, 0.5, 6.0) == Approx(6.0 * 0.95));
  // Epoch 1 in other units: the rough Helmert scales its GSD into the reference's.
  diachron::Helmert3 half{};
  half.scale = 0.5;
  CHECK(diachron::orthophoto_control_sigma(frames, half, 25.0, 0.5, 6.0) == Approx(6.0 * 0.475));
  // A reference height above the cameras: no ray meets it, the fallback's GSD.
  CHECK(diachron::orthophoto_control_sigma(frames, identity, 2000.0, 0.5, 6.0) == Approx(3.0));
  CHECK_THROWS_AS(diachron::orthophoto_control_sigma(frames, identity, 50.0, 0.5, 0.0), diachron::Error);
  CHECK_THROWS_AS(diachron::orthophoto_control_sigma(frames, identity, 50.0, 0.0, 6.0), diachron::Error);
}
