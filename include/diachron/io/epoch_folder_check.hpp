#pragma once
/// @file
/// check_epoch_folder(): an epoch folder's parts checked against each other before anything trusts
/// them. A user's SfM model, DSM and images come from different tools and runs; when they disagree
/// (a model aligned to the DSM's frame by a poor `model_aligner`, a DSM of another area, scans
/// rescanned at another size) every later stage still "works" and hands out confident, wrong
/// results. Three checks, each with its figures:
/// - the model's 3D points against the DSM (terrain/model_dsm_agreement.hpp): heights within a
///   tolerance of the DSM's cell and the images' GSD; a gross disagreement refuses, a mild one warns;
/// - each image's footprint on the DSM: the share of a grid of its pixels whose rays meet the DSM;
///   images partly or wholly beyond it are a note (they find fewer or no pairs; a block's edge
///   images often reach beyond its DSM), an epoch whose images all miss it refuses;
/// - each image file: readable, with the size its camera says (its header only, no pixels read).
/// Orthophoto epochs have no model nor camera: only their tiles' footprints are trivially on their
/// DSM, so nothing is checked but the file. Needs GDAL (diachron::io).

#include <algorithm>
#include <cstddef>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gdal_priv.h>

#include <diachron/core/error.hpp>
#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/terrain/gsd.hpp>
#include <diachron/terrain/model_dsm_agreement.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>

namespace diachron {

/// Options of check_epoch_folder().
struct EpochFolderCheckOptions {
  /// The model-against-DSM check's tolerances and verdict thresholds.
  ModelDsmAgreementOptions agreement;
  /// Rays per image side of the footprint grid (grid x grid pixels, corners included). >= 2.
  int footprint_grid = 5;
  /// An image whose footprint share on the DSM is below this is noted. In [0, 1].
  double min_footprint_share = 0.5;
  /// Open every image file's header (GDAL) to check it is there and of its camera's size.
  bool check_image_files = true;

  void check() const {
    agreement.check();
    DIACHRON_CHECK(footprint_grid >= 2, "EpochFolderCheckOptions::footprint_grid must be >= 2, got " << footprint_grid);
    DIACHRON_CHECK(min_footprint_share >= 0.0 && min_footprint_share <= 1.0,
                   "EpochFolderCheckOptions::min_footprint_share must be in [0, 1], got " << min_footprint_share);
  }
};

/// How serious one finding is: a note is reported and changes nothing (images partly beyond the
/// DSM, as edge images of a block are); a warning lets the run go on but lowers the trust of its
/// results; a refusal stops it before any matching.
enum class EpochCheckSeverity { note, warning, refusal };

inline const char* to_string(EpochCheckSeverity s) {
  return s == EpochCheckSeverity::refusal ? "refusal" : s == EpochCheckSeverity::warning ? "warning" : "note";
}

/// One finding: what is wrong, with its figures, and what the user can do about it.
struct EpochCheckIssue {
  EpochCheckSeverity severity = EpochCheckSeverity::refusal;
  std::string check;   ///< "model_dsm", "footprint" or "image_file"
  std::string what;    ///< the figures, in words
  std::string remedy;  ///< what to do
};

/// What check_epoch_folder() found. Default: not checked (`checked` false).
struct EpochFolderCheck {
  bool checked = false;
  /// The model's points against the DSM (verdict unknown for an orthophoto epoch or a model
  /// without points).
  ModelDsmAgreement agreement;
  /// The images' median GSD at the DSM's mean height (DSM units per px; 0 when unknown): the
  /// agreement's tolerance scales with it.
  double gsd = 0.0;
  /// Per image, the share of its footprint grid whose rays meet the DSM, in [0, 1].
  std::vector<double> footprint_share;
  /// Image files that could not be opened, and those of another size than their camera.
  std::size_t unreadable_images = 0;
  std::size_t wrong_size_images = 0;
  std::vector<EpochCheckIssue> issues;

