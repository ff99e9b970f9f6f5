// Tests of local_affine and its decomposition: a known similarity through MapTransfer, an affine
// with anisotropy, a homography's analytic Jacobian, the one-sided fallback, and a DsmTransfer
// between two nadir frames whose scale ratio and rotation are known.
#include <cmath>
#include <optional>

#include <catch2/catch.hpp>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <diachron/core/types.hpp>
#include <diachron/terrain/local_affine.hpp>

#include "terrain/pinhole_test_frame.hpp"

using Eigen::Matrix2d;
using Eigen::Vector2d;
using Eigen::Vector3d;

TEST_CASE("LocalAffine: recovers a similarity's scale and angle", "[terrain]") {
  for (double angle : {0.0, 0.4, -1.2, 2.9, -3.1})
    for (double scale : {0.25, 1.0, 3.7}) {
      const auto transfer = diachron::make_map_transfer([=](const Vector2d& p) {
        return Vector2d(scale * (Eigen::Rotation2Dd(angle) * p) + Vector2d(100.0, -20.0));
      });
      const auto a = diachron::local_affine(transfer, Vector2d(321.0, 123.0));
      REQUIRE(a);
      const auto d = diachron::decompose_affine(*a);
      CHECK(d.scale == Approx(scale).epsilon(1e-12));
      CHECK(d.sigma_max == Approx(scale).epsilon(1e-12));
      CHECK(d.sigma_min == Approx(scale).epsilon(1e-12));
      CHECK(d.rotation == Approx(angle).margin(1e-12));
      CHECK_FALSE(d.reflection);
      CHECK(diachron::affine_scale(*a) == Approx(scale).epsilon(1e-12));
      CHECK(diachron::affine_rotation(*a) == Approx(angle).margin(1e-12));
    }
}

TEST_CASE("LocalAffine: singular values of an anisotropic affine and a reflection", "[terrain]") {
  Matrix2d A;
  A << 2.0, 0.5, -0.3, 0.8;
  const auto transfer = diachron::make_map_transfer([A](const Vector2d& p) { return Vector2d(A * p); });
  const auto a = diachron::local_affine(transfer, Vector2d(5.0, 7.0), 2.5);
  REQUIRE(a);
  CHECK((*a - A).norm() < 1e-12);
  const Eigen::JacobiSVD<Matrix2d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vector2d sv = diachron::affine_singular_values(A);
  CHECK(sv.x() == Approx(svd.singularValues()(0)).epsilon(1e-12));
  CHECK(sv.y() == Approx(svd.singularValues()(1)).epsilon(1e-12));
  CHECK(diachron::affine_scale(A) == Approx(std::sqrt(A.determinant())));
  // Polar rotation: A = R S with S symmetric positive definite.
  const Matrix2d R = svd.matrixU() * svd.matrixV().transpose();
  CHECK(diachron::affine_rotation(A) == Approx(std::atan2(R(1, 0), R(0, 0))).margin(1e-12));

  Matrix2d mirror;  // rotate by 0.5 after flipping y
  mirror = Eigen::Rotation2Dd(0.5).toRotationMatrix() * Eigen::Vector2d(1.0, -1.0).asDiagonal();
  const auto dm = diachron::decompose_affine(2.0 * mirror);
  CHECK(dm.reflection);
  CHECK(dm.scale == Approx(2.0));
  CHECK(dm.rotation == Approx(0.5));
}

TEST_CASE("LocalAffine: homography Jacobian, one-sided fallback and failures", "[terrain]") {
  Eigen::Matrix3d H;
  H << 1.1, 0.2, 5.0, -0.1, 0.9, 3.0, 1e-4, -2e-4, 1.0;
  const auto map = [H](const Vector2d& p) -> std::optional<Vector2d> {
    if (p.x() < 0.0) return std::nullopt;  // a domain edge
    const Vector3d x = H * p.homogeneous();
    return Vector2d(x.head<2>() / x.z());
  };
  const auto transfer = diachron::make_map_transfer(map);
  const auto jacobian = [&H](const Vector2d& q) {  // analytic Jacobian of the homography
    const Vector3d x = H * q.homogeneous();
    Matrix2d J;
    for (int c = 0; c < 2; ++c)
      for (int r = 0; r < 2; ++r) J(r, c) = (H(r, c) * x.z() - x(r) * H(2, c)) / (x.z() * x.z());
    return J;
  };
  const Vector2d p(200.0, 150.0);
  const auto a = diachron::local_affine(transfer, p, 0.5);
  REQUIRE(a);
  CHECK((*a - jacobian(p)).norm() < 1e-7);
  // At x = 0 the left neighbour does not transfer: the x column is a forward difference.
  const auto edge = diachron::local_affine(transfer, Vector2d(0.0, 150.0), 1e-3);
  REQUIRE(edge);
  CHECK((*edge - jacobian(Vector2d(0.0, 150.0))).norm() < 1e-5);
  // Nothing transfers: nullopt. A bad step: an error.
  CHECK_FALSE(diachron::local_affine(transfer, Vector2d(-10.0, 0.0)));
  CHECK_THROWS_AS(diachron::local_affine(transfer, p, 0.0), diachron::Error);
}

TEST_CASE("LocalAffine: DsmTransfer between two nadir frames predicts scale and rotation", "[terrain]") {
  diachron::Raster<float> z(400, 400, 50.0f);
  const diachron::Dsm dsm(z, diachron::GeoTransform::north_up(0.0, 800.0, 2.0));
  const auto master = diachron::test::make_frame(Vector3d(400.0, 400.0, 1050.0), 1000.0);
  for (double roll : {0.0, 0.5, -2.0, 3.0}) {
    // Higher by a factor 2 above the ground, and turned about the optical axis by `roll`.
    const auto secondary = diachron::test::make_frame(Vector3d(420.0, 380.0, 2050.0), 1000.0, roll);
    const auto transfer = diachron::make_dsm_transfer(master, dsm, secondary);
    const auto a = diachron::local_affine(transfer, Vector2d(450.0, 530.0));
    REQUIRE(a);
    const auto d = diachron::decompose_affine(*a);
    CHECK(d.scale == Approx(0.5).epsilon(1e-9));
    CHECK(d.sigma_max / d.sigma_min == Approx(1.0).epsilon(1e-9));
    CHECK(d.rotation == Approx(roll).margin(1e-9));
  }
}
