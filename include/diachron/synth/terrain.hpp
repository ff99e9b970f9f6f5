#pragma once
/// @file
/// Synthetic terrain for multi-epoch scenes: a ground surface (procedural relief with a dome or a
/// valley, or a real DEM resampled onto the scene grid), plus the objects that give the DSM and
/// the images structure: fields, roads and buildings, each with the epochs in which it exists.
///
/// Everything is in the world frame (metres, Z up). The landscape is a description, not a raster:
/// surface_dsm() rasterises the surface of one epoch and the texture module paints the same
/// objects, so the DSM and the images agree by construction.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/synth/noise.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// The large-scale landform added to the procedural relief.
enum class Landform {
  none,    ///< relief noise only
  dome,    ///< a Gaussian hill in the middle of the scene
  valley,  ///< a Gaussian trough across the scene, at a random azimuth
};

/// Trees as 3D objects of the true surface (so of the DSMs too): forest stands, hedgerows and
/// single trees. Every count defaults to 0 (no trees), which keeps the plain test scene as it was;
/// SceneOptions::decades_apart() turns them on. Lengths and heights in metres.
struct VegetationOptions {
  /// Share of the scene area covered by forest stands. In [0, 0.9].
  double forest_fraction = 0.0;
  /// Typical diameter of a forest stand (each is drawn 0.6 to 1.4 times this, with a ragged edge). > 0.
  double stand_diameter_m = 220.0;
  /// Distance between neighbouring trees of a stand (jittered grid). > 0.
  double forest_tree_spacing_m = 6.0;
  /// Free-standing trees per square kilometre. >= 0.
  double single_trees_per_km2 = 0.0;
  /// Hedgerows (straight rows of trees) per square kilometre. >= 0.
  double hedgerows_per_km2 = 0.0;
  /// Typical hedgerow length (drawn 0.5 to 1.5 times this) and tree spacing along it. > 0.
  double hedgerow_length_m = 160.0;
  double hedgerow_tree_spacing_m = 4.0;
  /// Tree heights, uniform in [min, max]. 0 < min <= max.
  double tree_min_height_m = 8.0;
  double tree_max_height_m = 22.0;
  /// Crown radius as a fraction of the tree height (about 0.2 for broadleaves). > 0.
  double crown_ratio = 0.22;

  bool any() const { return forest_fraction > 0.0 || single_trees_per_km2 > 0.0 || hedgerows_per_km2 > 0.0; }

  void check() const {
    DIACHRON_CHECK(forest_fraction >= 0.0 && forest_fraction <= 0.9, "VegetationOptions::forest_fraction must be in [0, 0.9]");
    DIACHRON_CHECK(stand_diameter_m > 0.0 && forest_tree_spacing_m > 0.0,
                   "VegetationOptions: stand diameter and tree spacing must be > 0");
    DIACHRON_CHECK(single_trees_per_km2 >= 0.0 && single_trees_per_km2 <= 1e5 && hedgerows_per_km2 >= 0.0 &&
                       hedgerows_per_km2 <= 1e4,
                   "VegetationOptions: tree and hedgerow densities must be >= 0");
    DIACHRON_CHECK(hedgerow_length_m > 0.0 && hedgerow_tree_spacing_m > 0.0,
                   "VegetationOptions: hedgerow length and spacing must be > 0");
    DIACHRON_CHECK(tree_min_height_m > 0.0 && tree_min_height_m <= tree_max_height_m && tree_max_height_m <= 100.0,
                   "VegetationOptions: need 0 < tree_min_height_m <= tree_max_height_m <= 100");
    DIACHRON_CHECK(crown_ratio > 0.0 && crown_ratio <= 1.0, "VegetationOptions::crown_ratio must be in (0, 1]");
  }
};

/// Options of the ground surface and of the objects on it. Lengths in metres, heights in metres.
struct TerrainOptions {
  /// Cell size of the world DSM grid, metres. Rendering samples this surface, so it should be
  /// at most the ground sampling distance of the images. > 0.
  double cell_m = 1.0;
  /// World X and Y of the scene centre, metres. Large values (a UTM easting of 5e5 m, a
  /// northing of 5e6 m) exercise the numerics of every consumer. Ignored when a real DEM is
  /// given (its own georeferencing is used).
  double centre_x_m = 0.0;
  double centre_y_m = 0.0;
  /// Mean ground height, metres (procedural relief only).
  double base_height_m = 200.0;
  /// Amplitude of the multi-octave relief noise, metres (peak deviation from the base). >= 0.
  double relief_amplitude_m = 20.0;
  /// Wavelength of the first (largest) relief octave, metres. > 0.
  double relief_wavelength_m = 700.0;
  /// Number of relief octaves, each half the wavelength of the previous one. >= 1.
  int relief_octaves = 5;
  /// Large-scale landform and its height (dome) or depth (valley), metres. >= 0.
  Landform landform = Landform::valley;
  double landform_height_m = 35.0;
  /// Width scale of the landform (Gaussian sigma) as a fraction of the smaller scene side. > 0.
  double landform_width_fraction = 0.25;
  /// Typical field size, metres: fields are the cells of a jittered-grid Voronoi diagram. > 0.
  double field_size_m = 90.0;
  /// Number of straight roads crossing the scene. >= 0.
  int road_count = 3;
  /// Road width, metres. > 0.
  double road_width_m = 7.0;
  /// Buildings per square kilometre of scene (before epoch changes). >= 0.
  double building_density_per_km2 = 220.0;
  /// Fraction of the buildings grouped in villages (the rest are scattered). In [0, 1].
  double village_fraction = 0.7;
  /// Number of villages per square kilometre. >= 0.
  double villages_per_km2 = 1.5;
  /// Building footprint side lengths, metres, drawn uniformly in [min, max]. 0 < min <= max.
  double building_min_size_m = 8.0;
  double building_max_size_m = 24.0;
  /// Building heights (eaves above the ground), metres, uniform in [min, max]. 0 < min <= max.
  double building_min_height_m = 4.0;
  double building_max_height_m = 14.0;
  /// Fraction of buildings with a gable roof (the rest are flat). In [0, 1].
  double gable_fraction = 0.5;
  /// Also put buildings on a real DEM (its heights usually contain buildings already).
  bool buildings_on_real_dem = true;
  /// Trees (none by default).
  VegetationOptions vegetation;
  /// CRS text stored in the world DSM ("EPSG:32631", WKT, or empty for a local frame). A real
  /// DEM keeps its own CRS.
  std::string crs;

