// Tests of the effects of decades in the synthetic scenes: the decades_apart() preset, cast
// shadows against a brute-force ray test, trees in the true surface and the DSM, land-cover
// responses, decades of landscape change, the film radiometry and the JPEG-like compression.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/synth/compression.hpp>
#include <diachron/synth/scene.hpp>

using namespace diachron;

namespace {

// The preset at a quarter of the image size (same fields of view, so four times the GSD), with
// coarser texels and 2 m ground cells (the images' GSD is 2 to 4 m here): a scene that generates in
// a second or two, for the tests. The cast shadows over the ground grid are most of its cost, ten
// times more under the sanitizers, and a quarter of the cells quarters them.
SceneOptions small_decades(std::uint64_t seed) {
  SceneOptions o = SceneOptions::decades_apart();
  o.terrain.cell_m = 2.0;
  o.seed = seed;
  for (EpochOptions& e : o.epochs) {
    e.image_width_px /= 4;
    e.image_height_px /= 4;
    e.focal_px /= 4.0;
    e.tie_points = 200;
  }
  o.texture.texel_m = 1.0;
  o.check_points = 30;
  return o;
}

// Flat ground at 100 m with nothing on it, over a 200 x 200 m box.
Landscape flat_land() {
  TerrainOptions t;
  t.relief_amplitude_m = 0.0;
  t.landform = Landform::none;
  t.base_height_m = 100.0;
  t.road_count = 0;
  t.building_density_per_km2 = 0.0;
  return make_landscape(t, ChangeOptions{}, WorldBounds{-100.0, -100.0, 100.0, 100.0}, 2, 7);
}

}  // namespace

TEST_CASE("decades_apart: two epochs, e1 historical at twice the GSD of e2, every effect on", "[synth][decades]") {
  const SceneOptions o = SceneOptions::decades_apart();
  REQUIRE_NOTHROW(o.check());
  REQUIRE(o.epochs.size() == 2);
  const EpochOptions& e1 = o.epochs[0];
  const EpochOptions& e2 = o.epochs[1];
  CHECK(e1.name == "e1");
  CHECK(e2.name == "e2");
  CHECK(e1.gsd_m() == Approx(2.0 * e2.gsd_m()));
  for (const EpochOptions& e : o.epochs) {
    CHECK(e.image_width_px >= 1600);
    CHECK(e.image_height_px >= 1200);
    CHECK(e.look.cast_shadow > 0.0);
  }
  CHECK(o.terrain.vegetation.any());
  CHECK(o.changes.redrawn_layout_fraction > 0.0);
  CHECK(o.changes.new_roads > 0);
  CHECK(e1.look.tone_curve > 0.0);
  CHECK(e1.look.grain_size_px > 0.0);
  CHECK(e2.look.jpeg_quality > 0);
  CHECK(e1.dsm.dome_m > 0.0);
  CHECK(e1.dsm.noise_sigma_m > e2.dsm.noise_sigma_m);
  CHECK(e1.dsm.hole_fraction > e2.dsm.hole_fraction);
  // Some class is rendered with opposite contrast by the two films.
  bool inverted = false;
  for (std::size_t k = 0; k < static_cast<std::size_t>(kLandCoverCount); ++k)
    inverted = inverted || (e1.look.land_cover.gain[k] < 0.0) != (e2.look.land_cover.gain[k] < 0.0);
  CHECK(inverted);
  // Suns far apart, so cast shadows fall on other sides.
  CHECK(std::abs(e1.look.sun_azimuth_deg - e2.look.sun_azimuth_deg) >= 60.0);
}

// The tracer behind renders, shadows and the truth keeps a pointer to its DSM: no temporaries.
static_assert(std::is_constructible_v<detail::SurfaceTracer, const Dsm&>);
static_assert(!std::is_constructible_v<detail::SurfaceTracer, Dsm&&>);

