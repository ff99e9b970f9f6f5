// Tests of intersect_ray_dsm against analytic surfaces (plane, slope, step, sphere cap), steep
// relief between samples, near-vertical rays, and every "no intersection" outcome.
#include <cmath>
#include <functional>
#include <limits>
#include <optional>

#include <catch2/catch.hpp>

#include <diachron/core/types.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>

using diachron::Dsm;
using diachron::GeoTransform;
using diachron::Raster;
using diachron::Ray3;
using diachron::RayDsmOutcome;
using Eigen::Vector3d;

namespace {

Dsm make_dsm(int w, int h, double x0, double y0, double cell, const std::function<double(double, double)>& z) {
  const GeoTransform gt = GeoTransform::north_up(x0, y0, cell);
  Raster<float> r(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector2d p = gt.pixel_to_world({x, y});
      r(x, y) = static_cast<float>(z(p.x(), p.y()));
    }
  return Dsm(std::move(r), gt);
}

// A ray towards `target` from `distance` away, with zenith angle `zenith` and azimuth `azimuth` (radians).
Ray3 ray_towards(const Vector3d& target, double zenith, double azimuth, double distance) {
  const Vector3d up(std::sin(zenith) * std::cos(azimuth), std::sin(zenith) * std::sin(azimuth), std::cos(zenith));
  Ray3 r;
  r.origin = target + distance * up;
  r.direction = -up;
  return r;
}

// Reference: the first sign change of ray-height minus surface-height on a dense sampling.
std::optional<double> brute_force_first_crossing(const Dsm& dsm, const Ray3& ray, double t_max, double dt,
                                                 double t_min = 0.0) {
  double prev = std::numeric_limits<double>::quiet_NaN();
  for (double t = t_min; t <= t_max; t += dt) {
    const Vector3d p = ray.at(t);
    const double f = p.z() - dsm.height_at(p.x(), p.y());
    if (!std::isnan(prev) && prev > 0.0 && f <= 0.0) return t - dt * f / (f - prev);
    prev = f;
  }
  return std::nullopt;
}

const double kZeniths[] = {0.0, 1e-9, 0.2, diachron::kPi / 4, 1.2, 1.48};
const double kAzimuths[] = {0.0, 0.7, 2.0, 3.9, 5.5};

}  // namespace

TEST_CASE("RayDsm: plane and slope, rays at several incidence angles", "[terrain]") {
  const double cell = 2.0;
  struct Plane { double z0, gx, gy; };
  for (const Plane pl : {Plane{120.0, 0.0, 0.0}, Plane{50.0, 0.3, -0.2}, Plane{0.0, 1.7, 0.4}}) {
    const auto z = [&](double X, double Y) { return pl.z0 + pl.gx * (X - 400) + pl.gy * (Y - 300); };
    const Dsm dsm = make_dsm(200, 150, 400.0, 600.0, cell, z);
    double worst = 0.0;
    for (double zen : kZeniths)
      for (double az : kAzimuths) {
        const Vector3d target(500.3, 450.7, z(500.3, 450.7));
        const Ray3 ray = ray_towards(target, zen, az, 80.0);
        const auto r = diachron::intersect_ray_dsm(dsm, ray);
        INFO("plane gx " << pl.gx << " zenith " << zen << " azimuth " << az);
        // A steep plane can hide the target behind a nearer part of itself: use the analytic
        // first crossing of the ray with the plane.
        const Vector3d n(-pl.gx, -pl.gy, 1.0);
        const double above = ray.origin.z() - z(ray.origin.x(), ray.origin.y());
        if (above < 0.0) {
          // A grazing ray from uphill starts under a steep plane.
          CHECK(r.outcome == RayDsmOutcome::below_surface);
          continue;
        }
        const double t_plane = -above / n.dot(ray.direction);
        REQUIRE(r.success);
        REQUIRE(r.outcome == RayDsmOutcome::hit);
        CHECK(r.distance == Approx(t_plane).margin(1e-3 * cell));
        CHECK((r.point - ray.at(t_plane)).norm() < 1e-3 * cell);
        worst = std::max(worst, (r.point - ray.at(t_plane)).norm() / cell);
      }
    WARN("plane gx=" << pl.gx << ": worst intersection error " << worst << " cells");
  }
}

