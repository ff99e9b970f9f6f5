#include <cmath>

#include <catch2/catch.hpp>

#include <diachron/robust/ransac_report.hpp>

TEST_CASE("RansacReport: Report, defaults mean failure", "[robust]") {
  const diachron::RansacReport<double> report;
  CHECK_FALSE(report.success);
  CHECK_FALSE(report.message.empty());
  CHECK(report.inliers.empty());
  CHECK(report.inlier_mask.empty());
  CHECK(report.score == 0.0);
  CHECK(std::isinf(report.rms));
  CHECK(report.iterations == 0);
  CHECK(report.num_data == 0);
  CHECK(report.hypotheses_generated == 0);
  CHECK(report.hypotheses_stopped_early == 0);
  CHECK(report.degenerate_samples == 0);
  CHECK(report.best_updates == 0);
  CHECK(report.local_optimizations == 0);
  CHECK(report.local_optimization_improvements == 0);
  CHECK_FALSE(report.final_refit);
  CHECK(report.residual_evaluations == 0);
  CHECK(report.data_passes() == 0.0);
}

TEST_CASE("RansacReport: data_passes counts whole passes over the data", "[robust]") {
  diachron::RansacReport<double> report;
  report.num_data = 200;
  report.residual_evaluations = 5100;
  CHECK(report.data_passes() == Approx(25.5));
}
