#pragma once
/// @file
/// Decades-apart scenes over a real DEM instead of the procedural relief (`--dem PATH` of
/// precise_matching_eval and adjustment_eval, as `make_scene --dem`): the method's figures on
/// relief nobody tuned it to. Needs GDAL (diachron::io).

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <diachron/io/dsm_reproject.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/terrain/crs_kind.hpp>

namespace diachron::bench {

/// The DEM at `path` as scene terrain, in metres: a DEM in degrees (SRTM and the like) is
/// reprojected to its UTM zone first, since cells in degrees under heights in metres would make a
/// flat, stretched world. A file without a nodata tag has its -9999 samples taken as holes
/// (GeoTiffReadOptions::assume_untagged_nodata, for the merged Mount St. Helens DEMs).
inline Dsm read_terrain_dem(const std::string& path) {
  GeoTiffReadOptions read;
  read.assume_untagged_nodata = true;
  Dsm dem = read_geotiff_dsm(path, read);
  if (crs_kind(dem.crs()) == CrsKind::geographic) {
    const std::string utm = utm_crs_of(dem);
    std::fprintf(stderr, "%s is in degrees; reprojected to %s\n", path.c_str(), utm.c_str());
    dem = reproject_dsm(dem, utm);
  }
  return dem;
}

/// Every epoch of `options` flown `height_m` above the mean ground, each keeping its GSD (the focal
/// length follows the height), as `make_scene --flying-height`. Rugged real terrain needs a higher
/// flight than the preset's (1056 and 840 m) for the cameras to stay above it and the stereo
/// overlap to hold on the summits. Throws std::invalid_argument for a height that is not finite
/// and > 0.
inline void set_flying_height(SceneOptions& options, double height_m) {
  if (!(height_m > 0.0) || !std::isfinite(height_m))
    throw std::invalid_argument("the flying height must be finite and > 0 m");
  for (EpochOptions& epoch : options.epochs) {
    epoch.focal_px *= height_m / epoch.flying_height_m;
    epoch.flying_height_m = height_m;
  }
}

}  // namespace diachron::bench
