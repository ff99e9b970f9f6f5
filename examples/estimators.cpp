// Composing RANSAC from policies: the paper's configuration against the library's default.
//
// Builds noisy 2D point pairs related by a known similarity (the rough co-registration's model)
// and 3D pairs related by a known Helmert (the precise matching's), buries them in outliers, and
// runs two compositions of diachron::Ransac on each:
//   paper:   UniformSampler + InlierCount + FixedIterations (1000) + NoLocalOptimization, every
//            hypothesis compared exactly (bail_out_risk = 0)
//   default: UniformSampler + Msac (exact early exit and the bail-out test) + Adaptive + Refit
// and prints what each found: model error at the scene corners, true inliers recovered,
// iterations, passes over the data, and time. docs/concepts.md explains the policies and how to
// plug in a new model.
//
// Usage: estimators [outlier_ratio=0.8] [num_inliers=500] [seed=1], each parsed strictly (CLI11);
// exit status 2 on a bad argument.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Core>

#include "program_support.hpp"

#include <diachron/core/random.hpp>
#include <diachron/robust/robust_estimation.hpp>

namespace {

constexpr double kExtent = 1000.0;  // scene size: pixels (2D) or metres (3D)
constexpr double kSigma = 2.0;      // noise standard deviation per axis, same units

struct Scene2 {
  diachron::Similarity2 truth{0.7, 2.5, Eigen::Vector2d(300.0, -150.0)};
  std::vector<diachron::PointPair2> pairs;  // inliers first
};

Scene2 make_scene2(std::size_t inliers, std::size_t outliers, std::uint64_t seed) {
  Scene2 scene;
  diachron::RandomStream rng(seed, 2);
  for (std::size_t i = 0; i < inliers + outliers; ++i) {
    // One draw per statement, y before x: the order of a call's arguments is unspecified, and
    // compilers differ (core/random.hpp, "Order of draws").
    const double sy = rng.uniform(0, kExtent), sx = rng.uniform(0, kExtent);
    const Eigen::Vector2d source(sx, sy);
    Eigen::Vector2d target;
    if (i < inliers) {
      const double ny = rng.normal(0, kSigma), nx = rng.normal(0, kSigma);
      target = scene.truth(source) + Eigen::Vector2d(nx, ny);
    } else {
      const double ty = rng.uniform(-700, 600), tx = rng.uniform(-500, 800);
      target = Eigen::Vector2d(tx, ty);
    }
    scene.pairs.push_back({source, target});
  }
  return scene;
}

struct Scene3 {
  diachron::Helmert3 truth = diachron::Helmert3::from_axis_angle(
      1.02, Eigen::Vector3d(0.01, 0.02, -0.4), Eigen::Vector3d(120.0, 80.0, -15.0));
  std::vector<diachron::PointPair3> pairs;  // inliers first
};

Scene3 make_scene3(std::size_t inliers, std::size_t outliers, std::uint64_t seed) {
  Scene3 scene;
  diachron::RandomStream rng(seed, 3);
  for (std::size_t i = 0; i < inliers + outliers; ++i) {
    // z, y, x: as above.
    const double sz = rng.uniform(0, 150), sy = rng.uniform(0, kExtent), sx = rng.uniform(0, kExtent);
    const Eigen::Vector3d source(sx, sy, sz);
    const double nz = rng.normal(0, kSigma), ny = rng.normal(0, kSigma), nx = rng.normal(0, kSigma);
    const Eigen::Vector3d noise(nx, ny, nz);
    Eigen::Vector3d target = scene.truth(source) + noise;
    if (i >= inliers) {
      const double tz = rng.uniform(-100, 250), ty = rng.uniform(0, 1500), tx = rng.uniform(-200, 1400);
      target = Eigen::Vector3d(tx, ty, tz);
    }
    scene.pairs.push_back({source, target});
  }
  return scene;
}

// Largest displacement between the estimate and the truth over the scene's corners.
template <class Model, class Point>
double corner_error(const Model& estimate, const Model& truth, const std::vector<Point>& corners) {
  double worst = 0.0;
  for (const auto& c : corners) worst = std::max(worst, (estimate(c) - truth(c)).norm());
  return worst;
}

template <class Ransac, class Data, class Model, class Point>
void run(const char* name, const Ransac& ransac, const Data& data, const Model& truth,
         std::size_t true_inliers, const std::vector<Point>& corners) {
  const auto start = std::chrono::steady_clock::now();
  const auto report = ransac.run(data);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!report.success) {
    std::printf("  %-8s failed: %s (%zu iterations, %.2f ms)\n", name, report.message.c_str(),
                report.iterations, ms);
    return;
  }
  const auto found = static_cast<std::size_t>(
      std::count_if(report.inliers.begin(), report.inliers.end(),
                    [&](std::size_t i) { return i < true_inliers; }));
  std::printf(
      "  %-8s corner error %7.3f | inliers %5zu (true %5zu of %zu) | rms %6.3f | iterations %5zu |"
      " best %2zu LO %2zu | bailed out %4zu | passes %7.1f | %8.3f ms\n",
      name, corner_error(report.model, truth, corners), report.inliers.size(), found, true_inliers,
      report.rms, report.iterations, report.best_updates, report.local_optimizations,
      report.hypotheses_bailed_out, report.data_passes(), ms);
}

}  // namespace

