// Tests of local_relief(): a tilted plane has no relief whatever the grid's rotation; random heights
// against a brute-force oracle (every cell of the raster tested, the plane by QR on absolute
// coordinates); holes, collinear data and bad input.
#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/terrain/local_relief.hpp>

using diachron::Dsm;
using diachron::GeoTransform;
using diachron::LocalRelief;
using diachron::Raster;
using Eigen::Vector2d;

namespace {

// A grid of 2.5 m cells turned by 0.4 rad, so the disc's bounding box is not the grid's.
GeoTransform rotated_grid() {
  GeoTransform t;
  const double c = 2.5 * std::cos(0.4), s = 2.5 * std::sin(0.4);
  t.c = {4.5e5, c, -s, 5.2e6, s, c};
  return t;
}

// The oracle: every valid cell of the raster within the radius, the plane z = a + b X + c Y by QR.
LocalRelief oracle(const Dsm& dsm, const Vector2d& xy, double radius, int min_cells) {
  std::vector<Vector2d> at;
  std::vector<double> z;
  for (int y = 0; y < dsm.height(); ++y)
    for (int x = 0; x < dsm.width(); ++x) {
      const Vector2d w = dsm.pixel_to_world(Vector2d(x, y));
      if (dsm.valid(x, y) && (w - xy).norm() <= radius) {
        at.push_back(w);
        z.push_back(dsm.heights()(x, y));
      }
    }
  LocalRelief out;
  out.cells = static_cast<int>(z.size());
  if (out.cells < min_cells) return out;
  Eigen::MatrixXd a(out.cells, 3);
  Eigen::VectorXd b(out.cells);
  for (int i = 0; i < out.cells; ++i) {
    a.row(i) << 1.0, at[i].x(), at[i].y();
    b(i) = z[i];
  }
  const Eigen::VectorXd residual = b - a * a.colPivHouseholderQr().solve(b);
  out.valid = true;
  out.rms = std::sqrt(residual.squaredNorm() / out.cells);
  out.max_abs = residual.cwiseAbs().maxCoeff();
  return out;
}

}  // namespace

TEST_CASE("local_relief: a tilted plane has none, on a rotated grid", "[terrain]") {
  const GeoTransform t = rotated_grid();
  Raster<float> z(80, 60);
  for (int y = 0; y < z.height(); ++y)
    for (int x = 0; x < z.width(); ++x) {
      const Vector2d w = t.pixel_to_world(Vector2d(x, y));
      z(x, y) = static_cast<float>(300.0 + 0.3 * (w.x() - 4.5e5) - 0.2 * (w.y() - 5.2e6));
    }
  const Dsm dsm(z, t);
  const Vector2d centre = dsm.pixel_to_world(Vector2d(40.3, 29.6));
  const LocalRelief r = diachron::local_relief(dsm, centre, 20.0);
  REQUIRE(r.valid);
  // float heights of about 300 m round to 3e-5 m.
  CHECK(r.rms < 1e-4);
  CHECK(r.max_abs < 1e-4);
  CHECK(r.cells == oracle(dsm, centre, 20.0, 6).cells);
  CHECK(r.cells > 150);  // pi 20^2 / 2.5^2 = 201 cells
}

TEST_CASE("local_relief: random heights against the brute-force oracle", "[terrain]") {
  const GeoTransform t = rotated_grid();
  diachron::RandomStream random(17);
  Raster<float> z(70, 70);
  for (float& v : z) v = static_cast<float>(random.uniform(90.0, 110.0));
  for (int k = 0; k < 300; ++k) {
    // One draw per statement, y before x (core/random.hpp, "Order of draws").
    const int y = static_cast<int>(random.uniform(0.0, 69.99));
    z(static_cast<int>(random.uniform(0.0, 69.99)), y) = std::numeric_limits<float>::quiet_NaN();
  }
  const Dsm dsm(z, t);
  for (const Vector2d& px : {Vector2d(35.0, 35.0), Vector2d(2.2, 3.7), Vector2d(66.5, 10.1), Vector2d(35.5, 68.9)})
    for (const double radius : {3.0, 12.0, 40.0}) {
      const Vector2d centre = dsm.pixel_to_world(px);
      const LocalRelief got = diachron::local_relief(dsm, centre, radius);
      const LocalRelief want = oracle(dsm, centre, radius, 6);
      CAPTURE(px.transpose(), radius);
      REQUIRE(got.cells == want.cells);
      REQUIRE(got.valid == want.valid);
      if (!want.valid) continue;
      CHECK(got.rms == Approx(want.rms).epsilon(1e-9));
      CHECK(got.max_abs == Approx(want.max_abs).epsilon(1e-9));
      CHECK(got.rms > 3.0);  // uniform in [90, 110]: a standard deviation of 5.8
    }
}

