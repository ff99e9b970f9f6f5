#pragma once
/// @file
/// generate_scene(): a multi-epoch synthetic scene with complete ground truth, deterministic from
/// a seed. One terrain (procedural or a real DEM), per epoch a block of aerial images rendered by
/// ray casting through that epoch's surface, the epoch's SfM-like DSM in its own arbitrary frame,
/// true and "as estimated" orientations, intra-epoch tie points, and check points seen in every
/// epoch. Needs Eigen and the standard library only.
///
/// Frames: the world frame is metric, Z up (the DEM's CRS when a real DEM is used). Each epoch
/// has its own frame, related to the world by the true `world_from_epoch` Helmert; the true
/// `epoch2_from_epoch1` is `epoch_from_world(2) * world_from_epoch(1)` (Scene::transform).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/synth/epoch.hpp>
#include <diachron/synth/noise.hpp>
#include <diachron/synth/render.hpp>
#include <diachron/synth/terrain.hpp>
#include <diachron/synth/texture.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// A ground point seen in the images of every epoch, with its true pixel in each image that sees
/// it (no noise): the reference for check-point accuracy after co-registration.
struct CheckPoint {
  Eigen::Vector3d world = Eigen::Vector3d::Zero();  ///< world frame, metres
  struct Observation {
    int epoch = 0;                                   ///< index in Scene::epochs
    int image = 0;                                   ///< index in that epoch's images
    Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  ///< true pixel, px
  };
  std::vector<Observation> observations;
};

/// The probability of a change drawn anew at each of `steps` steps (an independent draw per item
/// and step, as ChangeOptions' fractions are) such that an item changes at least once over all of
/// them with probability `total`: 1 - (1 - p)^steps = total. `total` in [0, 1], `steps` >= 1;
/// exactly `total` for one step. Throws diachron::Error otherwise.
inline double per_step_fraction(double total, int steps) {
  DIACHRON_CHECK(total >= 0.0 && total <= 1.0 && steps >= 1,
                 "per_step_fraction: total must be in [0, 1] and steps >= 1, got " << total << " and " << steps);
  if (steps == 1) return total;
  return 1.0 - std::pow(1.0 - total, 1.0 / steps);
}

/// The relative growth per step that compounds to `total` over `steps` steps:
/// (1 + g)^steps = 1 + total. `total` >= 0, `steps` >= 1; exactly `total` for one step.
/// Throws diachron::Error otherwise.
inline double per_step_growth(double total, int steps) {
  DIACHRON_CHECK(total >= 0.0 && std::isfinite(total) && steps >= 1,
                 "per_step_growth: total must be finite and >= 0 and steps >= 1, got " << total << " and " << steps);
  if (steps == 1) return total;
  return std::pow(1.0 + total, 1.0 / steps) - 1.0;
}

/// The ChangeOptions of one step of a history of `steps` steps (epochs - 1) whose change from the
/// first epoch to the last is `total`'s, since ChangeOptions apply at each new epoch. Returns
/// `total` itself for one step. Throws diachron::Error for invalid `total` or `steps` < 1.
inline ChangeOptions changes_per_step(const ChangeOptions& total, int steps) {
  total.check();
  DIACHRON_CHECK(steps >= 1, "changes_per_step: steps must be >= 1, got " << steps);
  if (steps == 1) return total;
  ChangeOptions c = total;
  // Drawn anew per item at each step: a field's crop, a region's layout, a building, a tree, a
  // stand changes at least once over the steps with the total's probability.
  c.changed_field_fraction = per_step_fraction(total.changed_field_fraction, steps);
  c.redrawn_layout_fraction = per_step_fraction(total.redrawn_layout_fraction, steps);
  c.removed_building_fraction = per_step_fraction(total.removed_building_fraction, steps);
  c.cut_tree_fraction = per_step_fraction(total.cut_tree_fraction, steps);
  c.cleared_stand_fraction = per_step_fraction(total.cleared_stand_fraction, steps);
  // Counts per step (fractions of the initial number, or per km2): they add up over the steps, up to
  // the rounding of each step's count to whole items.
  const auto n = static_cast<double>(steps);
  c.new_building_fraction = total.new_building_fraction / n;
  c.new_villages_per_km2 = total.new_villages_per_km2 / n;
  c.new_tree_fraction = total.new_tree_fraction / n;
  c.new_stand_fraction = total.new_stand_fraction / n;
  // Roads are whole: at least the total, so that no step-count loses them all (2 roads over 3 or 4
  // steps give a road per step).
  c.new_roads = (total.new_roads + steps - 1) / steps;
  // A tree's growth compounds from epoch to epoch (Tree::height_in).
  c.tree_growth = per_step_growth(total.tree_growth, steps);
  // Unchanged: seasonal_shift is each epoch's own offset about the mean, not an accumulation;
  // layout_region_m is a size; consolidation is the enlargement of one redraw of a region's layout
  // (a region redrawn at a single step looks as after the whole change in one step; the few redrawn
  // at two steps are consolidated twice).
  return c;
}

/// Options of generate_scene(). Defaults give the small two-epoch test scene (2 x 3 images of
/// 400 x 300 px per epoch, about 1.9 m ground sampling distance).
struct SceneOptions {
  /// Seed of everything random; the same seed gives the same scene on any thread count.
  std::uint64_t seed = 0;
  /// The epochs, oldest first (the last one is the reference of the check points). >= 1.
  std::vector<EpochOptions> epochs = {EpochOptions::historical("e1"), EpochOptions::recent("e2")};
  TerrainOptions terrain;
  ChangeOptions changes;
  TextureOptions texture;
  /// A real DEM to use as the ground (world frame = its frame); empty for procedural terrain.
  /// It must cover every image footprint; holes are filled.
  std::optional<Dsm> real_dem;
  /// Number of check points wanted (fewer when the epochs overlap too little). >= 0.
  int check_points = 100;
  /// Margin added around the union of all image footprints, metres. >= 0.
  double margin_m = 40.0;
  /// A point counts as seen by an image when the ray of its projection meets the surface within
  /// this distance of it, metres (occlusion test). > 0.
  double visibility_tolerance_m = 0.01;
  /// Worker threads: 0 = all cores. Results do not depend on it.
  std::size_t threads = 0;

