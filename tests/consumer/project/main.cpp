// An outside project: find_package(diachron), link diachron::core, estimate a Helmert robustly.
// Built against every installed tree the consumer tests make, including one without OpenCV, Ceres
// and GDAL: the Helmert RANSAC needs Eigen and nanoflann only. With CONSUMER_UMBRELLA (the consumer
// of every component) it includes the umbrella header, which must not pull OpenCV, Ceres or GDAL
// either; the other consumers include only what they use, since parsing the umbrella is most of a
// consumer's build and one check of it is enough. This is the umbrella's check: an outside project
// without our precompiled header, so a header it lists that does not stand alone fails here too.
#include <cstdio>
#include <vector>

#ifdef CONSUMER_UMBRELLA
#include <diachron/diachron.hpp>
#else
#include <diachron/core/random.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/robust/robust_estimation.hpp>
#endif

#ifdef CONSUMER_UMBRELLA
// The umbrella exposes the concept models.
static_assert(diachron::is_estimator_v<diachron::Similarity2Estimator>);
static_assert(diachron::is_estimator_v<diachron::Helmert3Estimator>);
#endif

#if defined(CV_VERSION) || defined(CERES_VERSION_STRING) || defined(GDAL_RELEASE_NAME)
#error "the Helmert RANSAC pulled in OpenCV, Ceres or GDAL"
#endif

int main() {
  diachron::RandomStream rng(7);
  const diachron::Helmert3 truth{0.5, diachron::random_rotation(rng), {500000.0, 5000000.0, 100.0}};
  std::vector<diachron::PointPair3> pairs;
  for (int i = 0; i < 200; ++i) {
    // One draw per statement, z before y before x: the order of a call's arguments is unspecified
    // (diachron/core/random.hpp, "Order of draws").
    const double pz = rng.uniform(0, 100), py = rng.uniform(0, 1000);
    const Eigen::Vector3d x(rng.uniform(0, 1000), py, pz);
    Eigen::Vector3d y = truth(x);
    if (i % 4 == 0) {
      const double dz = rng.uniform(-50, 50), dy = rng.uniform(-50, 50);
      y += Eigen::Vector3d(rng.uniform(-50, 50), dy, dz);
    }
    pairs.push_back({x, y});
  }
  diachron::RansacOptions options;
  options.threshold = 0.05;
  const auto report = diachron::ransac_helmert3(pairs, options);
  const double error = (report.model.translation - truth.translation).norm();
  std::printf("success %d, %zu inliers, translation error %.2e\n", report.success, report.inliers.size(), error);
  return report.success && report.inliers.size() >= 150 && error < 1e-6 ? 0 : 1;
}
