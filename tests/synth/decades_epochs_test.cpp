// Tests of SceneOptions::decades_apart(N) for N = 2 to 5 epochs: two epochs are the two-epoch preset
// value for value, more epochs add film flights of their own between it and the recent flight, the
// landscape's changes come in steps whose total is the two-epoch change, and a small three-epoch
// scene has check points in every epoch.

#include <array>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/synth/scene.hpp>

using namespace diachron;

namespace {

// Every option of an epoch that shapes its images, model and DSM.
bool same_epoch(const EpochOptions& a, const EpochOptions& b) {
  const LookOptions& l = a.look;
  const LookOptions& m = b.look;
  const SfmDsmOptions& d = a.dsm;
  const SfmDsmOptions& e = b.dsm;
  return a.name == b.name && a.rows == b.rows && a.columns == b.columns && a.forward_overlap == b.forward_overlap &&
         a.side_overlap == b.side_overlap && a.flying_height_m == b.flying_height_m && a.heading_deg == b.heading_deg &&
         a.alternate_direction == b.alternate_direction && a.block_offset_m == b.block_offset_m &&
         a.attitude_sigma_deg == b.attitude_sigma_deg && a.yaw_sigma_deg == b.yaw_sigma_deg &&
         a.position_sigma_m == b.position_sigma_m && a.image_width_px == b.image_width_px &&
         a.image_height_px == b.image_height_px && a.focal_px == b.focal_px &&
         a.principal_point_offset_px == b.principal_point_offset_px && a.distortion == b.distortion &&
         a.estimated_focal_scale == b.estimated_focal_scale &&
         a.estimated_principal_point_error_px == b.estimated_principal_point_error_px &&
         a.estimated_distortion_fraction == b.estimated_distortion_fraction && a.tie_points == b.tie_points &&
         a.tie_noise_px == b.tie_noise_px && l.sun_azimuth_deg == m.sun_azimuth_deg &&
         l.sun_elevation_deg == m.sun_elevation_deg && l.shading == m.shading && l.gain == m.gain &&
         l.offset == m.offset && l.contrast == m.contrast && l.gamma == m.gamma && l.vignetting == m.vignetting &&
         l.blur_sigma_px == m.blur_sigma_px && l.grain_sigma == m.grain_sigma && l.scratches == m.scratches &&
         l.dust_per_megapixel == m.dust_per_megapixel && l.background == m.background &&
         l.cast_shadow == m.cast_shadow && l.land_cover.gain == m.land_cover.gain &&
         l.land_cover.offset == m.land_cover.offset && l.tone_curve == m.tone_curve &&
         l.exposure_unevenness == m.exposure_unevenness && l.unevenness_wavelength == m.unevenness_wavelength &&
         l.grain_size_px == m.grain_size_px && l.scan_line_sigma == m.scan_line_sigma &&
         l.scan_stripes == m.scan_stripes && l.jpeg_quality == m.jpeg_quality && d.cell_gsd == e.cell_gsd &&
         d.noise_sigma_m == e.noise_sigma_m && d.ripple_m == e.ripple_m && d.hole_fraction == e.hole_fraction &&
         d.hole_radius_m == e.hole_radius_m && d.min_views == e.min_views && d.dome_m == e.dome_m &&
         a.frame.is_world == b.frame.is_world && a.frame.max_tilt_deg == b.frame.max_tilt_deg;
}

// The film flights' camera: focal length, flying height, principal point and distortion.
bool same_camera(const EpochOptions& a, const EpochOptions& b) {
  return a.focal_px == b.focal_px && a.flying_height_m == b.flying_height_m &&
         a.principal_point_offset_px == b.principal_point_offset_px && a.distortion == b.distortion;
}

}  // namespace