  /// A site seen by `epochs` flights decades apart, as hard as real historical pairs
  /// (docs/synthetic-scenes.md has the table of every value and what each effect does to matching).
  /// With 2 epochs (the default): `e1`, a 1960s-like flight on black-and-white film (1600 x 1200 px
  /// at 1.0 m, worn scan, poor DSM with a 3 m dome), and `e2`, a recent flight at 0.5 m
  /// (JPEG-compressed), over a landscape that changed for decades (most fields redrawn, new roads and
  /// housing, forests grown and cleared, trees grown and cut), with cast shadows under two different
  /// suns and land-cover classes whose brightness the two films render differently (trees dark on
  /// the old film, bright on the new one).
  /// With 3 to 5 epochs, `e1` .. `eN` oldest first: `epochs - 1` film flights of the 1950s to the
  /// 1980s, each with its own camera, block, sun, film and DSM (older: coarser, worse film, worse
  /// DSM), then the same recent `eN`; the landscape changes step by step, by the same total from the
  /// first epoch to the last as with two epochs (changes_per_step()).
  /// Throws diachron::Error unless 2 <= epochs <= 5.
  static SceneOptions decades_apart(int epochs = 2);

  void check() const {
    DIACHRON_CHECK(!epochs.empty(), "SceneOptions: need at least one epoch");
    for (std::size_t i = 0; i < epochs.size(); ++i) {
      epochs[i].check();
      for (std::size_t j = 0; j < i; ++j)
        DIACHRON_CHECK(epochs[i].name != epochs[j].name, "SceneOptions: two epochs are named " << epochs[i].name);
    }
    terrain.check();
    changes.check();
    texture.check();
    DIACHRON_CHECK(!real_dem || !real_dem->empty(), "SceneOptions::real_dem is empty");
    DIACHRON_CHECK(check_points >= 0 && check_points <= 10000000, "SceneOptions::check_points must be >= 0");
    DIACHRON_CHECK(margin_m >= 0.0 && std::isfinite(margin_m), "SceneOptions::margin_m must be >= 0");
    DIACHRON_CHECK(visibility_tolerance_m > 0.0, "SceneOptions::visibility_tolerance_m must be > 0");
  }
};

