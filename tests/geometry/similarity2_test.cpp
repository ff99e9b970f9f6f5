// Tests for Similarity2T: mapping, inverse, composition, cast and Ceres Jet derivatives.

#include <cmath>
#include <vector>

#include <ceres/jet.h>
#include <Eigen/Core>
#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/similarity2.hpp>

using diachron::kPi;
using diachron::Similarity2;
using diachron::Similarity2T;

namespace {

const std::vector<double> kSimilarityAngles = {0.0, 0.3,         -2.0, kPi / 2, kPi - 1e-9,
                                     kPi, -kPi + 1e-6, 3.0,  -3.1};

}  // namespace

TEST_CASE("Similarity2: maps a point as scale * R * x + t", "[geometry]") {
  const Similarity2 b_from_a{/*scale=*/2.0, /*angle=*/kPi / 2, /*translation=*/{1.0, 2.0}};
  const Eigen::Vector2d x = b_from_a(Eigen::Vector2d(1.0, 0.0));
  CHECK(x.x() == Approx(1.0).margin(1e-15));
  CHECK(x.y() == Approx(4.0));
  const Eigen::Vector2d y = b_from_a(Eigen::Vector2d(0.0, 3.0));
  CHECK(y.x() == Approx(-5.0));
  CHECK(y.y() == Approx(2.0).margin(1e-15));

  // Agrees with the homogeneous matrix and with linear().
  const Eigen::Vector2d p(-3.5, 7.25);
  const Eigen::Vector3d h = b_from_a.matrix() * p.homogeneous();
  CHECK((h.head<2>() - b_from_a(p)).norm() < 1e-13);
  CHECK((b_from_a.linear() * p + b_from_a.translation - b_from_a(p)).norm() < 1e-13);
  CHECK(b_from_a.rotation().determinant() == Approx(1.0));

  const Similarity2 id = Similarity2::identity();
  CHECK((id(p) - p).norm() == 0.0);
  const Similarity2 defaulted;
  CHECK((defaulted(p) - p).norm() == 0.0);
}

TEST_CASE("Similarity2: inverse undoes the transform, also near 180 degrees", "[geometry]") {
  diachron::RandomStream random(7);
  for (double angle : kSimilarityAngles) {
    for (double scale : {0.01, 0.5, 1.0, 3.0, 100.0}) {
      const Similarity2 b_from_a{
          scale, angle, {random.uniform(-100, 100), random.uniform(-100, 100)}};
      const Similarity2 a_from_b = b_from_a.inverse();
      CHECK(a_from_b.scale == Approx(1.0 / scale));
      CHECK(a_from_b.angle > -kPi);
      CHECK(a_from_b.angle <= kPi);
      for (int k = 0; k < 5; ++k) {
        // One draw per statement, y before x: the order of a call's arguments is unspecified
        // (core/random.hpp, "Order of draws"); this is the order the tests were written with.
        const double xy = random.uniform(-50, 50);
        const Eigen::Vector2d x(random.uniform(-50, 50), xy);
        CHECK((a_from_b(b_from_a(x)) - x).norm() < 1e-9 * (1.0 + x.norm()));
        CHECK(((b_from_a * a_from_b)(x)-x).norm() < 1e-9 * (1.0 + x.norm()) * scale);
      }
    }
  }
  // The inverse of a rotation by pi is a rotation by pi, not by -pi (angles stay in (-pi, pi]).
  CHECK(Similarity2{1.0, kPi, {0.0, 0.0}}.inverse().angle == kPi);
  CHECK_THROWS_AS((Similarity2{0.0, 0.0, {0.0, 0.0}}.inverse()), diachron::Error);
}