  void check() const {
    DIACHRON_CHECK(cell_m > 0.0 && std::isfinite(cell_m), "TerrainOptions::cell_m must be > 0, got " << cell_m);
    DIACHRON_CHECK(std::isfinite(centre_x_m) && std::isfinite(centre_y_m) && std::isfinite(base_height_m),
                   "TerrainOptions: centre and base height must be finite");
    DIACHRON_CHECK(relief_amplitude_m >= 0.0 && std::isfinite(relief_amplitude_m),
                   "TerrainOptions::relief_amplitude_m must be >= 0, got " << relief_amplitude_m);
    DIACHRON_CHECK(relief_wavelength_m > 0.0, "TerrainOptions::relief_wavelength_m must be > 0, got "
                                                  << relief_wavelength_m);
    DIACHRON_CHECK(relief_octaves >= 1 && relief_octaves <= 16,
                   "TerrainOptions::relief_octaves must be in [1, 16], got " << relief_octaves);
    DIACHRON_CHECK(landform_height_m >= 0.0 && std::isfinite(landform_height_m),
                   "TerrainOptions::landform_height_m must be >= 0, got " << landform_height_m);
    DIACHRON_CHECK(landform_width_fraction > 0.0, "TerrainOptions::landform_width_fraction must be > 0");
    DIACHRON_CHECK(field_size_m > 0.0, "TerrainOptions::field_size_m must be > 0, got " << field_size_m);
    DIACHRON_CHECK(road_count >= 0 && road_count <= 1000, "TerrainOptions::road_count must be in [0, 1000]");
    DIACHRON_CHECK(road_width_m > 0.0, "TerrainOptions::road_width_m must be > 0, got " << road_width_m);
    DIACHRON_CHECK(building_density_per_km2 >= 0.0 && building_density_per_km2 <= 1e5,
                   "TerrainOptions::building_density_per_km2 must be in [0, 1e5]");
    DIACHRON_CHECK(village_fraction >= 0.0 && village_fraction <= 1.0,
                   "TerrainOptions::village_fraction must be in [0, 1]");
    DIACHRON_CHECK(villages_per_km2 >= 0.0, "TerrainOptions::villages_per_km2 must be >= 0");
    DIACHRON_CHECK(building_min_size_m > 0.0 && building_min_size_m <= building_max_size_m,
                   "TerrainOptions: need 0 < building_min_size_m <= building_max_size_m");
    DIACHRON_CHECK(building_min_height_m > 0.0 && building_min_height_m <= building_max_height_m,
                   "TerrainOptions: need 0 < building_min_height_m <= building_max_height_m");
    DIACHRON_CHECK(gable_fraction >= 0.0 && gable_fraction <= 1.0, "TerrainOptions::gable_fraction must be in [0, 1]");
    vegetation.check();
  }
};

/// How the landscape changes from one epoch to the next (applied at each epoch after the first).
struct ChangeOptions {
  /// Fraction of fields whose crop pattern changes at each new epoch. In [0, 1].
  double changed_field_fraction = 0.3;
  /// Fraction of the existing buildings demolished at each new epoch. In [0, 1].
  double removed_building_fraction = 0.15;
  /// New buildings at each new epoch, as a fraction of the initial number. >= 0.
  double new_building_fraction = 0.25;
  /// Amplitude of the seasonal albedo shift of vegetated fields (albedo units, 0..1). >= 0.
  double seasonal_shift = 0.08;

  // Changes of decades (all 0 by default: the rates above are those of a few years).
  /// Fraction of the land, in square parcels of `layout_region_m`, whose field boundaries are
  /// redrawn at each new epoch (land consolidation), fields there `consolidation` times larger. In [0, 1].
  double redrawn_layout_fraction = 0.0;
  double layout_region_m = 350.0;
  double consolidation = 1.6;
  /// New straight roads at each new epoch. >= 0.
  int new_roads = 0;
  /// New villages (housing estates) per square kilometre at each new epoch; new buildings cluster
  /// in them as in the old villages. >= 0.
  double new_villages_per_km2 = 0.0;
  /// Relative height (and crown) growth of a tree from one epoch to the next, e.g. 0.3. >= 0.
  double tree_growth = 0.0;
  /// Fraction of free-standing and hedgerow trees cut at each new epoch. In [0, 1].
  double cut_tree_fraction = 0.0;
  /// New free-standing trees at each new epoch, as a fraction of the initial ones. >= 0.
  double new_tree_fraction = 0.0;
  /// Fraction of forest stands cleared at each new epoch. In [0, 1].
  double cleared_stand_fraction = 0.0;
  /// New (young) forest stands at each new epoch, as a fraction of the initial ones. >= 0.
  double new_stand_fraction = 0.0;

