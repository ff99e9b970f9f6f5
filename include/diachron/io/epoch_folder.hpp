#pragma once
/// @file
/// Epoch folders, the exchange format of the pipeline (docs/architecture.md): a COLMAP model, text
/// (cameras.txt, images.txt, points3D.txt) or binary (cameras.bin, images.bin, points3D.bin, as
/// COLMAP writes it; io/colmap_model.hpp), the images under images/ and the epoch's DSM as
/// dsm.tif, in the model's frame; or a MicMac project: the images (under images/ or at its top, as
/// MicMac keeps them), one `Ori-<name>/` orientation (io/micmac_orientation.hpp), its tie points in
/// `Homol/` (io/homol.hpp) and dsm.tif in the orientation's frame; the tie points are chained into
/// tracks, triangulated and held as a COLMAP model, so that what reads a COLMAP epoch reads a
/// MicMac one unchanged (docs/micmac-orientation.md, "MicMac epochs as input"); or an orthophoto
/// epoch: `ortho.tif` (any GDAL raster, grey or
/// colour, with a north-up geotransform) and `dsm.tif` in the same CRS (any grid), the usual modern
/// reference (a national orthophoto and its DEM). An orthophoto is cut into tiles, each a
/// pseudo-image of the epoch with an OrthoFrame (camera/ortho_frame.hpp), read on demand.
/// read_epoch_folder() checks the whole folder up front, so a missing image or an unknown camera
/// stops the run before any work, with the file named. Images
/// are read on demand (EpochFolder::load_image): archives hold hundreds of large scans. Masks are
/// optional, 0 where a pixel must not be matched (the scan's frame, fiducial marks, clouds:
/// matching/image_mask.hpp), COLMAP's way (`masks/<image name>.png`) or MicMac's (`<image name
/// without its extension>_Masq.tif` beside the image); an image without one is used whole.
/// Needs GDAL (diachron::io).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include <diachron/adjustment/tracks.hpp>
#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/epoch_frame.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/camera/ortho_frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/geometry/ray.hpp>
#include <diachron/io/colmap_model.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/io/grey_image.hpp>
#include <diachron/io/homol.hpp>
#include <diachron/io/micmac_orientation.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// One image of an epoch folder: its COLMAP id and name (relative to images/; for a MicMac epoch
/// the name its Orientation file carries, ids 1..N in name order), the file it is read from, and
/// its orientation as a diachron Frame (camera converted from the COLMAP model or the MicMac
/// calibration, pose in the model's frame, diachron pixel convention).
struct EpochImage {
  std::uint32_t id = 0;
  std::string name;
  std::string path;
  /// Its mask, `masks/<name>.png` (COLMAP) or else `images/<name stem>_Masq.tif` (MicMac), or empty
  /// when the folder has neither.
  std::string mask_path;
  Frame<FraserAffine> frame{Camera<FraserAffine>(1.0, 0.0, 0.0, 1, 1), Pose{}};
  /// Largest difference (px) between COLMAP's (or MicMac's) projection and the converted camera's
  /// over the image; 0 for models diachron holds exactly (every COLMAP model it reads but
  /// FULL_OPENCV with K4-K6; MicMac calibrations with CDist = PP and b1 = b2 = 0).
  double conversion_error_px = 0.0;
  /// For a tile of an orthophoto epoch: its frame (the orthophoto's geotransform moved to the tile),
  /// and `frame` above is unused; nullopt for a photo.
  std::optional<OrthoFrame> ortho;
  /// For a tile: its top-left pixel in the orthophoto (tile px + (tile_x, tile_y) = orthophoto px).
  int tile_x = 0, tile_y = 0;

  /// The image's frame whatever its kind: the photo's Frame, or the tile's OrthoFrame.
  EpochFrame epoch_frame() const { return ortho ? EpochFrame(*ortho) : EpochFrame(frame); }
  /// Its size, px.
  int width() const { return ortho ? ortho->width() : frame.camera().width(); }
  int height() const { return ortho ? ortho->height() : frame.camera().height(); }
};

