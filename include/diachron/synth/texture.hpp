#pragma once
/// @file
/// Ground texture of a synthetic scene: an albedo raster painted from the landscape of one epoch
/// (fields with crop patterns, hedges, bushes, roads, roofs, fine texture noise) so that images
/// rendered from it carry SIFT-type features, and so that epochs differ where the landscape
/// changed (re-cropped fields, new and removed buildings, bushes, a seasonal shift).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/synth/noise.hpp>
#include <diachron/synth/terrain.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of the ground texture. Albedo values are reflectances in [0, 1].
struct TextureOptions {
  /// Cell size of the albedo raster, metres: at most half the images' ground sampling distance
  /// keeps rendered images free of texture blockiness. > 0.
  double texel_m = 1.0;
  /// Amplitude of the fine texture noise added everywhere (albedo units). >= 0.
  double noise_amplitude = 0.06;
  /// Wavelength of the fine texture noise (two octaves: this and half of it), metres. > 0.
  double noise_wavelength_m = 5.0;
  /// Fraction of field borders lined by a hedge. In [0, 1].
  double hedge_fraction = 0.6;
  /// Hedge width, metres. > 0.
  double hedge_width_m = 2.5;
  /// Spacing of the bush lattice, metres (at most one bush per lattice cell). > 0.
  double bush_spacing_m = 22.0;
  /// Probability that a lattice cell holds a bush. In [0, 1].
  double bush_probability = 0.35;
  /// Probability that a bush disappears at each new epoch. In [0, 1].
  double bush_removal_probability = 0.1;
  /// Road surface albedo.
  double road_albedo = 0.72;
  /// Parallel rows: 0 = all cores. Results do not depend on it.
  std::size_t threads = 0;

  void check() const {
    DIACHRON_CHECK(texel_m > 0.0 && std::isfinite(texel_m), "TextureOptions::texel_m must be > 0, got " << texel_m);
    DIACHRON_CHECK(noise_amplitude >= 0.0, "TextureOptions::noise_amplitude must be >= 0");
    DIACHRON_CHECK(noise_wavelength_m > 0.0, "TextureOptions::noise_wavelength_m must be > 0");
    DIACHRON_CHECK(hedge_fraction >= 0.0 && hedge_fraction <= 1.0, "TextureOptions::hedge_fraction must be in [0, 1]");
    DIACHRON_CHECK(hedge_width_m > 0.0, "TextureOptions::hedge_width_m must be > 0");
    DIACHRON_CHECK(bush_spacing_m > 0.0, "TextureOptions::bush_spacing_m must be > 0");
    DIACHRON_CHECK(bush_probability >= 0.0 && bush_probability <= 1.0,
                   "TextureOptions::bush_probability must be in [0, 1]");
    DIACHRON_CHECK(bush_removal_probability >= 0.0 && bush_removal_probability <= 1.0,
                   "TextureOptions::bush_removal_probability must be in [0, 1]");
    DIACHRON_CHECK(road_albedo >= 0.0 && road_albedo <= 1.0, "TextureOptions::road_albedo must be in [0, 1]");
  }
};

/// Land-cover classes that a film or a sensor renders differently (LandCoverResponse).
enum class LandCover : int {
  crop = 0,   ///< ploughed and cropped fields
  grass = 1,  ///< meadows, the ground between orchard trees
  woody = 2,  ///< trees, hedges, bushes, orchard crowns
  road = 3,   ///< roads and their verges
  roof = 4,   ///< roofs
};
inline constexpr int kLandCoverCount = 5;

/// How one epoch's film or sensor renders each land-cover class: albedo' = offset + gain * albedo
/// per class, before the fine texture noise. Old orthochromatic or panchromatic film renders
/// vegetation dark, a modern sensor with near-infrared response renders it bright: a negative
/// gain inverts a class's contrast. The identity (the default) leaves the albedo unchanged.
struct LandCoverResponse {
  std::array<double, kLandCoverCount> gain = {1.0, 1.0, 1.0, 1.0, 1.0};
  std::array<double, kLandCoverCount> offset = {0.0, 0.0, 0.0, 0.0, 0.0};

