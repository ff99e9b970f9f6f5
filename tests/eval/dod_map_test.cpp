// DoD maps against brute-force oracles: a tilted plane moved by a Helmert with tilt (the moved surface
// is a plane, dZ analytic), a dome on a plane (a bisection along each vertical line, on the bilinear DSM
// and on the analytic surface), holes and cells off the moving DSM classified as a direct look-up
// says, walls that cannot converge, the identity; the stable mask against a test of every cell and
// point; the statistics against error_statistics; bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/eval/dod_map.hpp>

using namespace diachron;

namespace dod_map_test {

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();

// A DSM sampling `z(X, Y)` at its cell centres.
Dsm sampled(const GeoTransform& gt, int w, int h, const std::function<double(double, double)>& z) {
  Raster<float> r(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector2d c = gt.pixel_to_world({x, y});
      r(x, y) = static_cast<float>(z(c.x(), c.y()));
    }
  return Dsm(std::move(r), gt);
}

// A Helmert that rotates and scales about `centre` (moving frame) and then shifts by `shift`:
// X_ref = s R (X - centre) + centre + shift. Rotating about the origin would throw the test grids far off.
Helmert3 about(const Eigen::Vector3d& centre, double scale, double yaw, double pitch, double roll,
               const Eigen::Vector3d& shift) {
  Helmert3 h = Helmert3::from_yaw_pitch_roll(scale, yaw, pitch, roll, Eigen::Vector3d::Zero());
  h.translation = centre + shift - scale * (h.rotation * centre);
  return h;
}

// The oracle: the height Z at which the vertical line through (X, Y) meets the moved surface
// `height(u, v)` (moving frame), by a scan of Z for the first sign change of q.z - height(q.x, q.y),
// q = moving_from_reference(X, Y, Z), then bisection. Unrelated to dod_map's fixed-point iteration.
std::optional<double> vertical_crossing(const std::function<double(double, double)>& height, const Helmert3& to_ref,
                                        double X, double Y, double z_lo, double z_hi) {
  const Helmert3 to_moving = to_ref.inverse();
  const auto g = [&](double Z) {
    const Eigen::Vector3d q = to_moving(Eigen::Vector3d(X, Y, Z));
    return q.z() - height(q.x(), q.y());
  };
  constexpr double step = 0.25;
  double a = z_lo, ga = g(a);
  for (double b = z_lo + step; b <= z_hi; b += step) {
    const double gb = g(b);
    if (std::isnan(ga) || std::isnan(gb)) return std::nullopt;
    if ((ga <= 0.0) != (gb <= 0.0)) {
      for (int i = 0; i < 100; ++i) {
        const double m = 0.5 * (a + b), gm = g(m);
        if (std::isnan(gm)) return std::nullopt;
        if ((gm <= 0.0) == (ga <= 0.0)) {
          a = m;
          ga = gm;
        } else {
          b = m;
        }
      }
      return 0.5 * (a + b);
    }
    a = b;
    ga = gb;
  }
  return std::nullopt;
}

// Every valid cell's moved surface point lies on the moving DSM: the converged point is a true crossing.
void check_valid_cells_are_crossings(const DodMap& m, const Dsm& reference, const Dsm& moving, const Helmert3& to_ref,
                                     double max_residual_m) {
  const Helmert3 to_moving = to_ref.inverse();
  for (int y = 0; y < reference.height(); ++y)
    for (int x = 0; x < reference.width(); ++x) {
      if (m.status(x, y) != DodCellStatus::valid) continue;
      const Eigen::Vector2d c = reference.pixel_to_world({x, y});
      const double Z = static_cast<double>(reference.heights()(x, y)) + m.dz.heights()(x, y);
      const Eigen::Vector3d q = to_moving(Eigen::Vector3d(c.x(), c.y(), Z));
      const double residual = q.z() - moving.height_at(q.x(), q.y());
      CHECK(std::abs(residual) < max_residual_m);
    }
}

void check_counts_add_up(const DodMap& m) {
  CHECK(m.num_valid + m.num_reference_hole + m.num_moving_hole + m.num_outside + m.num_not_converged ==
        m.dz.heights().size());
  for (int y = 0; y < m.dz.height(); ++y)
    for (int x = 0; x < m.dz.width(); ++x)
      CHECK((m.status(x, y) == DodCellStatus::valid) == !std::isnan(m.dz.heights()(x, y)));
}

}  // namespace dod_map_test