/// How an orthophoto epoch is cut into tiles. Defaults: tiles about the size of the images
/// match_epochs is measured on (1600 x 1200 px, 53000 correlation cells of 6 px), so each tile's
/// pair costs what a photo pair costs, overlapping by a correlation window and a search so that no
/// point is lost at a seam.
struct OrthoTileOptions {
  /// Largest side of a tile, px (>= 64). An orthophoto at most this large (plus the overlap) on a
  /// side is one tile.
  int tile_px = 1536;
  /// Pixels two neighbouring tiles share (>= 0, < tile_px / 2): a 21 px window plus a 12 px search
  /// each side.
  int overlap_px = 64;

  void check() const {
    DIACHRON_CHECK(tile_px >= 64, "OrthoTileOptions::tile_px must be >= 64, got " << tile_px);
    DIACHRON_CHECK(overlap_px >= 0 && overlap_px < tile_px / 2,
                   "OrthoTileOptions::overlap_px must be in [0, tile_px / 2), got " << overlap_px);
  }
};

/// The tiles' origins along one side of `size` px: one tile when it fits in tile_px + overlap_px,
/// else evenly spaced tiles of at most tile_px sharing at least overlap_px. Returns (start, length).
inline std::vector<std::pair<int, int>> ortho_tile_spans(int size, const OrthoTileOptions& options) {
  options.check();
  DIACHRON_CHECK(size > 0, "ortho_tile_spans: an empty side (" << size << " px)");
  if (size <= options.tile_px + options.overlap_px) return {{0, size}};
  const int step = options.tile_px - options.overlap_px;
  const int n = 1 + (size - options.tile_px + step - 1) / step;  // tiles so that the last one reaches the end
  std::vector<std::pair<int, int>> out;
  for (int k = 0; k < n; ++k) {
    // Spread the tiles evenly: the k-th starts at round(k (size - tile) / (n - 1)).
    const int start = static_cast<int>((static_cast<long long>(k) * (size - options.tile_px)) / (n - 1));
    out.emplace_back(start, options.tile_px);
  }
  return out;
}

/// How a MicMac epoch folder is read (read_epoch_folder). Defaults: the folder's one Ori-* folder,
/// its `Homol/`, tracks kept when every observation reprojects within 3 px.
struct MicmacEpochOptions {
  /// The orientation to read, with or without its "Ori-" prefix ("SfM" or "Ori-SfM"). Empty: the
  /// folder's only `Ori-*` folder holding Orientation-*.xml files (several are refused). Set, the
  /// folder is read as a MicMac epoch even when it also holds a COLMAP model.
  std::string ori;
  /// The tie-point folder inside the epoch folder: "Homol", or "Homol<SH>" for the tie points of
  /// MicMac's `SH=` suffix (e.g. "Homol-Guided"). A folder without it gives a model without points.
  std::string homol = "Homol";
  /// Largest reprojection error (px) of any observation of a kept track, the frames as read: a
  /// track beyond it chains a wrong tie point (or the orientation does not fit the tie points) and
  /// is dropped. 3 px is ten times the noise of an SfM's tie points and well below a wrong one's
  /// error.
  double max_reprojection_px = 3.0;
  /// Smallest largest angle between two rays of a track, degrees, in (0, 180): below it the depth
  /// of the point is unreliable and the track is not placed.
  double min_angle_deg = 1.0;
  /// The conversion of the calibrations and the pixel convention, MicMac pixel minus diachron
  /// pixel (px), of both the Ori folder and the Homol files (one convention per project).
  MicmacReadOptions read;

  /// Precondition: a name without '/', a finite max_reprojection_px > 0 and valid nested options,
  /// else throws diachron::Error.
  void check() const {
    DIACHRON_CHECK(ori.find('/') == std::string::npos, "MicmacEpochOptions::ori '" << ori << "' must contain no '/'");
    DIACHRON_CHECK(!homol.empty() && homol.find('/') == std::string::npos,
                   "MicmacEpochOptions::homol '" << homol << "' must be a non-empty folder name without '/'");
    DIACHRON_CHECK(std::isfinite(max_reprojection_px) && max_reprojection_px > 0.0,
                   "MicmacEpochOptions::max_reprojection_px must be finite and > 0, got " << max_reprojection_px);
    DIACHRON_CHECK(min_angle_deg > 0.0 && min_angle_deg < 180.0,
                   "MicmacEpochOptions::min_angle_deg must be in (0, 180), got " << min_angle_deg);
    read.check();
  }
};

