#pragma once
/// @file
/// reproject_dsm(): a DSM warped into another CRS through GDAL (gdalwarp's engine, in memory), and
/// utm_crs_of(): the WGS 84 UTM zone of a DSM's centre, dsm_in_metres(): both, for a DSM in degrees.
/// Part of diachron::io: include it only from code that links GDAL.
///
/// Why: the rough co-registration fits a 3D similarity and so needs the same unit on all three
/// axes, which a DSM in a geographic CRS (SRTM, Copernicus DEM, ASTER: degrees, heights in metres)
/// does not have (terrain/crs_kind.hpp). Reprojecting both DSMs to one projected CRS in metres makes
/// them usable; the Helmert found then maps between the reprojected frames. Heights are not
/// changed (no vertical datum shift): only the horizontal grid is resampled.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/terrain/crs_kind.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of reproject_dsm().
struct DsmReprojectOptions {
  /// Output cell size in the target CRS's unit (metres for UTM), square cells. 0 (the default): the
  /// input's finer cell side at its centre, in the target unit, so that no direction is coarsened (a
  /// 3" cell at 46 degrees north is 64 m east by 93 m north: 64 m). GDAL's own choice lies between
  /// and would average heights along the finer direction.
  double cell_size = 0.0;
  /// GDAL resampling: "bilinear" (default: heights are a continuous surface), "near", "cubic".
  std::string resampling = "bilinear";

  void check() const {
    DIACHRON_CHECK(cell_size >= 0.0 && std::isfinite(cell_size),
                   "DsmReprojectOptions::cell_size must be >= 0 (0 = the input's finer cell side), got " << cell_size);
    DIACHRON_CHECK(resampling == "bilinear" || resampling == "near" || resampling == "cubic",
                   "DsmReprojectOptions::resampling must be bilinear, near or cubic, got '" << resampling << "'");
  }
};

namespace detail {

struct GdalWarpOptionsDeleter {
  void operator()(GDALWarpAppOptions* o) const { GDALWarpAppOptionsFree(o); }
};

inline OGRSpatialReference spatial_reference_of(const std::string& crs, const char* what) {
  OGRSpatialReference srs;
  DIACHRON_CHECK(!crs.empty(), what << ": the DSM has no CRS");
  DIACHRON_CHECK(srs.SetFromUserInput(crs.c_str()) == OGRERR_NONE,
                 what << ": CRS '" << crs.substr(0, 80) << "' is neither WKT nor a known code");
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);  // x = easting / longitude, as a geotransform
  return srs;
}

}  // namespace detail

/// The WGS 84 UTM zone of the DSM's centre as "EPSG:326zz" (north) or "EPSG:327zz" (south).
/// Throws diachron::Error when the DSM has no CRS or its centre cannot be transformed to
/// longitude and latitude.
inline std::string utm_crs_of(const Dsm& dsm) {
  detail::gdal_register_once();
  const detail::QuietGdalErrors quiet;
  DIACHRON_CHECK(!dsm.empty(), "utm_crs_of: empty DSM");
  const OGRSpatialReference source = detail::spatial_reference_of(dsm.crs(), "utm_crs_of");
  OGRSpatialReference wgs84;
  wgs84.importFromEPSG(4326);
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  const std::unique_ptr<OGRCoordinateTransformation> to_lonlat(OGRCreateCoordinateTransformation(&source, &wgs84));
  DIACHRON_CHECK(to_lonlat != nullptr,
                 "utm_crs_of: no transformation from the DSM's CRS to longitude and latitude"
                     << detail::QuietGdalErrors::last_message());
  const WorldBounds b = dsm.bounds();
  double x = 0.5 * (b.min_x + b.max_x), y = 0.5 * (b.min_y + b.max_y);
  DIACHRON_CHECK(to_lonlat->Transform(1, &x, &y) && std::isfinite(x) && std::isfinite(y),
                 "utm_crs_of: the DSM's centre has no longitude and latitude" << detail::QuietGdalErrors::last_message());
  const double lon = std::remainder(x, 360.0);  // in [-180, 180]
  const int zone = std::min(60, static_cast<int>(std::floor((lon + 180.0) / 6.0)) + 1);
  return "EPSG:" + std::to_string((y >= 0.0 ? 32600 : 32700) + zone);
}