using namespace dod_map_test;

TEST_CASE("dod_map: a tilted plane moved by a Helmert with tilt gives the analytic dZ", "[eval]") {
  // Moving epoch: Z = 30 + 0.4 u - 0.3 v (slope 0.5) over 200 x 200 cells of 1 m.
  const auto moving_plane = [](double u, double v) { return 30.0 + 0.4 * u - 0.3 * v; };
  const Dsm moving = sampled(GeoTransform::north_up(0.0, 200.0, 1.0), 200, 200, moving_plane);
  // 17 deg of yaw, 3 and 2 deg of tilt, 2 % scale.
  const Helmert3 to_ref = about({100.0, 100.0, 30.0}, 1.02, 0.3, 0.05, -0.04, {3.0, -2.0, 5.0});
  // Reference epoch: another plane, on 1.5 m cells that do not line up with the moving ones.
  const Dsm reference = sampled(GeoTransform::north_up(20.0, 180.0, 1.5), 100, 100,
                                [](double X, double Y) { return 35.0 + 0.2 * X + 0.1 * Y; });
  // The moved plane: normal R n, through the moved point (0, 0, 30).
  const Eigen::Vector3d n = to_ref.rotation * Eigen::Vector3d(-0.4, 0.3, 1.0);
  const Eigen::Vector3d p0 = to_ref(Eigen::Vector3d(0.0, 0.0, 30.0));
  const auto moved_plane = [&](double X, double Y) {
    return p0.z() - (n.x() * (X - p0.x()) + n.y() * (Y - p0.y())) / n.z();
  };

  const DodMap m = dod_map(reference, moving, to_ref);
  REQUIRE(m.success);
  CHECK(m.reason.empty());
  check_counts_add_up(m);
  CHECK(m.num_reference_hole == 0);
  CHECK(m.num_moving_hole == 0);
  CHECK(m.num_not_converged == 0);
  CHECK(m.num_outside > 0);  // the rotated footprint pokes out of the moving DSM at the corners
  CHECK(m.num_valid > 8000);
  CHECK(m.max_iterations_used >= 2);  // the tilt makes a single step miss
  CHECK(m.max_iterations_used <= 8);
  CHECK(m.dz.transform().c == reference.transform().c);
  const Helmert3 to_moving = to_ref.inverse();
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 100; ++x) {
      const Eigen::Vector2d c = reference.pixel_to_world({x, y});
      const double z = moved_plane(c.x(), c.y());
      const Eigen::Vector3d q = to_moving(Eigen::Vector3d(c.x(), c.y(), z));
      const bool well_inside = q.x() > 2.0 && q.x() < 198.0 && q.y() > 2.0 && q.y() < 198.0;
      const bool off = q.x() < 0.0 || q.x() > 200.0 || q.y() < 0.0 || q.y() > 200.0;
      if (well_inside) REQUIRE(m.status(x, y) == DodCellStatus::valid);
      if (off) CHECK(m.status(x, y) == DodCellStatus::outside);
      if (m.status(x, y) != DodCellStatus::valid) continue;
      // Far below 1 cm with the default options: 0.1 mm of horizontal miss on a slope of 0.5, float heights.
      CHECK(m.dz.heights()(x, y) == Approx(z - static_cast<double>(reference.heights()(x, y))).margin(2e-4));
    }
  check_valid_cells_are_crossings(m, reference, moving, to_ref, 1e-3);

  // A tighter tolerance tightens the answer: the default is not what limits it, the heights' floats are.
  DodMapOptions tight;
  tight.tolerance_m = 1e-7;
  const DodMap t = dod_map(reference, moving, to_ref, tight);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 100; ++x) {
      if (t.status(x, y) != DodCellStatus::valid) continue;
      const Eigen::Vector2d c = reference.pixel_to_world({x, y});
      CHECK(t.dz.heights()(x, y) ==
            Approx(moved_plane(c.x(), c.y()) - static_cast<double>(reference.heights()(x, y))).margin(3e-5));
    }

  // The same result on one thread and on several.
  DodMapOptions one;
  one.threads = 1;
  DodMapOptions two;
  two.threads = 2;
  const DodMap a = dod_map(reference, moving, to_ref, one), b = dod_map(reference, moving, to_ref, two);
  for (std::size_t i = 0; i < a.dz.heights().size(); ++i) {
    const float va = a.dz.heights().data()[i], vb = b.dz.heights().data()[i];
    CHECK(((std::isnan(va) && std::isnan(vb)) || va == vb));
  }
}