/// What the tie points of a MicMac epoch gave (EpochFolder::micmac_ties). Default: no Homol folder.
struct MicmacTiePointReport {
  std::string homol_dir;           ///< the Homol folder read, empty when the epoch has none
  std::size_t files = 0;           ///< tie-point files read, one per image pair
  std::size_t skipped_files = 0;   ///< files of a pair with an image the orientation does not hold
  std::size_t tie_points = 0;      ///< lines of the files read (pairs of observations)
  TrackReport tracks;              ///< build_tracks' report (conflicting and short tracks dropped)
  std::size_t failed_triangulation = 0;  ///< tracks triangulate_track could not place
  std::size_t large_reprojection = 0;    ///< tracks beyond MicmacEpochOptions::max_reprojection_px
  std::size_t points = 0;                ///< tracks kept, the model's points3d
};

/// What an epoch folder held, as read_epoch_folder() read it (EpochFolder::source()).
enum class EpochSource { colmap_text, colmap_binary, micmac, orthophoto };

/// "colmap_text", "colmap_binary", "micmac" or "orthophoto".
inline const char* epoch_source_name(EpochSource source) {
  switch (source) {
    case EpochSource::colmap_text: return "colmap_text";
    case EpochSource::colmap_binary: return "colmap_binary";
    case EpochSource::micmac: return "micmac";
    case EpochSource::orthophoto: return "orthophoto";
  }
  return "unknown";
}

/// An epoch folder as read: the model, its images in images.txt order (by id), and the DSM; or,
/// for an orthophoto epoch, no model, the orthophoto's tiles as images (row by row) and the DSM.
/// A MicMac epoch's model is built from its Ori and Homol folders (read_epoch_folder()).
struct EpochFolder {
  std::string directory;
  /// The COLMAP model; for a MicMac epoch, the orientation as the nearest COLMAP cameras (for
  /// exports: EpochImage::frame holds the camera as read) and the Homol tracks as points3D.
  ColmapModel model;
  /// The form the model was read in (binary when the folder holds both and they agree); text and
  /// meaningless for a MicMac or orthophoto epoch (source() says which).
  ColmapFormat model_format = ColmapFormat::text;
  /// A MicMac epoch's orientation folder (`<directory>/Ori-<name>`), empty otherwise.
  std::string micmac_ori;
  /// A MicMac epoch's tie points: what its Homol folder gave and what was kept.
  MicmacTiePointReport micmac_ties;
  std::vector<EpochImage> images;
  Dsm dsm;
  /// The orthophoto of an orthophoto epoch (`<directory>/ortho.tif`), empty for a photo epoch.
  std::string ortho_path;
  /// The whole orthophoto's frame (its tiles' frames are tiles of it); meaningful when is_ortho().
  OrthoFrame ortho;

  bool is_ortho() const { return !ortho_path.empty(); }
  bool is_micmac() const { return !micmac_ori.empty(); }

  /// What the folder held: a COLMAP model (text or binary), a MicMac project or an orthophoto.
  EpochSource source() const {
    if (is_ortho()) return EpochSource::orthophoto;
    if (is_micmac()) return EpochSource::micmac;
    return model_format == ColmapFormat::binary ? EpochSource::colmap_binary : EpochSource::colmap_text;
  }

  /// Index of the image called `name` in `images`, or images.size() when there is none.
  std::size_t find(const std::string& name) const {
    for (std::size_t i = 0; i < images.size(); ++i)
      if (images[i].name == name) return i;
    return images.size();
  }

  /// Reads image `i` as 8-bit grey (RGB becomes luma, 16-bit scans are stretched: read_image_grey8).
  /// Throws diachron::Error naming the file when it cannot be read or its size is not its camera's.
  /// An orthophoto's tile is read as its window of the orthophoto.
  Raster<std::uint8_t> load_image(std::size_t i) const {
    DIACHRON_CHECK(i < images.size(), "EpochFolder::load_image: image " << i << " of " << images.size());
    if (images[i].ortho) {
      GreyImageReadOptions window;
      window.window_x = images[i].tile_x;
      window.window_y = images[i].tile_y;
      window.window_width = images[i].ortho->width();
      window.window_height = images[i].ortho->height();
      return read_image_grey8(ortho_path, window);
    }
    return read_camera_sized(images[i].path, i, "image", "its camera");
  }