TEST_CASE("RayDsm: step (cliff between samples) is never skipped", "[terrain]") {
  // Columns with centre X < 50 are at 0, the others at 100: the bilinear surface is a ramp on
  // 49.5 <= X <= 50.5, 100 m high over one 1 m cell.
  const auto z = [](double X, double) { return X < 50.0 ? 0.0 : 100.0; };
  const Dsm dsm = make_dsm(100, 40, 0.0, 40.0, 1.0, z);
  for (double height : {1.0, 30.0, 50.0, 99.0}) {
    // Almost horizontal rays, from the low side towards the cliff, at several slants.
    for (double az : {0.0, 0.3, -0.6}) {
      Ray3 ray;
      ray.origin = Vector3d(50.0 - 40.0 * std::cos(az), 20.0 - 40.0 * std::sin(az), height + 1e-3 * 40.0);
      ray.direction = Vector3d(std::cos(az), std::sin(az), -1e-3).normalized();
      const auto r = diachron::intersect_ray_dsm(dsm, ray);
      REQUIRE(r.success);
      // On the ramp, Z = 100 (X - 49.5).
      const double expected_x = 49.5 + r.point.z() / 100.0;
      CHECK(r.point.x() == Approx(expected_x).margin(1e-3));
      CHECK(r.point.z() == Approx(height).margin(0.05));
    }
  }
  // From above: vertical rays land on the top or the bottom, and on the ramp between.
  for (double X : {20.0, 49.7, 50.2, 70.0}) {
    const auto r = diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(X, 20.0, 500.0), Vector3d(0, 0, -1)});
    REQUIRE(r.success);
    const double expected = X <= 49.5 ? 0.0 : (X >= 50.5 ? 100.0 : 100.0 * (X - 49.5));
    CHECK(r.point.z() == Approx(expected).margin(1e-3));
  }
}

TEST_CASE("RayDsm: a grazing ray finds a one-sample spike between march steps", "[terrain]") {
  Raster<float> r(101, 101, 0.0f);
  r(50, 50) = 100.0f;
  const Dsm dsm(r, GeoTransform::north_up(0, 101, 1.0));
  // Pixel (50, 50) is at world (50.5, 50.5). A ray at Z ~ 95 straight through it: the tent is only
  // 0.1 cell wide at that height, narrower than a march step.
  for (double offset : {0.0, 0.013, 0.021}) {
    Ray3 ray;
    ray.origin = Vector3d(5.0, 50.5 + offset, 95.0 + 45.5 * 1e-4);
    ray.direction = Vector3d(1.0, 0.0, -1e-4).normalized();
    diachron::RayDsmOptions coarse;
    coarse.step_cells = 4.0;  // coarse on purpose: the per-cell quadratic test must still see it
    const auto hit = diachron::intersect_ray_dsm(dsm, ray, coarse);
    const auto reference = brute_force_first_crossing(dsm, ray, 47.0, 1e-5, 44.0);
    REQUIRE(reference);
    REQUIRE(hit.success);
    INFO("offset " << offset);
    CHECK(hit.distance == Approx(*reference).margin(1e-3));
    CHECK(hit.point.x() < 50.5);
  }
}