  double apply(LandCover c, double albedo) const {
    const auto k = static_cast<std::size_t>(c);
    return offset[k] + gain[k] * albedo;
  }
  void check() const {
    for (int k = 0; k < kLandCoverCount; ++k)
      DIACHRON_CHECK(std::isfinite(gain[static_cast<std::size_t>(k)]) && std::isfinite(offset[static_cast<std::size_t>(k)]) &&
                         std::abs(gain[static_cast<std::size_t>(k)]) <= 10.0,
                     "LandCoverResponse: gain and offset of class " << k << " must be finite (|gain| <= 10)");
  }
};

/// An albedo raster over world X/Y (values in [0, 1], pixel-centre convention).
struct AlbedoMap {
  Raster<float> values;
  GeoTransform transform;

  /// Bilinear albedo at world (X, Y); clamped to the edge outside the raster.
  double sample(const Vec2& xy) const {
    if (values.empty()) return 0.0;
    const Vec2 p = transform.world_to_pixel(xy);
    const double x = std::clamp(p.x(), 0.0, values.width() - 1.0);
    const double y = std::clamp(p.y(), 0.0, values.height() - 1.0);
    const int x0 = std::min(static_cast<int>(x), std::max(values.width() - 2, 0));
    const int y0 = std::min(static_cast<int>(y), std::max(values.height() - 2, 0));
    const int x1 = std::min(x0 + 1, values.width() - 1), y1 = std::min(y0 + 1, values.height() - 1);
    const double fx = x - x0, fy = y - y0;
    const double top = values(x0, y0) + fx * (values(x1, y0) - values(x0, y0));
    const double bottom = values(x0, y1) + fx * (values(x1, y1) - values(x0, y1));
    return top + fy * (bottom - top);
  }
};

namespace detail {

/// The crop look of one field in one epoch, all drawn from a hash of (field, generation).
struct FieldLook {
  int pattern = 0;         // 0 stripes, 1 speckle, 2 orchard, 3 smooth
  double albedo = 0.4;     // mean albedo
  double contrast = 0.1;   // pattern amplitude
  Vec2 direction = Vec2::UnitX();
  double period = 8.0;     // metres
  double response = 1.0;   // seasonal response
  std::uint64_t seed = 0;  // pattern noise seed
};

inline FieldLook field_look(std::uint64_t field_seed, std::int64_t i, std::int64_t j, int generation) {
  RandomStream random(mix64(field_seed ^ static_cast<std::uint64_t>(i) * 0x9e3779b97f4a7c15ULL) ^
                          static_cast<std::uint64_t>(j),
                      static_cast<std::uint64_t>(generation));
  FieldLook look;
  look.pattern = static_cast<int>(random.uniform_index(4));
  look.albedo = random.uniform(0.22, 0.62);
  look.contrast = random.uniform(0.06, 0.16);
  const double angle = random.uniform(0.0, kPi);
  look.direction = Vec2(std::cos(angle), std::sin(angle));
  look.period = random.uniform(5.0, 12.0);
  look.response = random.uniform(-1.2, 1.2);
  look.seed = random.next_u64();
  return look;
}

/// The generation (number of crop changes so far) of field (i, j) at `epoch`.
inline int field_generation(std::uint64_t field_seed, std::int64_t i, std::int64_t j, int epoch,
                            double change_probability) {
  int generation = 0;
  for (int e = 1; e <= epoch; ++e)
    if (lattice_uniform(mix64(field_seed + static_cast<std::uint64_t>(e)), i, j) < change_probability) ++generation;
  return generation;
}

/// Albedo of the open land (fields, hedges, bushes, noise) at world (X, Y): no roads or roofs.
/// Keeps the Voronoi sites and the field look of the last query, since consecutive texels almost
/// always fall in the same lattice cell and field; one sampler per thread.
class LandSampler {
 public:
  LandSampler(const Landscape& land, const TextureOptions& options, int epoch, std::uint64_t seed,
              const LandCoverResponse& response = LandCoverResponse{})
      : land_(&land), options_(&options), response_(&response), epoch_(epoch), seed_(seed) {}

