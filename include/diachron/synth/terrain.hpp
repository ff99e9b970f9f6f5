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

  void check() const {
    DIACHRON_CHECK(changed_field_fraction >= 0.0 && changed_field_fraction <= 1.0,
                   "ChangeOptions::changed_field_fraction must be in [0, 1]");
    DIACHRON_CHECK(removed_building_fraction >= 0.0 && removed_building_fraction <= 1.0,
                   "ChangeOptions::removed_building_fraction must be in [0, 1]");
    DIACHRON_CHECK(new_building_fraction >= 0.0 && new_building_fraction <= 10.0,
                   "ChangeOptions::new_building_fraction must be in [0, 10]");
    DIACHRON_CHECK(seasonal_shift >= 0.0 && seasonal_shift <= 1.0, "ChangeOptions::seasonal_shift must be in [0, 1]");
  }
};

/// A straight road: the line through `point` along unit `direction`, `width` metres wide.
struct Road {
  Vec2 point = Vec2::Zero();
  Vec2 direction = Vec2::UnitX();
  double width = 7.0;

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

/// The world-frame description of a multi-epoch scene: ground surface and objects.
struct Landscape {
  /// Bare ground (no buildings), world frame, no holes. Its grid is the grid of every epoch's
  /// surface DSM.
  Dsm ground;
  std::vector<Road> roads;
  std::vector<Building> buildings;
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
};

namespace detail {

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
    crs = real_dem->crs();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const Vec2 xy = transform.pixel_to_world(Vec2(x, y));
        const double z = dem.height_at(xy);
        DIACHRON_CHECK(std::isfinite(z), "make_landscape: the real DEM does not cover the scene at ("
                                             << xy.x() << ", " << xy.y()
                                             << "); lower the flying height or use fewer images");
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
      road.point = Vec2(bounds.min_x + width_m * random.uniform(0.2, 0.8),
                        bounds.min_y + height_m * random.uniform(0.2, 0.8));
      const double azimuth = random.uniform(0.0, kPi);
      road.direction = Vec2(std::cos(azimuth), std::sin(azimuth));
      road.width = options.road_width_m;
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
    for (std::size_t v = 0; v < village_count; ++v)
      villages.emplace_back(Vec2(bounds.min_x + width_m * random.uniform(0.1, 0.9),
                                 bounds.min_y + height_m * random.uniform(0.1, 0.9)),
                            random.uniform(0.0, kPi));
    const double village_sigma = 0.25 * std::sqrt(1e6 / std::max(options.villages_per_km2, 1e-3));

    const auto place = [&](int first_epoch) {
      for (int attempt = 0; attempt < 50; ++attempt) {
        Building b;
        double yaw;
        if (random.uniform01() < options.village_fraction) {
          const auto& village = villages[random.uniform_index(villages.size())];
          b.centre = village.first + village_sigma * Vec2(random.normal(), random.normal());
          yaw = village.second + (random.uniform01() < 0.5 ? 0.0 : 0.5 * kPi) + random.normal(0.0, 0.05);
        } else {
          b.centre = Vec2(random.uniform(bounds.min_x, bounds.max_x), random.uniform(bounds.min_y, bounds.max_y));
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
    for (int e = 1; e < epoch_count; ++e) {
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
  return land;
}

/// The true surface of `epoch` in the world frame: the ground with that epoch's buildings, on the
/// ground's grid. Roofs are sampled at cell centres, so walls are one cell wide in the bilinear
/// surface.
inline Dsm surface_dsm(const Landscape& land, int epoch) {
  DIACHRON_CHECK(!land.ground.empty(), "surface_dsm: the landscape has no ground");
  Raster<float> heights = land.ground.heights();
  const GeoTransform& t = land.ground.transform();
  for (const Building& b : land.buildings) {
    if (!b.exists_in(epoch)) continue;
    const double r = b.radius();
    const Vec2 p0 = t.world_to_pixel(b.centre - Vec2(r, -r));
    const Vec2 p1 = t.world_to_pixel(b.centre + Vec2(r, -r));
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min(p0.x(), p1.x()))));
    const int x1 = std::min(heights.width() - 1, static_cast<int>(std::ceil(std::max(p0.x(), p1.x()))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min(p0.y(), p1.y()))));
    const int y1 = std::min(heights.height() - 1, static_cast<int>(std::ceil(std::max(p0.y(), p1.y()))));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const Vec2 xy = t.pixel_to_world(Vec2(x, y));
        if (!b.contains(xy)) continue;
        heights(x, y) = std::max(heights(x, y), static_cast<float>(b.roof_z(xy)));
      }
  }
  return Dsm(std::move(heights), t, land.ground.crs());
}

}  // namespace diachron
