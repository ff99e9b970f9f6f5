#pragma once
/// @file
/// Taking parts of the decades away from a decades-apart scene (a diagnostic of the benchmarks):
/// the landscape's changes between the epochs, epoch 1's sun, its land-cover response, its film as a
/// whole or one part of it (tone curve, blur, grain, scanner defects), each set to what epoch 2 has.
/// What is left tells what a part costs (precise_matching_eval --calm-only, real_pairs_eval
/// --decades-calm).

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <diachron/synth/scene.hpp>

namespace diachron::bench {

/// The parts calm_scene() knows, in the order they are applied.
inline const std::vector<std::string>& calm_parts() {
  static const std::vector<std::string> parts = {"changes", "sun", "cover", "film", "tone", "blur", "grain", "defects"};
  return parts;
}

/// Exits with a message naming the known parts when `parts` holds another (for option parsing).
inline void require_calm_parts(const std::vector<std::string>& parts, const char* option) {
  for (const std::string& part : parts)
    if (std::find(calm_parts().begin(), calm_parts().end(), part) == calm_parts().end()) {
      std::string known;
      for (const std::string& p : calm_parts()) known += (known.empty() ? "" : ", ") + p;
      std::fprintf(stderr, "unknown %s part %s (%s)\n", option, part.c_str(), known.c_str());
      std::exit(1);
    }
}

/// `options` (two epochs, epoch 1 the old one) with the decades' `parts` taken away, or all of them
/// when `all`: "changes" no landscape change between the epochs; "sun" epoch 1 under epoch 2's sun;
/// "cover" epoch 2's land-cover response; "film" epoch 2's tone, grain, scanner, dust, blur and no
/// JPEG (sun and cover kept), or one part of it: "tone", "blur", "grain", "defects".
inline void calm_scene(SceneOptions& options, const std::vector<std::string>& parts, bool all = false) {
  const auto calm = [&](const char* part) {
    return all || std::find(parts.begin(), parts.end(), part) != parts.end();
  };
  if (calm("changes")) {
    ChangeOptions none;  // the decades' own changes (trees, layouts, roads) are 0 by default
    none.changed_field_fraction = none.removed_building_fraction = none.new_building_fraction = 0.0;
    none.seasonal_shift = 0.0;
    options.changes = none;
    options.texture.bush_removal_probability = 0.0;
  }
  LookOptions& look1 = options.epochs[0].look;
  const LookOptions& look2 = options.epochs[1].look;
  if (calm("sun")) {
    look1.sun_azimuth_deg = look2.sun_azimuth_deg;
    look1.sun_elevation_deg = look2.sun_elevation_deg;
  }
  if (calm("cover")) look1.land_cover = look2.land_cover;
  if (calm("tone")) look1.tone_curve = look2.tone_curve;
  if (calm("blur")) look1.blur_sigma_px = look2.blur_sigma_px;
  if (calm("grain")) {
    look1.grain_sigma = look2.grain_sigma;
    look1.grain_size_px = look2.grain_size_px;
  }
  if (calm("defects")) {
    look1.scan_line_sigma = look2.scan_line_sigma;
    look1.scan_stripes = look2.scan_stripes;
    look1.scratches = look2.scratches;
    look1.dust_per_megapixel = look2.dust_per_megapixel;
  }
  if (calm("film")) {
    const LookOptions keep = look1;
    look1 = look2;
    look1.sun_azimuth_deg = keep.sun_azimuth_deg;
    look1.sun_elevation_deg = keep.sun_elevation_deg;
    look1.land_cover = keep.land_cover;
    look1.jpeg_quality = 0;
  }
}

}  // namespace diachron::bench