TEST_CASE("decades_apart(2) is the two-epoch preset, value for value", "[synth][decades]") {
  const SceneOptions o = SceneOptions::decades_apart(2);
  const SceneOptions d = SceneOptions::decades_apart();
  REQUIRE(o.epochs.size() == 2);
  REQUIRE(d.epochs.size() == 2);
  CHECK(same_epoch(o.epochs[0], d.epochs[0]));
  CHECK(same_epoch(o.epochs[1], d.epochs[1]));

  // The values the two-epoch preset had before it took a number of epochs (make_scene --preset
  // decades --seed 0 was checked to write the same bytes): a change of them changes every scene
  // the benchmarks and docs measured.
  const ChangeOptions& c = o.changes;
  CHECK(c.changed_field_fraction == 0.85);
  CHECK(c.redrawn_layout_fraction == 0.5);
  CHECK(c.layout_region_m == 350.0);
  CHECK(c.consolidation == 1.8);
  CHECK(c.seasonal_shift == 0.12);
  CHECK(c.removed_building_fraction == 0.2);
  CHECK(c.new_building_fraction == 0.7);
  CHECK(c.new_villages_per_km2 == 0.6);
  CHECK(c.new_roads == 2);
  CHECK(c.tree_growth == 0.35);
  CHECK(c.cut_tree_fraction == 0.35);
  CHECK(c.new_tree_fraction == 0.6);
  CHECK(c.cleared_stand_fraction == 0.25);
  CHECK(c.new_stand_fraction == 0.3);
  CHECK(o.texture.bush_removal_probability == 0.5);
  CHECK(o.texture.texel_m == 0.5);
  CHECK(o.check_points == 150);
  CHECK(o.terrain.building_density_per_km2 == 110.0);
  CHECK(o.terrain.relief_amplitude_m == 25.0);
  CHECK(o.terrain.relief_octaves == 7);

  const EpochOptions& e1 = o.epochs[0];
  CHECK(e1.name == "e1");
  CHECK(e1.focal_px == 1056.0);
  CHECK(e1.flying_height_m == 1056.0);
  CHECK(e1.rows == 2);
  CHECK(e1.columns == 2);
  CHECK(e1.heading_deg == 0.0);
  CHECK(e1.block_offset_m == Eigen::Vector2d::Zero());
  CHECK(e1.principal_point_offset_px == Eigen::Vector2d(6.0, -8.0));
  CHECK(e1.estimated_principal_point_error_px == Eigen::Vector2d(8.0, -4.0));
  CHECK(e1.distortion == EpochOptions::historical().distortion);
  CHECK(e1.look.sun_azimuth_deg == 125.0);
  CHECK(e1.look.sun_elevation_deg == 35.0);
  CHECK(e1.look.land_cover.gain == std::array<double, kLandCoverCount>{-0.8, 0.6, 0.8, 1.1, 0.9});
  CHECK(e1.look.tone_curve == 6.0);
  CHECK(e1.look.grain_sigma == 0.04);
  CHECK(e1.look.blur_sigma_px == 1.0);
  CHECK(e1.dsm.cell_gsd == 2.0);
  CHECK(e1.dsm.dome_m == 3.0);
  CHECK(e1.dsm.hole_fraction == 0.08);

  const EpochOptions& e2 = o.epochs[1];
  CHECK(e2.name == "e2");
  CHECK(e2.focal_px == 1680.0);
  CHECK(e2.flying_height_m == 840.0);
  CHECK(e2.rows == 3);
  CHECK(e2.columns == 3);
  CHECK(e2.heading_deg == 12.0);
  CHECK(e2.block_offset_m == Eigen::Vector2d(40.0, -30.0));
  CHECK(e2.look.sun_azimuth_deg == 230.0);
  CHECK(e2.look.land_cover.gain == std::array<double, kLandCoverCount>{1.0, 0.9, 2.6, 0.8, 1.0});
  CHECK(e2.look.jpeg_quality == 75);
  CHECK(e2.dsm.dome_m == 0.0);
}

TEST_CASE("decades_apart(N), N = 3 to 5: film flights of their own, oldest first, the recent one last",
          "[synth][decades]") {
  const SceneOptions two = SceneOptions::decades_apart(2);
  for (int n = 3; n <= 5; ++n) {
    INFO("epochs " << n);
    const SceneOptions o = SceneOptions::decades_apart(n);
    REQUIRE_NOTHROW(o.check());
    REQUIRE(o.epochs.size() == static_cast<std::size_t>(n));
    std::set<std::string> names;
    for (int k = 0; k < n; ++k) {
      CHECK(o.epochs[static_cast<std::size_t>(k)].name == "e" + std::to_string(k + 1));
      names.insert(o.epochs[static_cast<std::size_t>(k)].name);
    }
    CHECK(names.size() == static_cast<std::size_t>(n));

    // The last epoch is the two-epoch preset's recent flight under its new name.
    EpochOptions recent = o.epochs.back();
    CHECK(recent.name == "e" + std::to_string(n));
    recent.name = "e2";
    CHECK(same_epoch(recent, two.epochs[1]));

    // Up to four epochs the first is the 1960s flight, so the span of the change is the same.
    if (n <= 4) CHECK(same_epoch(o.epochs[0], two.epochs[0]));

    for (std::size_t k = 0; k + 1 < o.epochs.size(); ++k) {
      const EpochOptions& film = o.epochs[k];
      INFO("film epoch " << film.name);
      CHECK(film.gsd_m() >= 0.7 - 1e-12);
      CHECK(film.gsd_m() <= 1.2 + 1e-12);
      CHECK(film.gsd_m() > recent.gsd_m());
      CHECK(film.look.jpeg_quality == 0);
      CHECK(film.look.tone_curve > 0.0);
      CHECK(film.look.cast_shadow > 0.0);
      CHECK(film.dsm.dome_m > 0.0);
      for (std::size_t j = 0; j < k; ++j) {
        const EpochOptions& older = o.epochs[j];
        CHECK_FALSE(same_camera(older, film));
        CHECK(older.look.sun_azimuth_deg != film.look.sun_azimuth_deg);
        // Older: coarser, grainier, more blurred, a worse DSM.
        CHECK(older.gsd_m() > film.gsd_m());
        CHECK(older.look.grain_sigma > film.look.grain_sigma);
        CHECK(older.look.blur_sigma_px > film.look.blur_sigma_px);
        CHECK(older.dsm.noise_sigma_m > film.dsm.noise_sigma_m);
        CHECK(older.dsm.dome_m > film.dsm.dome_m);
        CHECK(older.dsm.hole_fraction > film.dsm.hole_fraction);
      }
    }
  }
}