  double operator()(const Vec2& xy) {
    const Landscape& land = *land_;
    const TextureOptions& options = *options_;
    const LandCoverResponse& response = *response_;
    const int layout = layout_generation(xy);
    const double s = layout_field_size_;
    const auto ci = static_cast<std::int64_t>(std::floor(xy.x() / s));
    const auto cj = static_cast<std::int64_t>(std::floor(xy.y() / s));
    if (!has_sites_ || ci != ci_ || cj != cj_ || layout != sites_layout_) load_sites(ci, cj, layout);
    // Jittered-grid Voronoi: the site of lattice cell (i, j) lies in its middle 70 %, so the
    // nearest two sites are among the 3 x 3 neighbouring cells.
    double d1 = 1e300, d2 = 1e300;
    int k1 = 0, k2 = 0;
    for (int k = 0; k < 9; ++k) {
      const double d = (sites_[k] - xy).squaredNorm();
      if (d < d1) {
        d2 = d1, k2 = k1;
        d1 = d, k1 = k;
      } else if (d < d2) {
        d2 = d, k2 = k;
      }
    }
    const std::int64_t i1 = ci_ + k1 % 3 - 1, j1 = cj_ + k1 / 3 - 1;
    const std::int64_t i2 = ci_ + k2 % 3 - 1, j2 = cj_ + k2 / 3 - 1;
    if (!has_look_ || i1 != look_i_ || j1 != look_j_ || layout != look_layout_) {
      look_ = field_look(layout_seed_, i1, j1, field_generation(layout_seed_, i1, j1, epoch_, land.changed_field_fraction));
      look_i_ = i1;
      look_j_ = j1;
      look_layout_ = layout;
      has_look_ = true;
    }
    const FieldLook& look = look_;
    const double along = xy.dot(look.direction);
    double albedo = look.albedo;
    LandCover cover = LandCover::crop;
    switch (look.pattern) {
      case 0:  // plough or crop rows
        albedo += look.contrast * std::sin(2.0 * kPi * along / look.period);
        break;
      case 1:  // patchy crop
        albedo += 2.0 * look.contrast * fbm(look.seed, xy.x(), xy.y(), 3.0 * look.period, 2);
        break;
      case 2: {  // orchard: a rotated lattice of dark tree crowns
        const double across = xy.x() * -look.direction.y() + xy.y() * look.direction.x();
        const double spacing = look.period + 4.0;
        const double u = along / spacing - std::floor(along / spacing) - 0.5;
        const double v = across / spacing - std::floor(across / spacing) - 0.5;
        const double r = std::sqrt(u * u + v * v) * spacing;
        cover = LandCover::grass;
        if (r < 2.2) {
          albedo = 0.12 + 0.05 * r;
          cover = LandCover::woody;
        }
        break;
      }
      default:  // smooth meadow
        albedo += 2.0 * look.contrast * fbm(look.seed, xy.x(), xy.y(), 40.0, 1);
        cover = LandCover::grass;
        break;
    }
    if (look.pattern != 2 && epoch_ < static_cast<int>(land.season_shift.size()))
      albedo += land.season_shift[static_cast<std::size_t>(epoch_)] * look.response;

    // Hedge along the border with the second-nearest field, on a random subset of borders.
    const Vec2 a = sites_[k1], b = sites_[k2];
    const Vec2 ab = b - a;
    const double border = std::abs((xy - 0.5 * (a + b)).dot(ab)) / ab.norm();
    if (border < 0.5 * options.hedge_width_m) {
      const bool first_low = i1 < i2 || (i1 == i2 && j1 < j2);
      const std::int64_t lo = first_low ? i1 * 1000003 + j1 : i2 * 1000003 + j2;
      const std::int64_t hi = first_low ? i2 * 1000003 + j2 : i1 * 1000003 + j1;
      if (lattice_uniform(layout_seed_ ^ 0x68656467ULL, lo, hi) < options.hedge_fraction) {
        albedo = 0.1 + 0.08 * border / options.hedge_width_m;
        cover = LandCover::woody;
      }
    }

    // A bush per lattice cell at most, kept inside its cell so only that cell needs testing.
    {
      const double spacing = options.bush_spacing_m;
      const auto bi = static_cast<std::int64_t>(std::floor(xy.x() / spacing));
      const auto bj = static_cast<std::int64_t>(std::floor(xy.y() / spacing));
      const std::uint64_t bseed = seed_ ^ 0x62757368ULL;
      if (lattice_uniform(bseed, bi, bj) < options.bush_probability) {
        bool alive = true;
        for (int e = 1; e <= epoch_ && alive; ++e)
          alive = lattice_uniform(mix64(bseed + static_cast<std::uint64_t>(e)), bi, bj) >= options.bush_removal_probability;
        if (alive) {
          const double radius = spacing * (0.06 + 0.08 * lattice_uniform(bseed ^ 1, bi, bj));
          const Vec2 centre((static_cast<double>(bi) + 0.3 + 0.4 * lattice_uniform(bseed ^ 2, bi, bj)) * spacing,
                            (static_cast<double>(bj) + 0.3 + 0.4 * lattice_uniform(bseed ^ 3, bi, bj)) * spacing);
          const double r = (xy - centre).norm();
          if (r < radius) {
            albedo = 0.08 + 0.1 * r / radius;
            cover = LandCover::woody;
          }
        }
      }
    }
    albedo = response.apply(cover, albedo);
    albedo += options.noise_amplitude * fbm(seed_ ^ 0x6e6f6973ULL, xy.x(), xy.y(), options.noise_wavelength_m, 2);
    return albedo;
  }