  void check() const {
    DIACHRON_CHECK(changed_field_fraction >= 0.0 && changed_field_fraction <= 1.0,
                   "ChangeOptions::changed_field_fraction must be in [0, 1]");
    DIACHRON_CHECK(removed_building_fraction >= 0.0 && removed_building_fraction <= 1.0,
                   "ChangeOptions::removed_building_fraction must be in [0, 1]");
    DIACHRON_CHECK(new_building_fraction >= 0.0 && new_building_fraction <= 10.0,
                   "ChangeOptions::new_building_fraction must be in [0, 10]");
    DIACHRON_CHECK(seasonal_shift >= 0.0 && seasonal_shift <= 1.0, "ChangeOptions::seasonal_shift must be in [0, 1]");
    DIACHRON_CHECK(redrawn_layout_fraction >= 0.0 && redrawn_layout_fraction <= 1.0,
                   "ChangeOptions::redrawn_layout_fraction must be in [0, 1]");
    DIACHRON_CHECK(layout_region_m > 0.0 && consolidation >= 0.25 && consolidation <= 10.0,
                   "ChangeOptions: layout_region_m must be > 0 and consolidation in [0.25, 10]");
    DIACHRON_CHECK(new_roads >= 0 && new_roads <= 1000, "ChangeOptions::new_roads must be in [0, 1000]");
    DIACHRON_CHECK(new_villages_per_km2 >= 0.0 && new_villages_per_km2 <= 100.0,
                   "ChangeOptions::new_villages_per_km2 must be in [0, 100]");
    DIACHRON_CHECK(tree_growth >= 0.0 && tree_growth <= 5.0, "ChangeOptions::tree_growth must be in [0, 5]");
    DIACHRON_CHECK(cut_tree_fraction >= 0.0 && cut_tree_fraction <= 1.0 && cleared_stand_fraction >= 0.0 &&
                       cleared_stand_fraction <= 1.0,
                   "ChangeOptions: cut and cleared fractions must be in [0, 1]");
    DIACHRON_CHECK(new_tree_fraction >= 0.0 && new_tree_fraction <= 10.0 && new_stand_fraction >= 0.0 &&
                       new_stand_fraction <= 10.0,
                   "ChangeOptions: new tree and stand fractions must be in [0, 10]");
  }
};

/// A straight road: the line through `point` along unit `direction`, `width` metres wide.
struct Road {
  Vec2 point = Vec2::Zero();
  Vec2 direction = Vec2::UnitX();
  double width = 7.0;
  int first_epoch = 0;  ///< first epoch (index) in which the road exists

  bool exists_in(int epoch) const { return epoch >= first_epoch; }

  /// Distance of world (X, Y) from the road's centre line, metres.
  double distance(const Vec2& xy) const {
    const Vec2 d = xy - point;
    return std::abs(d.x() * direction.y() - d.y() * direction.x());
  }
};

/// A box building with a flat or gable roof, existing in epochs [first_epoch, last_epoch].
struct Building {
  Vec2 centre = Vec2::Zero();  ///< world X/Y, metres
  double half_length = 5.0;    ///< along the ridge (local u axis), metres
  double half_width = 4.0;     ///< across the ridge (local v axis), metres
  double yaw = 0.0;            ///< angle of the u axis from world +X, counter-clockwise, radians
  double base_z = 0.0;         ///< ground height at the centre, metres
  double eave_height = 6.0;    ///< walls' height above base_z, metres
  double ridge_rise = 0.0;     ///< gable ridge above the eaves, metres (0 = flat roof)
  float roof_albedo = 0.5f;    ///< roof reflectance, 0..1
  int first_epoch = 0;         ///< first epoch (index) in which the building stands
  int last_epoch = std::numeric_limits<int>::max();  ///< last epoch (index) in which it stands

  bool exists_in(int epoch) const { return epoch >= first_epoch && epoch <= last_epoch; }

  /// Local (u along the ridge, v across) coordinates of world (X, Y), metres.
  Vec2 local(const Vec2& xy) const {
    const Vec2 d = xy - centre;
    const double c = std::cos(yaw), s = std::sin(yaw);
    return {c * d.x() + s * d.y(), -s * d.x() + c * d.y()};
  }
  bool contains(const Vec2& xy) const {
    const Vec2 l = local(xy);
    return std::abs(l.x()) <= half_length && std::abs(l.y()) <= half_width;
  }
  /// Roof height at world (X, Y) inside the footprint, metres.
  double roof_z(const Vec2& xy) const {
    const double v = std::abs(local(xy).y());
    return base_z + eave_height + ridge_rise * std::max(0.0, 1.0 - v / half_width);
  }
  /// Radius of the circle that holds the footprint, metres.
  double radius() const { return std::hypot(half_length, half_width); }
};

