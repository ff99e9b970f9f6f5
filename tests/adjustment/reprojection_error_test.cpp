// Reprojection cost functors: values equal Camera::project / Frame::project, Jet derivatives equal
// central numeric differences, the block helpers round-trip, bad arguments throw.

#include <array>
#include <cmath>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <ceres/cost_function.h>

#include <diachron/adjustment/reprojection_error.hpp>
#include <diachron/camera/camera.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>

#include "adjustment/catch_ceres.hpp"  // last: gives CHECK back to Catch after glog

using namespace diachron;

namespace {

Camera<FraserAffine> test_camera() {
  return Camera<FraserAffine>(265.0, 201.0, 147.5, 400, 300, {-0.025, 0.004, 0.001, 2e-4, -1.5e-4, 0.4, -0.2});
}

// A nadir camera (rotation near a half-turn, where angle-axis must still behave) 520 m up.
Pose test_pose() { return Pose::from_yaw_pitch_roll(Vec3(10.0, -20.0, 520.0), 0.3, 0.02, -0.03); }

// Central differences of a cost function with respect to every parameter, one residual pair.
std::vector<Eigen::Matrix<double, 2, Eigen::Dynamic>> numeric_jacobians(const ceres::CostFunction& cost,
                                                                        std::vector<std::vector<double>> blocks) {
  std::vector<Eigen::Matrix<double, 2, Eigen::Dynamic>> out;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    Eigen::Matrix<double, 2, Eigen::Dynamic> j(2, static_cast<int>(blocks[b].size()));
    for (std::size_t k = 0; k < blocks[b].size(); ++k) {
      const double x = blocks[b][k];
      const double h = 1e-6 * std::max(1.0, std::abs(x));
      double plus[2], minus[2];
      std::vector<const double*> ptrs;
      blocks[b][k] = x + h;
      for (const auto& v : blocks) ptrs.push_back(v.data());
      REQUIRE(cost.Evaluate(ptrs.data(), plus, nullptr));
      blocks[b][k] = x - h;
      ptrs.clear();
      for (const auto& v : blocks) ptrs.push_back(v.data());
      REQUIRE(cost.Evaluate(ptrs.data(), minus, nullptr));
      blocks[b][k] = x;
      j(0, static_cast<int>(k)) = (plus[0] - minus[0]) / (2.0 * h);
      j(1, static_cast<int>(k)) = (plus[1] - minus[1]) / (2.0 * h);
    }
    out.push_back(j);
  }
  return out;
}

// Residuals and analytic (Jet) Jacobians of a cost function, checked against numeric ones.
void check_jacobians(const ceres::CostFunction& cost, const std::vector<std::vector<double>>& blocks) {
  std::vector<const double*> ptrs;
  std::vector<std::vector<double>> jac(blocks.size());
  std::vector<double*> jac_ptrs;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    ptrs.push_back(blocks[b].data());
    jac[b].resize(2 * blocks[b].size());
    jac_ptrs.push_back(jac[b].data());
  }
  double residuals[2];
  REQUIRE(cost.Evaluate(ptrs.data(), residuals, jac_ptrs.data()));
  const auto numeric = numeric_jacobians(cost, blocks);
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const int n = static_cast<int>(blocks[b].size());
    for (int r = 0; r < 2; ++r)
      for (int k = 0; k < n; ++k) {
        const double analytic = jac[b][static_cast<std::size_t>(r * n + k)];
        const double expected = numeric[b](r, k);
        INFO("block " << b << " row " << r << " column " << k);
        CHECK(analytic == Approx(expected).epsilon(1e-5).margin(1e-6 * (1.0 + std::abs(expected))));
      }
  }
}

}  // namespace

TEST_CASE("ReprojectionError: residual is the Frame::project error divided by sigma", "[adjustment]") {
  const Camera<FraserAffine> camera = test_camera();
  const Pose pose = test_pose();
  const Frame<FraserAffine> frame(camera, pose);
  const Vec3 point(60.0, 15.0, 12.0);
  const Vec2 truth = *frame.project(point);
  const Vec2 observed = truth + Vec2(0.7, -1.1);

  const std::array<double, 6> pose_values = pose_block(pose);
  const auto intrinsics = camera.intrinsics();
  std::unique_ptr<ceres::CostFunction> cost(ReprojectionError<FraserAffine>::create(observed, 0.5));
  const double* blocks[] = {intrinsics.data(), pose_values.data(), point.data()};
  double residuals[2];
  REQUIRE(cost->Evaluate(blocks, residuals, nullptr));
  CHECK(residuals[0] == Approx(-0.7 / 0.5).margin(1e-9));
  CHECK(residuals[1] == Approx(1.1 / 0.5).margin(1e-9));

  // The split form gives the same residual.
  const auto cam8 = fraser_camera_block(camera);
  const auto affine = affine_block(camera);
  std::unique_ptr<ceres::CostFunction> split(SplitAffineReprojectionError::create(observed, 0.5));
  const double* split_blocks[] = {cam8.data(), affine.data(), pose_values.data(), point.data()};
  double split_residuals[2];
  REQUIRE(split->Evaluate(split_blocks, split_residuals, nullptr));
  CHECK(split_residuals[0] == Approx(residuals[0]).margin(1e-12));
  CHECK(split_residuals[1] == Approx(residuals[1]).margin(1e-12));

  // A weight multiplies the pixel difference before the sigma divides it.
  Eigen::Matrix2d weight;
  weight << 2.0, 0.5, -0.25, 0.75;
  std::unique_ptr<ceres::CostFunction> weighted(SplitAffineReprojectionError::create(observed, 0.5, weight));
  double weighted_residuals[2];
  REQUIRE(weighted->Evaluate(split_blocks, weighted_residuals, nullptr));
  const Eigen::Vector2d expected = weight * Eigen::Vector2d(-0.7, 1.1) / 0.5;
  CHECK(weighted_residuals[0] == Approx(expected.x()).margin(1e-9));
  CHECK(weighted_residuals[1] == Approx(expected.y()).margin(1e-9));
}

