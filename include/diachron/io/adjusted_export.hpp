#pragma once
/// @file
/// The adjusted orientation on disk (docs/adjusted-export.md): `DIR/adjusted/cameras.json` with
/// the exact Fraser + affine cameras (io/cameras_json.hpp) and, per epoch, a COLMAP text model
/// `DIR/adjusted/<epoch>/` whose cameras are the nearest COLMAP model (OPENCV when it holds the
/// camera exactly, else FULL_OPENCV, fitted when the shear B2 is not zero), with the measured
/// conversion error of each. Never writes into an input model. Standard library and Eigen only;
/// folders through POSIX calls (GCC's <filesystem> inlines cannot link when every inline function
/// is emitted, as the headers-alone check does).
///
/// write_adjusted_colmap() adds `DIR/adjusted/colmap/`: one COLMAP model of every epoch's images
/// with the tie points as points3D (`sparse/`, text or binary) and `images/`, symbolic links to the
/// image files, so that COLMAP's dense tools run on the adjusted orientation as they are.

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/conversion.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/colmap_model.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/folders.hpp>

namespace diachron {

/// Options of write_adjusted_export().
struct AdjustedExportOptions {
  /// How the COLMAP cameras are fitted and their error measured (grid over each image).
  ConversionOptions conversion;
  /// Folders that must not be written into (the input COLMAP models): the export refuses to run
  /// when one of its target folders is one of these (same file-system object, symbolic links and
  /// `..` resolved). Empty: no check beyond the fixed `adjusted/` layout.
  std::vector<std::string> protected_folders;
};

/// How one COLMAP camera of the export represents its diachron camera.
struct AdjustedCameraConversion {
  std::string epoch;
  std::uint32_t camera_id = 0;     ///< id in that epoch's cameras.txt
  std::string model;               ///< "OPENCV" or "FULL_OPENCV"
  bool exact = false;              ///< closed-form conversion (errors are rounding only)
  double max_error_px = 0.0;       ///< largest pixel distance over the image grid, px
  double rms_error_px = 0.0;       ///< RMS of the same, px
  std::vector<std::string> images; ///< the images that use it
};

/// What write_adjusted_export() wrote.
struct AdjustedExportReport {
  std::string cameras_json_path;                        ///< DIR/adjusted/cameras.json
  std::map<std::string, std::string> model_folders;     ///< epoch -> DIR/adjusted/<epoch>
  std::vector<AdjustedCameraConversion> cameras;        ///< one per COLMAP camera, by epoch then id
  double max_conversion_error_px = 0.0;                 ///< the largest max_error_px, px (0 for no camera)
};

/// The COLMAP model of the images of one epoch (every image when `epoch` is empty, e.g. for one
/// model over both epochs): one camera per distinct diachron camera (same size and intrinsics,
/// compared exactly), ids from 1 in order of first use; image ids from 1 in input order; poses as
/// given; no 2D or 3D points. `conversions` receives one entry per camera.
/// Precondition: every image taken has a distinct name without white space and a rotation matrix
/// (else throws diachron::Error).
inline ColmapModel adjusted_colmap_model(const std::vector<CamerasJsonImage>& images, const std::string& epoch,
                                         const ConversionOptions& conversion,
                                         std::vector<AdjustedCameraConversion>* conversions = nullptr);

/// Writes `images` (their adjusted orientation, all in one frame, e.g. epoch 2's) as
/// `<dir>/adjusted/cameras.json` and one COLMAP text model per epoch in `<dir>/adjusted/<epoch>/`
/// (folders created as needed; files in them replaced). Checks everything (names, epochs, poses,
/// protected folders) before writing anything.
/// Throws diachron::Error for an empty `dir`, an epoch name that is not a plain folder name
/// (empty, '.', '..', or with '/'), two images of an epoch with the same name, a target folder
/// that is a protected folder, or a file that cannot be written.
inline AdjustedExportReport write_adjusted_export(const std::vector<CamerasJsonImage>& images, const std::string& dir,
                                                  const AdjustedExportOptions& options = {});

/// One observation of an exported tie point: which image (an index into the `images` vector given
/// to write_adjusted_colmap()) and where, in diachron's pixel convention (centre of the top-left
/// pixel at (0, 0); the export adds COLMAP's 0.5).
struct ExportObservation {
  std::size_t image = 0;
  Vec2 pixel = Vec2::Zero();  ///< px, diachron convention
};

/// A tie point to export, independent of the adjustment's own types: its adjusted position in the
/// frame of the images' poses (frame units, e.g. m) and its observations (any number per image).
struct ExportTrack {
  Vec3 xyz = Vec3::Zero();
  std::vector<ExportObservation> observations;
};

/// Options of write_adjusted_colmap().
struct AdjustedColmapOptions {
  /// The form of the model in `DIR/adjusted/colmap/sparse/`: text (default, readable) or binary
  /// (what COLMAP writes; 3 to 4 times smaller for many points).
  ColmapFormat format = ColmapFormat::text;
  /// How the COLMAP cameras are fitted and their error measured (grid over each image).
  ConversionOptions conversion;
  /// Folders that must not be written into (the input models), as AdjustedExportOptions.
  std::vector<std::string> protected_folders;
  /// The colour of every point3D (0-255 each): the export has no image colours to sample.
  std::array<std::uint8_t, 3> rgb{{128, 128, 128}};

