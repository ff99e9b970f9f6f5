// Tests for Helmert3T and the rotation helpers: mapping, inverse, composition, constructors,
// random rotations, rotation angles near 180 degrees and Ceres Jet derivatives.

#include <cmath>
#include <vector>

#include <ceres/jet.h>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/rotation.hpp>

using diachron::Helmert3;
using diachron::Helmert3T;
using diachron::kPi;

namespace {

bool is_rotation(const Eigen::Matrix3d& r, double tolerance = 1e-12) {
  return (r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < tolerance &&
         std::abs(r.determinant() - 1.0) < tolerance;
}

Helmert3 random_helmert(diachron::RandomStream& random) {
  return Helmert3{
      random.uniform(0.1, 10.0),
      diachron::random_rotation(random),
      {random.uniform(-100, 100), random.uniform(-100, 100), random.uniform(-100, 100)}};
}

}  // namespace

TEST_CASE("Helmert3: maps epoch 1 into epoch 2 as scale * R * X1 + T", "[geometry]") {
  const Helmert3 epoch2_from_epoch1 = Helmert3::from_axis_angle(
      /*scale=*/2.0, /*axis_angle=*/Eigen::Vector3d(0, 0, kPi / 2),
      /*translation=*/{1.0, 2.0, 3.0});
  const Eigen::Vector3d x2 = epoch2_from_epoch1(Eigen::Vector3d(1.0, 0.0, 5.0));
  CHECK((x2 - Eigen::Vector3d(1.0, 4.0, 13.0)).norm() < 1e-14);

  const Eigen::Vector3d p(-3.5, 7.25, 100.0);
  const Eigen::Vector4d h = epoch2_from_epoch1.matrix() * p.homogeneous();
  CHECK((h.head<3>() - epoch2_from_epoch1(p)).norm() < 1e-12);
  CHECK((Helmert3::identity()(p) - p).norm() == 0.0);
  CHECK((Helmert3{}(p)-p).norm() == 0.0);
}

TEST_CASE("Helmert3: inverse and composition identities", "[geometry]") {
  diachron::RandomStream random(3);
  for (int trial = 0; trial < 50; ++trial) {
    const Helmert3 epoch2_from_epoch1 = random_helmert(random);
    const Helmert3 epoch3_from_epoch2 = random_helmert(random);
    const Helmert3 epoch1_from_epoch2 = epoch2_from_epoch1.inverse();
    const Helmert3 epoch3_from_epoch1 = epoch3_from_epoch2 * epoch2_from_epoch1;
    CHECK(is_rotation(epoch3_from_epoch1.rotation));
    CHECK(epoch1_from_epoch2.scale == Approx(1.0 / epoch2_from_epoch1.scale));
    for (int k = 0; k < 5; ++k) {
      // One draw per statement, z before y before x: the order of a call's arguments is
      // unspecified (core/random.hpp, "Order of draws"); this is the order the tests were written
      // with.
      const double xz = random.uniform(-50, 50), xy = random.uniform(-50, 50);
      const Eigen::Vector3d x(random.uniform(-50, 50), xy, xz);
      CHECK((epoch1_from_epoch2(epoch2_from_epoch1(x)) - x).norm() < 1e-10 * (1 + x.norm()));
      const Eigen::Vector3d expected = epoch3_from_epoch2(epoch2_from_epoch1(x));
      CHECK((epoch3_from_epoch1(x) - expected).norm() < 1e-10 * (1 + expected.norm()));
    }
    const Helmert3 round_trip = epoch1_from_epoch2 * epoch2_from_epoch1;
    CHECK((round_trip.matrix() - Eigen::Matrix4d::Identity()).norm() < 1e-11);
    CHECK((epoch3_from_epoch1.matrix() - epoch3_from_epoch2.matrix() * epoch2_from_epoch1.matrix())
              .norm() < 1e-9);
  }
  CHECK_THROWS_AS((Helmert3{0.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()}.inverse()),
                  diachron::Error);
}

TEST_CASE("Helmert3: yaw-pitch-roll is Rz * Ry * Rx", "[geometry]") {
  const double yaw = 0.4, pitch = -1.1, roll = 2.5;
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                       .toRotationMatrix();
  const Helmert3 h = Helmert3::from_yaw_pitch_roll(1.0, yaw, pitch, roll, {5, 0, 1});
  CHECK((h.rotation - expected).norm() < 1e-14);
  CHECK((h.translation - Eigen::Vector3d(5, 0, 1)).norm() == 0.0);
}

TEST_CASE("Rotation helpers: axis-angle agrees with Eigen, also near 0 and 180 degrees",
          "[geometry]") {
  diachron::RandomStream random(5);
  for (double angle : {0.0, 1e-12, 1e-7, 0.5, 2.0, kPi - 1e-9, kPi, kPi - 1e-6}) {
    for (int k = 0; k < 10; ++k) {
      const double az = random.normal(), ay = random.normal();
      const Eigen::Vector3d axis = Eigen::Vector3d(random.normal(), ay, az).normalized();
      const Eigen::Matrix3d r = diachron::rotation_from_axis_angle<double>(axis * angle);
      const Eigen::Matrix3d expected = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
      CHECK((r - expected).norm() < 1e-14);
      CHECK(is_rotation(r));
      CHECK(diachron::rotation_angle(r) == Approx(angle).margin(1e-14));
      const Eigen::Vector3d back = diachron::axis_angle_from_rotation(r);
      // At exactly pi the axis sign is ambiguous; the rotation is what must come back.
      CHECK((diachron::rotation_from_axis_angle<double>(back) - r).norm() < 1e-12);
    }
  }
  CHECK(diachron::rotation_distance(Eigen::Matrix3d::Identity(),
                                    diachron::rotation_from_axis_angle<double>({0, 0.3, 0})) ==
        Approx(0.3));
}

TEST_CASE("Rotation helpers: wrap_angle maps into (-pi, pi]", "[geometry]") {
  CHECK(diachron::wrap_angle(kPi) == kPi);
  CHECK(diachron::wrap_angle(-kPi) == kPi);
  CHECK(diachron::wrap_angle(3 * kPi) == Approx(kPi));
  CHECK(diachron::wrap_angle(-kPi + 1e-6) == Approx(-kPi + 1e-6));
  CHECK(diachron::wrap_angle(2 * kPi + 0.25) == Approx(0.25));
  CHECK(diachron::wrap_angle(-7.0) == Approx(-7.0 + 2 * kPi));
  CHECK(std::isnan(diachron::wrap_angle(std::nan(""))));
}

TEST_CASE("Rotation helpers: random rotations are proper, deterministic and spread", "[geometry]") {
  diachron::RandomStream a(42), b(42), c(43);
  Eigen::Vector3d mean_column = Eigen::Vector3d::Zero();
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    const Eigen::Matrix3d ra = diachron::random_rotation(a);
    const Eigen::Matrix3d rb = diachron::random_rotation(b);
    CHECK(is_rotation(ra));
    CHECK((ra - rb).norm() == 0.0);
    mean_column += ra.col(0);
  }
  // Haar measure: the image of a fixed vector is uniform on the sphere, so its mean is ~0.
  CHECK((mean_column / n).norm() < 0.1);
  CHECK((diachron::random_rotation(c) - diachron::random_rotation(a)).norm() > 1e-3);