  /// True when a finding must stop the run.
  bool refused() const {
    return !checked || std::any_of(issues.begin(), issues.end(),
                                   [](const EpochCheckIssue& i) { return i.severity == EpochCheckSeverity::refusal; });
  }
};

/// Width and height of the raster image at `path` from its header (GDAL opens it without reading
/// pixels), or nullopt when GDAL cannot open it.
inline std::optional<std::pair<int, int>> image_file_size(const std::string& path) {
  detail::gdal_register_once();
  detail::QuietGdalErrors quiet;
  GDALDataset* data = static_cast<GDALDataset*>(
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  if (!data) return std::nullopt;
  const std::pair<int, int> size(data->GetRasterXSize(), data->GetRasterYSize());
  GDALClose(data);
  return size;
}

/// Checks `epoch`'s model, DSM and image files against each other (see the file comment). Never
/// throws for what it finds: the findings are in the result. Throws diachron::Error for bad options.
inline EpochFolderCheck check_epoch_folder(const EpochFolder& epoch, const EpochFolderCheckOptions& options = {}) {
  options.check();
  EpochFolderCheck out;
  out.checked = true;
  const std::string where = "epoch '" + epoch.directory + "'";
  // Image files first: the cheapest and the one that would otherwise fail hours later, when the
  // image's first pair comes.
  if (options.check_image_files) {
    std::vector<std::string> unreadable, wrong;
    const std::vector<std::string> files =
        epoch.is_ortho() ? std::vector<std::string>{epoch.ortho_path} : std::vector<std::string>{};
    for (const std::string& path : files)
      if (!image_file_size(path)) unreadable.push_back(path);
    if (!epoch.is_ortho())
      for (const EpochImage& image : epoch.images) {
        const std::optional<std::pair<int, int>> size = image_file_size(image.path);
        if (!size) {
          unreadable.push_back(image.path);
          continue;
        }
        if (size->first != image.width() || size->second != image.height()) {
          std::ostringstream m;
          m << image.path << " is " << size->first << " x " << size->second << " px, its camera "
            << image.width() << " x " << image.height();
          wrong.push_back(m.str());
        }
      }
    out.unreadable_images = unreadable.size();
    out.wrong_size_images = wrong.size();
    if (!unreadable.empty()) {
      std::ostringstream m;
      m << where << ": " << unreadable.size() << " image file" << (unreadable.size() == 1 ? "" : "s")
        << " cannot be read (first: " << unreadable.front() << ")";
      out.issues.push_back({EpochCheckSeverity::refusal, "image_file", m.str(),
                            "check that every image the model names is in the epoch folder, readable by GDAL"});
    }
    if (!wrong.empty()) {
      std::ostringstream m;
      m << where << ": " << wrong.size() << " image" << (wrong.size() == 1 ? " is" : "s are")
        << " not of their camera's size (first: " << wrong.front() << ")";
      out.issues.push_back({EpochCheckSeverity::refusal, "image_file", m.str(),
                            "give the images the SfM model was made from (a rescan or a resampled copy needs "
                            "its own model)"});
    }
  }
  if (epoch.is_ortho() || epoch.images.empty() || epoch.dsm.empty()) return out;

  // Footprints: a grid of each image's pixels, their rays met with the DSM. And the images' GSD at
  // the DSM's mean height for the model's tolerance (a model offset vertically would bias a GSD
  // taken on its own points).
  const int n = options.footprint_grid;
  std::size_t missing = 0, weak = 0;
  std::string first_weak;
  double weakest = 1.0;
  std::vector<double> gsd;
  const double ground = epoch.dsm.statistics().mean;
  for (const EpochImage& image : epoch.images) {
    const EpochFrame frame = image.epoch_frame();
    const Eigen::Vector2d centre((image.width() - 1) / 2.0, (image.height() - 1) / 2.0);
    if (const std::optional<double> g = gsd_at_height(frame, ground, centre); g && std::isfinite(*g)) gsd.push_back(*g);
    std::size_t hit = 0;
    for (int gy = 0; gy < n; ++gy)
      for (int gx = 0; gx < n; ++gx) {
        const Eigen::Vector2d px((image.width() - 1) * gx / double(n - 1), (image.height() - 1) * gy / double(n - 1));
        const std::optional<Ray3> ray = frame.ray(px);
        if (ray && ray_dsm_point(epoch.dsm, *ray)) ++hit;
      }
    const double share = static_cast<double>(hit) / static_cast<double>(n * n);
    out.footprint_share.push_back(share);
    weakest = std::min(weakest, share);
    if (share == 0.0) ++missing;
    if (share < options.min_footprint_share) {
      ++weak;
      if (first_weak.empty()) first_weak = image.name;
    }
  }
  if (missing == epoch.images.size()) {
    std::ostringstream m;
    m << where << ": none of its " << epoch.images.size() << " images sees its DSM (no ray of a " << n << " x " << n
      << " grid per image meets it)";
    out.issues.push_back({EpochCheckSeverity::refusal, "footprint", m.str(),
                          "the model and dsm.tif are not of one place or frame: give the DSM made from this model, "
                          "or align the model to the DSM's frame"});
  } else if (weak > 0) {
    std::ostringstream m;
    m << where << ": " << weak << " of " << epoch.images.size() << " images see the DSM on less than "
      << options.min_footprint_share * 100.0 << " % of their footprint (least " << weakest * 100.0 << " %, first: "
      << first_weak << ")";
    out.issues.push_back({EpochCheckSeverity::note, "footprint", m.str(),
                          "extend the DSM over every image, or expect fewer pairs for those images"});
  }

  // The model's points against the DSM, the tolerance scaled by the images' median GSD.
  if (!gsd.empty()) {
    std::nth_element(gsd.begin(), gsd.begin() + static_cast<std::ptrdiff_t>(gsd.size() / 2), gsd.end());
    out.gsd = gsd[gsd.size() / 2];
  }
  std::vector<Eigen::Vector3d> points;
  points.reserve(epoch.model.points3d.size());
  for (const auto& [id, point] : epoch.model.points3d)
    if (point.xyz.allFinite()) points.push_back(point.xyz);
  out.agreement = model_dsm_agreement(points, epoch.dsm, out.gsd, options.agreement);
  const ModelDsmAgreement& a = out.agreement;
  std::ostringstream remedy;
  remedy.precision(3);
  remedy << "bring the model into the DSM's frame (or give the DSM made from this model)";
  if (a.best_offset.allFinite() && a.best_share > a.share_within)
    remedy << "; moving the model by (" << a.best_offset.x() << ", " << a.best_offset.y() << ", " << a.best_offset.z()
           << ") DSM units puts " << a.best_share * 100.0 << " % of its points on the DSM"
           << (a.best_on_edge ? " (the search's edge: the offset may be larger)" : "");
  else if (std::isfinite(a.median_dz))
    remedy << "; its points lie a median " << a.median_dz << " DSM units above the DSM";
  if (a.verdict == ModelDsmVerdict::gross)
    out.issues.push_back({EpochCheckSeverity::refusal, "model_dsm", where + ": its model and its DSM disagree: " + a.message,
                          remedy.str()});
  else if (a.verdict == ModelDsmVerdict::mild)
    out.issues.push_back({EpochCheckSeverity::warning, "model_dsm", where + ": its model and its DSM disagree mildly: " +
                                                                        a.message,
                          remedy.str() + "; results hold with less margin"});
  else if (a.verdict == ModelDsmVerdict::unknown && epoch.model.points3d.empty())
    out.issues.push_back({EpochCheckSeverity::warning, "model_dsm", where + ": its model has no 3D points: " + a.message,
                          "export the model with its points (points3D) so that it can be checked against the DSM"});
  return out;
}

}  // namespace diachron
