// Tests of the GSD (MicMac's definition): H / f for a nadir pinhole over flat ground, on the DSM
// and on a horizontal plane; the dependence on the ground height; failures.
#include <cmath>

#include <catch2/catch.hpp>

#include <diachron/terrain/gsd.hpp>

#include "terrain/pinhole_test_frame.hpp"

using Eigen::Vector2d;
using Eigen::Vector3d;

TEST_CASE("Gsd: H/f for a nadir pinhole over flat ground", "[terrain]") {
  diachron::Raster<float> z(500, 500, 120.0f);
  const diachron::Dsm dsm(z, diachron::GeoTransform::north_up(0.0, 1000.0, 2.0));
  const auto frame = diachron::test::make_frame(Vector3d(500.0, 500.0, 1620.0), 3000.0, 0.7);
  for (const Vector2d& px : {Vector2d(500.0, 500.0), Vector2d(100.0, 850.0), Vector2d(930.5, 12.25)}) {
    const auto on_dsm = diachron::gsd_on_dsm(frame, dsm, px);
    const auto on_plane = diachron::gsd_at_height(frame, 120.0, px);
    REQUIRE(on_dsm);
    REQUIRE(on_plane);
    CHECK(*on_dsm == Approx(1500.0 / 3000.0).epsilon(1e-9));
    CHECK(*on_plane == Approx(1500.0 / 3000.0).epsilon(1e-12));
  }
  // AltiSol variant: the GSD scales with the height above the chosen plane.
  CHECK(*diachron::gsd_at_height(frame, 620.0, Vector2d(10.0, 10.0)) == Approx(1000.0 / 3000.0).epsilon(1e-12));
}

TEST_CASE("Gsd: oblique frame and failures", "[terrain]") {
  diachron::Raster<float> z(500, 500, 0.0f);
  const diachron::Dsm dsm(z, diachron::GeoTransform::north_up(-500.0, 1000.0, 4.0));
  // Tilted 30 degrees: at the principal point the x step is still H' / f with H' the slant range.
  const auto tilted = diachron::test::make_frame(Vector3d(0.0, 0.0, 1000.0), 1000.0, 0.0, 0.5236);
  const auto g = diachron::gsd_on_dsm(tilted, dsm, Vector2d(500.0, 500.0));
  REQUIRE(g);
  CHECK(*g == Approx(1000.0 / std::cos(0.5236) / 1000.0).epsilon(1e-4));
  // Plane above the camera (behind it for a downward frame), DSM missed: nullopt.
  CHECK_FALSE(diachron::gsd_at_height(tilted, 2000.0, Vector2d(500.0, 500.0)));
  const auto far = diachron::test::make_frame(Vector3d(1e5, 0.0, 1000.0));
  CHECK_FALSE(diachron::gsd_on_dsm(far, dsm, Vector2d(500.0, 500.0)));
  CHECK_THROWS_AS(diachron::gsd_at_height(tilted, std::nan(""), Vector2d(500.0, 500.0)), diachron::Error);
}