TEST_CASE("cast shadows: the shading map agrees with a brute-force ray test around a tower", "[synth][decades]") {
  Landscape land = flat_land();
  Building tower;
  tower.centre = Vec2(0.0, 0.0);
  tower.half_length = 8.0;
  tower.half_width = 6.0;
  tower.yaw = 0.3;
  tower.base_z = 100.0;
  tower.eave_height = 20.0;
  land.buildings.push_back(tower);
  const Dsm surface = surface_dsm(land, 0);

  LookOptions look;
  look.shading = 0.6;
  look.cast_shadow = 1.0;
  look.sun_azimuth_deg = 210.0;
  look.sun_elevation_deg = 40.0;
  const AlbedoMap with = shading_map(surface, look, 2);
  look.cast_shadow = 0.0;
  const AlbedoMap without = shading_map(surface, look, 2);
  const Vec3 sun = detail::sun_direction(look);

  // Brute force: a ground cell is in shadow when the ray to the sun passes through the tower box.
  int agree = 0, compared = 0, shadowed = 0;
  for (int y = 0; y < surface.height(); ++y)
    for (int x = 0; x < surface.width(); ++x) {
      const Vec2 xy = surface.transform().pixel_to_world(Vec2(x, y));
      const Vec2 local = tower.local(xy);
      // Skip the tower and a 1.5 m band around it and around the shadow's edge (the surface is
      // bilinear between cell centres, so the walls are one cell wide).
      if (std::abs(local.x()) < tower.half_length + 1.5 && std::abs(local.y()) < tower.half_width + 1.5) continue;
      // How deep the ray to the sun goes into the box (negative: how far it passes from it).
      double depth = -std::numeric_limits<double>::infinity();
      for (double t = 0.0; t < 60.0; t += 0.05) {
        const Vec3 p = Vec3(xy.x(), xy.y(), 100.0) + t * sun;
        const Vec2 l = tower.local(p.head<2>());
        depth = std::max(depth, std::min({tower.half_length - std::abs(l.x()), tower.half_width - std::abs(l.y()),
                                          tower.base_z + tower.eave_height - p.z()}));
      }
      const bool inside = depth > 0.0;
      const bool near_edge = std::abs(depth) < 1.5;
      if (near_edge) continue;
      ++compared;
      const bool dark = with.values(x, y) < without.values(x, y) - 0.1f;
      if (dark == inside) ++agree;
      if (inside) ++shadowed;
    }
  REQUIRE(compared > 20000);
  CHECK(shadowed > 150);  // 20 m tall at 40 degrees: a shadow of about 24 m beyond the tower
  CHECK(agree == compared);
  // A shadowed cell keeps only the sky light, 1 - shading.
  const Vec2 behind = Vec2(0.0, 0.0) - 18.0 * Vec2(std::cos(deg_to_rad(210.0)), std::sin(deg_to_rad(210.0)));
  const Vec2 p = surface.world_to_pixel(behind);
  CHECK(with.values(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y()))) == Approx(0.4f));
}