TEST_CASE("RayDsm: sphere cap to 1e-3 cell", "[terrain]") {
  const double R = 1000.0, cx = 350.0, cy = 350.0, base = R - 46.0;
  const auto z = [&](double X, double Y) {
    const double r2 = (X - cx) * (X - cx) + (Y - cy) * (Y - cy);
    return std::max(0.0, std::sqrt(std::max(0.0, R * R - r2)) - base);
  };
  const Dsm dsm = make_dsm(700, 700, 0.0, 700.0, 1.0, z);
  const Vector3d centre(cx, cy, -base);
  double worst = 0.0;
  for (double zen : kZeniths)
    for (double az : kAzimuths)
      for (const Eigen::Vector2d& xy : {Eigen::Vector2d(350.2, 350.1), Eigen::Vector2d(200.3, 420.9),
                                       Eigen::Vector2d(410.0, 150.5)}) {
        const Vector3d target(xy.x(), xy.y(), z(xy.x(), xy.y()));
        const Ray3 ray = ray_towards(target, zen, az, 300.0);
        // Analytic first crossing with the sphere.
        const Vector3d oc = ray.origin - centre;
        const double bq = oc.dot(ray.direction), cq = oc.squaredNorm() - R * R;
        const double t = -bq - std::sqrt(bq * bq - cq);
        const auto r = diachron::intersect_ray_dsm(dsm, ray);
        INFO("zenith " << zen << " azimuth " << az << " target " << xy.transpose());
        REQUIRE(r.success);
        // Against the bilinear surface the DSM defines, at every incidence.
        // Above Z = 47 the ray is over the whole cap: start the dense search there.
        const double t_band = std::max(0.0, (ray.origin.z() - 47.0) / -ray.direction.z());
        const auto reference = brute_force_first_crossing(dsm, ray, 400.0, 4e-3, t_band);
        REQUIRE(reference);
        CHECK(r.distance == Approx(*reference).margin(1e-3));
        // Against the sphere itself: the DSM differs from it by the interpolation error
        // (~ cell^2 / 8R = 1.3e-4 cell in height), which a grazing ray stretches along itself
        // by 1 / sin(incidence), so the analytic check is made up to 45 degrees off nadir.
        if (zen <= diachron::kPi / 4 + 1e-9) {
          CHECK(r.distance == Approx(t).margin(1e-3));
          worst = std::max(worst, std::abs(r.distance - t));
        }
      }
  WARN("sphere cap: worst distance to the sphere (zenith <= 45 deg) " << worst << " cells");
}

TEST_CASE("RayDsm: near-vertical rays over a large height range", "[terrain]") {
  const auto z = [](double X, double Y) { return 2000.0 + 500.0 * std::sin(X / 40.0) * std::cos(Y / 30.0); };
  const Dsm dsm = make_dsm(300, 300, 0.0, 300.0, 1.0, z);
  for (double eps : {0.0, 1e-12, 1e-7, 1e-4}) {
    Ray3 ray{Vector3d(123.4, 201.7, 1e6), Vector3d(eps, -eps, -1.0).normalized()};
    const auto r = diachron::intersect_ray_dsm(dsm, ray);
    REQUIRE(r.success);
    CHECK(r.point.z() == Approx(dsm.height_at(r.point.x(), r.point.y())).margin(1e-4));
    const auto reference = brute_force_first_crossing(dsm, Ray3{ray.at(1e6 - 3000.0), ray.direction}, 2000.0, 1e-2);
    REQUIRE(reference);
    CHECK(r.distance == Approx(*reference + 1e6 - 3000.0).margin(1e-3));
  }
}