/// `dsm` warped into `target_crs` (WKT or a code such as "EPSG:32633"); holes stay holes (NaN),
/// cells outside the input's footprint are holes, heights are not changed. The result's CRS is the
/// target's WKT. Throws diachron::Error when the DSM has no CRS, a CRS is not understood, or GDAL
/// fails (its message quoted).
inline Dsm reproject_dsm(const Dsm& dsm, const std::string& target_crs, const DsmReprojectOptions& options = {}) {
  options.check();
  detail::gdal_register_once();
  const detail::QuietGdalErrors quiet;
  DIACHRON_CHECK(!dsm.empty(), "reproject_dsm: empty DSM");
  const OGRSpatialReference source = detail::spatial_reference_of(dsm.crs(), "reproject_dsm");
  const OGRSpatialReference target = detail::spatial_reference_of(target_crs, "reproject_dsm (target)");

  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  DIACHRON_CHECK(mem != nullptr, "reproject_dsm: GDAL has no MEM driver");
  const detail::GdalDatasetPtr input(mem->Create("", dsm.width(), dsm.height(), 1, GDT_Float32, nullptr));
  DIACHRON_CHECK(input != nullptr, "reproject_dsm: cannot create a dataset" << detail::QuietGdalErrors::last_message());
  GeoTransform gt = dsm.transform();
  input->SetGeoTransform(gt.c.data());
  input->SetSpatialRef(&source);
  GDALRasterBand* in_band = input->GetRasterBand(1);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  in_band->SetNoDataValue(nan);
  DIACHRON_CHECK(in_band->RasterIO(GF_Write, 0, 0, dsm.width(), dsm.height(),
                                   const_cast<float*>(dsm.heights().data()), dsm.width(), dsm.height(), GDT_Float32,
                                   0, 0, nullptr) == CE_None,
                 "reproject_dsm: cannot fill the input dataset" << detail::QuietGdalErrors::last_message());

  char* target_wkt = nullptr;
  target.exportToWkt(&target_wkt);
  const std::string wkt = target_wkt ? target_wkt : "";
  CPLFree(target_wkt);
  double cell_size = options.cell_size;
  if (cell_size == 0.0) {
    const std::unique_ptr<OGRCoordinateTransformation> to_target(OGRCreateCoordinateTransformation(&source, &target));
    DIACHRON_CHECK(to_target != nullptr, "reproject_dsm: no transformation to '" << target_crs.substr(0, 80) << "'"
                                                                               << detail::QuietGdalErrors::last_message());
    const Eigen::Vector2d c(0.5 * (dsm.width() - 1), 0.5 * (dsm.height() - 1));
    double x[3], y[3];
    const Eigen::Vector2d probes[3] = {c, c + Eigen::Vector2d(1.0, 0.0), c + Eigen::Vector2d(0.0, 1.0)};
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector2d w = gt.pixel_to_world(probes[i]);
      x[i] = w.x();
      y[i] = w.y();
    }
    DIACHRON_CHECK(to_target->Transform(3, x, y) != 0, "reproject_dsm: the DSM's centre has no position in '"
                                                           << target_crs.substr(0, 80) << "'"
                                                           << detail::QuietGdalErrors::last_message());
    cell_size = std::min(std::hypot(x[1] - x[0], y[1] - y[0]), std::hypot(x[2] - x[0], y[2] - y[0]));
    DIACHRON_CHECK(std::isfinite(cell_size) && cell_size > 0.0, "reproject_dsm: degenerate cell size " << cell_size);
  }
  std::vector<std::string> args{"-of", "MEM", "-t_srs", wkt, "-r", options.resampling,
                                "-srcnodata", "nan", "-dstnodata", "nan", "-ot", "Float32",
                                // Exact per-cell transformation: gdalwarp's default approximates it
                                // to 1/8 cell, a height error of 1/8 of the slope per cell.
                                "-et", "0"};
  char cs[64];
  std::snprintf(cs, sizeof cs, "%.17g", cell_size);
  args.insert(args.end(), {"-tr", cs, cs});
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::unique_ptr<GDALWarpAppOptions, detail::GdalWarpOptionsDeleter> warp_options(
      GDALWarpAppOptionsNew(argv.data(), nullptr));
  DIACHRON_CHECK(warp_options != nullptr, "reproject_dsm: bad warp options" << detail::QuietGdalErrors::last_message());
  GDALDatasetH source_handle = GDALDataset::ToHandle(input.get());
  int usage_error = 0;
  const detail::GdalDatasetPtr output(
      GDALDataset::FromHandle(GDALWarp("", nullptr, 1, &source_handle, warp_options.get(), &usage_error)));
  DIACHRON_CHECK(output != nullptr && usage_error == 0,
                 "reproject_dsm: GDAL could not warp the DSM to '" << target_crs.substr(0, 80) << "'"
                                                                  << detail::QuietGdalErrors::last_message());

  const int w = output->GetRasterXSize(), h = output->GetRasterYSize();
  DIACHRON_CHECK(w > 0 && h > 0, "reproject_dsm: empty output " << w << " x " << h);
  GeoTransform out_gt;
  DIACHRON_CHECK(output->GetGeoTransform(out_gt.c.data()) == CE_None, "reproject_dsm: the output has no geotransform");
  Raster<float> heights(w, h);
  DIACHRON_CHECK(output->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, w, h, heights.data(), w, h, GDT_Float32, 0, 0,
                                                    nullptr) == CE_None,
                 "reproject_dsm: cannot read the output" << detail::QuietGdalErrors::last_message());
  return Dsm(std::move(heights), out_gt, wkt);
}

/// `dsm` with its cells in metres: a DSM in a geographic CRS (degrees, e.g. SRTM) is warped to the
/// UTM zone of its centre (utm_crs_of, reproject_dsm), any other is returned as it is. For code
/// that takes DEMs of any kind and needs one unit on all three axes (`make_scene --dem`, the
/// benchmarks' `--dem`). `utm`, when given, receives the zone's code ("EPSG:326zz"), or "" when
/// nothing was warped. Throws as utm_crs_of and reproject_dsm do.
inline Dsm dsm_in_metres(Dsm dsm, std::string* utm = nullptr, const DsmReprojectOptions& options = {}) {
  if (utm) utm->clear();
  if (crs_kind(dsm.crs()) != CrsKind::geographic) return dsm;
  const std::string zone = utm_crs_of(dsm);
  if (utm) *utm = zone;
  return reproject_dsm(dsm, zone, options);
}

}  // namespace diachron