TEST_CASE("dod_map: a dome on the moving epoch is recovered, as a bisection along each vertical finds it", "[eval]") {
  // Moving epoch: a tilted plane plus a paraboloid dome of 4 m (zero on a circle of 80 m).
  const auto plane = [](double u, double v) { return 50.0 + 0.3 * u + 0.2 * v; };
  const auto dome = [](double u, double v) {
    const double r2 = (u - 100.0) * (u - 100.0) + (v - 100.0) * (v - 100.0);
    return 4.0 * (1.0 - r2 / (80.0 * 80.0));
  };
  const auto surface = [&](double u, double v) { return plane(u, v) + dome(u, v); };
  const Dsm moving = sampled(GeoTransform::north_up(0.0, 200.0, 1.0), 200, 200, surface);
  const Helmert3 to_ref = about({100.0, 100.0, 50.0}, 0.98, -0.2, -0.06, 0.03, {-4.0, 6.0, -3.0});
  // Reference epoch: the moved plane (no dome), from the oracle on the analytic plane.
  const GeoTransform ref_gt = GeoTransform::north_up(30.0, 170.0, 1.25);
  const Dsm reference = sampled(ref_gt, 112, 112, [&](double X, double Y) {
    return vertical_crossing(plane, to_ref, X, Y, 0.0, 200.0).value_or(std::numeric_limits<double>::quiet_NaN());
  });
  REQUIRE(reference.statistics().count == 112u * 112u);

  const DodMap m = dod_map(reference, moving, to_ref);
  REQUIRE(m.success);
  check_counts_add_up(m);
  CHECK(m.num_valid == 112u * 112u);  // the footprint lies well inside the moving DSM
  check_valid_cells_are_crossings(m, reference, moving, to_ref, 1e-3);
  const auto bilinear = [&](double u, double v) { return moving.height_at(u, v); };
  const Helmert3 to_moving = to_ref.inverse();
  double peak = -1e9;
  for (int y = 0; y < 112; y += 3)
    for (int x = 0; x < 112; x += 3) {
      const Eigen::Vector2d c = ref_gt.pixel_to_world({x, y});
      const double z_ref = reference.heights()(x, y);
      const double dz = m.dz.heights()(x, y);
      // The bilinear moving DSM, bisected: the same surface, another method.
      const std::optional<double> on_dsm = vertical_crossing(bilinear, to_ref, c.x(), c.y(), z_ref - 20.0, z_ref + 20.0);
      REQUIRE(on_dsm);
      CHECK(dz == Approx(*on_dsm - z_ref).margin(2e-4));
      // The analytic surface: bilinear interpolation of the dome costs < 0.1 mm on 1 m cells.
      const std::optional<double> exact = vertical_crossing(surface, to_ref, c.x(), c.y(), z_ref - 20.0, z_ref + 20.0);
      REQUIRE(exact);
      CHECK(dz == Approx(*exact - z_ref).margin(5e-4));
      // And the dome itself: the crossing q lies the dome's height d above the plane, and the plane
      // point below it along the reference vertical (v, in the moving frame) L = d / (v.z - g . v.xy)
      // away, g the plane's gradient; dZ is that distance scaled into the reference frame.
      const Eigen::Vector3d q = to_moving(Eigen::Vector3d(c.x(), c.y(), *exact));
      const Eigen::Vector3d v = to_ref.rotation.transpose() * Eigen::Vector3d::UnitZ();
      const double along = v.z() - (0.3 * v.x() + 0.2 * v.y());
      CHECK(dz == Approx(0.98 * dome(q.x(), q.y()) / along).margin(5e-4));
      peak = std::max(peak, dz);
    }
  CHECK(peak == Approx(0.98 * 4.0).margin(0.15));
}

