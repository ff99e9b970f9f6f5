// Pose: construction checks, aerial helpers and the move into another frame by a similarity.

#include <cmath>

#include <catch2/catch.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

using namespace diachron;

namespace {

Mat3 rotation(double angle, const Vec3& axis) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

}  // namespace

TEST_CASE("Pose: X_cam = R (X - C) and its inverse", "[camera]") {
  const Mat3 r = rotation(0.7, Vec3(1.0, -2.0, 0.5));
  const Vec3 c(100.0, -50.0, 1200.0);
  const Pose pose(r, c);
  const Vec3 x(10.0, 20.0, 30.0);
  CHECK((pose.cam_from_world(x) - r * (x - c)).norm() <= 1e-12);
  CHECK((pose.world_from_cam(pose.cam_from_world(x)) - x).norm() <= 1e-10);
  CHECK((pose.cam_from_world_translation() + r * c).norm() <= 1e-10);
  const Pose same = Pose::from_cam_from_world(r, pose.cam_from_world_translation());
  CHECK((same.centre() - c).norm() <= 1e-9);
  CHECK((pose.viewing_direction() - r.transpose() * Vec3::UnitZ()).norm() <= 1e-15);
}

TEST_CASE("Pose: nadir look_at and yaw-pitch-roll agree and read like a map", "[camera]") {
  const Vec3 c(500.0, 800.0, 3000.0);
  const Pose looked = Pose::look_at(c, Vec3(500.0, 800.0, 0.0));
  const Pose angles = Pose::from_yaw_pitch_roll(c, 0.0, 0.0, 0.0);
  CHECK((looked.cam_from_world_rotation() - angles.cam_from_world_rotation()).norm() <= 1e-15);
  // Image right is east (+X), image down is south (-Y), forward is down (-Z).
  CHECK((looked.cam_from_world_rotation().row(0) - Vec3::UnitX().transpose()).norm() <= 1e-15);
  CHECK((looked.cam_from_world_rotation().row(1) + Vec3::UnitY().transpose()).norm() <= 1e-15);
  CHECK((looked.viewing_direction() + Vec3::UnitZ()).norm() <= 1e-15);
  // A point north-east of the nadir point is up-right in the image (x > 0, y < 0).
  const Vec3 p = looked.cam_from_world(Vec3(600.0, 900.0, 0.0));
  CHECK(p.x() > 0.0);
  CHECK(p.y() < 0.0);
  CHECK(p.z() == Approx(3000.0));

  // yaw = +90 deg turns the image axes counter-clockwise: image right points north.
  const Pose yawed = Pose::from_yaw_pitch_roll(c, 0.5 * kPi, 0.0, 0.0);
  CHECK((yawed.world_direction_from_cam(Vec3::UnitX()) - Vec3::UnitY()).norm() <= 1e-15);
  // pitch > 0 tilts the view towards the image top (north at yaw 0), roll > 0 towards east.
  const Pose pitched = Pose::from_yaw_pitch_roll(c, 0.0, 0.1, 0.0);
  CHECK(pitched.viewing_direction().y() == Approx(std::sin(0.1)));
  const Pose rolled = Pose::from_yaw_pitch_roll(c, 0.0, 0.0, 0.1);
  CHECK(rolled.viewing_direction().x() == Approx(std::sin(0.1)));
  // look_at towards a tilted target gives a proper rotation whose z points at it.
  const Pose oblique = Pose::look_at(c, Vec3(1500.0, 300.0, 0.0));
  CHECK(oblique.cam_from_world_rotation().determinant() == Approx(1.0));
  CHECK((oblique.viewing_direction() - (Vec3(1500.0, 300.0, 0.0) - c).normalized()).norm() <=
        1e-15);
}

TEST_CASE("Pose: transformed by a similarity keeps camera-frame directions", "[camera]") {
  const Pose pose = Pose::from_yaw_pitch_roll(Vec3(10.0, 20.0, 1500.0), 0.3, 0.05, -0.02);
  const double s = 1.37;
  const Mat3 r = rotation(0.4, Vec3(0.2, 0.1, 1.0));
  const Vec3 t(1e5, -2e4, 300.0);
  const Pose moved = pose.transformed(s, r, t);
  CHECK((moved.centre() - (s * r * pose.centre() + t)).norm() <= 1e-9);
  CHECK((moved.cam_from_world_rotation() - pose.cam_from_world_rotation() * r.transpose())
            .norm() <= 1e-14);
  for (const Vec3& x : {Vec3(0, 0, 0), Vec3(300, -200, 50), Vec3(-1000, 700, 120)}) {
    const Vec3 before = pose.cam_from_world(x);
    const Vec3 after = moved.cam_from_world(s * r * x + t);
    CHECK((after - s * before).norm() <= 1e-9 * before.norm());
  }
}

TEST_CASE("Pose: transformed by a Helmert3 equals transformed by its (scale, R, t)", "[camera]") {
  const Pose pose = Pose::from_yaw_pitch_roll(Vec3(10.0, 20.0, 1500.0), 0.3, 0.05, -0.02);
  const diachron::Helmert3 h{1.37, rotation(0.4, Vec3(0.2, 0.1, 1.0)), Vec3(1e5, -2e4, 300.0)};
  const Pose by_parts = pose.transformed(h.scale, h.rotation, h.translation);
  const Pose by_helmert = pose.transformed(h);
  CHECK(by_helmert.centre() == by_parts.centre());
  CHECK(by_helmert.cam_from_world_rotation() == by_parts.cam_from_world_rotation());
  // The Helmert's own map and the moved pose agree: camera coordinates scale by s.
  const Vec3 x(300, -200, 50);
  CHECK((by_helmert.cam_from_world(h(x)) - h.scale * pose.cam_from_world(x)).norm() <= 1e-9);
  CHECK_THROWS_AS(pose.transformed(diachron::Helmert3{0.0, Mat3::Identity(), Vec3::Zero()}), Error);
}

TEST_CASE("Pose: bad arguments throw diachron::Error", "[camera]") {
  Mat3 reflection = Mat3::Identity();
  reflection(2, 2) = -1.0;
  CHECK_THROWS_AS(Pose(reflection, Vec3::Zero()), Error);
  CHECK_THROWS_AS(Pose(2.0 * Mat3::Identity(), Vec3::Zero()), Error);
  CHECK_THROWS_AS(Pose(Mat3::Identity(), Vec3(0.0, std::nan(""), 0.0)), Error);
  CHECK_THROWS_AS(Pose::look_at(Vec3::Zero(), Vec3::Zero()), Error);
  CHECK_THROWS_AS(Pose::look_at(Vec3::Zero(), Vec3(0, 10, 0), Vec3::UnitY()), Error);
  CHECK_THROWS_AS(Pose::from_yaw_pitch_roll(Vec3::Zero(), std::nan(""), 0.0, 0.0), Error);
  const Pose pose;
  CHECK_THROWS_AS(pose.transformed(0.0, Mat3::Identity(), Vec3::Zero()), Error);
  CHECK_THROWS_AS(pose.transformed(-1.0, Mat3::Identity(), Vec3::Zero()), Error);
  CHECK_THROWS_AS(pose.transformed(1.0, reflection, Vec3::Zero()), Error);
  // Stored orientations with rounding (1e-9) are accepted and re-orthonormalised.
  Mat3 rounded = rotation(0.3, Vec3::UnitZ());
  rounded(0, 1) += 1e-9;
  const Pose fine(rounded, Vec3::Zero());
  const Mat3 r = fine.cam_from_world_rotation();
  CHECK((r.transpose() * r - Mat3::Identity()).norm() <= 1e-15);
}