  /// Images with a mask.
  std::size_t masks() const {
    std::size_t n = 0;
    for (const EpochImage& image : images) n += !image.mask_path.empty();
    return n;
  }

  /// Reads image `i`'s mask as 8-bit grey (0 = ignore the pixel), or an empty raster when it has
  /// none. Throws diachron::Error naming the file when it cannot be read or its size is not its
  /// camera's.
  Raster<std::uint8_t> load_mask(std::size_t i) const {
    DIACHRON_CHECK(i < images.size(), "EpochFolder::load_mask: image " << i << " of " << images.size());
    if (images[i].mask_path.empty()) return {};
    return read_camera_sized(images[i].mask_path, i, "mask", "its image's camera");
  }

 private:
  // Reads `path` (an image or a mask, `what`) as 8-bit grey and checks that it is image i's camera's
  // size; `whose` names that camera in the message.
  Raster<std::uint8_t> read_camera_sized(const std::string& path, std::size_t i, const char* what,
                                         const char* whose) const {
    Raster<std::uint8_t> raster = read_image_grey8(path);
    const Camera<FraserAffine>& camera = images[i].frame.camera();
    const std::string camera_file =
        is_micmac() ? micmac_ori : directory + "/" + colmap_file_name("cameras", model_format);
    DIACHRON_CHECK(raster.width() == camera.width() && raster.height() == camera.height(),
                   what << " '" << path << "' is " << raster.width() << " x " << raster.height() << " px but "
                        << whose << " in " << camera_file << " is " << camera.width() << " x "
                        << camera.height());
    return raster;
  }
};

