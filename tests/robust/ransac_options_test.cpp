#include <limits>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/robust/ransac_options.hpp>

using diachron::RansacOptions;

TEST_CASE("RansacOptions: Options, defaults are pinned and valid", "[robust]") {
  const RansacOptions options;
  CHECK(options.threshold == 1.0);
  CHECK(options.max_iterations == 1000);  // the paper's count
  CHECK(options.min_iterations == 0);
  CHECK(options.confidence == 0.999);
  CHECK(options.seed == 0);
  CHECK(options.threads == 1);
  CHECK(options.min_inliers == 0);
  CHECK(options.max_sample_attempts == 100);
  CHECK(options.final_refit);
  CHECK_NOTHROW(options.check());
}

TEST_CASE("RansacOptions: check() rejects every out-of-range field", "[robust]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto rejects = [](auto mutate) {
    RansacOptions options;
    mutate(options);
    CHECK_THROWS_AS(options.check(), diachron::Error);
  };
  rejects([](RansacOptions& o) { o.threshold = 0.0; });
  rejects([](RansacOptions& o) { o.threshold = -1.0; });
  rejects([&](RansacOptions& o) { o.threshold = nan; });
  rejects([&](RansacOptions& o) { o.threshold = inf; });
  rejects([](RansacOptions& o) { o.max_iterations = 0; });
  rejects([](RansacOptions& o) { o.min_iterations = 1001; });
  rejects([](RansacOptions& o) { o.confidence = 0.0; });
  rejects([](RansacOptions& o) { o.confidence = 1.5; });
  rejects([&](RansacOptions& o) { o.confidence = nan; });
  rejects([](RansacOptions& o) { o.max_sample_attempts = 0; });

  RansacOptions edge;
  edge.confidence = 1.0;  // "always run max_iterations"
  edge.min_iterations = edge.max_iterations;
  edge.threads = 0;  // all cores
  CHECK_NOTHROW(edge.check());

  RansacOptions named;
  named.threshold = -2.0;
  try {
    named.check();
    FAIL("check() accepted a negative threshold");
  } catch (const diachron::Error& error) {
    CHECK(std::string(error.what()).find("threshold") != std::string::npos);
  }
}

TEST_CASE("RansacOptions: bail_out_risk must be in [0, 1)", "[robust]") {
  diachron::RansacOptions options;
  options.bail_out_risk = -0.1;
  CHECK_THROWS_AS(options.check(), diachron::Error);
  options.bail_out_risk = 1.0;
  CHECK_THROWS_AS(options.check(), diachron::Error);
  options.bail_out_risk = 0.0;
  CHECK_NOTHROW(options.check());
}