TEST_CASE("Similarity2: composition applies the right operand first", "[geometry]") {
  diachron::RandomStream random(11);
  for (double angle_a : kSimilarityAngles) {
    for (double angle_b : kSimilarityAngles) {
      const Similarity2 c_from_b{
          random.uniform(0.1, 10), angle_a, {random.uniform(-10, 10), random.uniform(-10, 10)}};
      const Similarity2 b_from_a{
          random.uniform(0.1, 10), angle_b, {random.uniform(-10, 10), random.uniform(-10, 10)}};
      const Similarity2 c_from_a = c_from_b * b_from_a;
      CHECK(c_from_a.angle > -kPi);
      CHECK(c_from_a.angle <= kPi);
      CHECK(c_from_a.scale == Approx(c_from_b.scale * b_from_a.scale));
      const double xy = random.uniform(-10, 10);
      const Eigen::Vector2d x(random.uniform(-10, 10), xy);
      const Eigen::Vector2d expected = c_from_b(b_from_a(x));
      CHECK((c_from_a(x) - expected).norm() < 1e-10 * (1.0 + expected.norm()));
      // Matrix form agrees: composition is matrix product.
      CHECK((c_from_a.matrix() - c_from_b.matrix() * b_from_a.matrix()).norm() < 1e-10 * 100.0);
    }
  }
}

TEST_CASE("Similarity2: cast keeps the transform", "[geometry]") {
  const Similarity2 b_from_a{1.5, -0.7, {3.0, -4.0}};
  const Similarity2T<float> as_float = b_from_a.cast<float>();
  const Eigen::Vector2f xf = as_float(Eigen::Vector2f(2.0f, 5.0f));
  const Eigen::Vector2d xd = b_from_a(Eigen::Vector2d(2.0, 5.0));
  CHECK((xf.cast<double>() - xd).norm() < 1e-5);
  const Similarity2 back = as_float.cast<double>();
  CHECK(back.angle == Approx(-0.7).epsilon(1e-6));
}

TEST_CASE("Similarity2: Ceres Jet derivatives match finite differences", "[geometry]") {
  using Jet = ceres::Jet<double, 4>;
  // Parameters: scale, angle, tx, ty; the Jet carries d/d(parameter).
  const double p[4] = {1.7, 2.9, -3.0, 12.0};
  const Eigen::Vector2d x(4.5, -2.25);
  const Similarity2T<Jet> jet_transform{Jet(p[0], 0), Jet(p[1], 1),
                                        Eigen::Matrix<Jet, 2, 1>(Jet(p[2], 2), Jet(p[3], 3))};
  const Eigen::Matrix<Jet, 2, 1> y = jet_transform(x.cast<Jet>());

  auto evaluate = [&x](const double* q) { return Similarity2{q[0], q[1], {q[2], q[3]}}(x); };
  const double h = 1e-6;
  for (int k = 0; k < 4; ++k) {
    double plus[4] = {p[0], p[1], p[2], p[3]};
    double minus[4] = {p[0], p[1], p[2], p[3]};
    plus[k] += h;
    minus[k] -= h;
    const Eigen::Vector2d numeric = (evaluate(plus) - evaluate(minus)) / (2 * h);
    INFO("parameter " << k);
    CHECK(y(0).v(k) == Approx(numeric(0)).margin(1e-7));
    CHECK(y(1).v(k) == Approx(numeric(1)).margin(1e-7));
  }
  CHECK(y(0).a == Approx(evaluate(p)(0)));

  // inverse and composition are differentiable too: d(scale of inverse)/d(scale) = -1/s^2.
  const Similarity2T<Jet> inv = jet_transform.inverse();
  CHECK(inv.scale.v(0) == Approx(-1.0 / (p[0] * p[0])));
  const Similarity2T<Jet> twice = jet_transform * jet_transform;
  CHECK(twice.scale.v(0) == Approx(2.0 * p[0]));
  // 2.9 + 2.9 wraps past pi; the derivative of the angle is still 2.
  CHECK(twice.angle.a == Approx(2 * 2.9 - 2 * kPi));
  CHECK(twice.angle.v(1) == Approx(2.0));
  const Similarity2T<Jet> from_double = Similarity2{p[0], p[1], {p[2], p[3]}}.cast<Jet>();
  CHECK(from_double(x.cast<Jet>())(0).a == Approx(y(0).a));
}