namespace detail {

// The film flights of decades_apart(), oldest first: 0 = 1950s, 1 = 1960s (the two-epoch preset's
// e1, value for value), 2 = 1970s, 3 = 1980s. All are 1600 x 1200 px scans (one scanning campaign
// of the archive) at 0.7 to 1.2 m; the older the flight, the coarser its GSD, the less stable its
// aircraft, the worse its camera is known, the more worn and grainy its film and the worse the DSM
// matched on it. Every block covers the recent block's study area, so check points exist in all.
inline EpochOptions decades_film_flight(int decade, std::string name) {
  EpochOptions e = EpochOptions::historical(std::move(name));
  e.image_width_px = 1600;
  e.image_height_px = 1200;
  e.tie_points = 1500;
  e.look.shading = 0.6;
  e.look.cast_shadow = 0.85;
  // A DSM at 2 GSD (MicMac's usual ZoomF 2 on scanned film).
  e.dsm.cell_gsd = 2.0;
  switch (decade) {
    case 0:
      // 1950s: a normal-angle lens flown high (f / width 0.94), 1.2 m GSD, lines flown westwards
      // with 35 % side overlap (its large footprints kept over the study area); the strongest lens
      // distortion, the worst known camera, a low spring sun.
      e.focal_px = 1500.0;
      e.flying_height_m = 1800.0;
      e.rows = 2;
      e.columns = 2;
      e.side_overlap = 0.35;
      e.heading_deg = 180.0;
      e.block_offset_m = Eigen::Vector2d(-30.0, 20.0);
      e.attitude_sigma_deg = 1.5;
      e.yaw_sigma_deg = 3.0;
      e.principal_point_offset_px = Eigen::Vector2d(-9.0, 7.0);
      e.distortion = {-0.04, 0.007, 0.0, 3e-4, -2.5e-4, 0.6, -0.3};
      e.estimated_focal_scale = 1.015;
      e.estimated_principal_point_error_px = Eigen::Vector2d(-11.0, 6.0);
      e.estimated_distortion_fraction = 0.4;
      e.look.sun_azimuth_deg = 100.0;
      e.look.sun_elevation_deg = 28.0;
      e.look.gain = 0.8;
      e.look.offset = 0.1;
      e.look.contrast = 0.8;
      e.look.gamma = 1.3;
      e.look.vignetting = 0.25;
      e.look.land_cover.gain = {-0.9, 0.5, 0.7, 1.2, 0.85};
      e.look.land_cover.offset = {0.8, 0.05, 0.0, 0.05, 0.05};
      e.look.tone_curve = 7.0;
      e.look.exposure_unevenness = 0.3;
      e.look.grain_sigma = 0.05;
      e.look.grain_size_px = 1.5;
      e.look.scan_line_sigma = 0.01;
      e.look.scan_stripes = 5;
      e.look.scratches = 9;
      e.look.dust_per_megapixel = 550.0;
      e.look.blur_sigma_px = 1.3;
      e.dsm.noise_sigma_m = 0.5;
      e.dsm.ripple_m = 1.3;
      e.dsm.hole_fraction = 0.1;
      e.dsm.hole_radius_m = 24.0;
      e.dsm.dome_m = 4.0;
      break;
    case 1:
      // 1960s: wide-angle film camera (f / width 0.66), 1.0 m GSD, a 2 x 2 block (the two-epoch
      // preset's e1; the distortion and estimated camera are historical()'s).
      e.focal_px = 1056.0;
      e.flying_height_m = 1056.0;
      e.rows = 2;
      e.columns = 2;
      e.principal_point_offset_px = Eigen::Vector2d(6.0, -8.0);
      e.estimated_principal_point_error_px = Eigen::Vector2d(8.0, -4.0);
      e.look.sun_azimuth_deg = 125.0;
      e.look.sun_elevation_deg = 35.0;
      // Old film renders vegetation dark and inverts the crop contrast of a near-infrared sensor.
      e.look.land_cover.gain = {-0.8, 0.6, 0.8, 1.1, 0.9};
      e.look.land_cover.offset = {0.75, 0.05, 0.0, 0.05, 0.05};
      e.look.tone_curve = 6.0;
      e.look.exposure_unevenness = 0.25;
      e.look.grain_sigma = 0.04;
      e.look.grain_size_px = 1.2;
      e.look.scan_line_sigma = 0.008;
      e.look.scan_stripes = 4;
      e.look.scratches = 6;
      e.look.dust_per_megapixel = 400.0;
      e.look.blur_sigma_px = 1.0;
      e.dsm.noise_sigma_m = 0.4;
      e.dsm.ripple_m = 1.0;
      e.dsm.hole_fraction = 0.08;
      e.dsm.hole_radius_m = 20.0;
      e.dsm.dome_m = 3.0;
      break;
    case 2:
      // 1970s: f / width 0.78, 0.9 m GSD, north-south lines; the crop inversion weaker.
      e.focal_px = 1250.0;
      e.flying_height_m = 1125.0;
      e.rows = 2;
      e.columns = 2;
      e.heading_deg = 90.0;
      e.block_offset_m = Eigen::Vector2d(30.0, 20.0);
      e.principal_point_offset_px = Eigen::Vector2d(4.0, 6.0);
      e.distortion = {-0.02, 0.003, 0.0, 1.5e-4, -1e-4, 0.3, -0.15};
      e.estimated_focal_scale = 1.008;
      e.estimated_principal_point_error_px = Eigen::Vector2d(5.0, -7.0);
      e.look.sun_azimuth_deg = 150.0;
      e.look.sun_elevation_deg = 42.0;
      e.look.gain = 0.88;
      e.look.offset = 0.06;
      e.look.contrast = 0.88;
      e.look.gamma = 1.2;
      e.look.vignetting = 0.18;
      e.look.land_cover.gain = {-0.6, 0.7, 0.9, 1.05, 0.95};
      e.look.land_cover.offset = {0.65, 0.05, 0.0, 0.03, 0.03};
      e.look.tone_curve = 5.0;
      e.look.exposure_unevenness = 0.2;
      e.look.grain_sigma = 0.032;
      e.look.grain_size_px = 1.0;
      e.look.scan_line_sigma = 0.006;
      e.look.scan_stripes = 3;
      e.look.scratches = 4;
      e.look.dust_per_megapixel = 300.0;
      e.look.blur_sigma_px = 0.9;
      e.dsm.noise_sigma_m = 0.35;
      e.dsm.ripple_m = 0.8;
      e.dsm.hole_fraction = 0.06;
      e.dsm.hole_radius_m = 18.0;
      e.dsm.dome_m = 2.2;
      break;
    default:
      // 1980s: f / width 0.94, 0.7 m GSD, 3 lines of 2 images; the best film of the archive, whose
      // crops are only slightly inverted.
      DIACHRON_CHECK(decade == 3, "decades_film_flight: decade index must be in [0, 3], got " << decade);
      e.focal_px = 1500.0;
      e.flying_height_m = 1050.0;
      e.rows = 3;
      e.columns = 2;
      e.heading_deg = -8.0;
      e.block_offset_m = Eigen::Vector2d(-20.0, -40.0);
      e.principal_point_offset_px = Eigen::Vector2d(-5.0, -3.0);
      e.distortion = {-0.015, 0.0025, 0.0, 1e-4, -8e-5, 0.25, -0.1};
      e.estimated_focal_scale = 1.006;
      e.estimated_principal_point_error_px = Eigen::Vector2d(4.0, 3.0);
      e.look.sun_azimuth_deg = 75.0;
      e.look.sun_elevation_deg = 48.0;
      e.look.gain = 0.9;
      e.look.offset = 0.05;
      e.look.contrast = 0.92;
      e.look.gamma = 1.15;
      e.look.vignetting = 0.15;
      e.look.land_cover.gain = {-0.3, 0.8, 1.1, 1.0, 1.0};
      e.look.land_cover.offset = {0.5, 0.04, 0.0, 0.0, 0.0};
      e.look.tone_curve = 4.0;
      e.look.exposure_unevenness = 0.15;
      e.look.grain_sigma = 0.025;
      e.look.grain_size_px = 0.8;
      e.look.scan_line_sigma = 0.004;
      e.look.scan_stripes = 2;
      e.look.scratches = 3;
      e.look.dust_per_megapixel = 200.0;
      e.look.blur_sigma_px = 0.8;
      e.dsm.noise_sigma_m = 0.3;
      e.dsm.ripple_m = 0.6;
      e.dsm.hole_fraction = 0.05;
      e.dsm.hole_radius_m = 15.0;
      e.dsm.dome_m = 1.5;
      break;
  }
  return e;
}

// The recent flight of decades_apart(): a frame camera (f / width 1.05), 0.5 m GSD, a 3 x 3 block
// over the same study area as the film flights, JPEG delivery.
inline EpochOptions decades_recent_flight(std::string name) {
  EpochOptions e = EpochOptions::recent(std::move(name));
  e.image_width_px = 1600;
  e.image_height_px = 1200;
  e.focal_px = 1680.0;
  e.flying_height_m = 840.0;
  e.rows = 3;
  e.columns = 3;
  e.principal_point_offset_px = Eigen::Vector2d(-4.0, 4.0);
  e.estimated_principal_point_error_px = Eigen::Vector2d(-3.0, 5.0);
  e.block_offset_m = Eigen::Vector2d(40.0, -30.0);
  e.tie_points = 1500;
  e.look.sun_azimuth_deg = 230.0;
  e.look.sun_elevation_deg = 55.0;
  e.look.shading = 0.6;
  e.look.cast_shadow = 0.85;
  e.look.land_cover.gain = {1.0, 0.9, 2.6, 0.8, 1.0};
  e.look.land_cover.offset = {0.0, 0.05, 0.2, 0.0, 0.0};
  e.look.jpeg_quality = 75;
  return e;
}

}  // namespace detail

