#pragma once
/// @file
/// GeoTIFF DSMs through GDAL: read a single-band raster into a Dsm (nodata -> NaN, geotransform,
/// CRS), write a Dsm back as float32 GeoTIFF with nodata, and read and write 8-bit images (PNG / TIFF).
/// Part of diachron::io: include it only from code that links GDAL.

#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <sys/stat.h>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of read_geotiff_dsm().
struct GeoTiffReadOptions {
  /// Band to read, 1-based; 0 (the default) means "the file must have exactly one band", so a
  /// multi-band image given by mistake is an error rather than a silently chosen band.
  int band = 0;
  /// Only for a band *without* a nodata tag: also treat samples equal to `untagged_nodata` as holes.
  /// Off by default, because then -9999 may be a genuine value; turn it on for files known to use a
  /// sentinel without declaring it (e.g. the merged Mount St. Helens DEMs). A tagged nodata value
  /// is always honoured; non-finite samples are always holes (a Dsm marks holes with NaN).
  bool assume_untagged_nodata = false;
  /// The sentinel used when assume_untagged_nodata is on. -9999 by default.
  double untagged_nodata = -9999.0;
  /// Accept a raster without a geotransform, using GDAL's default (pixel grid, Y down). Off by
  /// default: a DSM without georeferencing is usually a mistake in the caller's data.
  bool allow_missing_geotransform = false;

  void check() const {
    DIACHRON_CHECK(band >= 0, "GeoTiffReadOptions::band must be >= 0 (0 = the only band), got " << band);
    DIACHRON_CHECK(std::isfinite(untagged_nodata), "GeoTiffReadOptions::untagged_nodata must be finite");
  }
};

/// Options of write_geotiff_dsm().
struct GeoTiffWriteOptions {
  /// Value written at holes and declared as the band's nodata. -9999 by default.
  double nodata = -9999.0;
  /// GeoTIFF COMPRESS creation option ("DEFLATE", "LZW", "NONE"). "DEFLATE" by default.
  std::string compression = "DEFLATE";

  void check() const { DIACHRON_CHECK(std::isfinite(nodata), "GeoTiffWriteOptions::nodata must be finite"); }
};