TEST_CASE("trees: in the true surface, growing, cut and cleared between epochs", "[synth][decades]") {
  TerrainOptions t;
  t.relief_amplitude_m = 2.0;
  t.building_density_per_km2 = 20.0;
  t.vegetation.forest_fraction = 0.1;
  t.vegetation.single_trees_per_km2 = 100.0;
  t.vegetation.hedgerows_per_km2 = 10.0;
  ChangeOptions c;
  c.tree_growth = 0.3;
  c.cut_tree_fraction = 0.4;
  c.new_tree_fraction = 0.5;
  c.cleared_stand_fraction = 0.5;
  c.new_stand_fraction = 0.5;
  const Landscape land = make_landscape(t, c, WorldBounds{0.0, 0.0, 1500.0, 1500.0}, 2, 11);
  REQUIRE(land.trees.size() > 500);
  const Dsm s0 = surface_dsm(land, 0);
  const Dsm s1 = surface_dsm(land, 1);
  int standing = 0, grown = 0, gone = 0, born = 0, first_epoch_trees = 0;
  for (const Tree& tree : land.trees) {
    CHECK(tree.height_in(1) >= tree.height_in(0));
    for (int e = 0; e < 2; ++e) {
      const double top = (e == 0 ? s0 : s1).height_at(tree.centre);
      // Crowns narrower than two cells may fall between the grid's cell centres.
      if (tree.exists_in(e) && tree.crown_radius(e) >= 2.0 * t.cell_m) {
        // The crown top is the tree's height (or higher where crowns overlap).
        CHECK(top >= tree.base_z + tree.height_in(e) - 0.35 * tree.height_in(e));
      }
      if (tree.exists_in(e) && e == 0) ++standing;
    }
    if (tree.first_epoch == 0) ++first_epoch_trees;
    if (tree.exists_in(0) && tree.exists_in(1) && tree.height_in(1) > 1.05 * tree.height_in(0)) ++grown;
    if (tree.exists_in(0) && !tree.exists_in(1)) ++gone;
    if (!tree.exists_in(0) && tree.exists_in(1)) ++born;
  }
  CHECK(standing > 400);
  CHECK(grown > standing / 2);
  CHECK(gone > standing / 5);   // cut singles and hedgerows, cleared stands
  CHECK(born > 50);             // new singles and young stands
  CHECK(first_epoch_trees == standing);
  // No tree grows through a building, in any epoch.
  for (const Tree& tree : land.trees)
    for (const Building& b : land.buildings) CHECK_FALSE(b.contains(tree.centre));
}

TEST_CASE("land-cover responses: per-class gain and offset, the identity changes nothing", "[synth][decades]") {
  TerrainOptions t;
  t.vegetation.single_trees_per_km2 = 300.0;
  const WorldBounds bounds{0.0, 0.0, 400.0, 300.0};
  const Landscape land = make_landscape(t, ChangeOptions{}, bounds, 2, 5);
  REQUIRE(!land.trees.empty());
  TextureOptions texture;
  texture.noise_amplitude = 0.0;  // so that the response is the whole difference
  const AlbedoMap plain = render_albedo(land, 0, bounds, texture, 9);
  const AlbedoMap identity = render_albedo(land, 0, bounds, texture, 9, LandCoverResponse{});
  CHECK(plain.values.width() == identity.values.width());
  CHECK(std::equal(plain.values.begin(), plain.values.end(), identity.values.begin()));

  // Every class at gain 0.5, offset 0.1: every texel is 0.1 + 0.5 of its plain albedo.
  LandCoverResponse half;
  half.gain.fill(0.5);
  half.offset.fill(0.1);
  const AlbedoMap halved = render_albedo(land, 0, bounds, texture, 9, half);
  std::size_t k = 0;
  double worst = 0.0;
  for (float v : plain.values) worst = std::max(worst, std::abs(halved.values.data()[k++] - (0.1 + 0.5 * v)));
  CHECK(worst < 1e-5);

  // Woody cover painted white: tree crowns turn 1, roads keep their albedo.
  LandCoverResponse white_trees;
  white_trees.gain[static_cast<std::size_t>(LandCover::woody)] = 0.0;
  white_trees.offset[static_cast<std::size_t>(LandCover::woody)] = 1.0;
  const AlbedoMap white = render_albedo(land, 0, bounds, texture, 9, white_trees);
  for (const Tree& tree : land.trees) {
    const Vec2 p = white.transform.world_to_pixel(tree.centre);
    const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
    if (white.values.contains(x, y)) CHECK(white.values(x, y) == 1.0f);
  }
  int road_texels = 0;
  for (const Road& road : land.roads)
    for (double s = -150.0; s <= 150.0; s += 7.0) {
      const Vec2 xy = road.point + s * road.direction;
      const Vec2 p = white.transform.world_to_pixel(xy);
      const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
      bool near_tree = false;
      for (const Tree& tree : land.trees) near_tree = near_tree || (tree.centre - xy).norm() < tree.crown_radius(0) + 2.0;
      if (!white.values.contains(x, y) || near_tree) continue;
      CHECK(white.values(x, y) == plain.values(x, y));
      ++road_texels;
    }
  CHECK(road_texels > 10);
}

