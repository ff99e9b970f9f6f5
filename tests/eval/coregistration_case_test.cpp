#include <catch2/catch.hpp>

#include <cmath>

#include <diachron/eval/coregistration_case.hpp>

namespace {

// A smooth, non-symmetric world DEM on a UTM-like grid: every window of it is distinguishable.
diachron::Dsm world_dem(int w = 300, int h = 200, double cell = 10.0) {
  diachron::Raster<float> z(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      z(x, y) = static_cast<float>(1000.0 + 80.0 * std::sin(0.05 * x) * std::cos(0.07 * y) + 0.3 * x - 0.2 * y);
  return diachron::Dsm(std::move(z), diachron::GeoTransform::north_up(500000.0, 5100000.0, cell), "EPSG:32632");
}

}  // namespace

TEST_CASE("make_coregistration_case: the truth maps master points onto the secondary surface", "[eval]") {
  const diachron::Dsm world = world_dem();
  diachron::CoregistrationCaseOptions options;
  options.noise_sigma_cells = 0.0;
  options.hole_fraction = 0.0;
  options.overlap_min = 0.4;
  options.overlap_max = 0.6;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const auto c = diachron::make_coregistration_case(world, world, options, seed);
    REQUIRE(c.overlap >= 0.4);
    REQUIRE(c.overlap <= 0.6);
    int checked = 0;
    for (int y = 0; y < c.master.height(); y += 7)
      for (int x = 0; x < c.master.width(); x += 7) {
        if (!c.master.valid(x, y)) continue;
        const Eigen::Vector2d xy = c.master.pixel_to_world({double(x), double(y)});
        const Eigen::Vector3d p2 = c.secondary_from_master({xy.x(), xy.y(), c.master.heights()(x, y)});
        const double z2 = c.secondary.height_at(p2.x(), p2.y());
        if (std::isnan(z2)) continue;
        // Bilinear resampling of a smooth surface: within a few centimetres of a 10 m grid.
        REQUIRE(std::abs(z2 - p2.z()) < 0.2);
        ++checked;
      }
    REQUIRE(checked > 50);
  }
}

TEST_CASE("make_coregistration_case: deterministic in the seed", "[eval]") {
  const diachron::Dsm world = world_dem();
  diachron::CoregistrationCaseOptions options;
  const auto a = diachron::make_coregistration_case(world, world, options, 9);
  const auto b = diachron::make_coregistration_case(world, world, options, 9);
  const auto c = diachron::make_coregistration_case(world, world, options, 10);
  REQUIRE(a.secondary_from_master.translation == b.secondary_from_master.translation);
  REQUIRE(a.master.width() == b.master.width());
  REQUIRE(std::equal(a.master.heights().begin(), a.master.heights().end(), b.master.heights().begin(),
                     [](float u, float v) { return (std::isnan(u) && std::isnan(v)) || u == v; }));
  REQUIRE(a.secondary_from_master.translation != c.secondary_from_master.translation);
}

TEST_CASE("helmert_error_on_overlap: zero for the truth, the offset for a shifted estimate", "[eval]") {
  const diachron::Dsm world = world_dem();
  diachron::CoregistrationCaseOptions options;
  const auto c = diachron::make_coregistration_case(world, world, options, 4);
  const auto exact = diachron::helmert_error_on_overlap(c.secondary_from_master, c);
  REQUIRE(exact.valid);
  REQUIRE(exact.samples > 100);
  REQUIRE(exact.max < 1e-6);
  diachron::Helmert3 shifted = c.secondary_from_master;
  shifted.translation += Eigen::Vector3d(3.0, -4.0, 0.0);
  const auto off = diachron::helmert_error_on_overlap(shifted, c);
  REQUIRE(off.rms == Approx(5.0).epsilon(1e-9));
  REQUIRE(off.max == Approx(5.0).epsilon(1e-9));
}

TEST_CASE("make_coregistration_case: bad options and disjoint DEMs are errors", "[eval]") {
  const diachron::Dsm world = world_dem();
  diachron::CoregistrationCaseOptions bad;
  bad.overlap_min = 0.0;
  REQUIRE_THROWS_AS(diachron::make_coregistration_case(world, world, bad, 0), diachron::Error);
  diachron::Raster<float> z(10, 10, 5.0f);
  const diachron::Dsm far(std::move(z), diachron::GeoTransform::north_up(0.0, 0.0, 1.0));
  REQUIRE_THROWS_AS(diachron::make_coregistration_case(world, far, {}, 0), diachron::Error);
}