namespace detail {

inline void gdal_register_once() {
  static std::once_flag flag;
  std::call_once(flag, [] { GDALAllRegister(); });
}

/// Silences GDAL's default error printing (library code never prints) for its lifetime; the last
/// message stays available to build our own error. GDAL's handler stack is per thread.
class QuietGdalErrors {
 public:
  QuietGdalErrors() {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
  }
  ~QuietGdalErrors() { CPLPopErrorHandler(); }
  QuietGdalErrors(const QuietGdalErrors&) = delete;
  QuietGdalErrors& operator=(const QuietGdalErrors&) = delete;
  static std::string last_message() {
    const char* m = CPLGetLastErrorMsg();
    return (m && *m) ? std::string(" (GDAL: ") + m + ")" : std::string();
  }
};

struct GdalDatasetCloser {
  void operator()(GDALDataset* d) const {
    if (d) GDALClose(GDALDataset::ToHandle(d));
  }
};
using GdalDatasetPtr = std::unique_ptr<GDALDataset, GdalDatasetCloser>;

/// Closes a dataset being written; closing flushes, and a failure there (disk full) must not pass
/// silently. GDAL < 3.7 reports it only through the error state.
inline void close_written(GdalDatasetPtr& ds, const std::string& path) {
  CPLErrorReset();
  GDALClose(GDALDataset::ToHandle(ds.release()));
  DIACHRON_CHECK(CPLGetLastErrorType() != CE_Failure && CPLGetLastErrorType() != CE_Fatal,
                 "cannot write '" << path << "': closing failed" << QuietGdalErrors::last_message());
}

inline bool file_exists(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0;
}

/// Driver for an output path from its extension (".png" -> PNG, else GeoTIFF).
inline std::string driver_for(const std::string& path) {
  const auto dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos ? std::string() : path.substr(dot + 1);
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (ext == "png") return "PNG";
  if (ext == "jpg" || ext == "jpeg") return "JPEG";
  return "GTiff";
}

/// WKT of a CRS given as WKT or user text ("EPSG:26910"); throws naming `path` when unparsable.
inline std::string crs_to_wkt(const std::string& crs, const std::string& path) {
  OGRSpatialReference srs;
  DIACHRON_CHECK(srs.SetFromUserInput(crs.c_str()) == OGRERR_NONE,
                 "cannot write '" << path << "': CRS '" << crs.substr(0, 80) << "' is neither WKT nor a known code");
  char* wkt = nullptr;
  srs.exportToWkt(&wkt);
  std::string out = wkt ? wkt : "";
  CPLFree(wkt);
  return out;
}

// Opens `path` read-only as a raster; throws naming it (as a `what`, e.g. "DSM") when it is missing
// or GDAL cannot open it. Call it inside a QuietGdalErrors scope, whose last message it quotes.
inline GdalDatasetPtr open_raster(const std::string& path, const char* what) {
  gdal_register_once();
  DIACHRON_CHECK(file_exists(path), "cannot read " << what << " '" << path << "': no such file");
  GdalDatasetPtr ds(GDALDataset::FromHandle(
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
  DIACHRON_CHECK(ds != nullptr, "cannot read " << what << " '" << path << "': not a raster GDAL can open"
                                                << QuietGdalErrors::last_message());
  return ds;
}

}  // namespace detail

/// Reads a single-band GeoTIFF (or any raster GDAL reads: float or integer samples) into a Dsm.
/// Samples are converted to float (integers beyond 2^24 lose precision); a band scale / offset is
/// applied. Holes: the band's nodata value, non-finite samples, and (see GeoTiffReadOptions) an
/// untagged sentinel. The CRS is returned as WKT (empty when the file has none).
/// Throws diachron::Error naming the file when it is missing, not a raster GDAL can open, has
/// several bands where one is expected, lacks the requested band, has no geotransform (unless
/// allowed), or cannot be read.
inline Dsm read_geotiff_dsm(const std::string& path, const GeoTiffReadOptions& options = {}) {
  options.check();
  const detail::QuietGdalErrors quiet;
  const detail::GdalDatasetPtr ds = detail::open_raster(path, "DSM");
  const int bands = ds->GetRasterCount();
  DIACHRON_CHECK(bands >= 1, "cannot read DSM '" << path << "': the file has no raster band");
  if (options.band == 0)
    DIACHRON_CHECK(bands == 1, "cannot read DSM '" << path << "': it has " << bands
                                                   << " bands, one expected (choose one with GeoTiffReadOptions::band)");
  const int band_index = options.band == 0 ? 1 : options.band;
  DIACHRON_CHECK(band_index <= bands,
                 "cannot read DSM '" << path << "': band " << band_index << " requested, the file has " << bands);
  GDALRasterBand* band = ds->GetRasterBand(band_index);
  const int w = ds->GetRasterXSize(), h = ds->GetRasterYSize();
  DIACHRON_CHECK(w > 0 && h > 0, "cannot read DSM '" << path << "': empty raster " << w << " x " << h);
  const GDALDataType type = band->GetRasterDataType();
  DIACHRON_CHECK(!GDALDataTypeIsComplex(type), "cannot read DSM '" << path << "': complex samples are not heights");

  GeoTransform gt;
  if (ds->GetGeoTransform(gt.c.data()) != CE_None) {
    DIACHRON_CHECK(options.allow_missing_geotransform,
                   "cannot read DSM '" << path << "': no geotransform (allow_missing_geotransform to use pixel units)");
    gt = GeoTransform{};
  }
  for (double v : gt.c) DIACHRON_CHECK(std::isfinite(v), "cannot read DSM '" << path << "': non-finite geotransform");
  DIACHRON_CHECK(gt.c[1] * gt.c[5] - gt.c[2] * gt.c[4] != 0.0,
                 "cannot read DSM '" << path << "': singular geotransform");

  // Read as double so that integer nodata values compare exactly before the float conversion.
  std::vector<double> buffer(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  const CPLErr err = band->RasterIO(GF_Read, 0, 0, w, h, buffer.data(), w, h, GDT_Float64, 0, 0, nullptr);
  DIACHRON_CHECK(err == CE_None, "cannot read DSM '" << path << "': read failed" << detail::QuietGdalErrors::last_message());

  int has_nodata = 0;
  const double nodata = band->GetNoDataValue(&has_nodata);
  const bool use_nodata = has_nodata != 0 && !std::isnan(nodata);
  const bool use_sentinel = has_nodata == 0 && options.assume_untagged_nodata;
  int has_scale = 0, has_offset = 0;
  const double scale = band->GetScale(&has_scale), offset = band->GetOffset(&has_offset);
  const bool rescale = (has_scale && scale != 1.0) || (has_offset && offset != 0.0);

  Raster<float> heights(w, h);
  float* out = heights.data();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < buffer.size(); ++i) {
    const double v = buffer[i];
    if (!std::isfinite(v) || (use_nodata && v == nodata) || (use_sentinel && v == options.untagged_nodata)) {
      out[i] = nan;
      continue;
    }
    out[i] = static_cast<float>(rescale ? v * scale + offset : v);
  }

  std::string crs;
  if (const OGRSpatialReference* srs = ds->GetSpatialRef()) {
    char* wkt = nullptr;
    if (srs->exportToWkt(&wkt) == OGRERR_NONE && wkt) crs = wkt;
    CPLFree(wkt);
  }
  return Dsm(std::move(heights), gt, std::move(crs));
}

/// What a raster says of where it lies, read without its pixels: its size, its geotransform (if
/// it has one) and its CRS as WKT (empty when it has none).
struct RasterGeoreference {
  int width = 0, height = 0;
  bool has_geotransform = false;
  GeoTransform transform;
  std::string crs;
};

/// Reads the georeference of the raster at `path` (any GDAL raster). Throws diachron::Error naming
/// the file when it is missing, cannot be opened or is empty; a missing geotransform is not an
/// error here (RasterGeoreference::has_geotransform says so), a non-finite one is.
inline RasterGeoreference read_raster_georeference(const std::string& path) {
  const detail::QuietGdalErrors quiet;
  const detail::GdalDatasetPtr ds = detail::open_raster(path, "raster");
  RasterGeoreference out;
  out.width = ds->GetRasterXSize();
  out.height = ds->GetRasterYSize();
  DIACHRON_CHECK(out.width > 0 && out.height > 0 && ds->GetRasterCount() >= 1,
                 "cannot read raster '" << path << "': empty (" << out.width << " x " << out.height << ", "
                                        << ds->GetRasterCount() << " bands)");
  out.has_geotransform = ds->GetGeoTransform(out.transform.c.data()) == CE_None;
  if (!out.has_geotransform) out.transform = GeoTransform{};
  for (double v : out.transform.c)
    DIACHRON_CHECK(std::isfinite(v), "cannot read raster '" << path << "': non-finite geotransform");
  if (const OGRSpatialReference* srs = ds->GetSpatialRef()) {
    char* wkt = nullptr;
    if (srs->exportToWkt(&wkt) == OGRERR_NONE && wkt) out.crs = wkt;
    CPLFree(wkt);
  }
  return out;
}

/// True when two CRS given as WKT (or any form GDAL reads) are the same; two empty ones are the
/// same (both in an arbitrary local frame), an empty and a non-empty one are not.
inline bool same_crs(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty()) return a.empty() && b.empty();
  if (a == b) return true;
  const detail::QuietGdalErrors quiet;
  OGRSpatialReference sa, sb;
  if (sa.SetFromUserInput(a.c_str()) != OGRERR_NONE || sb.SetFromUserInput(b.c_str()) != OGRERR_NONE) return false;
  return sa.IsSame(&sb) != 0;
}

/// A hole value a DSM seems to hold as heights: its lowest height is one of the usual sentinels
/// (-9999, -99999, -32767, -32768, or the lowest float) and lies more than 1000 units below every
/// other height. Such a file had no nodata tag (or another one), and reading it with
/// GeoTiffReadOptions::assume_untagged_nodata and that value makes those cells holes; as heights
/// they are cliffs that a DSM image and every match would take for terrain. Programs warn with it;
/// nothing is changed here. nullopt when the DSM shows no such value.
inline std::optional<double> suspected_untagged_nodata(const Dsm& dsm) {
  float lowest = std::numeric_limits<float>::infinity(), second = std::numeric_limits<float>::infinity();
  for (const float v : dsm.heights()) {
    if (std::isnan(v) || v == lowest) continue;
    if (v < lowest) {
      second = lowest;
      lowest = v;
    } else if (v < second) {
      second = v;
    }
  }
  if (std::isinf(lowest)) return std::nullopt;  // no valid cell (a Dsm holds no infinities)
  for (const double sentinel : {-9999.0, -99999.0, -32767.0, -32768.0, static_cast<double>(-std::numeric_limits<float>::max())})
    if (static_cast<double>(lowest) == static_cast<double>(static_cast<float>(sentinel)) &&
        (!std::isfinite(second) || static_cast<double>(second) - sentinel > 1000.0))
      return sentinel;
  return std::nullopt;
}

/// Writes `dsm` as a single-band float32 GeoTIFF: holes as `nodata` (declared in the file), the
/// geotransform, and the CRS (WKT or user text such as "EPSG:32633"; none when empty). Overwrites.
/// Throws diachron::Error naming the file when it cannot be created or written, or when the CRS
/// text is not understood.
inline void write_geotiff_dsm(const Dsm& dsm, const std::string& path, const GeoTiffWriteOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!dsm.empty(), "cannot write '" << path << "': empty DSM");
  detail::gdal_register_once();
  const detail::QuietGdalErrors quiet;
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  DIACHRON_CHECK(driver != nullptr, "cannot write '" << path << "': GDAL has no GTiff driver");
  const std::string wkt = dsm.crs().empty() ? std::string() : detail::crs_to_wkt(dsm.crs(), path);
  char** create_options = nullptr;
  create_options = CSLSetNameValue(create_options, "COMPRESS", options.compression.c_str());
  detail::GdalDatasetPtr ds(driver->Create(path.c_str(), dsm.width(), dsm.height(), 1, GDT_Float32, create_options));
  CSLDestroy(create_options);
  DIACHRON_CHECK(ds != nullptr, "cannot write '" << path << "': cannot create the file"
                                                 << detail::QuietGdalErrors::last_message());
  GeoTransform gt = dsm.transform();
  ds->SetGeoTransform(gt.c.data());
  if (!wkt.empty()) ds->SetProjection(wkt.c_str());
  GDALRasterBand* band = ds->GetRasterBand(1);
  band->SetNoDataValue(options.nodata);
  std::vector<float> buffer(dsm.heights().begin(), dsm.heights().end());
  const float fill = static_cast<float>(options.nodata);
  for (float& v : buffer)
    if (std::isnan(v)) v = fill;
  const CPLErr err = band->RasterIO(GF_Write, 0, 0, dsm.width(), dsm.height(), buffer.data(), dsm.width(),
                                    dsm.height(), GDT_Float32, 0, 0, nullptr);
  DIACHRON_CHECK(err == CE_None, "cannot write '" << path << "': write failed" << detail::QuietGdalErrors::last_message());
  detail::close_written(ds, path);
}