TEST_CASE("dod_map: holes of either DSM and cells off the moving DSM, as a direct look-up says", "[eval]") {
  // No rotation: the moving surface at a reference cell is the moving DSM's bilinear height at
  // (X - 20.25, Y), one step, so the direct look-up is the oracle for values and classes.
  const GeoTransform gt = GeoTransform::north_up(0.0, 100.0, 1.0);
  RandomStream rng(11, 0);
  Raster<float> zm(100, 100), zr(100, 100);
  for (float& v : zm) v = static_cast<float>(rng.uniform(10.0, 20.0));
  for (float& v : zr) v = static_cast<float>(rng.uniform(10.0, 20.0));
  zm(50, 50) = kNan;  // a hole of the moving epoch
  zm(51, 10) = kNan;
  zr(80, 20) = kNan;  // a hole of the reference
  zr(5, 5) = kNan;    // a reference hole that is also off the moving DSM: a reference hole
  const Dsm moving(zm, gt), reference(zr, gt);
  const Eigen::Vector3d shift(20.25, 0.0, 0.5);
  const Helmert3 to_ref{1.0, Eigen::Matrix3d::Identity(), shift};

  const DodMap m = dod_map(reference, moving, to_ref);
  REQUIRE(m.success);
  check_counts_add_up(m);
  std::size_t valid = 0, moving_hole = 0, outside = 0;
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 100; ++x) {
      if (std::isnan(zr(x, y))) {
        CHECK(m.status(x, y) == DodCellStatus::reference_hole);
        continue;
      }
      const Eigen::Vector2d c = gt.pixel_to_world({x, y});
      const double u = c.x() - shift.x(), v = c.y();
      const double z = moving.height_at(u, v);
      if (!std::isnan(z)) {
        ++valid;
        REQUIRE(m.status(x, y) == DodCellStatus::valid);
        CHECK(m.dz.heights()(x, y) == Approx(z + 0.5 - static_cast<double>(zr(x, y))).margin(1e-5));
        continue;
      }
      const Eigen::Vector2d px = gt.world_to_pixel({u, v});
      const bool inside = px.x() >= 0.0 && px.y() >= 0.0 && px.x() <= 99.0 && px.y() <= 99.0;
      ++(inside ? moving_hole : outside);
      CHECK(m.status(x, y) == (inside ? DodCellStatus::moving_hole : DodCellStatus::outside));
    }
  CHECK(m.num_valid == valid);
  CHECK(m.num_moving_hole == moving_hole);
  CHECK(m.num_outside == outside);
  CHECK(m.num_reference_hole == 2);
  // By hand: column x reads the moving DSM at its pixel x - 20.25, so the 21 first columns are off
  // (less the reference hole among them), a hole at moving column 50 spoils reference columns 70 and
  // 71 of its row (weights 0.75 and 0.25), and the one at (51, 10) columns 71 and 72 of row 10.
  CHECK(m.num_outside == 21u * 100u - 1u);
  CHECK(m.status(0, 0) == DodCellStatus::outside);
  CHECK(m.status(20, 40) == DodCellStatus::outside);
  CHECK(m.status(21, 40) == DodCellStatus::valid);
  CHECK(m.status(70, 50) == DodCellStatus::moving_hole);
  CHECK(m.status(71, 50) == DodCellStatus::moving_hole);
  CHECK(m.status(72, 50) == DodCellStatus::valid);
  CHECK(m.status(70, 49) == DodCellStatus::valid);
  CHECK(m.num_moving_hole == 4);
}