namespace detail {

// The orthophoto epoch of `directory` (ortho.tif + dsm.tif): its georeference checked against its
// DSM's, its tiles.
inline EpochFolder read_ortho_epoch_folder(const std::string& directory, const GeoTiffReadOptions& dsm_options,
                                           const OrthoTileOptions& tiles) {
  EpochFolder out;
  out.directory = directory;
  out.ortho_path = directory + "/ortho.tif";
  const RasterGeoreference geo = read_raster_georeference(out.ortho_path);
  DIACHRON_CHECK(geo.has_geotransform, "epoch folder '" << directory
                                                        << "': ortho.tif has no geotransform; an orthophoto epoch "
                                                           "needs one (georeference it, e.g. with gdal_translate -a_ullr)");
  try {
    out.ortho = OrthoFrame(geo.transform, geo.width, geo.height);
  } catch (const Error& e) {
    DIACHRON_CHECK(false, "epoch folder '" << directory << "': ortho.tif: " << e.what());
  }
  out.dsm = read_geotiff_dsm(directory + "/dsm.tif", dsm_options);
  DIACHRON_CHECK(out.dsm.statistics().count > 0, "epoch folder '" << directory << "': dsm.tif has no valid cell");
  DIACHRON_CHECK(same_crs(geo.crs, out.dsm.crs()),
                 "epoch folder '" << directory << "': ortho.tif and dsm.tif are in different CRS ("
                                  << (geo.crs.empty() ? std::string("none") : geo.crs.substr(0, 60)) << " / "
                                  << (out.dsm.crs().empty() ? std::string("none") : out.dsm.crs().substr(0, 60))
                                  << "); reproject one onto the other (gdalwarp -t_srs)");
  const std::vector<std::pair<int, int>> xs = ortho_tile_spans(geo.width, tiles), ys = ortho_tile_spans(geo.height, tiles);
  for (const auto& [y0, h] : ys)
    for (const auto& [x0, w] : xs) {
      EpochImage tile;
      tile.id = static_cast<std::uint32_t>(out.images.size() + 1);
      tile.name = "ortho_x" + std::to_string(x0) + "_y" + std::to_string(y0) + ".tif";
      tile.path = out.ortho_path;
      tile.ortho = out.ortho.tile(x0, y0, w, h);
      tile.tile_x = x0;
      tile.tile_y = y0;
      out.images.push_back(std::move(tile));
    }
  return out;
}

// The mask of the image at `path` (named `name` in the epoch): COLMAP's `masks/<name>.png` under
// the epoch folder, else MicMac's `<path without extension>_Masq.tif` beside the image; "" for none.
inline std::string epoch_image_mask(const std::string& directory, const std::string& name, const std::string& path) {
  const std::string colmap_mask = directory + "/masks/" + name + ".png";
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  const std::string micmac_mask =
      (dot != std::string::npos && (slash == std::string::npos || dot > slash) ? path.substr(0, dot) : path) +
      "_Masq.tif";
  for (const std::string& candidate : {colmap_mask, micmac_mask})
    if (is_regular_file(candidate)) return candidate;
  return "";
}

// Whether the folder `folder` holds an `Orientation-<image>.xml` file.
inline bool holds_micmac_orientation(const std::string& folder) {
  for (const std::string& entry : folder_entries(folder))
    if (entry.size() > kMicmacOrientationPrefix.size() + kMicmacXmlSuffix.size() &&
        entry.compare(0, kMicmacOrientationPrefix.size(), kMicmacOrientationPrefix) == 0 &&
        entry.compare(entry.size() - kMicmacXmlSuffix.size(), kMicmacXmlSuffix.size(), kMicmacXmlSuffix) == 0 &&
        is_regular_file(folder + "/" + entry))
      return true;
  return false;
}

// The `Ori-*` folders of `directory` (names, sorted), split into those holding Orientation files
// and the others.
inline std::pair<std::vector<std::string>, std::vector<std::string>> micmac_ori_folders(const std::string& directory) {
  std::pair<std::vector<std::string>, std::vector<std::string>> out;
  for (const std::string& entry : folder_entries(directory))
    if (entry.size() > 4 && entry.compare(0, 4, "Ori-") == 0 && is_folder(directory + "/" + entry))
      (holds_micmac_orientation(directory + "/" + entry) ? out.first : out.second).push_back(entry);
  return out;
}

inline std::string joined_names(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// The point nearest to a track's rays in the least-squares sense (sum of squared distances to the
// lines), or nullopt when a ray is missing, the rays' widest angle is below `min_angle_deg` or the
// system is degenerate. Eigen only, so that reading an epoch needs no Ceres header (the refined
// triangulation of adjustment/triangulation.hpp differentiates with ceres::Jet); the points are
// the model's, checked against the DSM and refined by the adjustment, and a track whose point
// reprojects beyond MicmacEpochOptions::max_reprojection_px is dropped anyway.
inline std::optional<Vec3> micmac_track_point(const std::vector<Frame<FraserAffine>>& frames, const Track& track,
                                              double min_angle_deg) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Vec3 b = Vec3::Zero();
  std::vector<Vec3> directions;
  for (const TrackObservation& o : track.observations) {
    const std::optional<Ray3> ray = frames[static_cast<std::size_t>(o.image)].ray(o.pixel);
    if (!ray) return std::nullopt;
    const Vec3 d = ray->direction.normalized();
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - d * d.transpose();
    a += p;
    b += p * ray->origin;
    directions.push_back(d);
  }
  double widest = 0.0;
  for (std::size_t i = 0; i < directions.size(); ++i)
    for (std::size_t j = i + 1; j < directions.size(); ++j)
      widest = std::max(widest, std::acos(std::clamp(directions[i].dot(directions[j]), -1.0, 1.0)));
  if (directions.size() < 2 || widest < deg_to_rad(min_angle_deg)) return std::nullopt;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(a);
  if (lu.rank() < 3) return std::nullopt;
  const Vec3 x = lu.solve(b);
  if (!x.allFinite()) return std::nullopt;
  return x;
}

// The Homol tie points of a MicMac epoch as tracks over `images` (indices into it), each
// triangulated with the frames and kept when every observation reprojects within
// options.max_reprojection_px; added to `out.model` as points3D (ids 1..) and 2D points.
inline void read_micmac_tie_points(EpochFolder& out, const MicmacEpochOptions& options) {
  const std::string homol_dir = out.directory + "/" + options.homol;
  if (!is_folder(homol_dir)) return;
  MicmacTiePointReport& report = out.micmac_ties;
  report.homol_dir = homol_dir;
  std::map<std::string, int> index;
  for (std::size_t i = 0; i < out.images.size(); ++i) index.emplace(out.images[i].name, static_cast<int>(i));
  const std::vector<HomolPair> pairs = list_homol_pairs(homol_dir);
  if (pairs.empty()) {
    // MicMac's default tie points are binary; reading none of them silently would lose them all.
    for (const std::string& sub : folder_entries(homol_dir))
      for (const std::string& file : folder_entries(homol_dir + "/" + sub))
        DIACHRON_CHECK(file.size() < 4 || file.compare(file.size() - 4, 4, ".dat") != 0,
                       "epoch folder '" << out.directory << "': " << options.homol << "/" << sub << "/" << file
                                        << " is MicMac's binary tie-point form, which is not read; export the "
                                           "tie points as text (Tapioca ... ExpTxt=1)");
  }
  std::set<std::pair<std::string, std::string>> listed;
  for (const HomolPair& p : pairs) listed.emplace(p.image1, p.image2);

  // MicMac's tools (Tapioca) match each pair both ways and the two files need not hold the same
  // points: chaining both would put one keypoint at two nearby pixels and drop its track as
  // conflicting. So each pair is read once, from Pastis<first>/<second>.txt in name order, or from
  // the other file, swapped, when only that one exists.
  std::vector<std::vector<ImagePixel>> ties;
  for (const HomolPair& p : pairs) {
    if (p.image1 == p.image2) continue;
    const bool forward = p.image1 < p.image2;
    if (!forward && listed.count({p.image2, p.image1})) continue;
    const auto a = index.find(p.image1), b = index.find(p.image2);
    if (a == index.end() || b == index.end()) {
      ++report.skipped_files;
      continue;
    }
    const PointMatches matches = read_homol(p.path, options.read.pixel_shift_px);
    ++report.files;
    report.tie_points += matches.size();
    for (const PointMatch& m : matches) ties.push_back({ImagePixel{a->second, m.a}, ImagePixel{b->second, m.b}});
  }
  const TrackSet tracks = build_tracks(ties, {}, static_cast<int>(out.images.size()));
  report.tracks = tracks.report;

  std::vector<Frame<FraserAffine>> frames;
  frames.reserve(out.images.size());
  for (const EpochImage& image : out.images) frames.push_back(image.frame);
  for (const Track& track : tracks.tracks) {
    const std::optional<Vec3> t = micmac_track_point(frames, track, options.min_angle_deg);
    if (!t) {
      ++report.failed_triangulation;
      continue;
    }
    double largest = 0.0, sum = 0.0;
    for (const TrackObservation& o : track.observations) {
      const std::optional<Vec2> px = frames[static_cast<std::size_t>(o.image)].project(*t);
      const double e = px ? (*px - o.pixel).norm() : std::numeric_limits<double>::infinity();
      largest = std::max(largest, e);
      sum += e;
    }
    if (!(largest <= options.max_reprojection_px)) {
      ++report.large_reprojection;
      continue;
    }
    ColmapPoint3D point;
    point.id = out.model.points3d.size() + 1;
    point.xyz = *t;
    point.error = sum / static_cast<double>(track.observations.size());  // COLMAP's: the mean, px
    for (const TrackObservation& o : track.observations) {
      ColmapImage& image = out.model.images.at(out.images[static_cast<std::size_t>(o.image)].id);
      point.track.push_back({image.id, static_cast<std::uint32_t>(image.points2d.size())});
      image.points2d.push_back({colmap_pixel_from_diachron(o.pixel), static_cast<std::int64_t>(point.id)});
    }
    out.model.points3d.emplace(point.id, std::move(point));
  }
  report.points = out.model.points3d.size();
}

// The MicMac epoch of `directory` with the orientation `ori` ("Ori-<name>"): images, frames,
// DSM, and the model of read_micmac_tie_points.
inline EpochFolder read_micmac_epoch_folder(const std::string& directory, const std::string& ori,
                                            const GeoTiffReadOptions& dsm_options, const MicmacEpochOptions& options) {
  EpochFolder out;
  out.directory = directory;
  out.micmac_ori = micmac_ori_folder(directory, ori);
  const std::vector<MicmacOriImage> oriented = read_micmac_ori_folder(directory, ori, options.read);
  out.dsm = read_geotiff_dsm(directory + "/dsm.tif", dsm_options);
  DIACHRON_CHECK(out.dsm.statistics().count > 0, "epoch folder '" << directory << "': dsm.tif has no valid cell");
  // One COLMAP camera per distinct calibration (images converted from one file hold equal cameras).
  std::vector<const Camera<FraserAffine>*> cameras;
  for (const MicmacOriImage& o : oriented) {
    EpochImage image;
    image.id = static_cast<std::uint32_t>(out.images.size() + 1);
    image.name = o.name;
    // MicMac runs in the folder holding the images; diachron's layout keeps them under images/.
    image.path = directory + "/images/" + o.name;
    if (!is_regular_file(image.path) && is_regular_file(directory + "/" + o.name)) image.path = directory + "/" + o.name;
    DIACHRON_CHECK(is_regular_file(image.path),
                   "epoch folder '" << directory << "': image '" << o.name << "' (" << o.orientation_file
                                    << ") is in neither images/ nor the folder itself");
    image.mask_path = epoch_image_mask(directory, o.name, image.path);
    image.frame = Frame<FraserAffine>(o.camera, o.pose);
    image.conversion_error_px = o.conversion_exact ? 0.0 : o.conversion_max_error_px;

    std::size_t c = 0;
    while (c < cameras.size() && !same_micmac_camera(*cameras[c], o.camera)) ++c;
    if (c == cameras.size()) {
      cameras.push_back(&o.camera);
      const auto id = static_cast<std::uint32_t>(c + 1);
      out.model.cameras.emplace(id, colmap_camera_from_camera(o.camera, id, options.read.conversion).model);
    }
    ColmapImage colmap_image;
    colmap_image.id = image.id;
    colmap_image.name = o.name;
    colmap_image.camera_id = static_cast<std::uint32_t>(c + 1);
    colmap_image.pose = o.pose;
    out.model.images.emplace(image.id, std::move(colmap_image));
    out.images.push_back(std::move(image));
  }
  read_micmac_tie_points(out, options);
  return out;
}

}  // namespace detail