  diachron::RandomStream small(9);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Matrix3d r = diachron::random_rotation(small, 0.01);
    CHECK(is_rotation(r));
    CHECK(diachron::rotation_angle(r) <= 0.01 + 1e-15);
  }
}

TEST_CASE("Helmert3: Ceres Jet derivatives match finite differences", "[geometry]") {
  using Jet = ceres::Jet<double, 4>;
  // Parameters: scale and the axis-angle vector; translation constant.
  const double p[4] = {1.3, 0.4, -1.2, 2.1};
  const Eigen::Vector3d t(10.0, -5.0, 2.0);
  const Eigen::Vector3d x(4.5, -2.25, 30.0);
  const Helmert3T<Jet> jet_transform = Helmert3T<Jet>::from_axis_angle(
      Jet(p[0], 0), Eigen::Matrix<Jet, 3, 1>(Jet(p[1], 1), Jet(p[2], 2), Jet(p[3], 3)),
      t.cast<Jet>());
  const Eigen::Matrix<Jet, 3, 1> y = jet_transform(x.cast<Jet>());

  auto evaluate = [&](const double* q) {
    return Helmert3::from_axis_angle(q[0], Eigen::Vector3d(q[1], q[2], q[3]), t)(x);
  };
  const double h = 1e-6;
  for (int k = 0; k < 4; ++k) {
    double plus[4] = {p[0], p[1], p[2], p[3]};
    double minus[4] = {p[0], p[1], p[2], p[3]};
    plus[k] += h;
    minus[k] -= h;
    const Eigen::Vector3d numeric = (evaluate(plus) - evaluate(minus)) / (2 * h);
    for (int row = 0; row < 3; ++row) {
      INFO("parameter " << k << ", row " << row);
      CHECK(y(row).v(k) == Approx(numeric(row)).margin(1e-6));
      CHECK(y(row).a == Approx(evaluate(p)(row)));
    }
  }

  // At the identity rotation (first-order branch) the derivative wrt the axis-angle is -[x]_x * s.
  const Helmert3T<Jet> at_identity = Helmert3T<Jet>::from_axis_angle(
      Jet(2.0, 0), Eigen::Matrix<Jet, 3, 1>(Jet(0.0, 1), Jet(0.0, 2), Jet(0.0, 3)),
      Eigen::Matrix<Jet, 3, 1>::Zero());
  const Eigen::Matrix<Jet, 3, 1> y0 = at_identity(x.cast<Jet>());
  // d(R x)/d(w_z) at w = 0 is e_z x x = (-x_y, x_x, 0).
  CHECK(y0(0).v(3) == Approx(-2.0 * x.y()));
  CHECK(y0(1).v(3) == Approx(2.0 * x.x()));
  CHECK(std::isfinite(y0(2).v(1)));

  const Helmert3T<Jet> inv = jet_transform.inverse();
  CHECK(inv.scale.v(0) == Approx(-1.0 / (p[0] * p[0])));
  const Helmert3T<Jet> from_double = Helmert3{}.cast<Jet>();
  CHECK(from_double.scale.a == 1.0);
}