TEST_CASE("decades_apart(N): the changes come in steps whose total is the two-epoch change", "[synth][decades]") {
  const SceneOptions two = SceneOptions::decades_apart(2);
  const ChangeOptions& total = two.changes;
  for (int n = 3; n <= 5; ++n) {
    INFO("epochs " << n);
    const int steps = n - 1;
    const SceneOptions o = SceneOptions::decades_apart(n);
    const ChangeOptions& c = o.changes;
    const auto at_least_once = [&](double p) { return 1.0 - std::pow(1.0 - p, steps); };
    CHECK(std::abs(at_least_once(c.changed_field_fraction) - total.changed_field_fraction) < 1e-12);
    CHECK(std::abs(at_least_once(c.redrawn_layout_fraction) - total.redrawn_layout_fraction) < 1e-12);
    CHECK(std::abs(at_least_once(c.removed_building_fraction) - total.removed_building_fraction) < 1e-12);
    CHECK(std::abs(at_least_once(c.cut_tree_fraction) - total.cut_tree_fraction) < 1e-12);
    CHECK(std::abs(at_least_once(c.cleared_stand_fraction) - total.cleared_stand_fraction) < 1e-12);
    CHECK(std::abs(at_least_once(o.texture.bush_removal_probability) - two.texture.bush_removal_probability) < 1e-12);
    CHECK(c.changed_field_fraction < total.changed_field_fraction);
    CHECK(std::abs(steps * c.new_building_fraction - total.new_building_fraction) < 1e-12);
    CHECK(std::abs(steps * c.new_villages_per_km2 - total.new_villages_per_km2) < 1e-12);
    CHECK(std::abs(steps * c.new_tree_fraction - total.new_tree_fraction) < 1e-12);
    CHECK(std::abs(steps * c.new_stand_fraction - total.new_stand_fraction) < 1e-12);
    CHECK(std::abs(std::pow(1.0 + c.tree_growth, steps) - (1.0 + total.tree_growth)) < 1e-12);
    // Whole roads: the fewest per step that give at least the total.
    CHECK(c.new_roads * steps >= total.new_roads);
    CHECK((c.new_roads - 1) * steps < total.new_roads);
    // Not rates: the same at every step.
    CHECK(c.seasonal_shift == total.seasonal_shift);
    CHECK(c.layout_region_m == total.layout_region_m);
    CHECK(c.consolidation == total.consolidation);
    REQUIRE_NOTHROW(c.check());
  }
  // One step is the total itself, bit for bit.
  const ChangeOptions one = changes_per_step(total, 1);
  CHECK(one.changed_field_fraction == total.changed_field_fraction);
  CHECK(one.tree_growth == total.tree_growth);
  CHECK(one.new_building_fraction == total.new_building_fraction);
  CHECK(per_step_fraction(0.3, 1) == 0.3);
  CHECK(per_step_growth(0.35, 1) == 0.35);
  CHECK(per_step_fraction(1.0, 3) == 1.0);
  CHECK(per_step_fraction(0.0, 3) == 0.0);
  CHECK_THROWS_AS(per_step_fraction(1.5, 2), Error);
  CHECK_THROWS_AS(per_step_growth(-0.1, 2), Error);
  CHECK_THROWS_AS(changes_per_step(total, 0), Error);
}

TEST_CASE("decades_apart: epochs outside [2, 5] throw, naming the range", "[synth][decades]") {
  for (int n : {-1, 0, 1, 6, 100}) {
    INFO("epochs " << n);
    CHECK_THROWS_AS(SceneOptions::decades_apart(n), Error);
    CHECK_THROWS_WITH(SceneOptions::decades_apart(n), Catch::Contains("[2, 5]"));
  }
}

TEST_CASE("a small three-epoch decades scene has check points seen in every epoch", "[synth][decades]") {
  // The preset with 400 x 300 px images and focal lengths, flying heights and block offsets a
  // quarter of the preset's: the same GSDs and blocks over a study area a quarter as wide.
  SceneOptions o = SceneOptions::decades_apart(3);
  o.seed = 3;
  o.check_points = 30;
  for (EpochOptions& e : o.epochs) {
    e.image_width_px = 400;
    e.image_height_px = 300;
    e.focal_px /= 4.0;
    e.flying_height_m /= 4.0;
    e.block_offset_m /= 4.0;
    e.tie_points = 100;
  }
  const Scene scene = generate_scene(o);
  REQUIRE(scene.epochs.size() == 3);
  CHECK(scene.epochs[0].images.size() == 4);
  CHECK(scene.epochs[1].images.size() == 6);
  CHECK(scene.epochs[2].images.size() == 9);
  CHECK(scene.check_points.size() >= 20);
  for (const CheckPoint& cp : scene.check_points) {
    std::set<int> epochs;
    for (const CheckPoint::Observation& obs : cp.observations) epochs.insert(obs.epoch);
    CHECK(epochs == std::set<int>{0, 1, 2});
  }
}