TEST_CASE("local_relief: a bump on flat ground, holes, collinear data and bad input", "[terrain]") {
  Raster<float> z(40, 40, 50.0f);
  z(20, 20) = 60.0f;  // one cell 10 m up
  const Dsm dsm(z, GeoTransform::north_up(0.0, 40.0, 1.0));
  const Vector2d at = dsm.pixel_to_world(Vector2d(20.0, 20.0));
  const LocalRelief bump = diachron::local_relief(dsm, at, 5.0);
  const LocalRelief want = oracle(dsm, at, 5.0, 6);
  REQUIRE(bump.valid);
  CHECK(bump.cells == want.cells);
  CHECK(bump.rms == Approx(want.rms).epsilon(1e-12));
  CHECK(bump.max_abs == Approx(10.0 * (1.0 - 1.0 / bump.cells)).epsilon(1e-9));  // the fit lifts by 10 / n
  // Far away the same DSM is flat.
  CHECK(diachron::local_relief(dsm, dsm.pixel_to_world(Vector2d(6.0, 6.0)), 5.0).rms < 1e-12);

  // Holes: four valid cells in the disc are fewer than the six required, enough for three.
  Raster<float> holes(20, 20, std::numeric_limits<float>::quiet_NaN());
  holes(9, 9) = 1.0f;
  holes(10, 9) = 2.0f;
  holes(9, 10) = 3.0f;
  holes(10, 10) = 5.0f;
  const Dsm sparse(holes, GeoTransform::north_up(0.0, 20.0, 1.0));
  const Vector2d mid = sparse.pixel_to_world(Vector2d(9.5, 9.5));
  const LocalRelief few = diachron::local_relief(sparse, mid, 4.0);
  CHECK_FALSE(few.valid);
  CHECK(few.cells == 4);
  CHECK(std::isinf(few.rms));
  const LocalRelief enough = diachron::local_relief(sparse, mid, 4.0, 3);
  REQUIRE(enough.valid);
  CHECK(enough.rms == Approx(oracle(sparse, mid, 4.0, 3).rms).epsilon(1e-12));

  // One row of data: the tilt across it is undetermined.
  Raster<float> row(20, 20, std::numeric_limits<float>::quiet_NaN());
  for (int x = 0; x < 20; ++x) row(x, 10) = static_cast<float>(x % 3);
  const Dsm strip(row, GeoTransform::north_up(0.0, 20.0, 1.0));
  CHECK_FALSE(diachron::local_relief(strip, strip.pixel_to_world(Vector2d(10.0, 10.0)), 6.0).valid);

  // Outside the DSM: nothing to measure.
  CHECK_FALSE(diachron::local_relief(dsm, Vector2d(-500.0, 900.0), 5.0).valid);
  CHECK_FALSE(diachron::local_relief(Dsm(), at, 5.0).valid);

  CHECK_THROWS_WITH(diachron::local_relief(dsm, at, 0.0), Catch::Contains("radius must be finite and > 0"));
  CHECK_THROWS_WITH(diachron::local_relief(dsm, at, std::nan("")), Catch::Contains("radius must be finite and > 0"));
  CHECK_THROWS_WITH(diachron::local_relief(dsm, at, 5.0, 2), Catch::Contains("min_cells must be >= 3"));
}