  void check() const { conversion.check(); }
};

/// What write_adjusted_colmap() wrote.
struct AdjustedColmapReport {
  std::string folder;         ///< DIR/adjusted/colmap
  std::string model_folder;   ///< DIR/adjusted/colmap/sparse: the COLMAP model
  std::string images_folder;  ///< DIR/adjusted/colmap/images: a symbolic link per image
  ColmapFormat format = ColmapFormat::text;
  /// One per COLMAP camera (epoch empty: the model holds every epoch), as in AdjustedExportReport.
  std::vector<AdjustedCameraConversion> cameras;
  double max_conversion_error_px = 0.0;   ///< the largest max_error_px, px
  std::size_t images = 0;                 ///< images in the model
  std::size_t points = 0;                 ///< points3D written
  std::size_t observations = 0;           ///< their track elements (2D points with a 3D point)
  std::size_t skipped_tracks = 0;         ///< tracks left out: non-finite xyz or no observation
  /// Reprojection error of the observations in the adjusted (exact, Fraser + affine) frames, px:
  /// mean and largest over the observations that project (a point behind its camera does not).
  double mean_reprojection_error_px = 0.0;
  double max_reprojection_error_px = 0.0;
  std::size_t unprojected_observations = 0;  ///< observations whose point does not project
};

/// The COLMAP model of all `images` (one model over every epoch) with `tracks` as points3D:
/// cameras and images as adjusted_colmap_model() with an empty epoch (image ids 1.. in input order,
/// one camera per distinct diachron camera), then per kept track (finite xyz, at least one
/// observation) a point3D with ids 1.. in track order, colour `options.rgb`, and as error the mean
/// distance between its observations and its projections in the adjusted frames (px; -1 when none
/// projects); each observation becomes a 2D point of its image (COLMAP pixel convention), in track
/// order. `report`, when given, receives cameras, counts and reprojection errors (not the folders).
/// Throws diachron::Error for image names that are not unique (across epochs), empty, absolute, with
/// white space or with an empty, "." or ".." component, an observation of an image that does not
/// exist or a non-finite pixel.
inline ColmapModel adjusted_colmap_model_with_points(const std::vector<CamerasJsonImage>& images,
                                                     const std::vector<ExportTrack>& tracks,
                                                     const AdjustedColmapOptions& options = {},
                                                     AdjustedColmapReport* report = nullptr);

/// Writes one COLMAP model of every image (all in one frame, e.g. epoch 2's) with `tracks` as its
/// points3D (adjusted_colmap_model_with_points()) as `DIR/adjusted/colmap/`:
/// ```
/// DIR/adjusted/colmap/sparse/   the model (cameras, images, points3D; .txt or .bin: options.format;
///                               the other form's files, if a previous run left them, are removed)
/// DIR/adjusted/colmap/images/   per image a symbolic link named as the image in the model (a name
///                               with '/' makes sub-folders) to the absolute canonical path of
///                               `image_paths[i]` (links replaced; other entries left alone)
/// ```
/// so that `colmap image_undistorter --image_path DIR/adjusted/colmap/images --input_path
/// DIR/adjusted/colmap/sparse --output_path ...` runs as it is. `image_paths` is parallel to
/// `images`. Checks everything (names, paths, observations, protected folders, the entries the links
/// replace) before writing anything.
/// Throws diachron::Error for an empty `dir`, `image_paths` of another size, an image file that
/// does not exist, an epoch named "colmap" (its per-epoch model folder would be this one), a target
/// folder that is a protected folder, an entry of images/ in the way that is not a symbolic link,
/// what adjusted_colmap_model_with_points() refuses, or a file that cannot be written.
inline AdjustedColmapReport write_adjusted_colmap(const std::vector<CamerasJsonImage>& images,
                                                  const std::vector<std::string>& image_paths,
                                                  const std::vector<ExportTrack>& tracks, const std::string& dir,
                                                  const AdjustedColmapOptions& options = {});

// Implementation ----------------------------------------------------------------------------------

namespace detail {

// True when the two paths name the same existing file-system object (device and inode), which
// sees through symbolic links, "..", and different spellings of one folder.
inline bool adjusted_same_object(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  if (::stat(a.c_str(), &sa) != 0 || ::stat(b.c_str(), &sb) != 0) return false;
  return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

inline bool adjusted_same_camera(const Camera<FraserAffine>& a, const Camera<FraserAffine>& b) {
  return a.width() == b.width() && a.height() == b.height() && a.intrinsics() == b.intrinsics();
}

}  // namespace detail

inline ColmapModel adjusted_colmap_model(const std::vector<CamerasJsonImage>& images, const std::string& epoch,
                                         const ConversionOptions& conversion,
                                         std::vector<AdjustedCameraConversion>* conversions) {
  ColmapModel model;
  std::vector<Camera<FraserAffine>> distinct;
  std::vector<AdjustedCameraConversion> out;
  std::uint32_t next_image = 1;
  for (const CamerasJsonImage& im : images) {
    if (!epoch.empty() && im.epoch != epoch) continue;
    // images.txt separates its fields by white space, so a name cannot hold any.
    DIACHRON_CHECK(!im.name.empty() && im.name.find_first_of(" \t\r\n") == std::string::npos,
                   "adjusted_colmap_model: image name '" << im.name << "' is empty or has white space");
    DIACHRON_CHECK(!model.find_image(im.name), "adjusted_colmap_model: epoch '" << epoch << "' has two images named '"
                                                                                << im.name << "'");
    std::size_t k = 0;
    while (k < distinct.size() && !detail::adjusted_same_camera(distinct[k], im.camera)) ++k;
    const auto camera_id = static_cast<std::uint32_t>(k + 1);
    if (k == distinct.size()) {
      distinct.push_back(im.camera);
      const ConversionResult<ColmapCamera> c = colmap_camera_from_camera(im.camera, camera_id, conversion);
      model.cameras.emplace(camera_id, c.model);
      AdjustedCameraConversion record;
      record.epoch = epoch;
      record.camera_id = camera_id;
      record.model = c.model.model;
      record.exact = c.exact;
      record.max_error_px = c.max_error_px;
      record.rms_error_px = c.rms_error_px;
      out.push_back(std::move(record));
    }
    out[k].images.push_back(im.name);
    ColmapImage image;
    image.id = next_image++;
    image.name = im.name;
    image.camera_id = camera_id;
    image.pose = im.pose();
    model.images.emplace(image.id, std::move(image));
  }
  if (conversions) conversions->insert(conversions->end(), out.begin(), out.end());
  return model;
}

inline AdjustedExportReport write_adjusted_export(const std::vector<CamerasJsonImage>& images, const std::string& dir,
                                                  const AdjustedExportOptions& options) {
  DIACHRON_CHECK(!dir.empty(), "write_adjusted_export: empty output folder name");
  options.conversion.check();
  const std::string root = dir + "/adjusted";
  // Epochs in order of first appearance, so the report reads in the caller's order.
  std::vector<std::string> epochs;
  for (const CamerasJsonImage& im : images) {
    DIACHRON_CHECK(!im.epoch.empty() && im.epoch != "." && im.epoch != ".." && im.epoch.find('/') == std::string::npos,
                   "write_adjusted_export: image '" << im.name << "' has the epoch name '" << im.epoch
                                                    << "', which is not a plain folder name");
    if (std::find(epochs.begin(), epochs.end(), im.epoch) == epochs.end()) epochs.push_back(im.epoch);
  }
  std::vector<std::string> targets{root};
  for (const std::string& e : epochs) targets.push_back(root + "/" + e);
  for (const std::string& target : targets)
    for (const std::string& input : options.protected_folders)
      DIACHRON_CHECK(!detail::adjusted_same_object(target, input),
                     "write_adjusted_export: the target folder '" << target << "' is the input model '" << input
                                                                  << "', which is never overwritten");
  // Everything that can fail on the content is built before the first file is written.
  AdjustedExportReport report;
  std::map<std::string, ColmapModel> models;
  for (const std::string& e : epochs) {
    ColmapModel m = adjusted_colmap_model(images, e, options.conversion, &report.cameras);
    m.check();
    models.emplace(e, std::move(m));
  }
  static_cast<void>(cameras_json(images));  // throws for an empty name or epoch, a non-finite pose

  make_folders(root, "write_adjusted_export");
  report.cameras_json_path = root + "/cameras.json";
  write_cameras_json(images, report.cameras_json_path);
  for (const std::string& e : epochs) {
    const std::string folder = root + "/" + e;
    make_folders(folder, "write_adjusted_export");
    write_colmap_text(models.at(e), folder);
    report.model_folders.emplace(e, folder);
  }
  for (const AdjustedCameraConversion& c : report.cameras)
    report.max_conversion_error_px = std::max(report.max_conversion_error_px, c.max_error_px);
  return report;
}

namespace detail {

// An image name usable as a path under images/: relative, no empty, "." or ".." component (a link
// must stay inside the folder), no white space (images.txt splits on it).
inline void check_export_image_name(const std::string& name) {
  DIACHRON_CHECK(!name.empty() && name.find_first_of(" \t\r\n") == std::string::npos &&
                     name.find('\0') == std::string::npos,
                 "write_adjusted_colmap: image name '" << name << "' is empty or has white space");
  for (std::size_t start = 0;;) {
    const std::size_t slash = name.find('/', start);
    const std::string part = name.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
    DIACHRON_CHECK(!part.empty() && part != "." && part != "..",
                   "write_adjusted_colmap: image name '" << name
                                                         << "' is not a relative path inside images/ (an empty, '.' or "
                                                            "'..' component, or a leading '/')");
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
}

// The absolute canonical path of an existing regular file (symbolic links and ".." resolved).
inline std::optional<std::string> canonical_file(const std::string& path) {
  if (!is_regular_file(path)) return std::nullopt;
  char* resolved = ::realpath(path.c_str(), nullptr);
  if (!resolved) return std::nullopt;
  std::string out(resolved);
  std::free(resolved);
  return out;
}

inline bool is_symbolic_link(const std::string& path) {
  struct stat info {};
  return ::lstat(path.c_str(), &info) == 0 && S_ISLNK(info.st_mode);
}

inline bool path_exists_no_follow(const std::string& path) {
  struct stat info {};
  return ::lstat(path.c_str(), &info) == 0;
}

}  // namespace detail

inline ColmapModel adjusted_colmap_model_with_points(const std::vector<CamerasJsonImage>& images,
                                                     const std::vector<ExportTrack>& tracks,
                                                     const AdjustedColmapOptions& options,
                                                     AdjustedColmapReport* report) {
  options.check();
  // Names first, with both epochs in the message: adjusted_colmap_model() would only say "two images".
  std::map<std::string, std::size_t> by_name;
  for (std::size_t i = 0; i < images.size(); ++i) {
    detail::check_export_image_name(images[i].name);
    const auto [it, inserted] = by_name.emplace(images[i].name, i);
    DIACHRON_CHECK(inserted, "write_adjusted_colmap: images " << it->second << " (epoch '" << images[it->second].epoch
                                                              << "') and " << i << " (epoch '" << images[i].epoch
                                                              << "') are both named '" << images[i].name
                                                              << "'; names must be unique across epochs (prefix them "
                                                                 "with the epoch)");
  }
  AdjustedColmapReport out;
  ColmapModel model = adjusted_colmap_model(images, "", options.conversion, &out.cameras);
  std::vector<Frame<FraserAffine>> frames;
  frames.reserve(images.size());
  for (const CamerasJsonImage& im : images) frames.push_back(im.frame());
  // Image ids are 1.. in input order (adjusted_colmap_model), so image i is id i + 1.
  const auto image_id = [](std::size_t i) { return static_cast<std::uint32_t>(i + 1); };
  for (std::size_t t = 0; t < tracks.size(); ++t)
    for (const ExportObservation& o : tracks[t].observations) {
      DIACHRON_CHECK(o.image < images.size(), "write_adjusted_colmap: track " << t << " observes image " << o.image
                                                                              << ", but there are " << images.size());
      DIACHRON_CHECK(o.pixel.allFinite(), "write_adjusted_colmap: track " << t << " has a non-finite pixel in image '"
                                                                          << images[o.image].name << "'");
    }
  double error_sum = 0.0;
  std::size_t projected = 0;
  std::uint64_t next_point = 1;
  for (const ExportTrack& track : tracks) {
    if (!track.xyz.allFinite() || track.observations.empty()) {
      ++out.skipped_tracks;
      continue;
    }
    ColmapPoint3D point;
    point.id = next_point++;
    point.xyz = track.xyz;
    point.rgb = options.rgb;
    double sum = 0.0;
    std::size_t n = 0;
    for (const ExportObservation& o : track.observations) {
      ColmapImage& image = model.images.at(image_id(o.image));
      point.track.push_back({image.id, static_cast<std::uint32_t>(image.points2d.size())});
      image.points2d.push_back({colmap_pixel_from_diachron(o.pixel), static_cast<std::int64_t>(point.id)});
      const std::optional<Vec2> px = frames[o.image].project(track.xyz);
      if (!px) {
        ++out.unprojected_observations;
        continue;
      }
      const double e = (*px - o.pixel).norm();
      sum += e;
      ++n;
      out.max_reprojection_error_px = std::max(out.max_reprojection_error_px, e);
    }
    // COLMAP's "unknown" error when no observation projects (behind every camera that sees it).
    point.error = n ? sum / static_cast<double>(n) : -1.0;
    error_sum += sum;
    projected += n;
    out.observations += point.track.size();
    model.points3d.emplace(point.id, std::move(point));
  }
  if (report) {
    report->cameras = std::move(out.cameras);
    for (const AdjustedCameraConversion& c : report->cameras)
      report->max_conversion_error_px = std::max(report->max_conversion_error_px, c.max_error_px);
    report->format = options.format;
    report->images = model.images.size();
    report->points = model.points3d.size();
    report->observations = out.observations;
    report->skipped_tracks = out.skipped_tracks;
    report->mean_reprojection_error_px = projected ? error_sum / static_cast<double>(projected) : 0.0;
    report->max_reprojection_error_px = out.max_reprojection_error_px;
    report->unprojected_observations = out.unprojected_observations;
  }
  return model;
}

inline AdjustedColmapReport write_adjusted_colmap(const std::vector<CamerasJsonImage>& images,
                                                  const std::vector<std::string>& image_paths,
                                                  const std::vector<ExportTrack>& tracks, const std::string& dir,
                                                  const AdjustedColmapOptions& options) {
  DIACHRON_CHECK(!dir.empty(), "write_adjusted_colmap: empty output folder name");
  options.check();
  DIACHRON_CHECK(image_paths.size() == images.size(), "write_adjusted_colmap: " << image_paths.size()
                                                                                << " image paths for " << images.size()
                                                                                << " images");
  for (const CamerasJsonImage& im : images)
    DIACHRON_CHECK(im.epoch != "colmap", "write_adjusted_colmap: image '"
                                             << im.name
                                             << "' is of an epoch named 'colmap', whose per-epoch model folder "
                                                "(DIR/adjusted/colmap) is the combined model's; rename the epoch");
  AdjustedColmapReport report;
  report.folder = dir + "/adjusted/colmap";
  report.model_folder = report.folder + "/sparse";
  report.images_folder = report.folder + "/images";
  for (const std::string& target : {dir + "/adjusted", report.folder, report.model_folder, report.images_folder})
    for (const std::string& input : options.protected_folders)
      DIACHRON_CHECK(!detail::adjusted_same_object(target, input),
                     "write_adjusted_colmap: the target folder '" << target << "' is the input model '" << input
                                                                  << "', which is never overwritten");
  // Everything that can fail on the content is checked before the first file is written.
  const ColmapModel model = adjusted_colmap_model_with_points(images, tracks, options, &report);
  model.check();
  std::vector<std::string> targets;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const std::optional<std::string> file = detail::canonical_file(image_paths[i]);
    DIACHRON_CHECK(file, "write_adjusted_colmap: the file of image '" << images[i].name << "', '" << image_paths[i]
                                                                      << "', does not exist or is not a file");
    const std::string link = report.images_folder + "/" + images[i].name;
    DIACHRON_CHECK(!detail::path_exists_no_follow(link) || detail::is_symbolic_link(link),
                   "write_adjusted_colmap: '" << link << "' exists and is not a symbolic link; it is never replaced");
    targets.push_back(*file);
  }

