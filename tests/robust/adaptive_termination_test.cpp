#include <cmath>
#include <cstddef>
#include <limits>

#include <catch2/catch.hpp>

#include <diachron/robust/adaptive_termination.hpp>

using diachron::adaptive_iterations;
using diachron::Adaptive;
using diachron::all_inlier_sample_probability;
using diachron::RansacOptions;

static_assert(diachron::is_termination_v<Adaptive>, "Adaptive is a Termination");

TEST_CASE("Adaptive: the all-inlier probability is the exact without-replacement product",
          "[robust]") {
  CHECK(all_inlier_sample_probability(50, 100, 2) == Approx(50.0 * 49.0 / (100.0 * 99.0)));
  CHECK(all_inlier_sample_probability(10, 100, 3) == Approx(720.0 / 970200.0));
  CHECK(all_inlier_sample_probability(2, 100, 3) == 0.0);  // fewer inliers than the sample
  CHECK(all_inlier_sample_probability(7, 7, 3) == 1.0);
}

TEST_CASE("Adaptive: golden iteration counts", "[robust]") {
  // ceil(log(1 - c) / log(1 - prod (I - i) / (N - i))), computed independently.
  CHECK(adaptive_iterations(50, 100, 2, 0.99) == 17);
  CHECK(adaptive_iterations(10, 100, 3, 0.99) == 6204);  // (I/N)^m would say 4603
  CHECK(adaptive_iterations(100, 1000, 2, 0.999) == 694);  // (I/N)^m would say 688
  CHECK(adaptive_iterations(200, 2000, 2, 0.999) == 691);
  CHECK(adaptive_iterations(500, 1000, 2, 0.999) == 25);
  CHECK(adaptive_iterations(100, 1000, 3, 0.999) == 7096);  // (I/N)^m would say 6905
  CHECK(adaptive_iterations(30, 100, 3, 0.999) == 272);
  CHECK(adaptive_iterations(1, 50, 1, 0.999) == 342);
  CHECK(adaptive_iterations(100, 100, 2, 0.999) == 1);
  CHECK(std::isinf(adaptive_iterations(1, 100, 2, 0.999)));
  CHECK(std::isinf(adaptive_iterations(50, 100, 2, 1.0)));
}

TEST_CASE("Adaptive: clamps to min/max iterations and applies the multiplier", "[robust]") {
  RansacOptions options;
  options.confidence = 0.99;
  const Adaptive adaptive;
  CHECK(adaptive.required_iterations(options, 50, 100, 2) == 17);
  CHECK(adaptive.required_iterations(options, 0, 100, 2) == 1000);  // no model yet: the cap
  CHECK(adaptive.required_iterations(options, 10, 100, 3) == 1000);  // 6204 capped
  options.min_iterations = 40;
  CHECK(adaptive.required_iterations(options, 50, 100, 2) == 40);
  options.min_iterations = 0;
  CHECK(Adaptive{3.0}.required_iterations(options, 50, 100, 2) == 51);
  CHECK(Adaptive{2.5}.required_iterations(options, 50, 100, 2) == 43);  // ceil(42.5)
  options.confidence = 1.0;  // "always run max_iterations"
  CHECK(adaptive.required_iterations(options, 100, 100, 2) == 1000);
}

TEST_CASE("Adaptive: an invalid multiplier throws at construction, not from run()", "[robust]") {
  CHECK_THROWS_AS(Adaptive{0.5}, diachron::Error);
  CHECK_THROWS_AS(Adaptive{std::nan("")}, diachron::Error);
  CHECK_THROWS_AS(Adaptive{std::numeric_limits<double>::infinity()}, diachron::Error);
  CHECK(Adaptive{}.multiplier() == 1.0);
  CHECK(Adaptive{1.0}.multiplier() == 1.0);
  CHECK(Adaptive{3.0}.multiplier() == 3.0);
}
