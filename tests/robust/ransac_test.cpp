#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/robust/prosac_sampler.hpp>
#include <diachron/robust/ransac.hpp>

#include "robust/test_estimators.hpp"

using diachron::Ransac;
using diachron::RansacOptions;
using diachron_test::LineEstimator;
using diachron_test::MeanEstimator;

namespace {

static_assert(diachron::is_estimator_v<MeanEstimator>, "the archetype is an Estimator");
static_assert(!diachron::estimator_has_refine_v<MeanEstimator>, "the archetype has no refine");
static_assert(!diachron::estimator_has_degenerate_v<MeanEstimator>,
              "the archetype has no degenerate");
static_assert(diachron::estimator_has_refine_v<LineEstimator>, "LineEstimator refines");

RansacOptions line_options(std::uint64_t seed = 0) {
  RansacOptions options;
  options.threshold = 3.0;  // 3 sigma for the unit noise of make_line_data
  options.seed = seed;
  return options;
}

template <class Model, class Equal>
void require_same_report(const diachron::RansacReport<Model>& a,
                         const diachron::RansacReport<Model>& b, Equal model_equal) {
  REQUIRE(a.success == b.success);
  REQUIRE(a.message == b.message);
  REQUIRE(model_equal(a.model, b.model));
  REQUIRE(a.inliers == b.inliers);
  REQUIRE(a.inlier_mask == b.inlier_mask);
  REQUIRE(a.score == b.score);
  REQUIRE(a.rms == b.rms);
  REQUIRE(a.iterations == b.iterations);
  REQUIRE(a.hypotheses_generated == b.hypotheses_generated);
  REQUIRE(a.hypotheses_stopped_early == b.hypotheses_stopped_early);
  REQUIRE(a.degenerate_samples == b.degenerate_samples);
  REQUIRE(a.best_updates == b.best_updates);
  REQUIRE(a.local_optimizations == b.local_optimizations);
  REQUIRE(a.local_optimization_improvements == b.local_optimization_improvements);
  REQUIRE(a.final_refit == b.final_refit);
  REQUIRE(a.residual_evaluations == b.residual_evaluations);
}

bool same_line(const diachron_test::Line& a, const diachron_test::Line& b) {
  return a.normal == b.normal && a.offset == b.offset;
}

std::size_t count_true_inliers_found(const std::vector<std::size_t>& inliers,
                                     std::size_t true_inliers) {
  std::size_t found = 0;
  for (std::size_t i : inliers) found += i < true_inliers ? 1 : 0;
  return found;
}

}  // namespace

TEST_CASE("Ransac: EstimateRobust, line under 1 % noise and 10/50/90 % outliers", "[robust]") {
  // 200 inliers on a line over [0, 100] with sigma = 1 (1 % of the extent), threshold 3 sigma.
  // Tolerance on the fitted line: its largest vertical deviation at either end of [0, 100]. The
  // least-squares line from the 200 true inliers alone has an end-point standard error of
  // sigma * sqrt(1/n + 50^2 / (n * 100^2 / 12)) = 0.14. Outliers that fall inside the +-3.35
  // vertical band are inliers to any method (about 1 %, 7 % and 120 points, 60 % of the inliers,
  // at 10, 50 and 90 %); they are uniform across the band (sd 1.9 sigma), which about doubles the
  // standard error at 90 %. Tolerances: 0.75 (five standard errors) up to 50 %, 1.5 at 90 %.
  // A wrong model is off by tens.
  const std::size_t inliers = 200;
  for (const double outlier_ratio : {0.1, 0.5, 0.9}) {
    const auto outliers = static_cast<std::size_t>(
        std::lround(inliers * outlier_ratio / (1.0 - outlier_ratio)));
    for (std::uint64_t seed : {1u, 2u, 3u}) {
      const auto data = diachron_test::make_line_data(inliers, outliers, /*sigma=*/1.0, seed);
      const Ransac<LineEstimator> ransac(line_options(seed));
      const auto report = ransac.run(data);
      INFO("outliers " << outlier_ratio << " seed " << seed << " iterations " << report.iterations
                       << " passes " << report.data_passes());
      REQUIRE(report.success);
      REQUIRE(report.message.empty());
      CHECK(diachron_test::line_error(report.model) < (outlier_ratio < 0.6 ? 0.75 : 1.5));
      CHECK(count_true_inliers_found(report.inliers, inliers) >= 0.95 * inliers);
      CHECK(report.rms <= 3.0);
      CHECK(report.final_refit);
      CHECK(report.inlier_mask.size() == data.size());
      CHECK(report.iterations < 1000);  // the adaptive rule stopped before the cap
    }
  }
}

