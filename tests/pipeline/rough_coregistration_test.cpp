#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <ogr_spatialref.h>

#include <diachron/eval/coregistration_case.hpp>
#include <diachron/io/dsm_reproject.hpp>
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
diachron::Dsm synthetic_world(int w = 420, int h = 360, std::uint64_t seed = 11) {
  diachron::Raster<float> z(w, h);
  diachron::RandomStream rng(seed);
  std::vector<Eigen::Vector4d> bumps;
  for (int i = 0; i < 120; ++i) {
    // One draw per statement, the last argument first (height, radius, y, x): the order of a call's
    // arguments is unspecified (core/random.hpp, "Order of draws"); the world was made so.
    const double height = rng.uniform(-40, 60), radius = rng.uniform(4, 30), y = rng.uniform(0, h);
    bumps.emplace_back(rng.uniform(0, w), y, radius, height);
  }
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

TEST_CASE("rough_coregistration: a DSM in a geographic CRS is refused, naming the remedy", "[pipeline]") {
  const diachron::Dsm world = synthetic_world();
  const std::string wgs84 =
      R"(GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],)"
      R"(UNIT["degree",0.0174532925199433]])";
  const diachron::Dsm degrees(world.heights(), world.transform(), wgs84);
  CHECK_THROWS_WITH(diachron::rough_coregistration(degrees, world, sift_matcher()),
                    Catch::Contains("master DSM is in a geographic CRS") && Catch::Contains("reproject_dsm"));
  CHECK_THROWS_WITH(diachron::rough_coregistration(world, degrees, sift_matcher()),
                    Catch::Contains("secondary DSM is in a geographic CRS"));
}

namespace {

// `dsm`'s cells [x0, x0 + w) x [y0, y0 + h), georeferenced as they were.
diachron::Dsm crop(const diachron::Dsm& dsm, int x0, int y0, int w, int h) {
  diachron::Raster<float> z(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) z(x, y) = dsm.heights()(x0 + x, y0 + y);
  diachron::GeoTransform gt = dsm.transform();
  gt.c[0] += x0 * gt.c[1] + y0 * gt.c[2];
  gt.c[3] += x0 * gt.c[4] + y0 * gt.c[5];
  return diachron::Dsm(std::move(z), gt, dsm.crs());
}

}  // namespace

TEST_CASE("rough_coregistration: the SRTM pair shifted by (3, 5) cells, reprojected from degrees to UTM",
          "[pipeline]") {
  // demcompare's known-truth case: a real SRTM 3" DEM and the same DEM blurred and shifted by
  // (3, 5) cells, both in WGS 84 degrees. The centre 360 x 360 cells keep the test short.
  const auto ref_path = diachron::test::data_file("srtm-demcompare/srtm_ref.tif");
  const auto sec_path = diachron::test::data_file("srtm-demcompare/srtm_blurred_and_shifted.tif");
  DIACHRON_REQUIRE_FILE_OR_SKIP(ref_path, "srtm-demcompare/srtm_ref.tif");
  DIACHRON_REQUIRE_FILE_OR_SKIP(sec_path, "srtm-demcompare/srtm_blurred_and_shifted.tif");
  const diachron::Dsm ref = crop(diachron::read_geotiff_dsm(*ref_path), 320, 320, 360, 360);
  const diachron::Dsm sec = crop(diachron::read_geotiff_dsm(*sec_path), 320, 320, 360, 360);
  REQUIRE(ref.transform().c == sec.transform().c);

  // Oracle: the integer shift (i, j) with sec(x + i, y + j) closest to ref(x, y), by brute force.
  Eigen::Vector2d truth(0.0, 0.0);
  double best = std::numeric_limits<double>::infinity();
  for (int j = -8; j <= 8; ++j)
    for (int i = -8; i <= 8; ++i) {
      double sum = 0.0;
      int n = 0;
      for (int y = 10; y < 350; y += 2)
        for (int x = 10; x < 350; x += 2)
          if (ref.valid(x, y) && sec.valid(x + i, y + j)) {
            sum += std::abs(sec.heights()(x + i, y + j) - ref.heights()(x, y));
            ++n;
          }
      if (n > 0 && sum / n < best) best = sum / n, truth = Eigen::Vector2d(i, j);
    }
  REQUIRE(truth.cwiseAbs() == Eigen::Vector2d(3.0, 5.0));  // the data's README, up to the sign

  CHECK_THROWS_WITH(diachron::rough_coregistration(ref, sec, sift_matcher()), Catch::Contains("geographic CRS"));
  const std::string utm = diachron::utm_crs_of(ref);
  const auto report = diachron::rough_coregistration(diachron::reproject_dsm(ref, utm),
                                                     diachron::reproject_dsm(sec, utm), sift_matcher());
  INFO(report.message);
  REQUIRE(report.success);
  CHECK(report.trust == diachron::RoughCoregistrationTrust::kHigh);

  // The Helmert, applied in UTM, moves the crop's centre by the oracle's shift in the input grid.
  OGRSpatialReference wgs84, utm_srs;
  wgs84.SetFromUserInput(ref.crs().c_str());
  utm_srs.SetFromUserInput(utm.c_str());
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  utm_srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  const std::unique_ptr<OGRCoordinateTransformation> forward(OGRCreateCoordinateTransformation(&wgs84, &utm_srs));
  const std::unique_ptr<OGRCoordinateTransformation> back(OGRCreateCoordinateTransformation(&utm_srs, &wgs84));
  REQUIRE(forward);
  REQUIRE(back);
  const Eigen::Vector2d centre_px(180.0, 180.0);
  const Eigen::Vector2d lonlat = ref.transform().pixel_to_world(centre_px);
  double e = lonlat.x(), n = lonlat.y();
  REQUIRE(forward->Transform(1, &e, &n));
  const Eigen::Vector3d moved =
      report.epoch2_from_epoch1(Eigen::Vector3d(e, n, ref.height_at(lonlat.x(), lonlat.y())));
  double lon = moved.x(), lat = moved.y();
  REQUIRE(back->Transform(1, &lon, &lat));
  const Eigen::Vector2d shift = ref.transform().world_to_pixel(Eigen::Vector2d(lon, lat)) - centre_px;
  INFO("recovered shift " << shift.transpose() << " cells, oracle " << truth.transpose());
  CHECK((shift - truth).norm() < 0.25);
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

  // The surface refinement (on by default) tightens the Helmert of the matches (docs/
  // rough-coregistration.md, "Surface refinement": a median of 0.13-0.28 cells without it on the
  // real DEMs' cases, 0.01 with it).
  INFO(report.surface.message);
  CHECK(report.surface.accepted);
  CHECK(report.message.find("surfaces matched") != std::string::npos);
  diachron::RoughCoregistrationOptions unrefined;
  unrefined.refine_surface = false;
  const auto plain = diachron::rough_coregistration(c.master, c.secondary, sift_matcher(), unrefined);
  REQUIRE(plain.success);
  CHECK(plain.surface.message == "not run");
  const auto plain_err = diachron::helmert_error_on_overlap(plain.epoch2_from_epoch1, c);
  CHECK(err.rms < 0.1 * c.secondary.min_cell_size());
  CHECK(err.rms < plain_err.rms);
}

namespace {

// The synthetic terrain with a round hole of radius 20 cells at (200, 150).
diachron::Dsm world_with_hole() {
  const diachron::Dsm world = synthetic_world();
  diachron::Raster<float> z = world.heights();
  for (int y = 0; y < z.height(); ++y)
    for (int x = 0; x < z.width(); ++x)
      if (std::hypot(x - 200.0, y - 150.0) < 20.0) z(x, y) = std::numeric_limits<float>::quiet_NaN();
  return diachron::Dsm(std::move(z), world.transform(), "EPSG:32632");
}

// Matches from the truth of case `c`: master DSM-image pixels on a grid, mapped through the true
// Helmert into the secondary DSM image, each moved by a deterministic offset of up to `noise_px`
// secondary pixels in x and y (0 = exact).
std::vector<diachron::PointMatch> truth_matches(const diachron::CoregistrationCase& c, double noise_px) {
  std::vector<diachron::PointMatch> out;
  int k = 0;
  for (int y = 10; y < c.master.height() - 10; y += 12)
    for (int x = 10; x < c.master.width() - 10; x += 12) {
      const Eigen::Vector2d a(x, y);
      const Eigen::Vector2d xy = c.master.pixel_to_world(a);
      const double z = c.master.height_at(xy);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d x2 = c.secondary_from_master(Eigen::Vector3d(xy.x(), xy.y(), z));
      Eigen::Vector2d b = c.secondary.world_to_pixel(x2.head<2>());
      if (!std::isfinite(c.secondary.height_at(x2.head<2>()))) continue;
      // A fixed pseudo-random pattern in [-1, 1]: the same offsets in every run.
      ++k;
      b += noise_px * Eigen::Vector2d(std::sin(k * 12.9898) , std::cos(k * 78.233));
      out.push_back(diachron::PointMatch{a, b, 1.0});
    }
  return out;
}

}  // namespace

TEST_CASE("rough_coregistration: a masked matcher receives the DSM validity eroded by the hole margin",
          "[pipeline]") {
  const diachron::Dsm dsm = world_with_hole();
  std::mutex mutex;
  std::vector<diachron::Raster<std::uint8_t>> masks;
  auto recording = diachron::make_pair_matcher(
      [&](const diachron::Raster<std::uint8_t>&, const diachron::Raster<std::uint8_t>&,
          const diachron::Raster<std::uint8_t>& mask_a, const diachron::Raster<std::uint8_t>& mask_b) {
        std::lock_guard<std::mutex> lock(mutex);
        masks.push_back(mask_a);
        masks.push_back(mask_b);
        return std::vector<diachron::PointMatch>{};
      },
      true);
  diachron::RoughCoregistrationOptions options;
  options.scale_hypotheses.enabled = false;  // one call at the DSM's own resolution: its masks
  options.correlation_fallback = false;      // it would find the DSM in itself without features
  const auto report = diachron::rough_coregistration(dsm, dsm, recording, options);
  REQUIRE_FALSE(report.success);  // no matches
  REQUIRE(report.hypotheses.size() == 1);  // the flag of make_pair_matcher was heard
  REQUIRE(masks.size() == 2);
  const diachron::Raster<float> distance = diachron::detail::distance_to_holes(dsm);
  for (const auto& mask : masks) {
    REQUIRE(mask.width() == dsm.width());
    REQUIRE(mask.height() == dsm.height());
    std::size_t mismatches = 0, zeros = 0;
    for (int y = 0; y < dsm.height(); ++y)
      for (int x = 0; x < dsm.width(); ++x) {
        const bool expected = distance(x, y) >= options.min_hole_distance_px;
        mismatches += (mask(x, y) != 0) != expected;
        zeros += mask(x, y) == 0;
      }
    REQUIRE(mismatches == 0);
    // The hole (about pi 20^2 = 1257 cells) and its 6-cell rim (about 870 more) are masked.
    REQUIRE(zeros > 1800);
    REQUIRE(zeros < 2400);
    CHECK(mask(200, 150) == 0);        // in the hole
    CHECK(mask(200 + 23, 150) == 0);   // 3 cells from its edge
    CHECK(mask(200 + 30, 150) == 255); // 10 cells from its edge
    CHECK(mask(5, 5) == 255);          // the DSM's border is not a hole
  }
  // Switched off, the matcher is called without masks (it then sees all-valid ones).
  masks.clear();
  options.pass_masks = false;
  diachron::rough_coregistration(dsm, dsm, recording, options);
  REQUIRE(masks.size() == 2);
  for (const auto& mask : masks)
    for (int y = 0; y < mask.height(); ++y)
      for (int x = 0; x < mask.width(); ++x) REQUIRE(mask(x, y) == 255);
}

TEST_CASE("rough_coregistration: the trust grade separates matches that agree in 3D from ones that do not",
          "[pipeline]") {
  const auto c = synthetic_case(4);
  const double cell = c.secondary.min_cell_size();
  auto matcher_with_noise = [&](double noise_px) {
    return diachron::make_pair_matcher(
        [&c, noise_px](const diachron::Raster<std::uint8_t>&, const diachron::Raster<std::uint8_t>&) {
          return truth_matches(c, noise_px);
        },
        true);
  };
  diachron::RoughCoregistrationOptions options;
  options.min_hole_distance_px = 0.0;  // keep every synthetic match

  const auto exact = diachron::rough_coregistration(c.master, c.secondary, matcher_with_noise(0.0), options);
  INFO(exact.message);
  REQUIRE(exact.success);
  CHECK(exact.trust == diachron::RoughCoregistrationTrust::kHigh);
  CHECK(exact.rms_3d_cells < 0.5);
  CHECK(exact.rms_3d_cells == Approx(exact.rms_3d / cell));
  CHECK(diachron::helmert_error_on_overlap(exact.epoch2_from_epoch1, c).rms < 0.5 * cell);

  // Offsets of up to 8 secondary pixels pass the 10 px 2D RANSAC and the 10-cell 3D guard, so the
  // run succeeds, but its 3D residuals are several cells: graded low.
  const auto noisy = diachron::rough_coregistration(c.master, c.secondary, matcher_with_noise(8.0), options);
  INFO(noisy.message);
  REQUIRE(noisy.success);
  CHECK(noisy.rms_3d_cells > options.trusted_rms_3d_cells);
  CHECK(noisy.trust == diachron::RoughCoregistrationTrust::kLow);
  CHECK(noisy.message.find("trust low") != std::string::npos);

  // The check turns such a result into a failure with the reason.
  options.max_rms_3d_cells = 2.0;
  const auto rejected = diachron::rough_coregistration(c.master, c.secondary, matcher_with_noise(8.0), options);
  REQUIRE_FALSE(rejected.success);
  CHECK(rejected.trust == diachron::RoughCoregistrationTrust::kNone);
  CHECK(rejected.message.find("max_rms_3d_cells") != std::string::npos);
  // The caller asked for agreement in 3D, which the correlation fallback cannot show: it stays out.
  CHECK(options.correlation_fallback);
  CHECK_FALSE(rejected.correlation_ran);

  // Too few 3D inliers for a high grade, however small the residuals.
  options.max_rms_3d_cells = std::numeric_limits<double>::infinity();
  options.trusted_min_inliers_3d = 100000;
  const auto few = diachron::rough_coregistration(c.master, c.secondary, matcher_with_noise(0.0), options);
  REQUIRE(few.success);
  CHECK(few.trust == diachron::RoughCoregistrationTrust::kLow);
}

TEST_CASE("rough_coregistration_images: a custom DSM image (the docs' example)", "[pipeline]") {
  const auto c = synthetic_case(6);
  const diachron::Dsm& master_dsm = c.master;
  const diachron::Dsm& secondary_dsm = c.secondary;
  const auto matcher = sift_matcher();
  // --- docs/rough-coregistration.md, "A custom DSM image" (keep in sync) ---
  // Any 8-bit image on the DSM's grid: here the slope image brightened by a gamma of 0.5, so gentle
  // slopes get more grey levels. Its geotransform is the DSM's; the mask (optional) says where it
  // shows data: the pipeline also masks DSM holes and their rim for matchers that take masks.
  auto my_image = [](const diachron::Dsm& dsm) {
    diachron::GeoImage out{diachron::slope_image(dsm), dsm.transform()};
    out.mask = diachron::Raster<std::uint8_t>(dsm.width(), dsm.height(), 0);
    for (int y = 0; y < dsm.height(); ++y)
      for (int x = 0; x < dsm.width(); ++x) {
        const double v = out.image(x, y) / 255.0;
        out.image(x, y) = static_cast<std::uint8_t>(std::lround(255.0 * std::sqrt(v)));
        if (dsm.valid(x, y)) out.mask(x, y) = 255;
      }
    return out;
  };
  const diachron::GeoImage master_image = my_image(master_dsm);
  const diachron::GeoImage secondary_image = my_image(secondary_dsm);
  diachron::RoughCoregistrationOptions options;  // image_kind is not used: the images are given
  const diachron::RoughCoregistrationReport report = diachron::rough_coregistration_images(
      master_image, master_dsm, secondary_image, secondary_dsm, matcher, options);
  if (report.success && report.trust == diachron::RoughCoregistrationTrust::kHigh) {
    // report.epoch2_from_epoch1 maps epoch-1 (master) world points into epoch 2
  }
  // --- end of the docs' example ---
  INFO(report.message);
  REQUIRE(report.success);
  CHECK(report.trust == diachron::RoughCoregistrationTrust::kHigh);
  REQUIRE(diachron::helmert_error_on_overlap(report.epoch2_from_epoch1, c).rms < 2.0 * c.secondary.min_cell_size());
}

namespace {

struct PlainExtractor {
  diachron::Features extract(const diachron::Raster<std::uint8_t>&) const { return {}; }
};

// A FeaturePairMatcher whose extractor takes no mask but whose image overload does: the pipeline
// must call it directly with the masks instead of through the (unmasked) feature cache.
struct MaskedImageMatcher {
  PlainExtractor e;
  std::shared_ptr<std::atomic<int>> masked_calls = std::make_shared<std::atomic<int>>(0);
  std::shared_ptr<std::atomic<int>> plain_calls = std::make_shared<std::atomic<int>>(0);
  const PlainExtractor& extractor() const { return e; }
  bool rotation_invariant() const { return true; }
  std::vector<diachron::PointMatch> match(const diachron::Features&, const diachron::Features&) const {
    plain_calls->fetch_add(1);
    return {};
  }
  std::vector<diachron::PointMatch> match(const diachron::Raster<std::uint8_t>&,
                                          const diachron::Raster<std::uint8_t>&) const {
    plain_calls->fetch_add(1);
    return {};
  }
  std::vector<diachron::PointMatch> match(const diachron::Raster<std::uint8_t>&, const diachron::Raster<std::uint8_t>&,
                                          const diachron::Raster<std::uint8_t>&,
                                          const diachron::Raster<std::uint8_t>&) const {
    masked_calls->fetch_add(1);
    return {};
  }
};

}  // namespace

TEST_CASE("rough_coregistration: masks reach a FeaturePairMatcher whose extractor takes none", "[pipeline]") {
  STATIC_REQUIRE(diachron::is_feature_pair_matcher_v<MaskedImageMatcher>);
  STATIC_REQUIRE(diachron::detail::pipeline_matcher<MaskedImageMatcher>::masks);
  STATIC_REQUIRE_FALSE(diachron::detail::pipeline_matcher<MaskedImageMatcher>::cache);
  // SIFT's extractor takes masks, so it keeps the cache and gets masks through it.
  using Sift = diachron::ExtractorPairMatcher<diachron::SiftExtractor>;
  STATIC_REQUIRE(diachron::detail::pipeline_matcher<Sift>::cache);
  STATIC_REQUIRE(diachron::detail::pipeline_matcher<Sift>::masks);
  const diachron::Dsm dsm = world_with_hole();
  const MaskedImageMatcher matcher;
  diachron::RoughCoregistrationOptions options;
  options.scale_hypotheses.enabled = false;  // no match: scale hypotheses would call it again
  options.correlation_fallback = false;      // the calls are what is tested, not the answer
  diachron::rough_coregistration(dsm, dsm, matcher, options);
  CHECK(matcher.masked_calls->load() == 1);
  CHECK(matcher.plain_calls->load() == 0);
}

TEST_CASE("rough_coregistration: a 4x resolution gap needs the scale hypotheses", "[pipeline]") {
  // The master is the terrain at 20 m (4 x 4 blocks of the 5 m grid averaged), the secondary the
  // same terrain at 5 m; each whole, the master moved into a frame of unknown scale. The DSM images
  // differ in scale by 4 x the frame's cell jitter, and the 5 m slope image shows detail the 20 m
  // one never had.
  // Fine relief (bumps of 1-3 cells) on top of the hills: what a fine DSM shows and a coarse one
  // averages away, as a 2 m lidar DSM shows boulders and gullies a 10 m photogrammetric DSM misses.
  const diachron::Dsm hills = synthetic_world();
  diachron::Raster<float> z = hills.heights();
  diachron::RandomStream rng(23);
  const double amplitude = 8.0;  // m; at 2 and 4 m SIFT still matched the 5 m image to the 20 m one
  for (int i = 0; i < z.width() * z.height() / 12; ++i) {
    const double bx = rng.uniform(0, z.width()), by = rng.uniform(0, z.height()), r = rng.uniform(1.0, 3.0);
    const double a = rng.uniform(-amplitude, amplitude);
    for (int y = std::max(0, int(by - 3 * r)); y < std::min(z.height(), int(by + 3 * r) + 1); ++y)
      for (int x = std::max(0, int(bx - 3 * r)); x < std::min(z.width(), int(bx + 3 * r) + 1); ++x)
        z(x, y) += static_cast<float>(a * std::exp(-((x - bx) * (x - bx) + (y - by) * (y - by)) / (r * r)));
  }
  const diachron::Dsm world(std::move(z), hills.transform(), hills.crs());
  diachron::CoregistrationCaseOptions case_options;
  case_options.crop_windows = false;
  const auto c = diachron::make_coregistration_case(diachron::coarsen_dsm(world, 4), world, case_options, 5);
  diachron::RoughCoregistrationOptions without;
  without.scale_hypotheses.enabled = false;
  without.scale_hypotheses.upsample_below_px = 0;  // neither coarser levels nor enlarged images
  without.correlation_fallback = false;              // nor the dense search: the feature path alone
  const auto failed = diachron::rough_coregistration(c.master, c.secondary, sift_matcher(), without);
  INFO("without: " << failed.message);
  CHECK_FALSE(failed.success);
  REQUIRE(failed.scale_hypotheses.size() == 1);

  const auto report = diachron::rough_coregistration(c.master, c.secondary, sift_matcher());
  INFO("with: " << report.message);
  REQUIRE(report.success);
  const auto err = diachron::helmert_error_on_overlap(report.epoch2_from_epoch1, c);
  REQUIRE(err.valid);
  // Within 2 cells of the coarser DSM (20 m): no match is more precise than its image.
  CHECK(err.rms < 2.0 * 4.0 * world.min_cell_size());
  // The DSMs as given came first and failed; the winner coarsened the secondary (more valid cells).
  REQUIRE(report.scale_hypotheses.size() >= 2);
  CHECK_FALSE(report.scale_hypotheses.front().success);
  REQUIRE(report.best_scale_hypothesis > 0);
  const auto& winner = report.scale_hypotheses[static_cast<std::size_t>(report.best_scale_hypothesis)];
  CHECK(winner.success);
  CHECK(winner.hypothesis.master_level == 0);
  CHECK(winner.hypothesis.secondary_level >= 1);
  CHECK(report.secondary_image_factor ==
        Approx(static_cast<double>(winner.hypothesis.secondary_factor()) / winner.secondary_upsample));
  CHECK(winner.inliers >= winner.required_inliers);
  CHECK(winner.secondary_width == winner.secondary_upsample *
                                      ((world.width() + winner.hypothesis.secondary_factor() - 1) /
                                       winner.hypothesis.secondary_factor()));
  for (const auto& h : report.scale_hypotheses) CHECK(h.seconds >= 0.0);
}

TEST_CASE("scale hypotheses: the plan, and coarsen_dsm keeps the ground", "[pipeline]") {
  diachron::ScaleHypothesesOptions options;
  // The secondary has more valid cells: its levels first, then the master's; 48-cell floor.
  const auto plan = diachron::plan_scale_hypotheses(100, 120, 10000, 400, 480, 190000, options);
  REQUIRE(plan.size() == 5);  // 1, s/2, s/4, s/8 (400 / 8 = 50 >= 48), m/2 (100 / 4 < 48 stops there)
  CHECK(plan[0].name() == "1");
  CHECK(plan[1].name() == "s/2");
  CHECK(plan[3].name() == "s/8");
  CHECK(plan[4].name() == "m/2");
  options.enabled = false;
  CHECK(diachron::plan_scale_hypotheses(100, 120, 10000, 400, 480, 190000, options).size() == 1);
  options.max_level = 9;
  CHECK_THROWS_AS(options.check(), diachron::Error);

  const diachron::Dsm world = synthetic_world(40, 30);
  const diachron::Dsm coarse = diachron::coarsen_dsm(world, 4);
  REQUIRE(coarse.width() == 10);
  REQUIRE(coarse.height() == 8);  // 30 / 4 rounded up: a partial last block
  CHECK(coarse.min_cell_size() == Approx(20.0));
  // Cell (1, 1) is the mean of the 5 m cells 4..7 x 4..7, centred where their centres' mean is.
  double mean = 0.0;
  for (int y = 4; y < 8; ++y)
    for (int x = 4; x < 8; ++x) mean += world.heights()(x, y) / 16.0;
  CHECK(coarse.heights()(1, 1) == Approx(mean).epsilon(1e-6));
  const Eigen::Vector2d centre = world.pixel_to_world({5.5, 5.5});
  CHECK((coarse.pixel_to_world({1.0, 1.0}) - centre).norm() < 1e-6);
}

TEST_CASE("scale hypotheses: small DSM images are enlarged on the same ground", "[pipeline]") {
  // The factor: the smallest power of two that brings the shorter side to the floor, capped.
  CHECK(diachron::upsample_factor(200, 160, 4) == 1);
  CHECK(diachron::upsample_factor(100, 160, 4) == 2);
  CHECK(diachron::upsample_factor(30, 160, 4) == 4);  // 120 px: capped at 4
  CHECK(diachron::upsample_factor(30, 0, 4) == 1);    // 0: never
  diachron::ScaleHypothesesOptions options;
  options.max_upsample = 3;
  CHECK_THROWS_AS(options.check(), diachron::Error);

  // A ramp along x: bilinear enlargement keeps it a ramp, and every enlarged pixel's ground (through
  // upsample_transform) is where the small image has that value.
  diachron::Raster<std::uint8_t> small(6, 4, 0);
  for (int y = 0; y < small.height(); ++y)
    for (int x = 0; x < small.width(); ++x) small(x, y) = static_cast<std::uint8_t>(40 * x + 3 * y);
  const diachron::GeoTransform g{{1000.0, 8.0, 2.0, 5000.0, 1.5, -7.0}};  // rotated, sheared cells
  const int f = 4;
  const auto big = diachron::upsample_bilinear(small, f);
  const diachron::GeoTransform gb = diachron::upsample_transform(g, f);
  REQUIRE(big.width() == 24);
  REQUIRE(big.height() == 16);
  for (int y = 2; y < 14; ++y)  // away from the clamped borders
    for (int x = 2; x < 22; ++x) {
      const Eigen::Vector2d p = g.world_to_pixel(gb.pixel_to_world(Eigen::Vector2d(x, y)));
      CHECK(big(x, y) == Approx(40.0 * p.x() + 3.0 * p.y()).margin(0.51));
    }
  // The corners of the footprint are unchanged.
  CHECK((gb.pixel_to_world({-0.5, -0.5}) - g.pixel_to_world({-0.5, -0.5})).norm() < 1e-9);
  CHECK((gb.pixel_to_world({23.5, 15.5}) - g.pixel_to_world({5.5, 3.5})).norm() < 1e-9);
}

namespace {
// A matcher that never finds anything: the feature path fails on every hypothesis.
struct BlindMatcher {
  std::vector<diachron::PointMatch> match(const diachron::Raster<std::uint8_t>&, const diachron::Raster<std::uint8_t>&) const {
    return {};
  }
};
}  // namespace

TEST_CASE("rough_coregistration: the correlation fallback (on by default) answers when the features find nothing",
          "[pipeline]") {
  const diachron::CoregistrationCase c = synthetic_case(7);
  diachron::RoughCoregistrationOptions options;
  CHECK(options.correlation_fallback);
  options.scale_hypotheses.enabled = false;  // one failing feature hypothesis is enough here
  options.correlation_fallback = false;
  const auto without = diachron::rough_coregistration(c.master, c.secondary, BlindMatcher{}, options);
  CHECK_FALSE(without.success);
  CHECK_FALSE(without.correlation_ran);
  options.correlation_fallback = true;
  const auto with = diachron::rough_coregistration(c.master, c.secondary, BlindMatcher{}, options);
  INFO(with.message);
  REQUIRE(with.success);
  CHECK(with.correlation_ran);
  CHECK(with.correlation_used);
  CHECK(with.correlation.score > 0.8);
  CHECK(with.seconds.correlation > 0.0);
  // Its residuals cannot tell a right placement from a wrong one: never graded high.
  CHECK(with.trust == diachron::RoughCoregistrationTrust::kLow);
  const diachron::HelmertError e = diachron::helmert_error_on_overlap(with.epoch2_from_epoch1, c);
  REQUIRE(e.valid);
  CHECK(e.rms < 1.0 * c.secondary.min_cell_size());
}

TEST_CASE("rough_coregistration: a winner the search refuses is the answer only when the surfaces confirm it",
          "[pipeline]") {
  diachron::RoughCoregistrationOptions options;
  CHECK(options.surface_confirmation);
  options.scale_hypotheses.enabled = false;
  // A margin no winner reaches, and no answer by tiles: the search refuses every winner.
  options.correlation_search.min_margin = 1.99;
  options.correlation_search.max_tile_chance = 0.0;

  const diachron::CoregistrationCase c = synthetic_case(7);
  options.surface_confirmation = false;
  const auto refused = diachron::rough_coregistration(c.master, c.secondary, BlindMatcher{}, options);
  INFO(refused.message);
  CHECK_FALSE(refused.success);
  CHECK(refused.correlation_ran);
  CHECK_FALSE(refused.confirmed_by_surface);
  CHECK(refused.message.find("margin") != std::string::npos);

  options.surface_confirmation = true;
  const auto confirmed = diachron::rough_coregistration(c.master, c.secondary, BlindMatcher{}, options);
  INFO(confirmed.message);
  REQUIRE(confirmed.success);
  CHECK(confirmed.correlation_used);
  CHECK(confirmed.confirmed_by_surface);
  CHECK(confirmed.trust == diachron::RoughCoregistrationTrust::kLow);
  CHECK(confirmed.surface.accepted);
  CHECK(confirmed.agreement.valid);
  CHECK(confirmed.agreement.noise_ratio <= options.surface_confirmation_max_noise_ratio);
  CHECK(confirmed.message.find("confirmed by the surfaces") != std::string::npos);
  const diachron::HelmertError e = diachron::helmert_error_on_overlap(confirmed.epoch2_from_epoch1, c);
  REQUIRE(e.valid);
  CHECK(e.rms < 0.5 * c.secondary.min_cell_size());

  // A ratio no placement reaches: the same winner is refused, with the measured ratio in the reason.
  options.surface_confirmation_max_noise_ratio = 1e-3;
  const auto strict = diachron::rough_coregistration(c.master, c.secondary, BlindMatcher{}, options);
  INFO(strict.message);
  CHECK_FALSE(strict.success);
  CHECK(strict.message.find("not confirmed by the surfaces") != std::string::npos);
  CHECK(strict.message.find("a ratio above") != std::string::npos);
  options.surface_confirmation_max_noise_ratio = 3.0;
  // Nor when the overlap is fewer cells of the coarser DSM than asked for.
  options.surface_confirmation_min_cells = 1e9;
  const auto small = diachron::rough_coregistration(c.master, c.secondary, BlindMatcher{}, options);
  INFO(small.message);
  CHECK_FALSE(small.success);
  CHECK(small.message.find("fewer cells than") != std::string::npos);
  options.surface_confirmation_min_cells = 500.0;

  // Two terrains that share no ground: whatever the search's winner, the surfaces do not confirm it.
  const diachron::Dsm elsewhere = synthetic_world(420, 360, 29);
  diachron::CoregistrationCaseOptions case_options;
  case_options.overlap_min = case_options.overlap_max = 0.7;
  const diachron::Dsm foreign = diachron::make_coregistration_case(elsewhere, elsewhere, case_options, 8).secondary;
  const auto apart = diachron::rough_coregistration(c.master, foreign, BlindMatcher{}, options);
  INFO(apart.message);
  CHECK_FALSE(apart.success);
  CHECK_FALSE(apart.confirmed_by_surface);
}
