// Frame<Distortion>: world projection and pixel rays, their consistency, and invariance under a
// similarity move of the frame.

#include <cmath>
#include <limits>
#include <optional>

#include <catch2/catch.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/camera/frame.hpp>
#include <diachron/core/types.hpp>

using namespace diachron;

namespace {

// A 153 mm wide-angle camera 3000 m above ground, slightly tilted.
Frame<FraserAffine> aerial_frame() {
  const Camera<FraserAffine> camera(15300.0, 11511.8, 11492.4, 23000, 23000,
                                    {-0.08, 0.02, -0.005, 1e-4, -8e-5, 1.53, -0.77});
  const Pose pose = Pose::from_yaw_pitch_roll(Vec3(4.2e5, 5.1e6, 3000.0), 0.4, 0.02, -0.015);
  return Frame<FraserAffine>(camera, pose);
}

}  // namespace

TEST_CASE("Frame<FraserAffine>: a point on a pixel's ray projects back to the pixel",
          "[camera]") {
  const Frame<FraserAffine> frame = aerial_frame();
  for (double u = -0.5; u <= 22999.5; u += 2299.95) {
    for (double v = -0.5; v <= 22999.5; v += 2299.95) {
      const Vec2 pixel(u, v);
      const std::optional<Ray3> ray = frame.ray(pixel);
      REQUIRE(ray);
      CHECK(ray->direction.norm() == Approx(1.0).epsilon(1e-15));
      CHECK((ray->origin - frame.pose().centre()).norm() == 0.0);
      // World coordinates of ~5e6 m carry ~6e-10 m of rounding: the angle it subtends at range
      // t bounds the round trip (8e-6 px at 10 m, 3e-9 px at 3 km).
      for (const double t : {10.0, 3000.0, 1e5}) {
        const std::optional<Vec2> back = frame.project(ray->at(t));
        REQUIRE(back);
        CHECK((*back - pixel).norm() <= 1e-10 + 1e-4 / t);
      }
    }
  }
}

TEST_CASE("Frame<FraserAffine>: project then ray goes through the point", "[camera]") {
  const Frame<FraserAffine> frame = aerial_frame();
  const Vec3 ground(4.2e5 + 350.0, 5.1e6 - 820.0, 112.0);
  const std::optional<Vec2> pixel = frame.project(ground);
  REQUIRE(pixel);
  CHECK(frame.in_image(*pixel));
  const std::optional<Ray3> ray = frame.ray(*pixel);
  REQUIRE(ray);
  const Vec3 to_point = ground - ray->origin;
  const double off_axis = (to_point - to_point.dot(ray->direction) * ray->direction).norm();
  CHECK(off_axis <= 1e-6);  // metres, at ~3 km range
  CHECK(to_point.dot(ray->direction) > 0.0);
}

TEST_CASE("Frame<Fraser>: points behind the camera or non-finite give nullopt", "[camera]") {
  const Camera<Fraser> camera(1000.0, 499.5, 499.5, 1000, 1000, {0.01, 0, 0, 0, 0});
  const Frame<Fraser> frame(camera, Pose::look_at(Vec3(0, 0, 100), Vec3(0, 0, 0)));
  CHECK(frame.project(Vec3(0, 0, 0)));
  CHECK_FALSE(frame.project(Vec3(0, 0, 200)));   // above a nadir camera
  CHECK_FALSE(frame.project(Vec3(5, 5, 100)));   // on the centre plane
  CHECK_FALSE(frame.project(Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0)));
  CHECK_FALSE(frame.ray(Vec2(std::numeric_limits<double>::infinity(), 3.0)));
  CHECK(frame.in_image(Vec2(0.0, 999.0)));
  CHECK_FALSE(frame.in_image(Vec2(-1.0, 10.0)));
}

TEST_CASE("Frame<FraserAffine>: moving the frame by a similarity keeps its projections",
          "[camera]") {
  const Frame<FraserAffine> frame = aerial_frame();
  const double s = 0.93;
  const Mat3 r = Eigen::AngleAxisd(0.25, Vec3(0.1, -0.2, 1.0).normalized()).toRotationMatrix();
  const Vec3 t(-3.9e5, -4.7e6, 45.0);
  const Frame<FraserAffine> moved = frame.transformed(s, r, t);
  int checked = 0;
  for (double dx = -1500.0; dx <= 1500.0; dx += 500.0) {
    for (double dy = -1500.0; dy <= 1500.0; dy += 500.0) {
      const Vec3 x(4.2e5 + dx, 5.1e6 + dy, 80.0 + 0.01 * dx);
      const std::optional<Vec2> before = frame.project(x);
      const std::optional<Vec2> after = moved.project(s * r * x + t);
      REQUIRE(before.has_value() == after.has_value());
      if (before) {
        CHECK((*before - *after).norm() <= 1e-6);
        ++checked;
      }
    }
  }
  CHECK(checked == 49);
  // And rays map as the similarity says.
  const std::optional<Ray3> ray = frame.ray(Vec2(1234.0, 20000.0));
  const std::optional<Ray3> ray_moved = moved.ray(Vec2(1234.0, 20000.0));
  REQUIRE(ray);
  REQUIRE(ray_moved);
  CHECK((ray_moved->direction - r * ray->direction).norm() <= 1e-12);
  CHECK((ray_moved->origin - (s * r * ray->origin + t)).norm() <= 1e-6);
  // The Helmert3 overload is the same move.
  const Frame<FraserAffine> by_helmert = frame.transformed(diachron::Helmert3{s, r, t});
  const Vec3 x(4.2e5, 5.1e6, 80.0);
  REQUIRE(by_helmert.project(s * r * x + t));
  CHECK((*by_helmert.project(s * r * x + t) - *moved.project(s * r * x + t)).norm() == 0.0);
}