TEST_CASE("Ransac: Nominal, exact data give the exact line and every point", "[robust]") {
  const auto data = diachron_test::make_line_data(50, 0, /*sigma=*/0.0, 7);
  const Ransac<LineEstimator> ransac(line_options());
  const auto report = ransac.run(data);
  REQUIRE(report.success);
  CHECK(report.inliers.size() == 50);
  CHECK(diachron_test::line_error(report.model) < 1e-9);
  CHECK(report.rms < 1e-9);
  CHECK(report.iterations == 1);  // every sample is all-inlier: p = 1
  CHECK(report.score == Approx(50.0));
}

TEST_CASE("Ransac: report counters add up", "[robust]") {
  const auto data = diachron_test::make_line_data(100, 100, 1.0, 5);
  const Ransac<LineEstimator> ransac(line_options());
  const auto report = ransac.run(data);
  REQUIRE(report.success);
  CHECK(report.num_data == 200);
  CHECK(report.hypotheses_generated == report.iterations);  // no degenerate samples here
  CHECK(report.local_optimizations >= 1);
  CHECK(report.local_optimizations == report.best_updates);  // Refit works on every new best
  CHECK(report.local_optimization_improvements <= report.local_optimizations);
  // At least the inlier mask pass; at most a full pass per hypothesis plus LO and the final steps.
  CHECK(report.residual_evaluations >= data.size());
  CHECK(report.data_passes() < report.iterations + 40.0);
  std::size_t mask_count = 0;
  for (char c : report.inlier_mask) mask_count += c ? 1 : 0;
  CHECK(mask_count == report.inliers.size());
}

TEST_CASE("Ransac: deterministic for a seed, whatever the thread count", "[robust]") {
  const auto data = diachron_test::make_line_data(150, 350, 1.0, 11);
  auto options = line_options(42);
  const auto reference = Ransac<LineEstimator>(options).run(data);
  REQUIRE(reference.success);
  for (std::size_t threads : {1u, 2u, 4u}) {
    options.threads = threads;
    INFO("threads " << threads);
    require_same_report(reference, Ransac<LineEstimator>(options).run(data), same_line);
  }
  // Same with the paper's composition (1000 fixed iterations, inlier counting, no LO).
  using Paper = Ransac<LineEstimator, diachron::UniformSampler, diachron::InlierCount,
                       diachron::FixedIterations, diachron::NoLocalOptimization>;
  options.threads = 1;
  const auto paper_reference = Paper(options).run(data);
  for (std::size_t threads : {2u, 4u}) {
    options.threads = threads;
    require_same_report(paper_reference, Paper(options).run(data), same_line);
  }
  // And with several models per sample.
  std::vector<double> values;
  diachron::RandomStream rng(3, 0);
  for (int i = 0; i < 300; ++i) values.push_back(i % 3 == 0 ? -4.0 + rng.normal(0, 0.1)
                                                            : rng.uniform(-50, 50));
  RansacOptions sign_options;
  sign_options.threshold = 0.3;
  const auto sign_reference = Ransac<diachron_test::SignEstimator>(sign_options).run(values);
  REQUIRE(sign_reference.success);
  CHECK(sign_reference.model == Approx(-4.0).margin(0.1));
  for (std::size_t threads : {2u, 4u}) {
    sign_options.threads = threads;
    require_same_report(sign_reference, Ransac<diachron_test::SignEstimator>(sign_options).run(values),
                        [](double a, double b) { return a == b; });
  }
}

TEST_CASE("Ransac: different seeds give different samples", "[robust]") {
  const auto data = diachron_test::make_line_data(100, 100, 1.0, 13);
  // Without LO and final refit the model comes straight from a minimal sample, which the seed picks.
  using Plain = Ransac<LineEstimator, diachron::UniformSampler, diachron::Msac, diachron::Adaptive,
                       diachron::NoLocalOptimization>;
  auto options = line_options(0);
  options.final_refit = false;
  const auto a = Plain(options).run(data);
  const auto a_again = Plain(options).run(data);
  options.seed = 1;
  const auto b = Plain(options).run(data);
  REQUIRE(a.success);
  REQUIRE(b.success);
  require_same_report(a, a_again, same_line);
  CHECK_FALSE(same_line(a.model, b.model));
}

