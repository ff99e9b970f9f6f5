// The umbrella header compiles on its own, warning-free, and exposes the concept models.
#include <diachron/diachron.hpp>

#include <catch2/catch.hpp>

TEST_CASE("diachron.hpp: the Eigen-only part in one include", "[core]") {
  static_assert(diachron::is_estimator_v<diachron::Similarity2Estimator>);
  static_assert(diachron::is_estimator_v<diachron::Helmert3Estimator>);
  std::vector<diachron::PointPair3> pairs;
  diachron::RandomStream rng(1);
  const diachron::Helmert3 truth{1.5, diachron::random_rotation(rng), {10.0, -20.0, 5.0}};
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d x(rng.uniform(-100, 100), rng.uniform(-100, 100), rng.uniform(0, 50));
    pairs.push_back({x, truth(x)});
  }
  diachron::RansacOptions options;
  options.threshold = 0.01;
  const auto report = diachron::ransac_helmert3(pairs, options);
  REQUIRE(report.success);
  REQUIRE(report.inliers.size() == pairs.size());
  REQUIRE((report.model.translation - truth.translation).norm() < 1e-6);
}
