#pragma once
/// @file
/// The adjusted orientation on disk (docs/adjusted-export.md): `DIR/adjusted/cameras.json` with
/// the exact Fraser + affine cameras (io/cameras_json.hpp) and, per epoch, a COLMAP text model
/// `DIR/adjusted/<epoch>/` whose cameras are the nearest COLMAP model (OPENCV when it holds the
/// camera exactly, else FULL_OPENCV, fitted when the shear B2 is not zero), with the measured
/// conversion error of each. Never writes into an input model. Standard library and Eigen only;
/// folders through POSIX calls (GCC's <filesystem> inlines cannot link when every inline function
/// is emitted, as the headers-alone check does).

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <sys/stat.h>
#include <sys/types.h>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/conversion.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/core/error.hpp>
#include <diachron/io/cameras_json.hpp>
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

}  // namespace diachron