TEST_CASE("Ransac: the input is neither reordered nor modified", "[robust]") {
  const auto data = diachron_test::make_line_data(100, 100, 1.0, 17);
  const auto copy = data;
  RansacOptions options = line_options();
  options.threads = 2;
  const auto report = Ransac<LineEstimator>(options).run(data);
  REQUIRE(report.success);
  REQUIRE(data == copy);
  // Indices refer to the caller's order.
  for (std::size_t i : report.inliers) {
    CHECK(LineEstimator{}.residual(report.model, data[i]) <= options.threshold);
  }
  // The pointer + size overload gives the same report.
  require_same_report(report, Ransac<LineEstimator>(options).run(data.data(), data.size()),
                      same_line);
}

TEST_CASE("Ransac: EstimateMinimalDegenerate, degenerate samples are redrawn", "[robust]") {
  // 40 copies of one point off the line: pairs of copies are degenerate (8 % of the samples).
  struct StrictLine : LineEstimator {
    Models minimal(const Sample& sample) const {
      if (degenerate(sample)) throw std::logic_error("minimal called on a degenerate sample");
      return LineEstimator::minimal(sample);
    }
  };
  auto data = diachron_test::make_line_data(100, 0, 0.5, 19);
  for (int i = 0; i < 40; ++i) data.emplace_back(50.0, 90.0);
  auto options = line_options();
  options.threshold = 1.5;
  options.confidence = 1.0;  // all 1000 iterations, so that many samples are pairs of copies
  const auto report = Ransac<StrictLine>(options).run(data);
  REQUIRE(report.success);
  CHECK(report.degenerate_samples > 0);
  CHECK(count_true_inliers_found(report.inliers, 100) >= 95);
  CHECK(diachron_test::line_error(report.model) < 0.5);
}

TEST_CASE("Ransac: an all-degenerate set ends with success == false", "[robust]") {
  const std::vector<Eigen::Vector2d> data(30, Eigen::Vector2d(1.0, 2.0));
  auto options = line_options();
  options.max_iterations = 200;
  options.max_sample_attempts = 5;
  const auto report = Ransac<LineEstimator>(options).run(data);
  CHECK_FALSE(report.success);
  CHECK(report.message.find("degenerate") != std::string::npos);
  CHECK(report.iterations == 200);
  CHECK(report.degenerate_samples == 200 * 5);
  CHECK(report.hypotheses_generated == 0);
  CHECK(report.inliers.empty());
  CHECK(report.inlier_mask.empty());
}

TEST_CASE("Ransac: an all-outlier set ends with success == false", "[robust]") {
  // Random displacements in a 1000 x 1000 box: two agree within 1 with probability ~3e-6.
  std::vector<diachron::PointPair2> data;
  diachron::RandomStream rng(23, 0);
  // One draw per statement, y before x: the order of a call's arguments is unspecified
  // (core/random.hpp, "Order of draws").
  for (int i = 0; i < 50; ++i) {
    const double sy = rng.uniform(0, 1000);
    const Eigen::Vector2d source(rng.uniform(0, 1000), sy);
    const double dy = rng.uniform(-500, 500);
    data.push_back({source, source + Eigen::Vector2d(rng.uniform(-500, 500), dy)});
  }
  RansacOptions options;
  options.threshold = 1.0;
  const auto report = Ransac<diachron_test::TranslationEstimator>(options).run(data);
  CHECK_FALSE(report.success);
  CHECK(report.message.find("min_inliers") != std::string::npos);
  // Every hypothesis has one inlier (its own sample): Adaptive stops on that, exactly.
  CHECK(report.iterations == static_cast<std::size_t>(diachron::adaptive_iterations(1, 50, 1, 0.999)));
  CHECK(report.iterations == 342);
  CHECK(report.inliers.empty());
  // The same data with a consistent displacement added to 10 pairs succeed.
  for (int i = 0; i < 10; ++i) {
    const double sy = rng.uniform(0, 1000);
    const Eigen::Vector2d source(rng.uniform(0, 1000), sy);
    data.push_back({source, source + Eigen::Vector2d(30.0, -12.0)});
  }
  const auto found = Ransac<diachron_test::TranslationEstimator>(options).run(data);
  REQUIRE(found.success);
  CHECK(found.inliers.size() == 10);
  CHECK((found.model - Eigen::Vector2d(30.0, -12.0)).norm() < 1e-9);
}

