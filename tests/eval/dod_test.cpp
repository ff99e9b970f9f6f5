// The sparse DoD against a brute-force recomputation on a planar DSM (bilinear interpolation is
// exact on a plane), with points off the DSM, on holes, and bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/core/types.hpp>
#include <diachron/eval/dod.hpp>

using namespace diachron;

namespace {

// Z = 100 + 0.5 (X - 1000) - 0.25 (Y - 5000) over 20 x 15 cells of 2 m, top-left corner (1000, 5000),
// with a hole at pixel (10, 7).
double plane(double X, double Y) { return 100.0 + 0.5 * (X - 1000.0) - 0.25 * (Y - 5000.0); }

Dsm plane_dsm(bool with_hole) {
  const GeoTransform gt = GeoTransform::north_up(1000.0, 5000.0, 2.0);
  Raster<float> z(20, 15);
  for (int y = 0; y < 15; ++y)
    for (int x = 0; x < 20; ++x) {
      const Eigen::Vector2d w = gt.pixel_to_world({x, y});
      z(x, y) = static_cast<float>(plane(w.x(), w.y()));
    }
  if (with_hole) z(10, 7) = std::numeric_limits<float>::quiet_NaN();
  return Dsm(std::move(z), gt);
}

}  // namespace

TEST_CASE("sparse_dod: dZ and its statistics equal a brute-force recomputation", "[eval]") {
  const Dsm dsm = plane_dsm(false);
  RandomStream rng(7, 0);
  std::vector<Vec3> points;
  std::vector<double> expected;
  // Inside the grid of pixel centres: X in [1001, 1039], Y in [4971, 4999].
  for (int i = 0; i < 200; ++i) {
    const double X = rng.uniform(1001.0, 1039.0), Y = rng.uniform(4971.0, 4999.0);
    const double dz = 0.3 + 1.5 * rng.normal() + (i % 10 == 0 ? 20.0 : 0.0);  // 10 % "changed" points
    points.emplace_back(X, Y, plane(X, Y) + dz);
    expected.push_back(dz);
  }
  const DodReport r = sparse_dod(points, dsm);
  REQUIRE(r.success);
  CHECK(r.num_used == 200);
  CHECK(r.num_outside == 0);
  CHECK(r.num_hole == 0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    CHECK(r.status[i] == DodStatus::used);
    CHECK(r.dz[i] == Approx(expected[i]).margin(1e-9));
  }
  const ErrorStatistics s = error_statistics(expected);
  CHECK(r.statistics.mean == Approx(s.mean).margin(1e-9));
  CHECK(r.statistics.sigma == Approx(s.sigma).margin(1e-9));
  CHECK(r.statistics.mean_abs == Approx(s.mean_abs).margin(1e-9));
  CHECK(r.statistics.median == Approx(s.median).margin(1e-9));
  CHECK(r.statistics.nmad == Approx(s.nmad).margin(1e-9));
  // The changed points pull mu and sigma, hardly the median and NMAD.
  CHECK(r.statistics.mean > 1.5);
  CHECK(r.statistics.median == Approx(0.3).margin(0.4));
  CHECK(r.statistics.nmad == Approx(1.5).margin(0.4));
  CHECK(r.statistics.sigma > 5.0);
}

TEST_CASE("sparse_dod: points off the DSM and on holes are counted apart", "[eval]") {
  const Dsm dsm = plane_dsm(true);
  const Eigen::Vector2d hole = dsm.pixel_to_world({10.0, 7.0});
  const std::vector<Vec3> points{
      Vec3(1010.0, 4985.0, plane(1010.0, 4985.0) + 1.0),  // used (pixel (4.5, 7), far from the hole)
      Vec3(900.0, 4985.0, 0.0),                            // outside, west
      Vec3(1000.5, 4985.0, 0.0),  // in the footprint but within half a cell of the edge: no bilinear height
      Vec3(hole.x() + 0.5, hole.y() - 0.5, 0.0),  // next to the hole centre: hole
      Vec3(hole.x(), hole.y(), 0.0),               // on it: hole
      Vec3(hole.x() + 2.0, hole.y(), plane(hole.x() + 2.0, hole.y()) - 2.0),  // the next pixel centre: used
  };
  const DodReport r = sparse_dod(points, dsm);
  REQUIRE(r.success);
  CHECK(r.status == std::vector<DodStatus>{DodStatus::used, DodStatus::outside, DodStatus::outside, DodStatus::hole,
                                           DodStatus::hole, DodStatus::used});
  CHECK(r.num_used == 2);
  CHECK(r.num_outside == 2);
  CHECK(r.num_hole == 2);
  CHECK(r.dz[0] == Approx(1.0));
  CHECK(std::isnan(r.dz[1]));
  CHECK(r.dz[5] == Approx(-2.0));
  CHECK(r.statistics.mean == Approx(-0.5));
  CHECK(r.statistics.mean_abs == Approx(1.5));
}

TEST_CASE("sparse_dod: no usable point is success == false; non-finite points throw", "[eval]") {
  const Dsm dsm = plane_dsm(false);
  const DodReport off = sparse_dod({Vec3(0.0, 0.0, 0.0)}, dsm);
  CHECK_FALSE(off.success);
  CHECK_THAT(off.reason, Catch::Contains("1 outside"));
  CHECK(std::isnan(off.statistics.mean));
  const DodReport empty_dsm = sparse_dod({Vec3(1020.0, 4985.0, 0.0)}, Dsm());
  CHECK_FALSE(empty_dsm.success);
  CHECK(empty_dsm.num_outside == 1);
  CHECK_FALSE(sparse_dod({}, dsm).success);
  CHECK_THROWS_WITH(sparse_dod({Vec3(1020.0, 4985.0, 0.0), Vec3(1.0, std::nan(""), 0.0)}, dsm),
                    Catch::Contains("point 1"));
}