TEST_CASE("ReprojectionError: Jet derivatives equal numeric differentiation", "[adjustment]") {
  const Camera<FraserAffine> camera = test_camera();
  const Pose pose = test_pose();
  const std::array<double, 6> p = pose_block(pose);
  const std::vector<double> pose_values(p.begin(), p.end());
  const std::vector<double> point = {-40.0, 35.0, 8.0};
  const Vec2 observed(150.0, 90.0);

  SECTION("one intrinsics block, FraserAffine") {
    const auto i = camera.intrinsics();
    std::unique_ptr<ceres::CostFunction> cost(ReprojectionError<FraserAffine>::create(observed, 1.0));
    check_jacobians(*cost, {std::vector<double>(i.begin(), i.end()), pose_values, point});
  }
  SECTION("one intrinsics block, RadialK3") {
    const std::vector<double> i = {265.0, 201.0, 147.5, -0.02, 0.003, 0.0005};
    std::unique_ptr<ceres::CostFunction> cost(ReprojectionError<RadialK3>::create(observed, 2.0));
    check_jacobians(*cost, {i, pose_values, point});
  }
  SECTION("split camera and affine blocks") {
    const auto c = fraser_camera_block(camera);
    const auto a = affine_block(camera);
    std::unique_ptr<ceres::CostFunction> cost(SplitAffineReprojectionError::create(observed, 1.0));
    check_jacobians(*cost, {std::vector<double>(c.begin(), c.end()), std::vector<double>(a.begin(), a.end()),
                            pose_values, point});
  }
  SECTION("split blocks with an anisotropic weight") {
    const auto c = fraser_camera_block(camera);
    const auto a = affine_block(camera);
    Eigen::Matrix2d weight;
    weight << 1.5, 0.4, 0.4, 0.3;
    std::unique_ptr<ceres::CostFunction> cost(SplitAffineReprojectionError::create(observed, 2.0, weight));
    check_jacobians(*cost, {std::vector<double>(c.begin(), c.end()), std::vector<double>(a.begin(), a.end()),
                            pose_values, point});
  }
}

TEST_CASE("ReprojectionError: pose and camera blocks round-trip", "[adjustment]") {
  for (const Pose& pose : {test_pose(), Pose(), Pose::look_at(Vec3(0, 0, 100), Vec3(5, 3, 0))}) {
    const std::array<double, 6> block = pose_block(pose);
    const Pose back = pose_from_block(block.data());
    CHECK((back.cam_from_world_rotation() - pose.cam_from_world_rotation()).cwiseAbs().maxCoeff() < 1e-12);
    CHECK((back.centre() - pose.centre()).norm() < 1e-12);
  }
  const Camera<FraserAffine> camera = test_camera();
  const auto c = fraser_camera_block(camera);
  const auto a = affine_block(camera);
  const Camera<FraserAffine> back = camera_from_blocks(c.data(), a.data(), 400, 300);
  CHECK(back.intrinsics() == camera.intrinsics());
}

TEST_CASE("ReprojectionError: a point behind the camera fails evaluation, bad input throws", "[adjustment]") {
  const Camera<FraserAffine> camera = test_camera();
  const auto i = camera.intrinsics();
  const auto p = pose_block(test_pose());
  const Vec3 above(0.0, 0.0, 900.0);  // above a nadir camera flying at 520 m
  std::unique_ptr<ceres::CostFunction> cost(ReprojectionError<FraserAffine>::create(Vec2(1, 2)));
  const double* blocks[] = {i.data(), p.data(), above.data()};
  double residuals[2];
  CHECK_FALSE(cost->Evaluate(blocks, residuals, nullptr));
  CHECK_THROWS_AS(ReprojectionError<FraserAffine>::create(Vec2(1, 2), 0.0), Error);
  CHECK_THROWS_AS(SplitAffineReprojectionError::create(Vec2(NAN, 2), 1.0), Error);
  CHECK_THROWS_AS(SplitAffineReprojectionError::create(Vec2(1, 2), 1.0, Eigen::Matrix2d::Zero()), Error);
  CHECK_THROWS_AS(SplitAffineReprojectionError::create(Vec2(1, 2), 1.0, Eigen::Matrix2d::Constant(NAN)), Error);
}