/// Reads an 8-bit single-band image (PNG, TIFF, JPEG: anything GDAL opens whose band is Byte), e.g.
/// an epoch folder's images. No georeferencing is needed. Throws diachron::Error naming the file
/// when it is missing, cannot be opened, has several bands, or its samples are not 8-bit.
inline Raster<std::uint8_t> read_image_u8(const std::string& path) {
  const detail::QuietGdalErrors quiet;
  const detail::GdalDatasetPtr ds = detail::open_raster(path, "image");
  DIACHRON_CHECK(ds->GetRasterCount() == 1,
                 "cannot read image '" << path << "': it has " << ds->GetRasterCount() << " bands, one (grey) expected");
  GDALRasterBand* band = ds->GetRasterBand(1);
  DIACHRON_CHECK(band->GetRasterDataType() == GDT_Byte,
                 "cannot read image '" << path << "': samples are " << GDALGetDataTypeName(band->GetRasterDataType())
                                       << ", 8-bit expected");
  const int w = ds->GetRasterXSize(), h = ds->GetRasterYSize();
  DIACHRON_CHECK(w > 0 && h > 0, "cannot read image '" << path << "': empty raster " << w << " x " << h);
  Raster<std::uint8_t> out(w, h);
  const CPLErr err = band->RasterIO(GF_Read, 0, 0, w, h, out.data(), w, h, GDT_Byte, 0, 0, nullptr);
  DIACHRON_CHECK(err == CE_None, "cannot read image '" << path << "': read failed" << detail::QuietGdalErrors::last_message());
  return out;
}

