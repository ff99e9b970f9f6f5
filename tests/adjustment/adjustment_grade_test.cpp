#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include <diachron/adjustment/adjustment_grade.hpp>

namespace {

// A successful report with one free camera whose f, cx, cy and K1 moved by the given amounts,
// each with sigma `sigma` (NaN: no covariance).
diachron::BundleReport grade_test_report(double df, double dcx, double dk1, double sigma) {
  diachron::BundleReport r;
  r.success = true;
  r.message = "adjusted";
  r.covariance_available = std::isfinite(sigma);
  r.covariance_message = std::isfinite(sigma) ? "" : "rank deficient";
  diachron::CameraReport c;
  c.camera = 1;
  c.free = true;
  c.values = {{"f", 1000.0, 1000.0 + df, sigma}, {"cx", 800.0, 800.0 + dcx, sigma}, {"cy", 600.0, 600.0, sigma},
              {"K1", -0.01, -0.01 + dk1, std::isfinite(sigma) ? 1e-4 : sigma}};
  r.cameras.push_back(c);
  diachron::CameraReport fixed;  // the reference's camera: never graded
  fixed.camera = 0;
  fixed.values = {{"f", 1000.0, 5000.0, std::nan("")}};
  r.cameras.push_back(fixed);
  return r;
}

}  // namespace

TEST_CASE("grade_adjustment: a normal self-calibration is graded high", "[adjustment][grade]") {
  // f by 0.5 %, cx by 0.9 % (7 sigmas), K1 by 100 sigmas: what the decades scenes' film cameras do.
  const diachron::AdjustmentGrade g = diachron::grade_adjustment(grade_test_report(5.0, 9.0, 0.01, 1.3), 0.33);
  CHECK(g.graded);
  CHECK(g.high);
  CHECK(g.reasons.empty());
}

TEST_CASE("grade_adjustment: a focal length moved by a large share and many sigmas grades low", "[adjustment][grade]") {
  const diachron::AdjustmentGrade g = diachron::grade_adjustment(grade_test_report(60.0, 0.0, 0.0, 9.5), 0.3);
  CHECK_FALSE(g.high);
  REQUIRE(g.reasons.size() == 1);
  CHECK(g.reasons[0].find("f moved 60") != std::string::npos);
  CHECK(g.reasons[0].find("6 % of f") != std::string::npos);
  // The same share within its sigmas (a weak block) is not a finding.
  CHECK(diachron::grade_adjustment(grade_test_report(60.0, 0.0, 0.0, 20.0), 0.3).high);
}

TEST_CASE("grade_adjustment: no covariance and a wild export grade low, with each reason", "[adjustment][grade]") {
  const diachron::AdjustmentGrade g = diachron::grade_adjustment(grade_test_report(1.0, 1.0, 0.0, std::nan("")), 23.0);
  CHECK_FALSE(g.high);
  REQUIRE(g.reasons.size() == 2);
  CHECK(g.reasons[0].find("no covariance (rank deficient)") != std::string::npos);
  CHECK(g.reasons[1].find("23 px") != std::string::npos);
  diachron::AdjustmentGradeOptions lenient;
  lenient.require_covariance = false;
  lenient.max_conversion_error_px = 30.0;
  CHECK(diachron::grade_adjustment(grade_test_report(1.0, 1.0, 0.0, std::nan("")), 23.0, lenient).high);
}

TEST_CASE("grade_adjustment: a failed adjustment is low; defaults mean failure; options checked", "[adjustment][grade]") {
  diachron::BundleReport failed;
  failed.message = "too few tracks";
  const diachron::AdjustmentGrade g = diachron::grade_adjustment(failed);
  CHECK_FALSE(g.high);
  REQUIRE(g.reasons.size() == 1);
  CHECK(g.reasons[0].find("too few tracks") != std::string::npos);
  CHECK_FALSE(diachron::AdjustmentGrade{}.high);
  diachron::AdjustmentGradeOptions bad;
  bad.max_sigmas = 0.0;
  CHECK_THROWS_AS(diachron::grade_adjustment(grade_test_report(0, 0, 0, 1), 0.0, bad), diachron::Error);
}