/// A tree with an ellipsoidal crown on a short bare trunk, existing in epochs [first_epoch,
/// last_epoch] and growing by `growth` (relative) from each epoch to the next.
struct Tree {
  Vec2 centre = Vec2::Zero();  ///< world X/Y of the trunk, metres
  double base_z = 0.0;         ///< ground height at the trunk, metres
  double height = 15.0;        ///< height in its first epoch, metres
  double crown_ratio = 0.22;   ///< crown radius / height
  double growth = 0.0;         ///< relative growth per epoch
  float albedo = 0.15f;        ///< mean crown reflectance, 0..1
  std::uint64_t seed = 0;      ///< crown texture seed (combined with the epoch: crowns change)
  int first_epoch = 0;
  int last_epoch = std::numeric_limits<int>::max();

  bool exists_in(int epoch) const { return epoch >= first_epoch && epoch <= last_epoch; }
  /// Height in `epoch`, metres.
  double height_in(int epoch) const { return height * std::pow(1.0 + growth, std::max(0, epoch - first_epoch)); }
  /// Crown radius in `epoch`, metres.
  double crown_radius(int epoch) const { return crown_ratio * height_in(epoch); }
  /// Crown top at horizontal distance `r` from the trunk in `epoch`, or NaN outside the crown.
  /// The crown is the upper half of an ellipsoid whose equator is 55 % of the height up.
  double crown_z(double r, int epoch) const {
    const double h = height_in(epoch), radius = crown_ratio * h;
    if (!(r < radius)) return std::numeric_limits<double>::quiet_NaN();
    const double q = r / radius;
    return base_z + h * (0.55 + 0.45 * std::sqrt(1.0 - q * q));
  }
};

/// The world-frame description of a multi-epoch scene: ground surface and objects.
struct Landscape {
  /// Bare ground (no buildings), world frame, no holes. Its grid is the grid of every epoch's
  /// surface DSM.
  Dsm ground;
  std::vector<Road> roads;
  std::vector<Building> buildings;
  std::vector<Tree> trees;
  /// Seed of the field pattern (fields are a hash of their cell, not stored).
  std::uint64_t field_seed = 0;
  /// Field size (Voronoi site spacing), metres.
  double field_size_m = 90.0;
  /// Number of epochs the change history covers.
  int epoch_count = 2;
  /// Per-field probability of a crop change at each epoch after the first (ChangeOptions).
  double changed_field_fraction = 0.0;
  /// Seasonal albedo offset of each epoch (albedo units), multiplied by a per-field response.
  std::vector<double> season_shift;
  /// Field layout changes (ChangeOptions): per-region probability of a redrawn layout at each
  /// epoch after the first, region size and the field size factor of a redrawn layout.
  double redrawn_layout_fraction = 0.0;
  double layout_region_m = 350.0;
  double consolidation = 1.6;
};

namespace detail {

/// The cells of a `width` x `height` grid with geotransform `t` that a disc of `radius` metres
/// around `centre` can touch: [x0, x1] x [y0, y1], empty (x0 > x1) when it misses the grid.
struct CellBox {
  int x0 = 0, x1 = -1, y0 = 0, y1 = -1;
};
inline CellBox cell_box(const GeoTransform& t, const Vec2& centre, double radius, int width, int height) {
  const Vec2 p0 = t.world_to_pixel(centre - Vec2(radius, -radius));
  const Vec2 p1 = t.world_to_pixel(centre + Vec2(radius, -radius));
  return {std::max(0, static_cast<int>(std::floor(std::min(p0.x(), p1.x())))),
          std::min(width - 1, static_cast<int>(std::ceil(std::max(p0.x(), p1.x())))),
          std::max(0, static_cast<int>(std::floor(std::min(p0.y(), p1.y())))),
          std::min(height - 1, static_cast<int>(std::ceil(std::max(p0.y(), p1.y()))))};
}

/// Fills NaN cells of `heights` with the mean of their valid 8-neighbours, sweeping until none is
/// left (or no progress), so that a real DEM with nodata gaps becomes a closed surface.
inline void fill_dem_holes(Raster<float>& heights) {
  const int w = heights.width(), h = heights.height();
  std::vector<std::pair<int, float>> updates;
  for (int pass = 0; pass < w + h; ++pass) {
    updates.clear();
    bool any_hole = false;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        if (!std::isnan(heights(x, y))) continue;
        any_hole = true;
        double sum = 0.0;
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            if (!heights.contains(x + dx, y + dy)) continue;
            const float v = heights(x + dx, y + dy);
            if (!std::isnan(v)) {
              sum += v;
              ++n;
            }
          }
        if (n > 0) updates.emplace_back(y * w + x, static_cast<float>(sum / n));
      }
    if (!any_hole || updates.empty()) return;
    for (const auto& [index, value] : updates) heights.data()[index] = value;
  }
}

/// Procedural ground height at world (X, Y) relative to the scene centre.
struct ProceduralRelief {
  std::uint64_t seed = 0;
  double base = 0.0, amplitude = 0.0, wavelength = 1.0;
  int octaves = 1;
  Landform landform = Landform::none;
  double landform_height = 0.0, sigma = 1.0;
  Vec2 centre = Vec2::Zero(), valley_direction = Vec2::UnitX();

