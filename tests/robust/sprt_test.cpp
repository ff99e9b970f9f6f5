#include <atomic>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/robust/robust_estimation.hpp>
#include <diachron/robust/sprt.hpp>

#include "robust/test_estimators.hpp"

using diachron::PointPair2;
using diachron::RansacOptions;

namespace {

using diachron_test::similarity_pairs;

std::size_t true_found(const std::vector<std::size_t>& inliers, std::size_t count) {
  std::size_t n = 0;
  for (std::size_t i : inliers) n += i < count ? 1 : 0;
  return n;
}

// LineEstimator whose refine records the sizes it is called with.
std::atomic<std::size_t> g_min_refine{1000000};
std::atomic<std::size_t> g_max_refine{0};
struct RecordingLine : diachron_test::LineEstimator {
  std::optional<Model> refine(const Model& initial, const diachron::Subset<Datum>& data,
                              const double* weights) const {
    std::size_t v = g_min_refine.load();
    while (data.size() < v && !g_min_refine.compare_exchange_weak(v, data.size())) {
    }
    v = g_max_refine.load();
    while (data.size() > v && !g_max_refine.compare_exchange_weak(v, data.size())) {
    }
    return diachron_test::LineEstimator::refine(initial, data, weights);
  }
};

}  // namespace

TEST_CASE("SPRT: threshold A from the paper's fixed point, inactive when delta >= epsilon",
          "[robust]") {
  const auto test = diachron::make_sprt_test(0.5, 0.05, 200.0, 1.0);
  REQUIRE(test.active);
  // A = t_M C / m_S + 1 + ln A.
  const double c = 0.95 * std::log(0.95 / 0.5) + 0.05 * std::log(0.05 / 0.5);
  CHECK(test.threshold == Approx(200.0 * c + 1.0 + std::log(test.threshold)));
  CHECK(test.false_rejection() == Approx(1.0 / test.threshold));
  CHECK(test.log_inlier < 0.0);
  CHECK(test.log_outlier > 0.0);
  CHECK_FALSE(diachron::make_sprt_test(0.05, 0.05, 200.0, 1.0).active);
  CHECK_FALSE(diachron::make_sprt_test(0.5, 0.0, 200.0, 1.0).active);
  // The stopping rule only grows.
  CHECK(diachron::sprt_adjusted_iterations(100.0, 0.25, 0.01) >= 100.0);
  CHECK(diachron::sprt_adjusted_iterations(100.0, 0.25, 0.0) == 100.0);
}

TEST_CASE("SPRT: same winner as exact scoring at 10/50/90 % outliers", "[robust]") {
  const std::size_t inliers = 2000;
  for (double ratio : {0.1, 0.5, 0.9}) {
    const auto outliers = static_cast<std::size_t>(std::lround(inliers * ratio / (1.0 - ratio)));
    for (std::uint64_t seed : {1u, 2u, 3u, 4u, 5u}) {
      const auto data = similarity_pairs(inliers, outliers, seed);
      RansacOptions options;
      options.threshold = 3.0;
      options.seed = seed;
      options.max_iterations = 5000;
      options.bail_out_risk = 0.0;  // the SPRT alone against exact scoring
      const auto exact = diachron::ransac_similarity2(data, options);
      options.sprt = true;
      const auto sprt = diachron::ransac_similarity2(data, options);
      INFO("outliers " << ratio << " seed " << seed << " passes " << exact.data_passes()
                       << " vs " << sprt.data_passes());
      REQUIRE(exact.success);
      REQUIRE(sprt.success);
      CHECK(true_found(sprt.inliers, inliers) >= 0.95 * inliers);
      CHECK(true_found(exact.inliers, inliers) >= 0.95 * inliers);
      CHECK(std::abs(sprt.model.angle - exact.model.angle) < 1e-3);
      CHECK(std::abs(sprt.model.scale - exact.model.scale) < 1e-3);
      if (ratio >= 0.5) CHECK(sprt.hypotheses_rejected_sprt > 0);
      CHECK(sprt.hypotheses_rejected_sprt <= sprt.hypotheses_stopped_early);
    }
  }
}

TEST_CASE("SPRT, bail-out and subset LO: deterministic across 1, 2 and 4 threads", "[robust]") {
  const auto data = similarity_pairs(3000, 3000, 9);
  RansacOptions options;
  options.threshold = 3.0;
  options.seed = 17;
  for (int variant = 0; variant < 4; ++variant) {
    const bool sprt = (variant & 1) != 0;
    options.sprt = sprt;
    options.bail_out_risk = (variant & 2) != 0 ? 1e-3 : 0.0;
    options.threads = 1;
    const auto reference = diachron::ransac_similarity2(data, options);
    REQUIRE(reference.success);
    CHECK((reference.hypotheses_bailed_out > 0) == (options.bail_out_risk > 0.0));
    for (std::size_t threads : {2u, 4u}) {
      options.threads = threads;
      INFO("sprt " << sprt << " bail-out risk " << options.bail_out_risk << " threads " << threads);
      const auto report = diachron::ransac_similarity2(data, options);
      REQUIRE(report.model.angle == reference.model.angle);
      REQUIRE(report.model.scale == reference.model.scale);
      REQUIRE(report.model.translation == reference.model.translation);
      REQUIRE(report.inliers == reference.inliers);
      REQUIRE(report.score == reference.score);
      REQUIRE(report.iterations == reference.iterations);
      REQUIRE(report.hypotheses_stopped_early == reference.hypotheses_stopped_early);
      REQUIRE(report.hypotheses_rejected_sprt == reference.hypotheses_rejected_sprt);
      REQUIRE(report.hypotheses_bailed_out == reference.hypotheses_bailed_out);
      REQUIRE(report.local_optimizations == reference.local_optimizations);
      REQUIRE(report.residual_evaluations == reference.residual_evaluations);
    }
  }
}

TEST_CASE("Refit: LO refits see at most max_lo_data and never fewer than kSampleSize data",
          "[robust]") {
  const auto data = diachron_test::make_line_data(3000, 3000, 1.0, 5);
  RansacOptions options;
  options.threshold = 3.0;
  options.final_refit = false;  // only LO calls refine
  diachron::Refit refit;
  refit.max_lo_data = 200;
  g_min_refine = 1000000;
  g_max_refine = 0;
  const auto report =
      diachron::Ransac<RecordingLine, diachron::UniformSampler, diachron::Msac, diachron::Adaptive,
                       diachron::Refit>(options, {}, {}, {}, {}, refit)
          .run(data);
  REQUIRE(report.success);
  REQUIRE(report.local_optimizations >= 1);
  CHECK(g_max_refine.load() <= 200);
  CHECK(g_max_refine.load() >= 100);
  CHECK(g_min_refine.load() >= RecordingLine::kSampleSize);
  CHECK(report.inliers.size() > 2500);
}