TEST_CASE("dod_map: the identity gives zero; no overlap is a failure, not an error", "[eval]") {
  const GeoTransform gt = GeoTransform::north_up(500.0, 800.0, 2.0);
  RandomStream rng(3, 0);
  Raster<float> z(40, 30);
  for (float& v : z) v = static_cast<float>(rng.uniform(100.0, 160.0));
  z(0, 0) = z(17, 9) = z(39, 29) = kNan;
  const Dsm dsm(z, gt, "EPSG:2154");
  const DodMap m = dod_map(dsm, dsm, Helmert3::identity());
  REQUIRE(m.success);
  check_counts_add_up(m);
  CHECK(m.num_valid == 40u * 30u - 3u);
  CHECK(m.num_reference_hole == 3);
  CHECK(m.max_iterations_used == 1);
  CHECK(m.dz.crs() == "EPSG:2154");
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x)
      if (!std::isnan(z(x, y))) CHECK(m.dz.heights()(x, y) == 0.0f);

  // Moved 1 km east, nothing overlaps.
  const Helmert3 far{1.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d(1000.0, 0.0, 0.0)};
  const DodMap none = dod_map(dsm, dsm, far);
  CHECK_FALSE(none.success);
  CHECK(none.reason.find("outside") != std::string::npos);
  CHECK(none.num_outside == 40u * 30u - 3u);
  CHECK(none.dz.width() == 40);
  CHECK(none.dz.statistics().count == 0);
}

TEST_CASE("dod_map: walls converge under a small tilt; where they cannot, cells are NaN and counted", "[eval]") {
  // A 40 m block with vertical walls (slope 40 between two pixel centres). The iteration's rate there
  // is about tilt x 40: 0.4 under 0.01 rad (converges), 4 under 0.1 rad (cannot).
  const Dsm moving = sampled(GeoTransform::north_up(0.0, 100.0, 1.0), 100, 100,
                             [](double u, double v) { return (u > 40.0 && u < 60.0 && v > 30.0 && v < 70.0) ? 40.0 : 0.0; });
  const Dsm reference = sampled(GeoTransform::north_up(10.0, 90.0, 1.0), 80, 80, [](double, double) { return 0.0; });
  const Helmert3 small_tilt = about({50.0, 50.0, 0.0}, 1.0, 0.0, 0.01, 0.0, Eigen::Vector3d::Zero());
  const DodMap converged = dod_map(reference, moving, small_tilt);
  REQUIRE(converged.success);
  check_counts_add_up(converged);
  CHECK(converged.num_valid == 80u * 80u);
  CHECK(converged.max_iterations_used > 5);
  check_valid_cells_are_crossings(converged, reference, moving, small_tilt, 0.01);

  const Helmert3 large_tilt = about({50.0, 50.0, 0.0}, 1.0, 0.0, 0.1, 0.0, Eigen::Vector3d::Zero());
  const DodMap m = dod_map(reference, moving, large_tilt);
  REQUIRE(m.success);
  check_counts_add_up(m);
  CHECK(m.num_not_converged > 0);
  CHECK(m.num_not_converged < 400);  // the walls only
  // Whatever converged, even by the walls, is a true crossing of the moved surface.
  check_valid_cells_are_crossings(m, reference, moving, large_tilt, 0.01);
}