inline SceneOptions SceneOptions::decades_apart(int epochs) {
  DIACHRON_CHECK(epochs >= 2 && epochs <= 5,
                 "SceneOptions::decades_apart: epochs must be in [2, 5] (film flights of the 1950s to 1980s and a "
                 "recent one), got " << epochs);
  SceneOptions o;
  o.check_points = 150;

  // Landscape: fewer, more clustered buildings than the small test scene (whose density suits a
  // village-sized area), trees with height, and the changes of about forty years.
  o.terrain.building_density_per_km2 = 110.0;
  // Terrain with small-scale relief (banks, gullies, terraces down to about 10 m wavelength): the
  // part of a DSM that decades do not change, which the rough co-registration relies on.
  o.terrain.relief_amplitude_m = 25.0;
  o.terrain.relief_octaves = 7;
  o.terrain.village_fraction = 0.8;
  o.terrain.vegetation.forest_fraction = 0.12;
  o.terrain.vegetation.single_trees_per_km2 = 60.0;
  o.terrain.vegetation.hedgerows_per_km2 = 8.0;
  // The change from the first epoch to the last; with more epochs it comes in equal steps.
  ChangeOptions total;
  total.changed_field_fraction = 0.85;
  total.redrawn_layout_fraction = 0.5;
  total.consolidation = 1.8;
  total.seasonal_shift = 0.12;
  total.removed_building_fraction = 0.2;
  total.new_building_fraction = 0.7;
  total.new_villages_per_km2 = 0.6;
  total.new_roads = 2;
  total.tree_growth = 0.35;
  total.cut_tree_fraction = 0.35;
  total.new_tree_fraction = 0.6;
  total.cleared_stand_fraction = 0.25;
  total.new_stand_fraction = 0.3;
  const int steps = epochs - 1;
  o.changes = changes_per_step(total, steps);
  o.texture.texel_m = 0.5;  // half the recent GSD
  // A bush is removed by an independent draw at each new epoch, as a changed field is.
  o.texture.bush_removal_probability = per_step_fraction(0.5, steps);

  // Which film flights (detail::decades_film_flight) a scene of `epochs` epochs has: the 1960s
  // flight first up to four epochs, so that the first epoch and the total change stay those of the
  // two-epoch preset; five epochs add the 1950s before it.
  static constexpr std::array<std::array<int, 4>, 4> kFilms = {{{1, -1, -1, -1}, {1, 3, -1, -1}, {1, 2, 3, -1}, {0, 1, 2, 3}}};
  o.epochs.clear();
  for (int k = 0; k < steps; ++k)
    o.epochs.push_back(detail::decades_film_flight(kFilms[static_cast<std::size_t>(steps - 1)][static_cast<std::size_t>(k)],
                                                   "e" + std::to_string(k + 1)));
  o.epochs.push_back(detail::decades_recent_flight("e" + std::to_string(epochs)));
  return o;
}

/// A generated scene: the landscape, the epochs with their truth, the check points.
struct Scene {
  std::uint64_t seed = 0;
  /// World X/Y box of the scene (the grids of true surfaces and albedo), metres.
  WorldBounds bounds;
  /// Mean ground height the flying heights refer to, metres.
  double reference_height_m = 0.0;
  Landscape landscape;
  std::vector<SyntheticEpoch> epochs;
  std::vector<CheckPoint> check_points;

  /// The true Helmert from epoch `from` into epoch `to` (indices): X_to = H(X_from).
  Helmert3 transform(std::size_t to, std::size_t from) const {
    return epochs.at(to).epoch_from_world() * epochs.at(from).world_from_epoch;
  }
  /// The true Helmert from the first epoch into the second.
  Helmert3 epoch2_from_epoch1() const {
    DIACHRON_CHECK(epochs.size() >= 2, "epoch2_from_epoch1: the scene has " << epochs.size() << " epoch(s)");
    return transform(1, 0);
  }
};