TEST_CASE("decades of change: new roads, redrawn field layouts, more new buildings", "[synth][decades]") {
  TerrainOptions t;
  ChangeOptions c;
  c.new_roads = 3;
  c.redrawn_layout_fraction = 1.0;
  c.new_villages_per_km2 = 2.0;
  c.new_building_fraction = 0.8;
  const WorldBounds bounds{0.0, 0.0, 800.0, 800.0};
  const Landscape land = make_landscape(t, c, bounds, 2, 13);
  int new_roads = 0;
  for (const Road& road : land.roads) new_roads += road.first_epoch == 1 ? 1 : 0;
  CHECK(new_roads == 3);
  TextureOptions texture;
  texture.noise_amplitude = 0.0;
  const AlbedoMap a0 = render_albedo(land, 0, bounds, texture, 3);
  const AlbedoMap a1 = render_albedo(land, 1, bounds, texture, 3);
  // Every layout redrawn and every field's crop redrawn with it: almost no texel keeps its albedo.
  std::size_t same = 0;
  for (std::size_t k = 0; k < a0.values.size(); ++k) same += std::abs(a0.values.data()[k] - a1.values.data()[k]) < 1e-6f;
  CHECK(static_cast<double>(same) < 0.1 * static_cast<double>(a0.values.size()));
  // The new roads are painted in epoch 1 only.
  for (const Road& road : land.roads) {
    if (road.first_epoch != 1) continue;
    int differs = 0, samples = 0;
    for (double s = -300.0; s <= 300.0; s += 10.0) {
      const Vec2 p = a1.transform.world_to_pixel(road.point + s * road.direction);
      const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
      if (!a1.values.contains(x, y)) continue;
      ++samples;
      differs += std::abs(a1.values(x, y) - a0.values(x, y)) > 1e-6f;
    }
    CHECK(differs >= samples * 3 / 4);
  }
  // The plain change options (the few-year rates) redraw no layout: old hedges and borders stay.
  const Landscape plain = make_landscape(t, ChangeOptions{}, bounds, 2, 13);
  CHECK(plain.redrawn_layout_fraction == 0.0);
}