 private:
  /// The number of times the field layout of the region holding `xy` has been redrawn up to this
  /// epoch; sets layout_seed_ and layout_field_size_ for it. Generation 0 is the original layout.
  int layout_generation(const Vec2& xy) {
    const Landscape& land = *land_;
    if (land.redrawn_layout_fraction <= 0.0 || epoch_ == 0) {
      layout_seed_ = land.field_seed;
      layout_field_size_ = land.field_size_m;
      return 0;
    }
    const auto ri = static_cast<std::int64_t>(std::floor(xy.x() / land.layout_region_m));
    const auto rj = static_cast<std::int64_t>(std::floor(xy.y() / land.layout_region_m));
    if (!has_region_ || ri != region_i_ || rj != region_j_) {
      region_generation_ = 0;
      for (int e = 1; e <= epoch_; ++e)
        if (lattice_uniform(mix64(land.field_seed ^ (0x6c61796f7574ULL + static_cast<std::uint64_t>(e))), ri, rj) <
            land.redrawn_layout_fraction)
          ++region_generation_;
      region_i_ = ri;
      region_j_ = rj;
      has_region_ = true;
    }
    const int g = region_generation_;
    layout_seed_ = g == 0 ? land.field_seed : mix64(land.field_seed + 0x9e3779b97f4a7c15ULL * static_cast<std::uint64_t>(g));
    layout_field_size_ = land.field_size_m * std::pow(land.consolidation, g);
    return g;
  }

  void load_sites(std::int64_t ci, std::int64_t cj, int layout) {
    const double s = layout_field_size_;
    for (int k = 0; k < 9; ++k) {
      const std::int64_t i = ci + k % 3 - 1, j = cj + k / 3 - 1;
      sites_[k] = Vec2((static_cast<double>(i) + 0.15 + 0.7 * lattice_uniform(layout_seed_, i, j)) * s,
                       (static_cast<double>(j) + 0.15 + 0.7 * lattice_uniform(layout_seed_ ^ 0xabcdefULL, i, j)) * s);
    }
    ci_ = ci;
    cj_ = cj;
    sites_layout_ = layout;
    has_sites_ = true;
  }

  const Landscape* land_;
  const TextureOptions* options_;
  const LandCoverResponse* response_;
  int epoch_;
  std::uint64_t seed_;
  bool has_sites_ = false, has_look_ = false, has_region_ = false;
  std::int64_t ci_ = 0, cj_ = 0, look_i_ = 0, look_j_ = 0, region_i_ = 0, region_j_ = 0;
  int sites_layout_ = 0, look_layout_ = 0, region_generation_ = 0;
  std::uint64_t layout_seed_ = 0;
  double layout_field_size_ = 1.0;
  Vec2 sites_[9];
  FieldLook look_;
};

}  // namespace detail