TEST_CASE("RayDsm: misses, holes and bad rays", "[terrain]") {
  const auto flat = [](double, double) { return 10.0; };
  const Dsm dsm = make_dsm(50, 50, 0.0, 50.0, 1.0, flat);

  // Pointing up, and passing beside the DSM.
  CHECK(diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(25, 25, 100), Vector3d(0, 0, 1)}).outcome ==
        RayDsmOutcome::above_surface);
  CHECK(diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(80, 25, 100), Vector3d(0, 0, -1)}).outcome ==
        RayDsmOutcome::outside);
  CHECK(diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(-80, 25, 100), Vector3d(0, 1, -0.1).normalized()})
            .outcome == RayDsmOutcome::outside);
  // Slanted so that it would meet the plane Z = 10 only beyond the DSM's edge.
  const auto leaves = diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(25, 25, 100), Vector3d(1, 0, -1).normalized()});
  CHECK_FALSE(leaves.success);
  CHECK(leaves.outcome == RayDsmOutcome::above_surface);
  // Too short.
  diachron::RayDsmOptions short_ray;
  short_ray.max_distance = 50.0;
  CHECK(diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(25, 25, 100), Vector3d(0, 0, -1)}, short_ray).outcome ==
        RayDsmOutcome::above_surface);
  short_ray.max_distance = 95.0;
  CHECK(diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(25, 25, 100), Vector3d(0, 0, -1)}, short_ray).success);
  // Origin underground.
  CHECK(diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(25, 25, 5), Vector3d(0, 0.2, -1).normalized()}).outcome ==
        RayDsmOutcome::below_surface);
  // Non-unit direction is fine; the distance is along the normalised direction.
  const auto scaled = diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(25, 25, 100), Vector3d(0, 0, -7)});
  REQUIRE(scaled.success);
  CHECK(scaled.distance == Approx(90.0));
  CHECK(diachron::ray_dsm_point(dsm, Ray3{Vector3d(25, 25, 100), Vector3d(0, 0, -1)}).has_value());

  // A hole under the ray: the crossing is in missing data.
  Raster<float> holed = dsm.heights();
  for (int y = 20; y < 30; ++y)
    for (int x = 20; x < 30; ++x) holed(x, y) = std::numeric_limits<float>::quiet_NaN();
  const Dsm with_hole(holed, dsm.transform());
  const auto in_hole = diachron::intersect_ray_dsm(with_hole, Ray3{Vector3d(25, 25, 100), Vector3d(0, 0, -1)});
  CHECK_FALSE(in_hole.success);
  CHECK(in_hole.outcome == RayDsmOutcome::only_holes);
  // A peak far away widens the height range so that the slanted ray below meets valid ground
  // before the hole within it.
  holed(2, 2) = 30.0f;
  const Dsm with_hole_and_peak(holed, dsm.transform());
  const auto slanted = diachron::intersect_ray_dsm(
      with_hole_and_peak, Ray3{Vector3d(15, 25, 20), Vector3d(1, 0, -0.9).normalized()});
  CHECK_FALSE(slanted.success);
  CHECK(slanted.outcome == RayDsmOutcome::hidden_by_hole);
  // Over the hole but crossing after it, on valid ground: a hit.
  const auto after = diachron::intersect_ray_dsm(
      with_hole, Ray3{Vector3d(22, 25, 20), Vector3d(1, 0, -0.5).normalized()});
  REQUIRE(after.success);
  CHECK(after.point.x() == Approx(42.0).margin(1e-6));
  // All holes.
  const Dsm all_holes(Raster<float>(10, 10, std::numeric_limits<float>::quiet_NaN()), dsm.transform());
  CHECK(diachron::intersect_ray_dsm(all_holes, Ray3{Vector3d(5, 45, 100), Vector3d(0, 0, -1)}).outcome ==
        RayDsmOutcome::only_holes);
  CHECK(std::string(diachron::to_string(RayDsmOutcome::hidden_by_hole)).size() > 0);

  // Invalid input is an error.
  CHECK_THROWS_AS(diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(25, 25, 100), Vector3d::Zero()}), diachron::Error);
  CHECK_THROWS_AS(diachron::intersect_ray_dsm(dsm, Ray3{Vector3d(std::nan(""), 25, 100), Vector3d(0, 0, -1)}),
                  diachron::Error);
  diachron::RayDsmOptions bad;
  bad.step_cells = 0.0;
  CHECK_THROWS_AS(diachron::intersect_ray_dsm(dsm, Ray3{}, bad), diachron::Error);
}