TEST_CASE("film radiometry: S curve, uneven exposure, clumped grain, scan lines", "[synth][decades]") {
  const int w = 256, h = 192;
  Raster<float> ramp(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) ramp(x, y) = static_cast<float>(x) / (w - 1);
  LookOptions clean;
  clean.vignetting = 0.0;
  clean.blur_sigma_px = 0.0;
  clean.grain_sigma = 0.0;
  clean.dust_per_megapixel = 0.0;

  SECTION("the S curve keeps black and white, is monotone, and steepens the middle") {
    LookOptions s = clean;
    s.tone_curve = 6.0;
    const Raster<std::uint8_t> a = develop_image(ramp, clean, 1, 2, 1);
    const Raster<std::uint8_t> b = develop_image(ramp, s, 1, 2, 1);
    CHECK(b(0, 10) == 0);
    CHECK(b(w - 1, 10) == 255);
    for (int x = 1; x < w; ++x) CHECK(b(x, 10) >= b(x - 1, 10));
    CHECK(b(w / 2 + 10, 10) - b(w / 2 - 10, 10) > a(w / 2 + 10, 10) - a(w / 2 - 10, 10));
    CHECK(b(10, 10) < a(10, 10));
  }
  SECTION("uneven exposure varies slowly across the image") {
    Raster<float> grey(w, h, 0.5f);
    LookOptions u = clean;
    u.exposure_unevenness = 0.3;
    const Raster<std::uint8_t> img = develop_image(grey, u, 1, 2, 1);
    int lo = 255, hi = 0, step = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        lo = std::min<int>(lo, img(x, y));
        hi = std::max<int>(hi, img(x, y));
        if (x > 0) step = std::max(step, std::abs(img(x, y) - img(x - 1, y)));
      }
    CHECK(hi - lo > 20);  // visible over the image
    CHECK(step <= 2);     // but no edge a detector would take for a feature
  }
  SECTION("clumped grain is correlated between neighbours, white grain is not; same sigma") {
    Raster<float> grey(w, h, 0.5f);
    const auto stats = [&](const LookOptions& look) {
      const Raster<std::uint8_t> img = develop_image(grey, look, 4, 5, 2);
      double sum = 0.0, sum2 = 0.0, cross = 0.0;
      int n = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 1; x < w; ++x) {
          const double a = img(x, y) - 127.5, b = img(x - 1, y) - 127.5;
          sum += a;
          sum2 += a * a;
          cross += a * b;
          ++n;
        }
      const double mean = sum / n, var = sum2 / n - mean * mean;
      return std::make_pair(std::sqrt(var) / 255.0, (cross / n - mean * mean) / var);
    };
    LookOptions white = clean;
    white.grain_sigma = 0.05;
    LookOptions clumped = white;
    clumped.grain_size_px = 1.5;
    const auto [sigma_white, corr_white] = stats(white);
    const auto [sigma_clumped, corr_clumped] = stats(clumped);
    CHECK(sigma_white == Approx(0.05).epsilon(0.1));
    CHECK(sigma_clumped == Approx(0.05).epsilon(0.1));
    CHECK(std::abs(corr_white) < 0.05);
    CHECK(corr_clumped > 0.6);
  }
  SECTION("scan lines: rows differ, columns of one row do not") {
    Raster<float> grey(w, h, 0.5f);
    LookOptions scan = clean;
    scan.scan_line_sigma = 0.02;
    const Raster<std::uint8_t> img = develop_image(grey, scan, 1, 2, 1);
    int rows_differing = 0;
    for (int y = 0; y < h; ++y) {
      for (int x = 1; x < w; ++x) CHECK(img(x, y) == img(0, y));
      if (y > 0 && img(0, y) != img(0, y - 1)) ++rows_differing;
    }
    CHECK(rows_differing > h / 2);
  }
  SECTION("develop_image is deterministic whatever the threads, with every effect on") {
    LookOptions all = EpochOptions::historical().look;
    all.tone_curve = 5.0;
    all.exposure_unevenness = 0.2;
    all.grain_size_px = 1.0;
    all.scan_line_sigma = 0.01;
    all.scan_stripes = 3;
    all.jpeg_quality = 60;
    const Raster<std::uint8_t> a = develop_image(ramp, all, 8, 9, 1);
    const Raster<std::uint8_t> b = develop_image(ramp, all, 8, 9, 3);
    CHECK(std::equal(a.begin(), a.end(), b.begin()));
  }
}