/// Paints the albedo of `epoch` over `bounds` (world X/Y, metres) on a north-up grid of
/// `options.texel_m`. Rows are computed in parallel; the result does not depend on the threads.
/// @param seed seed of the texture noise and bushes (the fields use the landscape's own seed).
/// @param response how this epoch's film or sensor renders each land-cover class (identity by default).
inline AlbedoMap render_albedo(const Landscape& land, int epoch, const WorldBounds& bounds,
                               const TextureOptions& options, std::uint64_t seed,
                               const LandCoverResponse& response = LandCoverResponse{}) {
  options.check();
  response.check();
  DIACHRON_CHECK(bounds.max_x > bounds.min_x && bounds.max_y > bounds.min_y, "render_albedo: empty bounds");
  DIACHRON_CHECK(epoch >= 0 && epoch < land.epoch_count,
                 "render_albedo: epoch " << epoch << " outside the landscape's " << land.epoch_count << " epochs");
  const double texel = options.texel_m;
  const int w = static_cast<int>(std::ceil((bounds.max_x - bounds.min_x) / texel)) + 1;
  const int h = static_cast<int>(std::ceil((bounds.max_y - bounds.min_y) / texel)) + 1;
  DIACHRON_CHECK(static_cast<double>(w) * h <= 4.0e8,
                 "render_albedo: the texture would have " << w << " x " << h << " texels; increase texel_m");
  AlbedoMap map;
  map.transform = GeoTransform::north_up(bounds.min_x, bounds.max_y, texel);
  map.values.resize(w, h);

  std::vector<const Building*> buildings;
  for (const Building& b : land.buildings)
    if (b.exists_in(epoch)) buildings.push_back(&b);

  parallel_for(static_cast<std::size_t>(h), options.threads, [&](std::size_t row) {
    const int y = static_cast<int>(row);
    float* out = map.values.row(y);
    detail::LandSampler land_albedo(land, options, epoch, seed, response);
    for (int x = 0; x < w; ++x) {
      const Vec2 xy = map.transform.pixel_to_world(Vec2(x, y));
      double albedo = land_albedo(xy);
      for (const Road& road : land.roads) {
        if (!road.exists_in(epoch)) continue;
        const double d = road.distance(xy);
        if (d < 0.5 * road.width) {
          // Darker verges make the road edges crisp features; a faint wear pattern along it.
          const double edge = 0.5 * road.width - d;
          albedo = response.apply(LandCover::road,
                                  edge < 0.8 ? 0.35 : options.road_albedo + 0.03 * std::sin(xy.dot(road.direction) * 0.9));
        }
      }
      out[x] = static_cast<float>(albedo);
    }
  });

  // Roofs over everything: outline darker so that footprints show in the images.
  for (const Building* b : buildings) {
    const double r = b->radius();
    const detail::CellBox box = detail::cell_box(map.transform, b->centre, r, w, h);
    for (int y = box.y0; y <= box.y1; ++y)
      for (int x = box.x0; x <= box.x1; ++x) {
        const Vec2 xy = map.transform.pixel_to_world(Vec2(x, y));
        const Vec2 l = b->local(xy);
        const double du = b->half_length - std::abs(l.x()), dv = b->half_width - std::abs(l.y());
        if (du < 0.0 || dv < 0.0) continue;
        double albedo = b->roof_albedo;
        if (std::min(du, dv) < 0.7) albedo *= 0.55;
        if (b->ridge_rise > 0.0 && std::abs(l.y()) < 0.4) albedo = std::min(1.0, albedo * 1.25);
        map.values(x, y) = static_cast<float>(response.apply(LandCover::roof, albedo));
      }
  }
  // Tree crowns: a clumpy texture whose pattern is drawn anew in every epoch (leaves, branches and
  // gaps of a crown do not keep their place over decades); the crown's relief comes from the shading.
  for (const Tree& tree : land.trees) {
    if (!tree.exists_in(epoch)) continue;
    const double r = tree.crown_radius(epoch);
    const detail::CellBox box = detail::cell_box(map.transform, tree.centre, r, w, h);
    const std::uint64_t crown_seed = detail::mix64(tree.seed + static_cast<std::uint64_t>(epoch) * 0x9e3779b97f4a7c15ULL);
    for (int y = box.y0; y <= box.y1; ++y)
      for (int x = box.x0; x <= box.x1; ++x) {
        const Vec2 xy = map.transform.pixel_to_world(Vec2(x, y));
        const double d = (xy - tree.centre).norm();
        if (d >= r) continue;
        const double clumps = detail::fbm(crown_seed, xy.x(), xy.y(), std::max(0.4 * r, 1.0), 2);
        const double albedo = tree.albedo * (1.0 + 0.6 * clumps) * (1.0 - 0.25 * d / r);
        map.values(x, y) = static_cast<float>(response.apply(LandCover::woody, albedo));
      }
  }
  for (float& v : map.values) v = std::clamp(v, 0.0f, 1.0f);
  return map;
}

}  // namespace diachron