namespace detail {

// Stream purposes: every random draw of the generator comes from RandomStream(seed, id) with an
// id naming what it is for and which item, never which thread.
enum class SynthStream : std::uint64_t {
  camera = 1,
  pose = 2,
  frame = 3,
  dsm_noise = 4,
  dsm_holes = 5,
  tie = 6,
  check = 7,
  image = 8,
  texture = 9,
  landscape = 10,
  orthophoto = 11,
  full_size = 12,  // synth/full_size_scan.hpp
};

inline std::uint64_t stream_id(SynthStream purpose, std::uint64_t epoch, std::uint64_t item = 0) {
  return (static_cast<std::uint64_t>(purpose) << 56) ^ (epoch << 40) ^ item;
}

/// The pixel where `frame` sees world point `p`, if `p` is in the image and not hidden: the ray of
/// that pixel must meet the surface within `tolerance` of `p`.
template <class Distortion>
std::optional<Vec2> visible_pixel(const Frame<Distortion>& frame, const SurfaceTracer& tracer, const Vec3& p,
                                  double tolerance) {
  const std::optional<Vec2> px = frame.project(p);
  if (!px || !frame.in_image(*px)) return std::nullopt;
  const std::optional<Ray3> ray = frame.ray(*px);
  if (!ray) return std::nullopt;
  const std::optional<Vec3> hit = tracer.intersect(*ray);
  if (!hit || (*hit - p).norm() > tolerance) return std::nullopt;
  return px;
}

/// Gauss-Newton fit of a pose to 3D-2D correspondences for a given camera, from `initial`: what a
/// bundle adjustment with these (slightly wrong) intrinsics would settle on. Returns `initial`
/// when there are too few points.
template <class Distortion>
Pose fit_pose(const Camera<Distortion>& camera, const Pose& initial, const std::vector<Vec3>& points,
              const std::vector<Vec2>& pixels) {
  if (points.size() < 6) return initial;
  // Centre the problem on the camera so that large coordinates do not cost digits.
  const Vec3 origin = initial.centre();
  double depth = 0.0;
  for (const Vec3& p : points) depth += (p - origin).norm();
  depth /= static_cast<double>(points.size());
  Mat3 rotation = initial.cam_from_world_rotation();
  Vec3 centre = Vec3::Zero();
  const auto residuals = [&](const Mat3& r, const Vec3& c, Eigen::VectorXd& out) {
    out.resize(static_cast<Eigen::Index>(2 * points.size()));
    for (std::size_t k = 0; k < points.size(); ++k) {
      const Vec3 pc = r * (points[k] - origin - c);
      const std::optional<Vec2> px = camera.project(pc);
      const Vec2 e = px ? Vec2(*px - pixels[k]) : Vec2(1e6, 1e6);
      out.segment<2>(static_cast<Eigen::Index>(2 * k)) = e;
    }
  };
  Eigen::VectorXd r0, r1, r2;
  residuals(rotation, centre, r0);
  for (int iteration = 0; iteration < 20; ++iteration) {
    Eigen::MatrixXd j(r0.size(), 6);
    for (int p = 0; p < 6; ++p) {
      const double h = p < 3 ? 1e-6 : 1e-6 * depth;
      Vec3 delta = Vec3::Zero();
      delta(p % 3) = h;
      if (p < 3) {
        residuals(rotation_from_axis_angle<double>(delta) * rotation, centre, r1);
        residuals(rotation_from_axis_angle<double>(Vec3(-delta)) * rotation, centre, r2);
      } else {
        residuals(rotation, centre + delta, r1);
        residuals(rotation, centre - delta, r2);
      }
      j.col(p) = (r1 - r2) / (2.0 * h);
    }
    const Eigen::Matrix<double, 6, 6> n = j.transpose() * j;
    const Eigen::Matrix<double, 6, 1> step = -n.ldlt().solve(j.transpose() * r0);
    if (!step.allFinite()) break;
    const Mat3 r_new = rotation_from_axis_angle<double>(Vec3(step.head<3>())) * rotation;
    const Vec3 c_new = centre + step.tail<3>();
    residuals(r_new, c_new, r1);
    if (!(r1.squaredNorm() < r0.squaredNorm())) break;
    rotation = r_new;
    centre = c_new;
    r0 = r1;
    if (step.head<3>().norm() < 1e-12 && step.tail<3>().norm() < 1e-10 * depth) break;
  }
  return Pose(rotation, origin + centre);
}

inline Camera<FraserAffine> true_camera(const EpochOptions& o) {
  const double cx = 0.5 * (o.image_width_px - 1) + o.principal_point_offset_px.x();
  const double cy = 0.5 * (o.image_height_px - 1) + o.principal_point_offset_px.y();
  return Camera<FraserAffine>(o.focal_px, cx, cy, o.image_width_px, o.image_height_px, o.distortion);
}

inline Camera<FraserAffine> estimated_camera(const EpochOptions& o, const Camera<FraserAffine>& truth) {
  Camera<FraserAffine>::Params p = truth.params();
  for (int i = 0; i < 5; ++i) p[static_cast<std::size_t>(i)] *= o.estimated_distortion_fraction;
  p[5] = p[6] = 0.0;
  return Camera<FraserAffine>(truth.focal() * o.estimated_focal_scale,
                              truth.cx() + o.estimated_principal_point_error_px.x(),
                              truth.cy() + o.estimated_principal_point_error_px.y(), truth.width(), truth.height(), p);
}

/// Poses of the block: lines along `heading`, images along the lines, each with random attitude
/// and position errors.
inline std::vector<SyntheticImage> plan_block(const EpochOptions& o, const Vec2& centre, double reference_height,
                                              std::uint64_t seed, std::uint64_t epoch) {
  const double gsd = o.gsd_m();
  const double base = (1.0 - o.forward_overlap) * o.image_width_px * gsd;
  const double spacing = (1.0 - o.side_overlap) * o.image_height_px * gsd;
  const double heading = deg_to_rad(o.heading_deg);
  const Vec2 along(std::cos(heading), std::sin(heading));
  const Vec2 across(-along.y(), along.x());
  std::vector<SyntheticImage> images;
  for (int r = 0; r < o.rows; ++r)
    for (int c = 0; c < o.columns; ++c) {
      RandomStream random(seed, stream_id(SynthStream::pose, epoch, static_cast<std::uint64_t>(r * o.columns + c)));
      SyntheticImage image;
      image.name = o.name + "_r" + std::to_string(r) + "_c" + std::to_string(c);
      image.row = r;
      image.column = c;
      // Image +y points to -across for yaw = heading, so the first line lies at +across and
      // row 0 is at the top of a map drawn with the flight direction to the right.
      const Vec2 xy = centre + (c - 0.5 * (o.columns - 1)) * base * along - (r - 0.5 * (o.rows - 1)) * spacing * across;
      // One draw per statement, in the order z, y, x and roll, pitch (core/random.hpp, "Order of draws").
      const double dz = random.normal(), dy = random.normal(), dx = random.normal();
      const Vec3 position(xy.x() + o.position_sigma_m * dx, xy.y() + o.position_sigma_m * dy,
                          reference_height + o.flying_height_m + o.position_sigma_m * dz);
      const double yaw = heading + (o.alternate_direction && r % 2 == 1 ? kPi : 0.0) +
                         deg_to_rad(o.yaw_sigma_deg) * random.normal();
      const double roll = deg_to_rad(o.attitude_sigma_deg) * random.normal();
      const double pitch = deg_to_rad(o.attitude_sigma_deg) * random.normal();
      image.pose_world = Pose::from_yaw_pitch_roll(position, yaw, pitch, roll);
      images.push_back(std::move(image));
    }
  return images;
}

/// epoch_from_world = s R (X - centre) + shift, R = tilt * Rz(yaw).
inline Helmert3 draw_epoch_frame(const EpochFrameOptions& o, const Vec3& centre, std::uint64_t seed,
                                 std::uint64_t epoch) {
  if (o.is_world) return Helmert3::identity();
  RandomStream random(seed, stream_id(SynthStream::frame, epoch));
  const double yaw = std::isnan(o.yaw_deg) ? random.uniform(0.0, 2.0 * kPi) : deg_to_rad(o.yaw_deg);
  const double tilt_azimuth = random.uniform(0.0, 2.0 * kPi);
  const double tilt = deg_to_rad(o.max_tilt_deg) * random.uniform01();
  const double scale = std::exp(random.uniform(std::log(o.min_scale), std::log(o.max_scale)));
  const double shift_z = random.uniform(-o.max_shift, o.max_shift), shift_y = random.uniform(-o.max_shift, o.max_shift);
  const Vec3 shift(random.uniform(-o.max_shift, o.max_shift), shift_y, shift_z);
  const Mat3 r = rotation_from_axis_angle<double>(Vec3(std::cos(tilt_azimuth), std::sin(tilt_azimuth), 0.0) * tilt) *
                 rotation_from_axis_angle<double>(Vec3(0.0, 0.0, yaw));
  return Helmert3{scale, r, Vec3(shift - scale * (r * centre))};
}

/// The DSM of the epoch as its SfM delivers it: the true surface sampled on a grid of the epoch
/// frame along the epoch's vertical, then degraded (noise, ripple, dome, holes, unseen areas).
inline Dsm sfm_dsm(const SyntheticEpoch& epoch, const EpochOptions& o, const SurfaceTracer& tracer,
                   const std::vector<Vec3>& footprint_world, std::uint64_t seed, std::uint64_t index,
                   std::size_t threads) {
  const Helmert3 epoch_from_world = epoch.epoch_from_world();
  const double s = epoch_from_world.scale;
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x, max_x = -min_x, max_y = -min_x;
  double top = -std::numeric_limits<double>::infinity();
  for (const Vec3& p : footprint_world) {
    const Vec3 q = epoch_from_world(p);
    min_x = std::min(min_x, q.x());
    max_x = std::max(max_x, q.x());
    min_y = std::min(min_y, q.y());
    max_y = std::max(max_y, q.y());
  }
  for (const SyntheticImage& image : epoch.images) top = std::max(top, image.pose_epoch.centre().z());
  const double cell = o.dsm.cell_gsd * epoch.gsd_m * s;
  const int w = static_cast<int>(std::ceil((max_x - min_x) / cell)) + 1;
  const int h = static_cast<int>(std::ceil((max_y - min_y) / cell)) + 1;
  DIACHRON_CHECK(static_cast<double>(w) * h <= 1e8, "sfm_dsm: the epoch DSM would have " << w << " x " << h << " cells");
  const GeoTransform transform = GeoTransform::north_up(min_x, max_y, cell);
  Raster<float> heights(w, h, std::numeric_limits<float>::quiet_NaN());
  const Vec3 down = epoch.world_from_epoch.rotation * Vec3(0.0, 0.0, -1.0);
  const Vec2 middle(0.5 * (min_x + max_x), 0.5 * (min_y + max_y));
  const double half_diagonal = 0.5 * std::hypot(max_x - min_x, max_y - min_y);
  const std::uint64_t ripple_seed = detail::mix64(seed ^ stream_id(SynthStream::dsm_noise, index, 0xffffff));
  std::vector<Frame<FraserAffine>> frames;
  for (std::size_t i = 0; i < epoch.images.size(); ++i) frames.push_back(epoch.world_frame(i));

  parallel_for(static_cast<std::size_t>(h), threads, [&](std::size_t row) {
    const int y = static_cast<int>(row);
    RandomStream noise(seed, stream_id(SynthStream::dsm_noise, index, row));
    for (int x = 0; x < w; ++x) {
      const Vec2 xy = transform.pixel_to_world(Vec2(x, y));
      const double white = noise.normal();  // drawn for every cell so the stream stays aligned
      const Ray3 ray{epoch.world_from_epoch(Vec3(xy.x(), xy.y(), top + 10.0 * s)), down};
      const std::optional<Vec3> hit = tracer.intersect(ray);
      if (!hit) continue;
      int views = 0;
      for (const auto& frame : frames) {
        const std::optional<Vec2> px = frame.project(*hit);
        if (px && frame.in_image(*px)) ++views;
      }
      if (views < o.dsm.min_views) continue;
      double z = epoch_from_world(*hit).z();
      z += s * o.dsm.noise_sigma_m * white;
      z += s * o.dsm.ripple_m * fbm(ripple_seed, xy.x() / s, xy.y() / s, 200.0, 2);
      const double r = (xy - middle).norm() / std::max(half_diagonal, 1e-12);
      z += s * o.dsm.dome_m * (1.0 - r * r);
      heights(x, y) = static_cast<float>(z);
    }
  });

  if (o.dsm.hole_fraction > 0.0) {
    RandomStream random(seed, stream_id(SynthStream::dsm_holes, index));
    const double radius = o.dsm.hole_radius_m * s;
    const double area = (max_x - min_x) * (max_y - min_y);
    const auto holes = static_cast<int>(std::llround(o.dsm.hole_fraction * area / (kPi * radius * radius)));
    for (int k = 0; k < holes; ++k) {
      const double cy = random.uniform(min_y, max_y);  // y before x (core/random.hpp, "Order of draws")
      const Vec2 c(random.uniform(min_x, max_x), cy);
      const Vec2 pc = transform.world_to_pixel(c);
      const int rc = static_cast<int>(std::ceil(radius / cell));
      for (int y = std::max(0, static_cast<int>(pc.y()) - rc); y <= std::min(h - 1, static_cast<int>(pc.y()) + rc); ++y)
        for (int x = std::max(0, static_cast<int>(pc.x()) - rc); x <= std::min(w - 1, static_cast<int>(pc.x()) + rc); ++x)
          if ((transform.pixel_to_world(Vec2(x, y)) - c).norm() <= radius)
            heights(x, y) = std::numeric_limits<float>::quiet_NaN();
    }
  }
  return Dsm(std::move(heights), transform);
}

/// Ground points where the rays through the image corners meet the plane Z = z.
template <class Distortion>
std::vector<Vec3> corner_footprint(const Frame<Distortion>& frame, double z) {
  const double w = frame.camera().width(), h = frame.camera().height();
  std::vector<Vec3> out;
  const Vec2 corners[4] = {{-0.5, -0.5}, {w - 0.5, -0.5}, {w - 0.5, h - 0.5}, {-0.5, h - 0.5}};
  for (const Vec2& c : corners) {
    const std::optional<Ray3> ray = frame.ray(c);
    DIACHRON_CHECK(ray && ray->direction.z() < -1e-3,
                   "generate_scene: an image corner looks at or above the horizon; reduce the field of view or the tilt");
    out.push_back(ray->at((z - ray->origin.z()) / ray->direction.z()));
  }
  return out;
}

}  // namespace detail