int main(int argc, char** argv) {
  using diachron::programs::strict_number;
  double outlier_ratio = 0.8;
  std::size_t inliers = 500;
  std::uint64_t seed = 1;
  CLI::App app{
      "estimators: the paper's RANSAC composition and the library's default side by side, on noisy 2D\n"
      "(similarity) and 3D (Helmert) point pairs buried in outliers (docs/concepts.md). Exit status 2 on a\n"
      "bad argument.\n",
      "estimators"};
  app.add_option("outlier_ratio", outlier_ratio, "share of outliers among all pairs, in [0, 1) (default 0.8)")
      ->check(strict_number<double>(0.0, std::nextafter(1.0, 0.0), "a share in [0, 1)"));
  // A bound on the count keeps the scene in memory: ten million inliers and their outliers.
  app.add_option("num_inliers", inliers, "inlier pairs, at least 3 (default 500)")
      ->check(strict_number<std::size_t>(3, 10000000, "a count in [3, 10000000]"));
  app.add_option("seed", seed, "random seed (default 1)")
      ->check(strict_number<std::uint64_t>(0, std::numeric_limits<std::uint64_t>::max(), "a whole number >= 0"));
  if (const std::optional<int> status = diachron::programs::parse_options(app, argc, argv, 2)) return *status;
  // The outliers the ratio asks for, bounded as the inliers are (a ratio near 1 asks for billions).
  const double wanted = static_cast<double>(inliers) * outlier_ratio / (1.0 - outlier_ratio);
  if (!(wanted <= 1e7)) {
    std::fprintf(stderr, "estimators: outlier_ratio %.9g with %zu inliers asks for %.3g outliers, at most 1e7: give a "
                         "smaller ratio or fewer inliers\n", outlier_ratio, inliers, wanted);
    return 2;
  }
  const auto outliers = static_cast<std::size_t>(wanted);

  diachron::RansacOptions options;
  options.threshold = 3.0 * kSigma;
  options.seed = seed;
  std::printf("%zu inliers (noise sigma %.1f per axis), %zu outliers (%.0f %%), threshold %.1f\n",
              inliers, kSigma, outliers, 100.0 * outlier_ratio, options.threshold);

  // The paper compares every hypothesis exactly: no bail-out test for its composition.
  diachron::RansacOptions paper = options;
  paper.bail_out_risk = 0.0;

  const Scene2 scene2 = make_scene2(inliers, outliers, seed);
  const std::vector<Eigen::Vector2d> corners2{{0, 0}, {kExtent, 0}, {0, kExtent}, {kExtent, kExtent}};
  std::printf("2D similarity (2-point samples):\n");
  run("paper", diachron::PaperRansac<diachron::Similarity2Estimator>(paper), scene2.pairs,
      scene2.truth, inliers, corners2);
  run("default", diachron::DefaultRansac<diachron::Similarity2Estimator>(options), scene2.pairs,
      scene2.truth, inliers, corners2);

  const Scene3 scene3 = make_scene3(inliers, outliers, seed);
  std::vector<Eigen::Vector3d> corners3;
  for (double x : {0.0, kExtent})
    for (double y : {0.0, kExtent})
      for (double z : {0.0, 150.0}) corners3.emplace_back(x, y, z);
  std::printf("3D Helmert (3-point samples; the adaptive rule may need more than 1000 draws):\n");
  run("paper", diachron::PaperRansac<diachron::Helmert3Estimator>(paper), scene3.pairs,
      scene3.truth, inliers, corners3);
  run("default", diachron::DefaultRansac<diachron::Helmert3Estimator>(options), scene3.pairs,
      scene3.truth, inliers, corners3);
  diachron::RansacOptions uncapped = options;
  uncapped.max_iterations = 100000;
  run("uncapped", diachron::DefaultRansac<diachron::Helmert3Estimator>(uncapped), scene3.pairs,
      scene3.truth, inliers, corners3);
  return 0;
}