/// Writes an 8-bit single-band image; the format follows the extension (.png PNG, .jpg JPEG,
/// otherwise GeoTIFF). Handy for looking at DSM images and filter outputs. Throws diachron::Error
/// naming the file on failure.
inline void write_image_u8(const Raster<std::uint8_t>& image, const std::string& path) {
  DIACHRON_CHECK(!image.empty(), "cannot write '" << path << "': empty image");
  detail::gdal_register_once();
  const detail::QuietGdalErrors quiet;
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  const std::string driver_name = detail::driver_for(path);
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName(driver_name.c_str());
  DIACHRON_CHECK(mem != nullptr && driver != nullptr, "cannot write '" << path << "': GDAL has no " << driver_name << " driver");
  // PNG and JPEG drivers only copy: build in memory, then CreateCopy.
  detail::GdalDatasetPtr tmp(mem->Create("", image.width(), image.height(), 1, GDT_Byte, nullptr));
  DIACHRON_CHECK(tmp != nullptr, "cannot write '" << path << "': cannot allocate the image");
  const CPLErr err = tmp->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, image.width(), image.height(),
                                                     const_cast<std::uint8_t*>(image.data()), image.width(),
                                                     image.height(), GDT_Byte, 0, 0, nullptr);
  DIACHRON_CHECK(err == CE_None, "cannot write '" << path << "': copy failed");
  detail::GdalDatasetPtr out(driver->CreateCopy(path.c_str(), tmp.get(), FALSE, nullptr, nullptr, nullptr));
  DIACHRON_CHECK(out != nullptr, "cannot write '" << path << "'" << detail::QuietGdalErrors::last_message());
  detail::close_written(out, path);
}

}  // namespace diachron