TEST_CASE("JPEG-like compression: the standard table, near-lossless at 100, lossy at 10", "[synth][decades]") {
  CHECK(jpeg_quantisation_table(50)[0] == 16);
  CHECK(jpeg_quantisation_table(50)[63] == 99);
  CHECK(jpeg_quantisation_table(100)[10] == 1);
  CHECK(jpeg_quantisation_table(10)[0] == 80);
  CHECK_THROWS_AS(jpeg_quantisation_table(0), Error);

  const int w = 67, h = 45;  // not multiples of 8: border blocks are padded
  Raster<std::uint8_t> img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      img(x, y) = static_cast<std::uint8_t>(std::clamp(128.0 + 60.0 * std::sin(0.3 * x) * std::cos(0.45 * y) + ((x * 7 + y * 13) % 11), 0.0, 255.0));
  const auto max_error = [&](const Raster<std::uint8_t>& out) {
    int worst = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) worst = std::max(worst, std::abs(out(x, y) - img(x, y)));
    return worst;
  };
  CHECK(max_error(jpeg_like_compress(img, 100)) <= 2);
  CHECK(max_error(jpeg_like_compress(img, 10)) > 10);
  // A constant image stays constant at any quality (only its DC coefficient is non-zero), and
  // exact when that coefficient is a multiple of the step (128: zero after the level shift).
  for (const std::uint8_t level : {std::uint8_t{128}, std::uint8_t{136}}) {
    const Raster<std::uint8_t> flat_out = jpeg_like_compress(Raster<std::uint8_t>(w, h, level), 5);
    CHECK(std::all_of(flat_out.begin(), flat_out.end(), [&](std::uint8_t v) { return v == flat_out(0, 0); }));
    if (level == 128) CHECK(flat_out(0, 0) == 128);
  }
  // Block artefacts: at low quality, differences across block borders exceed those inside blocks.
  const Raster<std::uint8_t> low = jpeg_like_compress(img, 5, 2);
  CHECK(std::equal(low.begin(), low.end(), jpeg_like_compress(img, 5, 1).begin()));
}

TEST_CASE("a small decades scene: trees in the SfM DSM, shadows in the images, a worse historical DSM", "[synth][decades]") {
  const Scene scene = generate_scene(small_decades(2));
  REQUIRE(scene.epochs.size() == 2);
  const SyntheticEpoch& e1 = scene.epochs[0];
  const SyntheticEpoch& e2 = scene.epochs[1];
  CHECK(e1.gsd_m == Approx(2.0 * e2.gsd_m));
  REQUIRE(!scene.landscape.trees.empty());

  // Standing trees show in each epoch's DSM: at the trunks, the DSM (back in metres) stands
  // above the bare ground by a good part of the trees' height. The DSM cells of this small scene
  // are 8 to 16 m, so single crowns blur away but forest canopies remain.
  for (int e = 0; e < 2; ++e) {
    const SyntheticEpoch& epoch = scene.epochs[static_cast<std::size_t>(e)];
    const Helmert3 to_epoch = epoch.epoch_from_world();
    std::vector<double> excess, heights;
    for (const Tree& tree : scene.landscape.trees) {
      if (!tree.exists_in(e)) continue;
      const Vec3 foot = to_epoch(Vec3(tree.centre.x(), tree.centre.y(), tree.base_z));
      const double z = epoch.dsm.height_at(foot.head<2>());
      if (!std::isfinite(z)) continue;
      excess.push_back((z - foot.z()) / to_epoch.scale);
      heights.push_back(tree.height_in(e));
    }
    INFO("epoch " << e);
    REQUIRE(excess.size() > 100);
    std::nth_element(excess.begin(), excess.begin() + static_cast<std::ptrdiff_t>(excess.size() / 2), excess.end());
    std::nth_element(heights.begin(), heights.begin() + static_cast<std::ptrdiff_t>(heights.size() / 2), heights.end());
    CHECK(excess[excess.size() / 2] > 0.3 * heights[heights.size() / 2]);
  }
  // The historical DSM has more holes than the recent one.
  const auto hole_share = [](const Dsm& d) {
    std::size_t holes = 0;
    for (float v : d.heights()) holes += std::isnan(v);
    return static_cast<double>(holes) / static_cast<double>(d.heights().size());
  };
  CHECK(hole_share(e1.dsm) > hole_share(e2.dsm));
  // The images are darker in cast shadows: the e2 shading map has cells at the sky-light level.
  const AlbedoMap shading = shading_map(e2.true_surface, SceneOptions::decades_apart().epochs[1].look, 2);
  std::size_t dark = 0;
  for (float v : shading.values) dark += v < 0.45f;
  CHECK(dark > shading.values.size() / 200);
}