/// Reads the epoch folder `directory`: its COLMAP model (`cameras.txt`, `images.txt`, `points3D.txt`,
/// or the `.bin` files; both only when they agree: read_colmap_model()), `dsm.tif`, and checks that
/// every image of the model exists under `images/`; notes each image's mask where it
/// exists (EpochImage::mask_path, read on demand by EpochFolder::load_mask). A folder with
/// `ortho.tif` and no model is an orthophoto epoch: its tiles (`tiles`) become its images, named
/// `ortho_x<X>_y<Y>.tif` after their top-left pixel in the orthophoto.
///
/// A folder without a COLMAP model but with one `Ori-*` folder holding Orientation-*.xml files (or
/// with `micmac.ori` set) is a MicMac epoch: its images are those of the orientation, in name
/// order (ids 1..N), each looked up as `images/<name>`, else `<name>` at the folder's top (where
/// MicMac keeps them), with its frame from read_micmac_ori_folder (EpochImage::conversion_error_px
/// the calibration's measured conversion error). Its tie points (`micmac.homol`, default
/// `Homol/`, text files `Pastis<image>/<other>.txt`, pixels shifted by
/// `micmac.read.pixel_shift_px`) are chained into tracks (build_tracks), each triangulated with
/// the frames (triangulate_track) and kept when every observation reprojects within
/// `micmac.max_reprojection_px`; they become EpochFolder::model's points3D and its images' 2D
/// points, the cameras the nearest COLMAP ones (colmap_camera_from_camera), so that what reads a
/// COLMAP epoch's model reads it unchanged. EpochFolder::micmac_ties counts what was read, kept
/// and dropped. Without the Homol folder the model has no points (check_epoch_folder then warns
/// that the model cannot be checked against the DSM).
///
/// Throws diachron::Error naming the file (and line, or byte for a binary model) when the folder,
/// a file or an image is missing, a file cannot be parsed, a camera model has no diachron
/// counterpart, the DSM has no valid cell, the folder holds both a model and an orthophoto, or a
/// text and a binary model that differ, or the orthophoto has no geotransform, a rotated one, or
/// another CRS than its DSM; for a MicMac folder, when it holds several `Ori-*` folders and
/// `micmac.ori` names none (the message lists them), its `Ori-*` folders hold no Orientation file,
/// it also holds ortho.tif, its Homol folder holds only MicMac's binary `.dat` tie points, and as
/// read_micmac_ori_folder() and read_homol() do.
inline EpochFolder read_epoch_folder(const std::string& directory, const GeoTiffReadOptions& dsm_options = {},
                                     const OrthoTileOptions& tiles = {}, const MicmacEpochOptions& micmac = {}) {
  DIACHRON_CHECK(!directory.empty() && is_folder(directory),
                 "epoch folder '" << directory << "' does not exist or is not a folder");
  tiles.check();
  micmac.check();
  const bool has_ortho = is_regular_file(directory + "/ortho.tif");
  const bool has_model = is_regular_file(directory + "/images.txt") || is_regular_file(directory + "/cameras.txt") ||
                         has_colmap_model(directory, ColmapFormat::binary);
  // A named orientation is the user's choice, even beside a COLMAP model; unnamed, a COLMAP model
  // comes first (a MicMac project may hold a COLMAP export too) and the Ori folders are looked at
  // only without one.
  std::string ori = micmac.ori.empty() || micmac.ori.rfind("Ori-", 0) == 0 ? micmac.ori : "Ori-" + micmac.ori;
  if (ori.empty() && !has_model) {
    const auto [with_orientations, without] = detail::micmac_ori_folders(directory);
    DIACHRON_CHECK(with_orientations.size() <= 1,
                   "epoch folder '" << directory << "' holds no COLMAP model and several MicMac orientations ("
                                    << detail::joined_names(with_orientations)
                                    << "); name the one to read (MicmacEpochOptions::ori, e.g. \""
                                    << with_orientations.front().substr(4) << "\")");
    if (!with_orientations.empty()) ori = with_orientations.front();
    DIACHRON_CHECK(!ori.empty() || without.empty() || has_ortho,
                   "epoch folder '" << directory << "' holds no COLMAP model and its MicMac orientation folders ("
                                    << detail::joined_names(without)
                                    << ") hold no Orientation-<image>.xml; give a COLMAP model or an Ori folder "
                                       "with the Orientation files");
  }
  DIACHRON_CHECK(!(has_ortho && has_model), "epoch folder '" << directory
                                                             << "' holds both a COLMAP model and ortho.tif; an epoch "
                                                                "is one or the other: move one of them away");
  DIACHRON_CHECK(!(has_ortho && !ori.empty()), "epoch folder '" << directory << "' holds both a MicMac orientation ("
                                                                << ori
                                                                << ") and ortho.tif; an epoch is one or the other: "
                                                                   "move one of them away");
  if (!ori.empty()) return detail::read_micmac_epoch_folder(directory, ori, dsm_options, micmac);
  if (has_ortho) return detail::read_ortho_epoch_folder(directory, dsm_options, tiles);
  EpochFolder out;
  out.directory = directory;
  // A folder with no model file at all keeps the text reader's message (cameras.txt cannot be opened).
  if (has_colmap_model(directory, ColmapFormat::binary))
    out.model = read_colmap_model(directory, &out.model_format);
  else
    out.model = read_colmap_text(directory);
  const std::string images_file = colmap_file_name("images", out.model_format);
  DIACHRON_CHECK(!out.model.images.empty(), "epoch folder '" << directory << "': " << images_file << " lists no image");
  out.dsm = read_geotiff_dsm(directory + "/dsm.tif", dsm_options);
  DIACHRON_CHECK(out.dsm.statistics().count > 0, "epoch folder '" << directory << "': dsm.tif has no valid cell");
  for (const auto& [id, colmap_image] : out.model.images) {
    EpochImage image;
    image.id = id;
    image.name = colmap_image.name;
    image.path = directory + "/images/" + colmap_image.name;
    DIACHRON_CHECK(is_regular_file(image.path),
                   "epoch folder '" << directory << "': image '" << colmap_image.name << "' (id " << id << " in "
                                    << images_file << ") is missing from images/");
    image.mask_path = detail::epoch_image_mask(directory, colmap_image.name, image.path);
    const ColmapCamera& colmap_camera = out.model.cameras.at(colmap_image.camera_id);  // check()ed by the reader
    const ConversionResult<Camera<FraserAffine>> camera = camera_from_colmap(colmap_camera);
    image.frame = Frame<FraserAffine>(camera.model, colmap_image.pose);
    image.conversion_error_px = camera.exact ? 0.0 : camera.max_error_px;
    out.images.push_back(std::move(image));
  }
  return out;
}

}  // namespace diachron