  double operator()(double X, double Y) const {
    const double dx = X - centre.x(), dy = Y - centre.y();
    double z = base + amplitude * fbm(seed, dx, dy, wavelength, octaves);
    if (landform == Landform::dome) {
      z += landform_height * std::exp(-(dx * dx + dy * dy) / (2.0 * sigma * sigma));
    } else if (landform == Landform::valley) {
      const double d = dx * valley_direction.y() - dy * valley_direction.x();
      z -= landform_height * std::exp(-d * d / (2.0 * sigma * sigma));
    }
    return z;
  }
};

/// Nearest road clearance check: true when a disc of `radius` at `xy` stays off every road.
inline bool clear_of_roads(const std::vector<Road>& roads, const Vec2& xy, double radius) {
  for (const Road& r : roads)
    if (r.distance(xy) < radius + 0.5 * r.width + 2.0) return false;
  return true;
}

/// Whether a disc of `radius` at `xy` is clear of every building of any epoch (trees never grow
/// through walls, so the true surface stays a clean union of objects).
inline bool clear_of_buildings(const std::vector<Building>& buildings, const Vec2& xy, double radius) {
  for (const Building& b : buildings)
    if ((b.centre - xy).squaredNorm() < (b.radius() + radius + 1.0) * (b.radius() + radius + 1.0)) return false;
  return true;
}

/// A point uniform over `bounds`, its y drawn before its x (core/random.hpp, "Order of draws").
inline Vec2 uniform_point(RandomStream& random, const WorldBounds& bounds) {
  const double y = random.uniform(bounds.min_y, bounds.max_y);
  return Vec2(random.uniform(bounds.min_x, bounds.max_x), y);
}

/// Plants forest stands, hedgerows and single trees (VegetationOptions) and their history over
/// the epochs (ChangeOptions): growth, cutting, clearing, new trees and young stands.
inline void plant_trees(Landscape& land, const TerrainOptions& options, const ChangeOptions& changes,
                        const WorldBounds& bounds, int epoch_count, std::uint64_t seed) {
  const VegetationOptions& v = options.vegetation;
  RandomStream random(seed, 6);
  const double width_m = bounds.max_x - bounds.min_x, height_m = bounds.max_y - bounds.min_y;
  const double area_km2 = width_m * height_m * 1e-6;
  const auto inside = [&](const Vec2& xy, double reach) {
    const double margin = 2.0 * options.cell_m + reach;
    return xy.x() > bounds.min_x + margin && xy.x() < bounds.max_x - margin && xy.y() > bounds.min_y + margin &&
           xy.y() < bounds.max_y - margin;
  };
  const auto add_tree = [&](const Vec2& xy, double height, int first_epoch) {
    Tree t;
    t.centre = xy;
    t.height = height;
    t.crown_ratio = v.crown_ratio * random.uniform(0.8, 1.25);
    t.growth = changes.tree_growth * random.uniform(0.5, 1.5);
    t.albedo = static_cast<float>(random.uniform(0.1, 0.24));
    t.seed = random.next_u64();
    t.first_epoch = first_epoch;
    const double reach = t.crown_ratio * height * std::pow(1.0 + t.growth, epoch_count);
    if (!inside(xy, reach) || !detail::clear_of_roads(land.roads, xy, reach) || !clear_of_buildings(land.buildings, xy, reach))
      return false;
    t.base_z = land.ground.height_at(xy);
    if (!std::isfinite(t.base_z)) return false;
    land.trees.push_back(t);
    return true;
  };
  const auto stand = [&](int first_epoch, double height_scale) {
    const Vec2 centre = uniform_point(random, bounds);
    const double radius = 0.5 * v.stand_diameter_m * random.uniform(0.6, 1.4);
    const std::uint64_t edge_seed = random.next_u64();
    const double mean_height = random.uniform(v.tree_min_height_m, v.tree_max_height_m);
    const std::size_t first = land.trees.size();
    const double s = v.forest_tree_spacing_m;
    const int n = static_cast<int>(std::ceil(radius * 1.4 / s));
    for (int j = -n; j <= n; ++j)
      for (int i = -n; i <= n; ++i) {
        // y before x (core/random.hpp, "Order of draws")
        const double jitter_y = random.uniform(-0.35, 0.35), jitter_x = random.uniform(-0.35, 0.35);
        const Vec2 xy = centre + s * Vec2(i + jitter_x, j + jitter_y);
        const Vec2 d = xy - centre;
        // A ragged edge: the stand's radius varies by +-30 % with direction and position.
        const double edge = radius * (1.0 + 0.3 * fbm(edge_seed, d.x(), d.y(), 0.6 * radius, 2));
        if (d.norm() > edge) continue;
        const double h = std::clamp(mean_height * random.uniform(0.8, 1.2), v.tree_min_height_m, v.tree_max_height_m);
        add_tree(xy, h * height_scale, first_epoch);
      }
    return std::make_pair(first, land.trees.size());
  };

  // Forest stands of the first epoch.
  const double stand_area_km2 = kPi * 0.25 * v.stand_diameter_m * v.stand_diameter_m * 1e-6;
  const auto stand_count = static_cast<std::size_t>(std::llround(v.forest_fraction * area_km2 / stand_area_km2));
  std::vector<std::pair<std::size_t, std::size_t>> stands;
  for (std::size_t k = 0; k < stand_count; ++k) stands.push_back(stand(0, 1.0));
  // Hedgerows: straight rows of trees, some gaps.
  const auto hedgerow_count = static_cast<std::size_t>(std::llround(v.hedgerows_per_km2 * area_km2));
  std::vector<std::size_t> cuttable;
  for (std::size_t k = 0; k < hedgerow_count; ++k) {
    const Vec2 start = uniform_point(random, bounds);
    const double azimuth = random.uniform(0.0, kPi);
    const Vec2 dir(std::cos(azimuth), std::sin(azimuth));
    const double length = v.hedgerow_length_m * random.uniform(0.5, 1.5);
    for (double t = 0.0; t <= length; t += v.hedgerow_tree_spacing_m * random.uniform(0.8, 1.25)) {
      if (random.uniform01() < 0.15) continue;
      const Vec2 xy = start + t * dir + random.normal(0.0, 0.4) * Vec2(-dir.y(), dir.x());
      if (add_tree(xy, 0.8 * random.uniform(v.tree_min_height_m, v.tree_max_height_m), 0)) cuttable.push_back(land.trees.size() - 1);
    }
  }
  // Free-standing trees.
  const auto single_count = static_cast<std::size_t>(std::llround(v.single_trees_per_km2 * area_km2));
  const auto single = [&](int first_epoch, double height_scale) {
    const Vec2 xy = uniform_point(random, bounds);
    if (add_tree(xy, height_scale * random.uniform(v.tree_min_height_m, v.tree_max_height_m), first_epoch))
      cuttable.push_back(land.trees.size() - 1);
  };
  for (std::size_t k = 0; k < single_count; ++k) single(0, 1.0);

  // History: at each new epoch some trees are cut and stands cleared, new trees and young stands appear.
  const auto new_singles = static_cast<std::size_t>(std::llround(changes.new_tree_fraction * static_cast<double>(single_count)));
  const auto new_stands = static_cast<std::size_t>(std::llround(changes.new_stand_fraction * static_cast<double>(stand_count)));
  for (int e = 1; e < epoch_count; ++e) {
    for (std::size_t index : cuttable) {
      Tree& t = land.trees[index];
      if (t.exists_in(e) && t.first_epoch < e && random.uniform01() < changes.cut_tree_fraction) t.last_epoch = e - 1;
    }
    for (const auto& [first, last] : stands)
      if (first < last && land.trees[first].exists_in(e) && land.trees[first].first_epoch < e &&
          random.uniform01() < changes.cleared_stand_fraction)
        for (std::size_t i = first; i < last; ++i) land.trees[i].last_epoch = e - 1;
    for (std::size_t k = 0; k < new_singles; ++k) single(e, 0.5);
    for (std::size_t k = 0; k < new_stands; ++k) stands.push_back(stand(e, 0.45));
  }
}

}  // namespace detail