  make_folders(report.model_folder, "write_adjusted_colmap");
  // One form per folder: a model of the other form left by an earlier run would make the folder
  // ambiguous (read_colmap_model() refuses two forms that differ).
  const ColmapFormat other = options.format == ColmapFormat::text ? ColmapFormat::binary : ColmapFormat::text;
  for (const char* table : {"cameras", "images", "points3D"}) {
    const std::string stale = report.model_folder + "/" + colmap_file_name(table, other);
    DIACHRON_CHECK(!is_regular_file(stale) || ::unlink(stale.c_str()) == 0,
                   "write_adjusted_colmap: cannot remove '" << stale << "', left by an earlier export");
  }
  write_colmap_model(model, report.model_folder, options.format);
  make_folders(report.images_folder, "write_adjusted_colmap");
  for (std::size_t i = 0; i < images.size(); ++i) {
    const std::string link = report.images_folder + "/" + images[i].name;
    const std::size_t slash = link.find_last_of('/');
    make_folders(link.substr(0, slash), "write_adjusted_colmap");
    // Replaced, not kept: an earlier run may have linked another file under this name.
    if (detail::is_symbolic_link(link)) {
      DIACHRON_CHECK(::unlink(link.c_str()) == 0, "write_adjusted_colmap: cannot replace the link '" << link << "'");
    }
    DIACHRON_CHECK(::symlink(targets[i].c_str(), link.c_str()) == 0,
                   "write_adjusted_colmap: cannot create the link '" << link << "' to '" << targets[i]
                                                                      << "' (errno " << errno << ")");
  }
  return report;
}

}  // namespace diachron
