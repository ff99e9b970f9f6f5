#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include <diachron/eval/coregistration_case.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>

#include "support/test_paths.hpp"

namespace {

diachron::ExtractorPairMatcher<diachron::SiftExtractor> sift_matcher() {
  return diachron::ExtractorPairMatcher<diachron::SiftExtractor>(diachron::SiftExtractor{});
}

// Rough, hilly terrain with structure at several scales, so that a DSM image has features.
diachron::Dsm synthetic_world(int w = 420, int h = 360) {
  diachron::Raster<float> z(w, h);
  diachron::RandomStream rng(11);
  std::vector<Eigen::Vector4d> bumps;
  for (int i = 0; i < 120; ++i)
    bumps.emplace_back(rng.uniform(0, w), rng.uniform(0, h), rng.uniform(4, 30), rng.uniform(-40, 60));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double v = 500.0 + 0.2 * x;
      for (const auto& b : bumps) {
        const double d2 = ((x - b[0]) * (x - b[0]) + (y - b[1]) * (y - b[1])) / (b[2] * b[2]);
        if (d2 < 9.0) v += b[3] * std::exp(-d2);
      }
      z(x, y) = static_cast<float>(v);
    }
  return diachron::Dsm(std::move(z), diachron::GeoTransform::north_up(650000.0, 5200000.0, 5.0), "EPSG:32632");
}

// Master and secondary windows of one synthetic terrain, overlapping by 70 %.
diachron::CoregistrationCase synthetic_case(std::uint64_t seed) {
  const diachron::Dsm world = synthetic_world();
  diachron::CoregistrationCaseOptions case_options;
  case_options.overlap_min = case_options.overlap_max = 0.7;
  return diachron::make_coregistration_case(world, world, case_options, seed);
}

}  // namespace

TEST_CASE("rough_coregistration: recovers a known Helmert between two frames of one terrain", "[pipeline]") {
  const diachron::Dsm world = synthetic_world();
  diachron::CoregistrationCaseOptions case_options;
  case_options.overlap_min = 0.6;
  case_options.overlap_max = 0.8;
  for (std::uint64_t seed : {1u, 2u}) {
    const auto c = diachron::make_coregistration_case(world, world, case_options, seed);
    diachron::RoughCoregistrationOptions options;
    const auto report = diachron::rough_coregistration(c.master, c.secondary, sift_matcher(), options);
    INFO(report.message << " rotation " << c.rotation_deg << " scale " << c.scale);
    REQUIRE(report.success);
    const auto err = diachron::helmert_error_on_overlap(report.epoch2_from_epoch1, c);
    REQUIRE(err.valid);
    REQUIRE(err.rms < 2.0 * c.secondary.min_cell_size());
    // SIFT says it is rotation invariant, so the default tries one hypothesis only.
    REQUIRE(report.hypotheses.size() == 1);
  }
}

TEST_CASE("rough_coregistration: with rotation hypotheses forced, all four are reported", "[pipeline]") {
  const auto c = synthetic_case(3);
  diachron::RoughCoregistrationOptions options;
  options.skip_rotations_if_invariant = false;
  options.image_kind = diachron::DsmImageKind::kLocalRelief;
  const auto report = diachron::rough_coregistration(c.master, c.secondary, sift_matcher(), options);
  INFO(report.message);
  REQUIRE(report.success);
  REQUIRE(report.hypotheses.size() == 4);
  std::size_t best = 0;
  for (const auto& h : report.hypotheses) best = std::max(best, h.inliers);
  REQUIRE(report.inliers_2d.size() == best);
  REQUIRE(diachron::helmert_error_on_overlap(report.epoch2_from_epoch1, c).rms < 2.0 * c.secondary.min_cell_size());
}

TEST_CASE("rough_coregistration_images: the orthophoto mode lifts with the DSMs", "[pipeline]") {
  // Orthophotos are stand-ins here: the slope image on the DSM grid, as GeoImages.
  const auto c = synthetic_case(5);
  diachron::RoughCoregistrationOptions options;
  const diachron::GeoImage m{diachron::slope_image(c.master), c.master.transform()};
  const diachron::GeoImage s{diachron::slope_image(c.secondary), c.secondary.transform()};
  const auto report = diachron::rough_coregistration_images(m, c.master, s, c.secondary, sift_matcher(), options);
  INFO(report.message);
  REQUIRE(report.success);
  REQUIRE(diachron::helmert_error_on_overlap(report.epoch2_from_epoch1, c).rms < 2.0 * c.secondary.min_cell_size());
}

TEST_CASE("rough_coregistration: no overlap gives success == false with the reason", "[pipeline]") {
  const diachron::Dsm world = synthetic_world(600, 300);
  // Two disjoint halves of the terrain.
  auto half = [&](int x0) {
    diachron::Raster<float> z(280, 300);
    for (int y = 0; y < 300; ++y)
      for (int x = 0; x < 280; ++x) z(x, y) = world.heights()(x0 + x, y);
    diachron::GeoTransform gt = world.transform();
    gt.c[0] += x0 * gt.c[1];
    return diachron::Dsm(std::move(z), gt);
  };
  const auto report = diachron::rough_coregistration(half(0), half(310), sift_matcher());
  INFO(report.message);
  REQUIRE_FALSE(report.success);
  REQUIRE(report.message.find("overlap") != std::string::npos);
}

TEST_CASE("rough_coregistration: a DSM full of holes or constant gives a clear failure", "[pipeline]") {
  const diachron::Dsm world = synthetic_world(200, 200);
  diachron::Raster<float> holes(200, 200, std::numeric_limits<float>::quiet_NaN());
  const diachron::Dsm empty_dsm(std::move(holes), world.transform());
  const auto r1 = diachron::rough_coregistration(world, empty_dsm, sift_matcher());
  REQUIRE_FALSE(r1.success);
  REQUIRE(r1.message.find("no valid height") != std::string::npos);
  diachron::Raster<float> flat(200, 200, 100.0f);
  const diachron::Dsm flat_dsm(std::move(flat), world.transform());
  const auto r2 = diachron::rough_coregistration(world, flat_dsm, sift_matcher());
  REQUIRE_FALSE(r2.success);
  REQUIRE_FALSE(r2.message.empty());
}

TEST_CASE("rough_coregistration: recovers a fixed transform of a real DEM", "[pipeline]") {
  const auto path = diachron::test::data_file("longyearbyen-1990/dem_1990.tif");
  DIACHRON_REQUIRE_FILE_OR_SKIP(path, "longyearbyen-1990/dem_1990.tif");
  const diachron::Dsm world = diachron::read_geotiff_dsm(*path);
  diachron::CoregistrationCaseOptions case_options;
  case_options.overlap_min = 0.5;
  case_options.overlap_max = 0.5;
  const auto c = diachron::make_coregistration_case(world, world, case_options, 7);
  const auto report = diachron::rough_coregistration(c.master, c.secondary, sift_matcher());
  INFO(report.message);
  REQUIRE(report.success);
  const auto err = diachron::helmert_error_on_overlap(report.epoch2_from_epoch1, c);
  REQUIRE(err.rms < 2.0 * c.secondary.min_cell_size());
}