/// Builds the landscape over `bounds` (world X/Y box, metres).
/// @param real_dem when given, the ground is this DEM (holes filled, bilinearly resampled onto
///        the scene grid of `options.cell_m`); it must cover `bounds`. Otherwise the ground is
///        procedural.
/// @param epoch_count number of epochs of the change history (>= 1).
/// @param seed everything random derives from it (streams by purpose, never by thread).
/// Throws diachron::Error for invalid options or a DEM that does not cover `bounds`.
inline Landscape make_landscape(const TerrainOptions& options, const ChangeOptions& changes,
                                const WorldBounds& bounds, int epoch_count, std::uint64_t seed,
                                const Dsm* real_dem = nullptr) {
  options.check();
  changes.check();
  DIACHRON_CHECK(epoch_count >= 1, "make_landscape: need at least one epoch, got " << epoch_count);
  DIACHRON_CHECK(bounds.max_x > bounds.min_x && bounds.max_y > bounds.min_y,
                 "make_landscape: empty scene bounds");
  const double cell = options.cell_m;
  const int w = static_cast<int>(std::ceil((bounds.max_x - bounds.min_x) / cell)) + 1;
  const int h = static_cast<int>(std::ceil((bounds.max_y - bounds.min_y) / cell)) + 1;
  DIACHRON_CHECK(static_cast<double>(w) * h <= 4.0e8,
                 "make_landscape: the scene grid would have " << w << " x " << h
                                                               << " cells; increase TerrainOptions::cell_m");
  const GeoTransform transform = GeoTransform::north_up(bounds.min_x, bounds.max_y, cell);
  Raster<float> heights(w, h);

  Landscape land;
  land.field_seed = detail::mix64(seed ^ 0x6669656c64ULL);
  land.field_size_m = options.field_size_m;
  land.epoch_count = epoch_count;
  land.changed_field_fraction = changes.changed_field_fraction;
  std::string crs = options.crs;

  if (real_dem != nullptr) {
    DIACHRON_CHECK(!real_dem->empty(), "make_landscape: the real DEM is empty");
    Raster<float> filled = real_dem->heights();
    detail::fill_dem_holes(filled);
    const Dsm dem(std::move(filled), real_dem->transform(), real_dem->crs());
    const WorldBounds dem_box = dem.bounds();
    crs = real_dem->crs();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const Vec2 xy = transform.pixel_to_world(Vec2(x, y));
        const double z = dem.height_at(xy);
        DIACHRON_CHECK(std::isfinite(z), std::fixed << std::setprecision(1)
                                             << "make_landscape: the real DEM does not cover the scene at ("
                                             << xy.x() << ", " << xy.y() << "): the scene needs X ["
                                             << bounds.min_x << ", " << bounds.max_x << "] Y [" << bounds.min_y
                                             << ", " << bounds.max_y << "], the DEM has X [" << dem_box.min_x << ", "
                                             << dem_box.max_x << "] Y [" << dem_box.min_y << ", " << dem_box.max_y
                                             << "] (the footprints are taken at the DEM's lowest height); use "
                                                "smaller or fewer images, or a higher flight at the same GSD");
        heights(x, y) = static_cast<float>(z);
      }
  } else {
    RandomStream random(seed, 1);
    detail::ProceduralRelief relief;
    relief.seed = detail::mix64(seed ^ 0x72656c696566ULL);
    relief.base = options.base_height_m;
    relief.amplitude = options.relief_amplitude_m;
    relief.wavelength = options.relief_wavelength_m;
    relief.octaves = options.relief_octaves;
    relief.landform = options.landform;
    relief.landform_height = options.landform_height_m;
    relief.sigma = options.landform_width_fraction *
                   std::min(bounds.max_x - bounds.min_x, bounds.max_y - bounds.min_y);
    relief.centre = Vec2(0.5 * (bounds.min_x + bounds.max_x), 0.5 * (bounds.min_y + bounds.max_y));
    const double azimuth = random.uniform(0.0, kPi);
    relief.valley_direction = Vec2(std::cos(azimuth), std::sin(azimuth));
    // The relief is smooth at the scale of its finest octave, so it is evaluated on a coarse grid
    // (a quarter of that wavelength) and interpolated bilinearly: same surface, a fraction of the cost.
    const double finest = options.relief_wavelength_m / std::pow(2.0, options.relief_octaves - 1);
    const int step = std::clamp(static_cast<int>(0.25 * finest / cell), 1, 64);
    const int cw = (w - 1) / step + 2, ch = (h - 1) / step + 2;
    Raster<double> coarse(cw, ch);
    for (int y = 0; y < ch; ++y)
      for (int x = 0; x < cw; ++x) {
        const Vec2 xy = transform.pixel_to_world(Vec2(x * step, y * step));
        coarse(x, y) = relief(xy.x(), xy.y());
      }
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int x0 = x / step, y0 = y / step;
        const double fx = static_cast<double>(x - x0 * step) / step, fy = static_cast<double>(y - y0 * step) / step;
        const double top = coarse(x0, y0) + fx * (coarse(x0 + 1, y0) - coarse(x0, y0));
        const double bottom = coarse(x0, y0 + 1) + fx * (coarse(x0 + 1, y0 + 1) - coarse(x0, y0 + 1));
        heights(x, y) = static_cast<float>(top + fy * (bottom - top));
      }
  }
  land.ground = Dsm(std::move(heights), transform, crs);

  const double width_m = bounds.max_x - bounds.min_x, height_m = bounds.max_y - bounds.min_y;
  const double area_km2 = width_m * height_m * 1e-6;

  // Roads: lines through random points of the middle of the scene, at random azimuths.
  {
    RandomStream random(seed, 2);
    for (int i = 0; i < options.road_count; ++i) {
      Road road;
      const double fy = random.uniform(0.2, 0.8);
      road.point = Vec2(bounds.min_x + width_m * random.uniform(0.2, 0.8), bounds.min_y + height_m * fy);
      const double azimuth = random.uniform(0.0, kPi);
      road.direction = Vec2(std::cos(azimuth), std::sin(azimuth));
      road.width = options.road_width_m;
      land.roads.push_back(road);
    }
    // Roads built in later epochs (own stream, so that the first roads do not depend on them).
    RandomStream later(seed, 5);
    for (int e = 1; e < epoch_count; ++e)
      for (int i = 0; i < changes.new_roads; ++i) {
        Road road;
        const double fy = later.uniform(0.15, 0.85);
        road.point = Vec2(bounds.min_x + width_m * later.uniform(0.15, 0.85), bounds.min_y + height_m * fy);
        const double azimuth = later.uniform(0.0, kPi);
        road.direction = Vec2(std::cos(azimuth), std::sin(azimuth));
        road.width = options.road_width_m;
        road.first_epoch = e;
        land.roads.push_back(road);
      }
  }

  // Buildings: villages (clusters sharing an orientation) and scattered farms; placement rejects
  // overlaps and roads so that every building is a clean box in the DSM.
  const bool with_buildings = real_dem == nullptr || options.buildings_on_real_dem;
  if (with_buildings) {
    RandomStream random(seed, 3);
    const auto initial = static_cast<std::size_t>(std::llround(options.building_density_per_km2 * area_km2));
    const auto new_per_epoch = static_cast<std::size_t>(
        std::llround(changes.new_building_fraction * static_cast<double>(initial)));
    const auto village_count =
        std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(options.villages_per_km2 * area_km2)));
    std::vector<std::pair<Vec2, double>> villages;  // centre, yaw
    // A village: its yaw, then its centre's y, then x (core/random.hpp, "Order of draws").
    const auto new_village = [&] {
      const double yaw = random.uniform(0.0, kPi), fy = random.uniform(0.1, 0.9), fx = random.uniform(0.1, 0.9);
      villages.emplace_back(Vec2(bounds.min_x + width_m * fx, bounds.min_y + height_m * fy), yaw);
    };
    for (std::size_t v = 0; v < village_count; ++v) new_village();
    const double village_sigma = 0.25 * std::sqrt(1e6 / std::max(options.villages_per_km2, 1e-3));

    const auto place = [&](int first_epoch) {
      for (int attempt = 0; attempt < 50; ++attempt) {
        Building b;
        double yaw;
        if (random.uniform01() < options.village_fraction) {
          const auto& village = villages[random.uniform_index(villages.size())];
          const double dy = random.normal(), dx = random.normal();
          b.centre = village.first + village_sigma * Vec2(dx, dy);
          const double turn = random.uniform01() < 0.5 ? 0.0 : 0.5 * kPi;
          yaw = village.second + turn + random.normal(0.0, 0.05);
        } else {
          b.centre = detail::uniform_point(random, bounds);
          yaw = random.uniform(0.0, kPi);
        }
        const double a = random.uniform(options.building_min_size_m, options.building_max_size_m);
        const double c = random.uniform(options.building_min_size_m, options.building_max_size_m);
        b.half_length = 0.5 * std::max(a, c);
        b.half_width = 0.5 * std::min(a, c);
        b.yaw = yaw;
        b.eave_height = random.uniform(options.building_min_height_m, options.building_max_height_m);
        b.ridge_rise = random.uniform01() < options.gable_fraction ? b.half_width * random.uniform(0.4, 0.9) : 0.0;
        b.roof_albedo = static_cast<float>(random.uniform(0.25, 0.9));
        b.first_epoch = first_epoch;
        const double margin = 2.0 * cell + b.radius();
        if (b.centre.x() < bounds.min_x + margin || b.centre.x() > bounds.max_x - margin ||
            b.centre.y() < bounds.min_y + margin || b.centre.y() > bounds.max_y - margin)
          continue;
        if (!detail::clear_of_roads(land.roads, b.centre, b.radius())) continue;
        bool overlaps = false;
        for (const Building& o : land.buildings)
          if ((o.centre - b.centre).norm() < o.radius() + b.radius() + 3.0) {
            overlaps = true;
            break;
          }
        if (overlaps) continue;
        b.base_z = land.ground.height_at(b.centre);
        if (!std::isfinite(b.base_z)) continue;
        land.buildings.push_back(b);
        return;
      }
    };
    for (std::size_t i = 0; i < initial; ++i) place(0);
    const auto new_villages = static_cast<std::size_t>(std::llround(changes.new_villages_per_km2 * area_km2));
    for (int e = 1; e < epoch_count; ++e) {
      // Housing estates: new buildings cluster in the new villages as much as in the old ones.
      for (std::size_t v = 0; v < new_villages; ++v) new_village();
      for (Building& b : land.buildings)
        if (b.exists_in(e) && b.first_epoch < e && random.uniform01() < changes.removed_building_fraction)
          b.last_epoch = e - 1;
      for (std::size_t i = 0; i < new_per_epoch; ++i) place(e);
    }
  }

  {
    RandomStream random(seed, 4);
    for (int e = 0; e < epoch_count; ++e)
      land.season_shift.push_back(changes.seasonal_shift * random.uniform(-1.0, 1.0));
  }
  land.redrawn_layout_fraction = changes.redrawn_layout_fraction;
  land.layout_region_m = changes.layout_region_m;
  land.consolidation = changes.consolidation;
  if (options.vegetation.any()) detail::plant_trees(land, options, changes, bounds, epoch_count, seed);
  return land;
}