TEST_CASE("stable_mask_near_points: the cells within the radius of a point, as a test of every pair says", "[eval]") {
  SECTION("a point on a cell centre and a radius of one cell: the centre and its four neighbours") {
    const Dsm grid = sampled(GeoTransform::north_up(1000.0, 5000.0, 2.0), 20, 15, [](double, double) { return 0.0; });
    const Eigen::Vector2d c = grid.pixel_to_world({7.0, 4.0});
    const Raster<std::uint8_t> mask = stable_mask_near_points(grid, {Eigen::Vector3d(c.x(), c.y(), 123.0)}, 2.0);
    std::size_t set = 0;
    for (std::uint8_t v : mask) set += v;
    CHECK(set == 5);
    CHECK(mask(7, 4) == 1);
    CHECK(mask(6, 4) == 1);
    CHECK(mask(8, 4) == 1);
    CHECK(mask(7, 3) == 1);
    CHECK(mask(7, 5) == 1);
    CHECK(mask(8, 5) == 0);
  }
  SECTION("random points, some off the grid, on a rotated and sheared grid") {
    const GeoTransform gt{{1000.0, 1.5, 0.4, 5000.0, 0.3, -1.2}};
    const Dsm grid = sampled(gt, 60, 45, [](double, double) { return 1.0; });
    RandomStream rng(5, 0);
    std::vector<Eigen::Vector3d> points;
    for (int i = 0; i < 40; ++i) {
      const double Y = rng.uniform(4930.0, 5010.0);
      const double X = rng.uniform(990.0, 1110.0);
      points.emplace_back(X, Y, rng.uniform(0.0, 10.0));
    }
    for (const double radius : {0.5, 2.3, 7.0}) {
      const Raster<std::uint8_t> mask = stable_mask_near_points(grid, points, radius);
      std::size_t set = 0;
      for (int y = 0; y < 45; ++y)
        for (int x = 0; x < 60; ++x) {
          bool near = false;
          for (const Eigen::Vector3d& p : points)
            near = near || (gt.pixel_to_world({x, y}) - p.head<2>()).norm() <= radius;
          CHECK(mask(x, y) == (near ? 1 : 0));
          set += near ? 1 : 0;
        }
      CHECK(set > 0);
    }
  }
}

TEST_CASE("dod_map_statistics: over all valid cells and the stable ones, as error_statistics gives them", "[eval]") {
  const GeoTransform gt = GeoTransform::north_up(0.0, 0.0, 1.0);
  RandomStream rng(9, 0);
  Raster<float> z(30, 20);
  Raster<std::uint8_t> stable(30, 20, 0);
  std::vector<double> all, on_stable;
  std::size_t stable_cells = 0;
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 30; ++x) {
      const bool hole = (x + 3 * y) % 7 == 0;
      const bool is_stable = x < 12;  // stable terrain: small errors; elsewhere, changes of metres
      const double v = is_stable ? rng.normal(0.1, 0.2) : rng.normal(2.0, 3.0);
      z(x, y) = hole ? kNan : static_cast<float>(v);
      stable(x, y) = is_stable ? 1 : 0;
      stable_cells += is_stable ? 1 : 0;
      if (hole) continue;
      all.push_back(z(x, y));
      if (is_stable) on_stable.push_back(z(x, y));
    }
  const Dsm dz(z, gt);
  const auto same = [](const ErrorStatistics& a, const ErrorStatistics& b) {
    CHECK(a.count == b.count);
    CHECK(a.mean == Approx(b.mean).margin(1e-12));
    CHECK(a.sigma == Approx(b.sigma).margin(1e-12));
    CHECK(a.mean_abs == Approx(b.mean_abs).margin(1e-12));
    CHECK(a.median == Approx(b.median).margin(1e-12));
    CHECK(a.nmad == Approx(b.nmad).margin(1e-12));
  };
  const DodMapStatistics s = dod_map_statistics(dz, &stable);
  REQUIRE(s.success);
  CHECK(s.has_stable_mask);
  CHECK(s.num_cells == 600);
  CHECK(s.num_stable_cells == stable_cells);
  same(s.all, error_statistics(all));
  same(s.stable, error_statistics(on_stable));
  CHECK(s.stable.nmad < 0.5);
  CHECK(s.all.sigma > 1.0);

  const DodMapStatistics no_mask = dod_map_statistics(dz);
  REQUIRE(no_mask.success);
  CHECK_FALSE(no_mask.has_stable_mask);
  same(no_mask.all, error_statistics(all));
  CHECK(no_mask.stable.count == 0);
  CHECK(std::isnan(no_mask.stable.mean));

  // Failures: a mask without a valid stable cell, a map without a valid cell.
  const Raster<std::uint8_t> none(30, 20, 0);
  const DodMapStatistics unstable = dod_map_statistics(dz, &none);
  CHECK_FALSE(unstable.success);
  CHECK_FALSE(unstable.reason.empty());
  same(unstable.all, error_statistics(all));
  const DodMapStatistics empty = dod_map_statistics(Dsm(Raster<float>(4, 3, kNan), gt));
  CHECK_FALSE(empty.success);
  CHECK_FALSE(empty.reason.empty());
  CHECK(empty.all.count == 0);
  CHECK(DodMapStatistics{}.success == false);
  CHECK(DodMap{}.success == false);
}