TEST_CASE("Ransac: too few data, empty data and bad input", "[robust]") {
  const Ransac<LineEstimator> ransac(line_options());
  const auto empty = ransac.run(std::vector<Eigen::Vector2d>{});
  CHECK_FALSE(empty.success);
  CHECK(empty.message == "no data");
  const auto one = ransac.run(std::vector<Eigen::Vector2d>{Eigen::Vector2d(1, 2)});
  CHECK_FALSE(one.success);
  CHECK(one.message.find("fewer data (1) than the minimal sample (2)") != std::string::npos);
  CHECK(one.num_data == 1);
  CHECK_THROWS_AS(ransac.run(nullptr, 3), diachron::Error);
  CHECK_NOTHROW(ransac.run(nullptr, 0));

  RansacOptions bad = line_options();
  bad.threshold = 0.0;
  CHECK_THROWS_AS(Ransac<LineEstimator>(bad), diachron::Error);
  bad.threshold = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(Ransac<LineEstimator>(bad), diachron::Error);

  // Two points and min_inliers 0 (= kSampleSize + 1 = 3): a line through two points proves nothing.
  const auto two = ransac.run(std::vector<Eigen::Vector2d>{{0, 0}, {1, 1}});
  CHECK_FALSE(two.success);
  RansacOptions lenient = line_options();
  lenient.min_inliers = 2;
  CHECK(Ransac<LineEstimator>(lenient).run(std::vector<Eigen::Vector2d>{{0, 0}, {1, 1}}).success);
}

TEST_CASE("Ransac: non-finite data are outliers, never a NaN model", "[robust]") {
  auto data = diachron_test::make_line_data(100, 50, 1.0, 29);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 50; ++i) data.emplace_back(i % 2 ? nan : 3.0, i % 3 ? inf : nan);
  const auto report = Ransac<LineEstimator>(line_options()).run(data);
  REQUIRE(report.success);
  CHECK(report.model.normal.allFinite());
  CHECK(std::isfinite(report.model.offset));
  for (std::size_t i : report.inliers) CHECK(i < 150);
  CHECK(diachron_test::line_error(report.model) < 1.0);
}

TEST_CASE("Ransac: the minimal archetype (no refine, no degenerate) composes with every default",
          "[robust]") {
  std::vector<double> values;
  diachron::RandomStream rng(31, 0);
  for (int i = 0; i < 200; ++i) {
    values.push_back(i % 2 ? 5.0 + rng.normal(0.0, 0.1) : rng.uniform(-100.0, 100.0));
  }
  RansacOptions options;
  options.threshold = 0.3;
  const auto report = Ransac<MeanEstimator>(options).run(values);
  REQUIRE(report.success);
  CHECK(report.model == Approx(5.0).margin(0.1));
  CHECK_FALSE(report.final_refit);  // no refine: silently skipped
  CHECK(report.best_updates >= 1);
  CHECK(report.local_optimizations == 0);  // Refit without refine does nothing
  CHECK(report.local_optimization_improvements == 0);
  CHECK(report.inliers.size() >= 95);
}

TEST_CASE("Ransac: FixedIterations runs exactly max_iterations (the paper's 1000)", "[robust]") {
  const auto data = diachron_test::make_line_data(100, 10, 1.0, 37);
  using Paper = Ransac<LineEstimator, diachron::UniformSampler, diachron::InlierCount,
                       diachron::FixedIterations, diachron::NoLocalOptimization>;
  const auto report = Paper(line_options()).run(data);
  REQUIRE(report.success);
  CHECK(report.iterations == 1000);
  CHECK(report.hypotheses_generated == 1000);
  CHECK(report.best_updates >= 1);
  CHECK(report.local_optimizations == 0);  // NoLocalOptimization does no work
  CHECK(report.local_optimization_improvements == 0);
  // confidence = 1 makes Adaptive do the same.
  auto options = line_options();
  options.confidence = 1.0;
  CHECK(Ransac<LineEstimator>(options).run(data).iterations == 1000);
}

TEST_CASE("Ransac: PROSAC on quality-sorted data succeeds within a tiny budget", "[robust]") {
  // Inliers first (the best-ranked matches), 90 % outliers. Three uniform samples would hold two
  // inliers with probability 1 - (1 - 0.0099)^3 = 3 %; PROSAC's first sample is the top two.
  const auto data = diachron_test::make_line_data(100, 900, 1.0, 41);
  auto options = line_options();
  options.max_iterations = 3;
  const auto prosac = Ransac<LineEstimator, diachron::ProsacSampler>(options).run(data);
  REQUIRE(prosac.success);
  CHECK(prosac.iterations == 3);
  CHECK(count_true_inliers_found(prosac.inliers, 100) >= 95);
  CHECK(diachron_test::line_error(prosac.model) < 1.0);
}