/// The true surface of `epoch` in the world frame: the ground with that epoch's buildings and trees, on the
/// ground's grid. Roofs are sampled at cell centres, so walls are one cell wide in the bilinear
/// surface.
inline Dsm surface_dsm(const Landscape& land, int epoch) {
  DIACHRON_CHECK(!land.ground.empty(), "surface_dsm: the landscape has no ground");
  Raster<float> heights = land.ground.heights();
  const GeoTransform& t = land.ground.transform();
  for (const Building& b : land.buildings) {
    if (!b.exists_in(epoch)) continue;
    const double r = b.radius();
    const detail::CellBox box = detail::cell_box(t, b.centre, r, heights.width(), heights.height());
    for (int y = box.y0; y <= box.y1; ++y)
      for (int x = box.x0; x <= box.x1; ++x) {
        const Vec2 xy = t.pixel_to_world(Vec2(x, y));
        if (!b.contains(xy)) continue;
        heights(x, y) = std::max(heights(x, y), static_cast<float>(b.roof_z(xy)));
      }
  }
  for (const Tree& tree : land.trees) {
    if (!tree.exists_in(epoch)) continue;
    const double r = tree.crown_radius(epoch);
    const detail::CellBox box = detail::cell_box(t, tree.centre, r, heights.width(), heights.height());
    for (int y = box.y0; y <= box.y1; ++y)
      for (int x = box.x0; x <= box.x1; ++x) {
        const double z = tree.crown_z((t.pixel_to_world(Vec2(x, y)) - tree.centre).norm(), epoch);
        if (std::isfinite(z)) heights(x, y) = std::max(heights(x, y), static_cast<float>(z));
      }
  }
  return Dsm(std::move(heights), t, land.ground.crs());
}

}  // namespace diachron