TEST_CASE("dod_map and friends: bad input throws", "[eval]") {
  const GeoTransform gt = GeoTransform::north_up(0.0, 10.0, 1.0);
  const Dsm dsm(Raster<float>(10, 10, 1.0f), gt);
  const Helmert3 id = Helmert3::identity();
  CHECK_THROWS_AS(dod_map(Dsm(), dsm, id), Error);
  CHECK_THROWS_AS(dod_map(dsm, Dsm(), id), Error);
  Helmert3 bad = id;
  bad.translation.x() = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(dod_map(dsm, dsm, bad), Error);
  bad = id;
  bad.scale = 0.0;
  CHECK_THROWS_AS(dod_map(dsm, dsm, bad), Error);
  bad = id;
  bad.rotation(0, 1) = 0.1;  // not orthonormal
  CHECK_THROWS_AS(dod_map(dsm, dsm, bad), Error);
  bad = id;
  bad.rotation(2, 2) = -1.0;  // a reflection
  CHECK_THROWS_AS(dod_map(dsm, dsm, bad), Error);
  DodMapOptions o;
  o.max_iterations = 0;
  CHECK_THROWS_AS(dod_map(dsm, dsm, id, o), Error);
  o = DodMapOptions{};
  o.tolerance_m = 0.0;
  CHECK_THROWS_AS(dod_map(dsm, dsm, id, o), Error);

  const std::vector<Eigen::Vector3d> points{Eigen::Vector3d(5.0, 5.0, 0.0)};
  CHECK_THROWS_AS(stable_mask_near_points(dsm, points, 0.0), Error);
  CHECK_THROWS_AS(stable_mask_near_points(dsm, points, -1.0), Error);
  CHECK_THROWS_AS(stable_mask_near_points(dsm, points, std::numeric_limits<double>::infinity()), Error);
  CHECK_THROWS_AS(stable_mask_near_points(Dsm(), points, 1.0), Error);
  CHECK_THROWS_AS(stable_mask_near_points(dsm, {Eigen::Vector3d(std::nan(""), 0.0, 0.0)}, 1.0), Error);

  CHECK_THROWS_AS(dod_map_statistics(Dsm()), Error);
  const Raster<std::uint8_t> wrong(9, 10, 1);
  CHECK_THROWS_AS(dod_map_statistics(dsm, &wrong), Error);
}