/// Generates a scene (see the file comment and docs/synthetic-scenes.md).
/// Throws diachron::Error for invalid options, a real DEM that does not cover the images, or
/// cameras that are not above the terrain.
inline Scene generate_scene(const SceneOptions& options) {
  options.check();
  const std::uint64_t seed = options.seed;
  const std::size_t n_epochs = options.epochs.size();
  Scene scene;
  scene.seed = seed;

  // Scene centre, reference height and the lowest ground height (for footprints).
  Vec2 centre(options.terrain.centre_x_m, options.terrain.centre_y_m);
  double reference = options.terrain.base_height_m;
  double lowest = reference - options.terrain.relief_amplitude_m -
                  (options.terrain.landform == Landform::valley ? options.terrain.landform_height_m : 0.0);
  if (options.real_dem) {
    const WorldBounds b = options.real_dem->bounds();
    centre = Vec2(0.5 * (b.min_x + b.max_x), 0.5 * (b.min_y + b.max_y));
    reference = options.real_dem->statistics().mean;
    lowest = options.real_dem->statistics().min;
  }
  scene.reference_height_m = reference;

  // Cameras and poses first: they decide the extent of the scene.
  scene.epochs.resize(n_epochs);
  std::vector<std::vector<Vec3>> footprints(n_epochs);
  WorldBounds bounds{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (std::size_t e = 0; e < n_epochs; ++e) {
    const EpochOptions& o = options.epochs[e];
    SyntheticEpoch& epoch = scene.epochs[e];
    epoch.name = o.name;
    epoch.camera = detail::true_camera(o);
    epoch.estimated_camera = detail::estimated_camera(o, epoch.camera);
    epoch.gsd_m = o.gsd_m();
    epoch.images = detail::plan_block(o, centre + o.block_offset_m, reference, seed, e);
    for (std::size_t i = 0; i < epoch.images.size(); ++i) {
      for (const Vec3& p : detail::corner_footprint(epoch.world_frame(i), lowest)) {
        footprints[e].push_back(p);
        bounds.min_x = std::min(bounds.min_x, p.x());
        bounds.min_y = std::min(bounds.min_y, p.y());
        bounds.max_x = std::max(bounds.max_x, p.x());
        bounds.max_y = std::max(bounds.max_y, p.y());
      }
    }
  }
  const double margin = options.margin_m + 2.0 * options.terrain.cell_m;
  bounds.min_x -= margin;
  bounds.min_y -= margin;
  bounds.max_x += margin;
  bounds.max_y += margin;
  scene.bounds = bounds;

  scene.landscape = make_landscape(options.terrain, options.changes, bounds, static_cast<int>(n_epochs),
                                   detail::mix64(seed ^ detail::stream_id(detail::SynthStream::landscape, 0)),
                                   options.real_dem ? &*options.real_dem : nullptr);

  std::vector<Dsm> surfaces;
  surfaces.reserve(n_epochs);
  for (std::size_t e = 0; e < n_epochs; ++e) surfaces.push_back(surface_dsm(scene.landscape, static_cast<int>(e)));
  std::vector<detail::SurfaceTracer> tracers;
  tracers.reserve(n_epochs);
  for (std::size_t e = 0; e < n_epochs; ++e) tracers.emplace_back(surfaces[e]);

  for (std::size_t e = 0; e < n_epochs; ++e) {
    const EpochOptions& o = options.epochs[e];
    SyntheticEpoch& epoch = scene.epochs[e];
    const double top = surfaces[e].statistics().max;
    for (const SyntheticImage& image : epoch.images)
      DIACHRON_CHECK(image.pose_world.centre().z() > top + 1.0,
                     "generate_scene: image " << image.name << " flies at " << image.pose_world.centre().z()
                                              << " m, not above the highest surface point (" << top
                                              << " m); raise flying_height_m");

    TextureOptions texture = options.texture;
    texture.threads = options.threads;
    epoch.albedo = render_albedo(scene.landscape, static_cast<int>(e), bounds, texture,
                                 detail::mix64(seed ^ detail::stream_id(detail::SynthStream::texture, 0)),
                                 o.look.land_cover);
    const AlbedoMap shading = shading_map(surfaces[e], o.look, options.threads);
    const PixelDirections directions = PixelDirections::of(epoch.camera, options.threads);
    for (std::size_t i = 0; i < epoch.images.size(); ++i) {
      const Raster<float> radiance = render_radiance(epoch.world_frame(i), directions, tracers[e], epoch.albedo,
                                                     shading, o.look, options.threads);
      epoch.images[i].pixels =
          develop_image(radiance, o.look, seed, detail::stream_id(detail::SynthStream::image, e, i), options.threads);
    }

    // The epoch frame and the true poses in it.
    const Vec3 block_centre(centre.x() + o.block_offset_m.x(), centre.y() + o.block_offset_m.y(), reference);
    const Helmert3 epoch_from_world = detail::draw_epoch_frame(o.frame, block_centre, seed, e);
    epoch.world_from_epoch = epoch_from_world.inverse();
    for (SyntheticImage& image : epoch.images)
      image.pose_epoch =
          image.pose_world.transformed(epoch_from_world.scale, epoch_from_world.rotation, epoch_from_world.translation);

    epoch.dsm = detail::sfm_dsm(epoch, o, tracers[e], footprints[e], seed, e, options.threads);

    // Tie points: random pixels cast onto the surface and seen again by other images.
    {
      std::vector<std::optional<TiePoint>> slots(static_cast<std::size_t>(o.tie_points));
      std::vector<Frame<FraserAffine>> frames;
      for (std::size_t i = 0; i < epoch.images.size(); ++i) frames.push_back(epoch.world_frame(i));
      parallel_for(slots.size(), options.threads, [&](std::size_t k) {
        RandomStream random(seed, detail::stream_id(detail::SynthStream::tie, e, k));
        const std::size_t i = random.uniform_index(frames.size());
        const double py = random.uniform(2.0, epoch.camera.height() - 3.0);  // y first ("Order of draws")
        const Vec2 px(random.uniform(2.0, epoch.camera.width() - 3.0), py);
        const std::optional<Ray3> ray = frames[i].ray(px);
        if (!ray) return;
        const std::optional<Vec3> hit = tracers[e].intersect(*ray);
        if (!hit) return;
        TiePoint tie;
        tie.world = *hit;
        tie.epoch = epoch_from_world(*hit);
        for (std::size_t j = 0; j < frames.size(); ++j) {
          const std::optional<Vec2> seen =
              detail::visible_pixel(frames[j], tracers[e], *hit, options.visibility_tolerance_m);
          if (!seen) continue;
          const double ny = random.normal();
          const Vec2 noise(random.normal(), ny);
          tie.observations.push_back({static_cast<int>(j), *seen + o.tie_noise_px * noise});
        }
        if (tie.observations.size() >= 2) slots[k] = std::move(tie);
      });
      for (auto& slot : slots)
        if (slot) epoch.tie_points.push_back(std::move(*slot));
    }

    // The orientation an SfM with the estimated camera would find: each pose refitted to the
    // noise-free projections of the tie points.
    {
      std::vector<std::vector<Vec3>> points(epoch.images.size());
      std::vector<std::vector<Vec2>> pixels(epoch.images.size());
      for (const TiePoint& tie : epoch.tie_points)
        for (const ImageObservation& ob : tie.observations) {
          const auto i = static_cast<std::size_t>(ob.image);
          const std::optional<Vec2> px = epoch.epoch_frame(i).project(tie.epoch);
          if (!px) continue;
          points[i].push_back(tie.epoch);
          pixels[i].push_back(*px);
        }
      parallel_for(epoch.images.size(), options.threads, [&](std::size_t i) {
        epoch.images[i].estimated_pose =
            detail::fit_pose(epoch.estimated_camera, epoch.images[i].pose_epoch, points[i], pixels[i]);
      });
    }
  }

  // Check points: surface points of the reference (last) epoch that every epoch shares and sees.
  if (options.check_points > 0) {
    const std::size_t ref = n_epochs - 1;
    const std::size_t attempts = static_cast<std::size_t>(options.check_points) * 4;
    std::vector<std::optional<CheckPoint>> slots(attempts);
    std::vector<std::vector<Frame<FraserAffine>>> frames(n_epochs);
    for (std::size_t e = 0; e < n_epochs; ++e)
      for (std::size_t i = 0; i < scene.epochs[e].images.size(); ++i) frames[e].push_back(scene.epochs[e].world_frame(i));
    parallel_for(attempts, options.threads, [&](std::size_t k) {
      RandomStream random(seed, detail::stream_id(detail::SynthStream::check, 0, k));
      const Camera<FraserAffine>& cam = scene.epochs[ref].camera;
      const std::size_t i = random.uniform_index(frames[ref].size());
      const double py = random.uniform(8.0, cam.height() - 9.0);  // y first ("Order of draws")
      const Vec2 px(random.uniform(8.0, cam.width() - 9.0), py);
      const std::optional<Ray3> ray = frames[ref][i].ray(px);
      if (!ray) return;
      const std::optional<Vec3> hit = tracers[ref].intersect(*ray);
      if (!hit) return;
      CheckPoint cp;
      cp.world = *hit;
      for (std::size_t e = 0; e < n_epochs; ++e) {
        // The point must lie on every epoch's surface (not on a changed building).
        if (!(std::abs(surfaces[e].height_at(hit->head<2>()) - hit->z()) < 1e-6 * (1.0 + std::abs(hit->z())))) return;
        bool seen_in_epoch = false;
        for (std::size_t j = 0; j < frames[e].size(); ++j) {
          const std::optional<Vec2> seen =
              detail::visible_pixel(frames[e][j], tracers[e], *hit, options.visibility_tolerance_m);
          if (!seen) continue;
          seen_in_epoch = true;
          cp.observations.push_back({static_cast<int>(e), static_cast<int>(j), *seen});
        }
        if (!seen_in_epoch) return;
      }
      slots[k] = std::move(cp);
    });
    for (auto& slot : slots) {
      if (scene.check_points.size() >= static_cast<std::size_t>(options.check_points)) break;
      if (slot) scene.check_points.push_back(std::move(*slot));
    }
  }

  for (std::size_t e = 0; e < n_epochs; ++e) scene.epochs[e].true_surface = std::move(surfaces[e]);
  return scene;
}

}  // namespace diachron
