// match_epochs: inter-epoch tie points between two or more epochs of aerial images (paper section
// 3.2, Algorithm 1): rough co-registration of every epoch with the reference from the DSMs,
// overlapping image pairs of every two epochs, precise matching per pair, and optionally one
// combined adjustment of all epochs.
//
//   match_epochs EPOCH_DIR EPOCH_DIR [EPOCH_DIR ...] --out DIR [options]
//
// Each epoch folder holds a COLMAP model (text: cameras.txt, images.txt, points3D.txt; or COLMAP's
// binary .bin files), images/ and dsm.tif in the model's frame (what make_scene writes), and
// optionally masks/<image name>.png (COLMAP's masks) or images/<stem>_Masq.tif (MicMac's): 0 where
// no match may be, e.g. the scan's frame and fiducial marks; or it is an orthophoto epoch: ortho.tif
// (north-up geotransform) and dsm.tif in the same CRS, cut into tiles (io/epoch_folder.hpp). An
// epoch is named by its folder ("/data/1954" -> 1954). The reference is the last epoch given, or
// --reference NAME; every other epoch is free, taken in name order.
//
// Before any work, every option is parsed strictly (CLI11) and each epoch's model, DSM and image
// files are checked against each other (io/epoch_folder_check.hpp): a model that disagrees grossly
// with its DSM, or images that are unreadable or not of their camera's size, refuse the run (exit
// 1, with the figures and a remedy); a mild disagreement is a warning that lowers the trust.
// Each free epoch is co-registered with the reference from the DSMs (--rough auto), or through
// another free epoch already placed when that fails, or by a given transform (--rough
// identity|FILE, per epoch with NAME=). Every two epochs' overlapping image pairs are matched.
//
// The outputs are written into a fresh folder inside --out and moved into place when the run ends
// (exit 0 or 2): a rerun never leaves an earlier run's tie points beside its report; a run stopped
// by an error leaves --out as it was. --out must be new or empty, or --overwrite replaces an earlier
// run's outputs. Writes
//   DIR/rough_helmert_<epoch>.json  per free epoch, its rough co-registration, X_ref = scale R X + t
//   DIR/Homol/              final inter-epoch tie points of every pair, MicMac Homol (both directions;
//                           names as in images.txt, unless a name has a folder or two epochs use it: then
//                           every name is prefixed e<k>_, and DIR/homol_names.txt lists them)
//   DIR/report.json         the run (command line, version, threads, time per stage), the trust of the
//                           results and why, warnings, the input checks, per epoch and epoch pair
//   DIR/pairs/<a>__<b>.jpg  each pair: the secondary warped onto the master, the matches as dots
//   DIR/dod/<epoch>_rough.tif, .png  each free epoch's DoD with the reference after the rough
//                           co-registration (eval/dod_map.hpp), report.json's "dod"
// and with --adjust (the combined adjustment, pipeline/combined_epochs.hpp, in the reference's frame):
//   DIR/adjusted/cameras.json, DIR/adjusted/<epoch>/  the adjusted orientation (io/adjusted_export.hpp)
//   DIR/adjusted/colmap/    all epochs in one COLMAP model with the tie points as points3D, images/
//                           links (--colmap-format text|binary)
//   DIR/adjusted/micmac/Ori-diachron/  the same as MicMac orientations (io/micmac_orientation.hpp)
//   DIR/adjusted/residuals/<image>.png  reprojection residuals of the free epochs' tie points
//   DIR/dod/<epoch>.tif, .png, <epoch>_helmert.json  each free epoch's DoD after the adjustment
//   the "adjustment" section of report.json, and its grade (adjustment/adjustment_grade.hpp) in "trust"
// Progress on stderr (lines when it is not a terminal). Exit status: 0 success, 2 no co-registration,
// no overlap, no match or no adjustment (reason printed), 1 bad input. The input folders are never
// written to.

#include <algorithm>
#include <charconv>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <thread>
#include <type_traits>
#include <cstdlib>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include "program_support.hpp"

#include <diachron/core/progress.hpp>
#include <diachron/eval/dod_map.hpp>
#include <diachron/io/control_points.hpp>
#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/epoch_folder_check.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/io/helmert_json.hpp>
#include <diachron/io/homol.hpp>
#include <diachron/pipeline/epoch_placement.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/pipeline/precise_matching.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/draw_dod.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/vision/draw_pair_overlay.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>
#include <diachron/vision/xfeat.hpp>

#include <opencv2/imgproc.hpp>
#if DIACHRON_MATCH_EPOCHS_ADJUST
#include <diachron/adjustment/adjustment_grade.hpp>
#include <diachron/adjustment/triangulation.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/distortion_precision.hpp>
#include <diachron/eval/dsm_reintersection.hpp>
#include <diachron/io/adjusted_export.hpp>
#include <diachron/io/micmac_orientation.hpp>
#include <diachron/pipeline/combined_epochs.hpp>
#include <diachron/pipeline/orthophoto_reference.hpp>
#include <diachron/vision/draw_residuals.hpp>
#include <glog/logging.h>
#endif

namespace {

using namespace diachron;
using diachron::programs::Progress;
using diachron::programs::strict_number;

const char* kDescription =
    "match_epochs: inter-epoch tie points between two or more epochs of aerial images (rough\n"
    "co-registration from the DSMs, overlapping pairs, precise matching), and with --adjust one\n"
    "combined adjustment of all epochs. Each EPOCH_DIR, named by its folder: a COLMAP model (text\n"
    "cameras.txt images.txt points3D.txt, or COLMAP's .bin) or a MicMac project (Ori-NAME/, Homol/),\n"
    "images/, dsm.tif in the model's frame,\n"
    "optionally masks/<image name>.png or images/<stem>_Masq.tif (0 where no match may be); or an\n"
    "orthophoto epoch: ortho.tif and dsm.tif in one CRS. The last epoch given is the reference\n"
    "(--reference); the others are taken in name order. Each epoch's model, DSM and images are\n"
    "checked against each other before any work. Outputs go to --out (docs/precise-matching.md).\n"
    "Exit status: 0 success (report.json's \"trust\" grades it), 2 no answer (no co-registration,\n"
    "overlap, match or adjustment: the reason is printed), 1 bad input or options.\n";


std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') q += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    q += c;
  }
  return q + "\"";
}

std::string json_number_or_null(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream o;
  o.precision(10);
  o << v;
  return o.str();
}

// A file name for a pair picture: the image names with '/' made safe.
std::string safe(std::string name) {
  for (char& c : name)
    if (c == '/' || c == '\\' || c == ' ') c = '_';
  return name;
}



// An epoch's name: its folder's name ("/data/1954/" -> "1954"), of the resolved path when the
// folder exists (so that "." and "../1954" are named too).
std::string folder_name(const std::string& given) {
  std::string dir = given;
  if (char* real = ::realpath(given.c_str(), nullptr)) {
    dir = real;
    std::free(real);
  }
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  const std::size_t slash = dir.find_last_of('/');
  return slash == std::string::npos ? dir : dir.substr(slash + 1);
}

// The absolute, resolved path of an existing file or folder (as given when it cannot be resolved).
std::string absolute_path(const std::string& path) {
  std::string out = path;
  if (char* real = ::realpath(path.c_str(), nullptr)) {
    out = real;
    std::free(real);
  }
  return out;
}

// Whether two paths are one existing file-system object.
bool same_folder(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

// One input epoch and what the run found for it.
struct Epoch {
  std::string dir;   // as given
  std::string name;  // its folder's name: rough_helmert_<name>.json, adjusted/<name>/
  EpochFolder folder;
  std::vector<EpochFrame> frames;
  std::vector<std::string> homol;  // each image's name in Homol/
  std::string rough_mode = "auto";  // --rough: auto, identity or a helmert.json
  std::optional<Helmert3> given;    // the transform --rough gave
  RoughCoregistrationReport rough;  // its co-registration (none for the reference)
  std::string via;                  // the free epoch a chained co-registration went through
  bool placed = false;              // reference_from_epoch known
  Helmert3 reference_from_epoch = Helmert3::identity();
};

// Two epochs' overlapping image pairs and their matches; the master images are `master`'s.
struct EpochPair {
  std::size_t master = 0, secondary = 0;  // indices into the epochs
  Helmert3 secondary_from_master = Helmert3::identity();
  OverlappingPairsResult overlap;
  PreciseMatchingReport precise;
};

// The names of the images in Homol/. MicMac names tie-point files after the images, without
// folders, and one name must mean one image. The names of images.txt are kept when they allow that;
// when a name has a folder ("1954/0001.tif", as COLMAP allows) or two epochs use the same name
// (numbered from 0001 each), every name becomes "e<k>_" (k the epoch's place, from 1) + the name
// with '/' turned into '_', and DIR/homol_names.txt says which is which. Decided before any work,
// so that a clash stops the run at once instead of after the matching.
bool set_homol_names(std::vector<Epoch>& epochs) {
  std::set<std::string> seen;
  bool plain = true;
  for (const Epoch& e : epochs)
    for (const EpochImage& image : e.folder.images)
      plain = plain && image.name.find('/') == std::string::npos && seen.insert(image.name).second;
  seen.clear();
  for (std::size_t k = 0; k < epochs.size(); ++k) {
    Epoch& e = epochs[k];
    e.homol.clear();
    for (const EpochImage& image : e.folder.images) {
      std::string name = image.name;
      if (!plain) {
        for (char& c : name)
          if (c == '/') c = '_';
        name = "e" + std::to_string(k + 1) + "_" + name;
      }
      DIACHRON_CHECK(seen.insert(name).second, "two images of epoch " << e.name << " would share the Homol name '"
                                                                       << name << "' (one is '" << image.name
                                                                       << "'): rename one of them");
      e.homol.push_back(name);
    }
  }
  return !plain;
}

void write_homol_names(const std::string& path, const std::vector<Epoch>& epochs) {
  std::ofstream out(path);
  DIACHRON_CHECK(out.good(), "cannot write " << path);
  out << "# epoch (place in report.json's epochs, from 1), image name in images.txt, its name in Homol/\n";
  for (std::size_t k = 0; k < epochs.size(); ++k)
    for (std::size_t i = 0; i < epochs[k].folder.images.size(); ++i)
      out << k + 1 << ' ' << epochs[k].folder.images[i].name << ' ' << epochs[k].homol[i] << '\n';
  DIACHRON_CHECK(out.good(), "cannot write " << path);
}

// The pictures are drawn from copies of the images at most kPictureSidePx on their longer side
// (the pictures themselves are at most 1600 px): full-resolution archive scans (12000 px and more)
// would keep gigabytes of images in this cache. Images up to that size are kept as they are.
constexpr int kPictureSidePx = 2000;

struct Picture {
  Raster<std::uint8_t> image;
  Vec2 scale = Vec2::Ones();  // picture px per image px, per axis
  /// An image pixel (centre convention) in the picture.
  Vec2 at(const Vec2& p) const { return (p + Vec2::Constant(0.5)).cwiseProduct(scale) - Vec2::Constant(0.5); }
};

// The images of an epoch for the pictures, each read (and shrunk) once however many pairs show it.
class PictureImages {
 public:
  explicit PictureImages(const EpochFolder& epoch) : epoch_(epoch), images_(epoch.images.size()) {}
  const Picture& operator[](std::size_t i) {
    if (!images_.at(i)) {
      Picture p;
      p.image = epoch_.load_image(i);
      const int w = p.image.width(), h = p.image.height();
      const double s = std::min(1.0, static_cast<double>(kPictureSidePx) / std::max(w, h));
      if (s < 1.0) {
        const int pw = std::max(1, static_cast<int>(std::lround(w * s))), ph = std::max(1, static_cast<int>(std::lround(h * s)));
        cv::Mat small;
        cv::resize(as_mat(p.image), small, cv::Size(pw, ph), 0.0, 0.0, cv::INTER_AREA);
        p.image = to_raster<std::uint8_t>(small);
        p.scale = Vec2(static_cast<double>(pw) / w, static_cast<double>(ph) / h);
      }
      images_[i] = std::move(p);
    }
    return *images_[i];
  }

 private:
  const EpochFolder& epoch_;
  std::vector<std::optional<Picture>> images_;
};


// A pair's picture (vision/draw_pair_overlay.hpp): the secondary image warped onto the master's
// through the homography that best maps its final matches (least squares over all of them, in the
// pictures' pixels; over relief that is the plane the matches share, good enough to see whether
// the two images line up), the matches as dots coloured by their correlation score or, for the
// descriptor methods, by their distance to that homography (relief parallax included). Fewer than
// 4 matches draw no picture: they hold no homography.
void write_pair_picture(const std::string& path, const Picture& pa, const Picture& pb, const PointMatches& matches,
                        bool scores, const std::string& title) {
  std::vector<PointPair2> pairs;
  for (const PointMatch& m : matches) pairs.push_back({pb.at(m.b), pa.at(m.a)});
  const std::optional<Homography2> h = estimate_homography(pairs);
  if (!h) return;
  std::vector<Vec2> points;
  std::vector<double> values;
  for (std::size_t k = 0; k < matches.size(); ++k) {
    points.push_back(pairs[k].target);
    const std::optional<Vec2> mapped = (*h)(pairs[k].source);
    values.push_back(scores ? matches[k].score
                            : mapped ? (*mapped - pairs[k].target).norm() / pa.scale.x()
                                     : 1e9);  // off the scale: drawn as the worst
  }
  DrawPairOverlayOptions o;
  o.title = title;
  if (!scores) {
    o.values = PairOverlayValues::ResidualPx;
    o.value_low = 0.0;
    o.value_high = 10.0;
    o.value_name = "distance to the homography (master px)";
  } else {
    o.value_name = "correlation score";
  }
  write_pair_overlay_jpg(path, pa.image, pb.image, h->matrix, points, values, o);
}

#if DIACHRON_MATCH_EPOCHS_ADJUST
// "a,b" -> {"a", "b"}; "" -> none.
std::vector<std::string> comma_list(const std::string& list) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start < list.size()) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    out.push_back(list.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

// An intrinsic by the name report.json gives it; `option` names the option in the error.
Intrinsic intrinsic_named(const std::string& name, const char* option) {
  int k = 0;
  while (k < 8 && name != intrinsic_name(static_cast<Intrinsic>(k))) ++k;
  DIACHRON_CHECK(k < 8, option << ": unknown intrinsic '" << name << "' (f, cx, cy, K1, K2, K3, P1, P2)");
  return static_cast<Intrinsic>(k);
}

// --hold "K3,P1,P2" -> the intrinsics.
std::vector<Intrinsic> parse_intrinsics(const std::string& list) {
  std::vector<Intrinsic> out;
  for (const std::string& name : comma_list(list)) out.push_back(intrinsic_named(name, "--hold"));
  return out;
}

// --prior "f=2,cx=1" -> the priors.
std::vector<IntrinsicPrior> parse_priors(const std::string& list) {
  std::vector<IntrinsicPrior> out;
  for (const std::string& item : comma_list(list)) {
    const std::size_t eq = item.find('=');
    DIACHRON_CHECK(eq != std::string::npos, "--prior: '" << item << "' is not NAME=SIGMA (e.g. f=2)");
    const std::string name = item.substr(0, eq), value = item.substr(eq + 1);
    const Intrinsic intrinsic = intrinsic_named(name, "--prior");
    double sigma = std::numeric_limits<double>::quiet_NaN();
    try {
      std::size_t used = 0;
      sigma = std::stod(value, &used);
      if (used != value.size()) sigma = std::numeric_limits<double>::quiet_NaN();  // "2px"
    } catch (const std::exception&) {  // not a number: the check below says so
    }
    DIACHRON_CHECK(std::isfinite(sigma) && sigma > 0.0,
                   "--prior: the sigma of " << name << " must be a number > 0, got '" << value << "'");
    out.push_back({intrinsic, sigma});
  }
  return out;
}

// The epoch as the combined adjustment takes it: the frames and the tracks of points3D.txt as
// intra-epoch tie points (pixels in diachron's convention). Images whose cameras hold the same
// values share one (CombinedEpoch::cameras empty), or all do with `one_camera`.
CombinedEpoch combined_epoch(const EpochFolder& e, bool one_camera) {
  CombinedEpoch out;
  std::map<std::uint32_t, int> index;
  for (std::size_t i = 0; i < e.images.size(); ++i) {
    out.frames.push_back(e.images[i].frame);
    index[e.images[i].id] = static_cast<int>(i);
  }
  if (one_camera) out.cameras.assign(out.frames.size(), 0);
  for (const auto& [id, point] : e.model.points3d) {
    std::vector<ImagePixel> tie;
    for (const ColmapTrackElement& t : point.track) {
      const ColmapImage& image = e.model.images.at(t.image_id);
      tie.push_back({index.at(t.image_id), diachron_pixel_from_colmap(image.points2d.at(t.point2d_index).xy)});
    }
    if (tie.size() >= 2) out.tie_points.push_back(std::move(tie));
  }
  return out;
}

std::string json_rms(const ResidualRms& r) {
  std::ostringstream o;
  o.precision(6);
  o << "{\"rms_px\": ";
  if (std::isfinite(r.rms_px)) o << r.rms_px;
  else o << "null";
  o << ", \"observations\": " << r.observations << "}";
  return o.str();
}



// `images` (cameras.json's, named as images.txt names them) under their Homol names: one name per
// image over all epochs, as MicMac wants them.
std::vector<CamerasJsonImage> images_homol_named(std::vector<CamerasJsonImage> images, const std::vector<Epoch>& epochs) {
  std::size_t k = 0;
  for (const Epoch& e : epochs)
    for (std::size_t i = 0; i < e.folder.images.size() && !e.folder.is_ortho(); ++i, ++k) images.at(k).name = e.homol[i];
  return images;
}

struct MicmacExport {
  MicmacWriteReport written;
  double max_conversion_error_px = 0.0;
};

// DIR/adjusted/micmac/: Ori-diachron/ (every image of the photo epochs, AltiSol the reference DSM's
// mean height), a link per image named as in Homol/, and Homol -> ../../Homol.
MicmacExport write_micmac_export(const std::string& project, const std::vector<Epoch>& epochs,
                                 const std::vector<CamerasJsonImage>& images, double ground) {
  make_folders(project, "adjusted/micmac");
  MicmacWriteOptions options;
  options.ground_altitude = ground;
  MicmacExport out;
  out.written = write_micmac_ori_folder(project, "diachron", images, options);
  for (const MicmacWrittenCalibration& c : out.written.calibrations)
    out.max_conversion_error_px = std::max(out.max_conversion_error_px, c.conversion.exact ? 0.0 : c.conversion.max_error_px);
  for (const Epoch& e : epochs) {
    if (e.folder.is_ortho()) continue;
    for (std::size_t i = 0; i < e.folder.images.size(); ++i)
      std::filesystem::create_symlink(std::filesystem::absolute(e.folder.images[i].path), project + "/" + e.homol[i]);
  }
  std::filesystem::create_directory_symlink("../../Homol", project + "/Homol");
  return out;
}

// The control points of a control-point file with their image names resolved in the epochs:
// each name must be an image of exactly one epoch (orthophoto tiles are no images here).
// `what` names them in messages ("control point", "check point").
std::vector<EpochsControlPoint> epochs_control_points(const std::vector<ControlPointRecord>& records,
                                                      const std::vector<Epoch>& epochs, const char* what) {
  constexpr std::size_t kShared = std::numeric_limits<std::size_t>::max();
  std::map<std::string, std::pair<std::size_t, int>> where;  // name -> (epoch, index)
  for (std::size_t e = 0; e < epochs.size(); ++e) {
    if (epochs[e].folder.is_ortho()) continue;
    for (std::size_t i = 0; i < epochs[e].folder.images.size(); ++i) {
      const auto [it, inserted] = where.emplace(epochs[e].folder.images[i].name, std::make_pair(e, static_cast<int>(i)));
      if (!inserted && it->second.first != e) it->second.first = kShared;
    }
  }
  std::vector<EpochsControlPoint> out;
  for (const ControlPointRecord& r : records) {
    EpochsControlPoint g{r.position, r.sigma, std::vector<std::vector<ImagePixel>>(epochs.size())};
    for (const auto& [image, pixel] : r.observations) {
      const auto it = where.find(image);
      DIACHRON_CHECK(it != where.end(), what << " " << r.name << ": no image '" << image << "' in any epoch");
      DIACHRON_CHECK(it->second.first != kShared,
                     what << " " << r.name << ": image '" << image << "' is in two epochs; rename one of them");
      g.observations[it->second.first].push_back({it->second.second, pixel});
    }
    out.push_back(std::move(g));
  }
  return out;
}

// Per axis mu, sigma, |mu| (mean of |e|) and RMS of e = triangulated - given, reference units.
void check_point_json(std::ostream& o, const CheckPointReport& c) {
  o << "{\"used\": " << c.num_used << ", \"failed\": " << c.num_failed << ", \"rms_3d\": "
    << json_number_or_null(c.rms_3d_m);
  const char* axis[3] = {"x", "y", "z"};
  for (std::size_t k = 0; k < 3; ++k) {
    const ErrorStatistics& e = c.axes_m[k];
    o << ", \"" << axis[k] << "\": {\"mean\": " << json_number_or_null(e.mean) << ", \"sigma\": "
      << json_number_or_null(e.sigma) << ", \"mean_abs\": " << json_number_or_null(e.mean_abs)
      << ", \"rms\": " << json_number_or_null(e.rms) << "}";
  }
  o << "}";
}

// A free epoch's check points after the rough co-registration alone and after the adjustment.
struct EpochCheckPoints {
  std::size_t epoch = 0;
  CheckPointReport rough, adjusted;
};

// The "adjustment" section of report.json.
// `image_epoch`, `names`: per image of the adjustment (CombinedEpochsResult::image_camera's
// order), its epoch and its name.
std::string adjustment_json(const CombinedEpochsResult& a, const std::vector<Epoch>& epochs,
                            const std::vector<std::size_t>& image_epoch, const std::vector<std::string>& names,
                            const AdjustedExportReport* exported, AffineScope affine_scope,
                            const std::vector<ControlPointRecord>& control, const std::vector<EpochCheckPoints>& checked) {
  const BundleReport& r = a.report;
  std::ostringstream o;
  o << "  \"adjustment\": {\"success\": " << (r.success ? "true" : "false") << ", \"message\": " << quoted(r.message)
    << ", \"affine_scope\": " << quoted(affine_scope == AffineScope::per_camera ? "per_camera" : "per_image")
    << ",\n    \"tracks\": {\"input\": " << r.tracks_input << ", \"used\": " << r.tracks_used
    << ", \"inter_epoch\": " << r.inter_epoch_tracks << ", \"rejected\": " << r.tracks_rejected
    << ", \"dropped_conflicting\": " << a.tracks.dropped_conflicting << "}, \"observations\": {\"used\": "
    << r.observations_used << ", \"rejected\": " << r.observations_rejected << "},\n    \"epoch_links\": [";
  // Tracks shared by every two epochs (before the adjustment): what ties each epoch to the others.
  bool first_link = true;
  for (std::size_t x = 0; x < epochs.size(); ++x)
    for (std::size_t y = x + 1; y < epochs.size(); ++y) {
      const auto n = static_cast<Eigen::Index>(epochs.size());
      const std::size_t tracks = a.epoch_links.rows() == n ? a.epoch_links(static_cast<Eigen::Index>(x), static_cast<Eigen::Index>(y)) : 0;
      o << (first_link ? "" : ", ") << "{\"epochs\": [" << quoted(epochs[x].name) << ", " << quoted(epochs[y].name)
        << "], \"tracks\": " << tracks << "}";
      first_link = false;
    }
  o << "],\n    \"before\": {\"all\": " << json_rms(r.before.all) << ", \"intra_epoch\": " << json_rms(r.before.intra_epoch)
    << ", \"inter_epoch\": " << json_rms(r.before.inter_epoch) << "},\n    \"after\": {\"all\": "
    << json_rms(r.after.all) << ", \"intra_epoch\": " << json_rms(r.after.intra_epoch)
    << ", \"inter_epoch\": " << json_rms(r.after.inter_epoch) << "},\n    \"sigma0\": " << json_number_or_null(r.sigma0)
    << ", \"covariance\": " << quoted(r.covariance_available ? "available" : r.covariance_message)
    << ",\n    \"cameras\": [";
  for (std::size_t c = 0; c < r.cameras.size(); ++c) {
    // The camera's first image, in the adjustment's order.
    const auto at = std::find(a.image_camera.begin(), a.image_camera.end(), r.cameras[c].camera);
    const auto first = static_cast<std::size_t>(at - a.image_camera.begin());
    const std::size_t epoch = first < image_epoch.size() ? image_epoch[first] : 0;
    o << (c ? ",\n      " : "\n      ") << "{\"camera\": " << r.cameras[c].camera << ", \"free\": "
      << (r.cameras[c].free ? "true" : "false") << ", \"values\": {";
    for (std::size_t k = 0; k < r.cameras[c].values.size(); ++k) {
      const ParameterChange& p = r.cameras[c].values[k];
      o << (k ? ", " : "") << quoted(p.name) << ": {\"before\": " << json_number_or_null(p.before)
        << ", \"after\": " << json_number_or_null(p.after) << ", \"sigma\": " << json_number_or_null(p.sigma) << "}";
    }
    o << "}, \"held\": [";
    for (std::size_t k = 0; k < r.cameras[c].held.size(); ++k) o << (k ? ", " : "") << quoted(r.cameras[c].held[k]);
    o << "], \"priors\": {";
    for (std::size_t k = 0; k < r.cameras[c].priors.size(); ++k)
      o << (k ? ", " : "") << quoted(r.cameras[c].priors[k]) << ": " << json_number_or_null(r.cameras[c].prior_sigmas[k]);
    o << "}, \"epoch\": " << quoted(epochs[epoch].name) << ", \"images\": [";
    for (std::size_t i = 0, k = 0; i < a.image_camera.size(); ++i)
      if (a.image_camera[i] == r.cameras[c].camera) o << (k++ ? ", " : "") << quoted(names[i]);
    o << "], \"distortion_sigma\": ";
    // The covariance carried to the distortion over the image (eval/distortion_precision.hpp): what
    // the block determines, without the truth.
    const Frame<FraserAffine>* frame =
        first < image_epoch.size() ? &a.epochs[epoch][first - a.first_image[epoch]] : nullptr;
    const DistortionPrecision precision = !r.cameras[c].covariance.empty() && frame
                                              ? distortion_precision(frame->camera(), r.cameras[c].covariance)
                                              : DistortionPrecision{};
    if (precision.valid)
      o << "{\"worst_px\": " << json_number_or_null(precision.max_sigma_px) << ", \"rms_px\": "
        << json_number_or_null(precision.rms_sigma_px) << ", \"worst_pixel\": [" << precision.worst_pixel.x() << ", "
        << precision.worst_pixel.y() << "]}";
    else
      o << "null";
    o << "}";
  }
  o << "],\n    \"solves\": [";
  for (std::size_t k = 0; k < r.solves.size(); ++k)
    o << (k ? ", " : "") << "{\"stage\": " << quoted(r.solves[k].stage) << ", \"termination\": "
      << quoted(r.solves[k].termination) << ", \"iterations\": " << r.solves[k].iterations
      << ", \"seconds\": " << r.solves[k].seconds << "}";
  // The control points: used or not, and their adjusted point minus their given position.
  o << "],\n    \"control_points\": [";
  for (std::size_t k = 0; k < control.size() && k < a.control_points.size(); ++k) {
    const ControlPointOutcome& g = a.control_points[k];
    o << (k ? ",\n      " : "\n      ") << "{\"name\": " << quoted(control[k].name)
      << ", \"observations\": " << control[k].observations.size() << ", \"used\": " << (g.used ? "true" : "false")
      << ", \"error\": ";
    if (g.used)
      o << "[" << json_number_or_null(g.error.x()) << ", " << json_number_or_null(g.error.y()) << ", "
        << json_number_or_null(g.error.z()) << "]";
    else
      o << "null";
    o << "}";
  }
  o << "],\n    \"check_points\": ";
  if (!checked.empty()) {
    o << "{";
    for (std::size_t k = 0; k < checked.size(); ++k) {
      o << (k ? ",\n      " : "\n      ") << quoted(epochs[checked[k].epoch].name) << ": {\"rough\": ";
      check_point_json(o, checked[k].rough);
      o << ",\n        \"adjusted\": ";
      check_point_json(o, checked[k].adjusted);
      o << "}";
    }
    o << "}";
  } else {
    o << "null";
  }
  o << ",\n    \"max_conversion_error_px\": "
    << (exported ? json_number_or_null(exported->max_conversion_error_px) : std::string("null"))
    << ", \"seconds\": " << r.seconds << "},\n";
  return o.str();
}

// One picture per image of a free epoch: its tie-point observations and their reprojection
// residuals after the adjustment (observed - projected), magnified; named after its Homol name.
void write_residual_pictures(const std::string& dir, const std::vector<Epoch>& epochs, std::size_t reference,
                             std::vector<PictureImages>& images, const CombinedEpochsResult& a) {
  make_folder(dir, "match_epochs");
  for (std::size_t e = 0; e < epochs.size(); ++e) {
    if (e == reference || epochs[e].folder.is_ortho()) continue;
    const std::size_t n = epochs[e].folder.images.size(), first = a.first_image[e];
    std::vector<std::vector<Vec2>> pixels(n), residuals(n);
    for (std::size_t t = 0; t < a.track_list.size(); ++t) {
      if (!a.track_used[t]) continue;
      for (const TrackObservation& o : a.track_list[t].observations) {
        if (o.image < 0 || static_cast<std::size_t>(o.image) < first || static_cast<std::size_t>(o.image) >= first + n)
          continue;
        const std::size_t i = static_cast<std::size_t>(o.image) - first;
        const std::optional<Vec2> p = a.epochs[e][i].project(a.points[t]);
        if (!p) continue;
        pixels[i].push_back(images[e][i].at(o.pixel));
        residuals[i].push_back(o.pixel - *p);
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      std::string name = safe(epochs[e].homol[i]);
      const std::size_t dot = name.find_last_of('.');
      if (dot != std::string::npos && dot > 0) name.erase(dot);  // "a.tif" -> "a.png"
      write_residuals_png(dir + "/" + name + ".png", images[e][i].image, pixels[i], residuals[i]);
    }
  }
}
#endif

// The ground filter's threshold (GSD of the secondary image) that `method` uses: correlation matches
// have their own, tighter one (PreciseCorrelationOptions); the descriptor methods the shared one.
template <class Options>
auto& ground_threshold_gsd(Options& options, const std::string& method) {
  return method == "correlation" ? options.correlation.ground_threshold_gsd : options.ground.threshold_gsd;
}


// The rough co-registration of one epoch into the reference, as report.json gives it.
void rough_json(std::ostream& out, const Epoch& e) {
  const RoughCoregistrationReport& rough = e.rough;
  const std::string source = e.rough_mode == "auto" ? "dsm" : e.rough_mode == "identity" ? "identity" : "file";
  out << "{\"source\": " << quoted(source) << ", \"via\": " << (e.via.empty() ? "null" : quoted(e.via))
      << ", \"success\": " << (rough.success ? "true" : "false")
      << ", \"message\": " << quoted(rough.message) << ", \"inliers_2d\": " << rough.inliers_2d.size()
      << ", \"inliers_3d\": " << rough.inliers_3d.size() << ", \"rms_3d\": " << rough.rms_3d
      << ", \"trust\": " << quoted(to_string(rough.trust))
      << ", \"correlation_fallback_ran\": " << (rough.correlation_ran ? "true" : "false")
      << ", \"correlation_fallback_used\": " << (rough.correlation_used ? "true" : "false")
      << ", \"seconds_correlation_fallback\": " << rough.seconds.correlation
      << ", \"correlation_fallback_by_tiles\": " << (rough.correlation_used && rough.correlation.by_tiles ? "true" : "false")
      << ", \"surface_refinement\": " << quoted(rough.surface.message)
      << ", \"surface_refinement_accepted\": " << (rough.surface.accepted ? "true" : "false")
      << ", \"correlation_fallback_confirmed_by_surface\": " << (rough.confirmed_by_surface ? "true" : "false")
      << ", \"surface_noise_ratio\": "
      << (rough.agreement.valid && std::isfinite(rough.agreement.noise_ratio) ? std::to_string(rough.agreement.noise_ratio)
                                                                                : std::string("null"))
      << ", \"seconds\": " << rough.seconds.total << "}";
}

// An epoch's input checks (io/epoch_folder_check.hpp) as report.json gives them.
void input_check_json(std::ostream& o, const EpochFolderCheck& c) {
  const ModelDsmAgreement& a = c.agreement;
  double least = 1.0;
  for (double share : c.footprint_share) least = std::min(least, share);
  o << "{\"model_dsm\": {\"verdict\": " << quoted(to_string(a.verdict)) << ", \"message\": " << quoted(a.message)
    << ", \"points\": " << a.points << ", \"on_dsm\": " << a.on_dsm << ", \"tolerance\": " << json_number_or_null(a.tolerance)
    << ", \"median_dz\": " << json_number_or_null(a.median_dz) << ", \"nmad_dz\": " << json_number_or_null(a.nmad_dz)
    << ", \"share_within\": " << json_number_or_null(a.share_within) << ", \"best_offset\": ["
    << json_number_or_null(a.best_offset.x()) << ", " << json_number_or_null(a.best_offset.y()) << ", "
    << json_number_or_null(a.best_offset.z()) << "], \"best_share\": " << json_number_or_null(a.best_share)
    << "}, \"gsd\": " << json_number_or_null(c.gsd) << ", \"least_footprint_share\": "
    << (c.footprint_share.empty() ? std::string("null") : json_number_or_null(least))
    << ", \"unreadable_images\": " << c.unreadable_images << ", \"wrong_size_images\": " << c.wrong_size_images
    << ", \"issues\": [";
  for (std::size_t k = 0; k < c.issues.size(); ++k)
    o << (k ? ", " : "") << "{\"severity\": " << quoted(to_string(c.issues[k].severity)) << ", \"check\": "
      << quoted(c.issues[k].check) << ", \"what\": " << quoted(c.issues[k].what) << ", \"remedy\": "
      << quoted(c.issues[k].remedy) << "}";
  o << "]}";
}

// report.json: per epoch (its co-registration), per epoch pair (overlapping pairs, matches).
// `sections`: further top-level members, each "  \"key\": ...,\n" (the adjustment's).
void write_report(const std::string& path, const std::vector<Epoch>& epochs, std::size_t reference,
                  const std::vector<EpochPair>& pairs, const PreciseMatchingOptions& options, const std::string& method,
                  const std::string& matcher, const std::string& sections = "") {
  std::ofstream out(path);
  DIACHRON_CHECK(out.good(), "cannot write " << path);
  out.precision(10);
  out << "{\n  \"method\": " << quoted(method) << ",\n  \"matcher\": " << quoted(matcher) << ",\n";
  out << sections;
  out << "  \"reference\": " << quoted(epochs[reference].name) << ",\n  \"epochs\": [";
  for (std::size_t k = 0; k < epochs.size(); ++k) {
    const Epoch& e = epochs[k];
    out << (k ? ",\n    " : "\n    ") << "{\"name\": " << quoted(e.name) << ", \"folder\": " << quoted(e.dir)
        << ", \"kind\": " << quoted(e.folder.is_ortho() ? "orthophoto" : "photos") << ", \"images\": "
        << e.folder.images.size() << ", \"masks\": " << e.folder.masks()
        << ", \"reference\": " << (k == reference ? "true" : "false") << ",\n     \"rough_coregistration\": ";
    if (k == reference) out << "null";
    else rough_json(out, e);
    out << "}";
  }
  out << "],\n";
  out << "  \"ground_filter\": {\"on\": " << (options.use_ground_filter ? "true" : "false")
      << ", \"threshold_gsd\": " << ground_threshold_gsd(options, method);
  if (method == "correlation") out << ", \"floor_master_gsd\": " << options.correlation.ground_floor_master_gsd;
  out << "},\n";
  if (method == "correlation")
    out << "  \"master_sharpen\": {\"amount\": " << options.correlation.master_sharpen.amount
        << ", \"sigma_px\": " << options.correlation.master_sharpen.sigma_px << "},\n";
  std::size_t tentative = 0, grounded = 0, final_matches = 0;
  double seconds = 0.0;
  for (const EpochPair& p : pairs) {
    tentative += p.precise.tentative;
    grounded += p.precise.grounded;
    final_matches += p.precise.final_matches;
    seconds += p.precise.seconds_total;
  }
  out << "  \"precise_matching\": {\"tentative\": " << tentative << ", \"after_ground_filter\": " << grounded
      << ", \"final\": " << final_matches << ", \"seconds\": " << seconds << "},\n";
  out << "  \"epoch_pairs\": [";
  for (std::size_t q = 0; q < pairs.size(); ++q) {
    const EpochPair& ep = pairs[q];
    const Epoch& a = epochs[ep.master];
    const Epoch& b = epochs[ep.secondary];
    const OverlappingPairsResult& overlap = ep.overlap;
    const PreciseMatchingReport& precise = ep.precise;
    out << (q ? ",\n    " : "\n    ") << "{\"master\": " << quoted(a.name) << ", \"secondary\": " << quoted(b.name)
        << ",\n     \"overlapping_pairs\": {\"candidates\": " << overlap.candidate_pairs
        << ", \"overlapping\": " << overlap.overlapping_pairs << ", \"kept\": " << overlap.pairs.size()
        << ", \"invalid_footprints\": [" << overlap.invalid_master_footprints << ", "
        << overlap.invalid_secondary_footprints << "], \"message\": " << quoted(overlap.message) << "},\n";
    out << "     \"precise_matching\": {\"success\": " << (precise.success ? "true" : "false")
        << ", \"message\": " << quoted(precise.message) << ", \"tentative\": " << precise.tentative
        << ", \"after_ground_filter\": " << precise.grounded << ", \"final\": " << precise.final_matches
        << ", \"seconds_features\": " << precise.seconds_features << ", \"seconds\": " << precise.seconds_total
        << ",\n      \"pairs\": [";
    for (std::size_t k = 0; k < precise.pairs.size() && k < overlap.pairs.size(); ++k) {
      const PrecisePairReport& p = precise.pairs[k];
      const ImagePairOverlap& o = overlap.pairs[k];
      out << (k ? ",\n        " : "\n        ") << "{\"master\": " << quoted(a.folder.images[p.master].name)
          << ", \"secondary\": " << quoted(b.folder.images[p.secondary].name)
          << ", \"overlap_fraction\": " << o.fraction_of_smaller << ", \"tentative\": " << p.tentative.size()
          << ", \"masked\": " << p.masked << ", \"after_ground_filter\": " << p.grounded.size()
          << ", \"final\": " << p.matches.size() << ", \"message\": " << quoted(p.message)
          << ", \"seconds\": {\"images\": " << p.seconds.images << ", \"tentative\": " << p.seconds.tentative
          << ", \"ground\": " << p.seconds.ground << ", \"ncc\": " << p.seconds.ncc << ", \"total\": " << p.seconds.total
          << "}}";
    }
    out << "]}}";
  }
  out << "]\n}\n";
  out.close();
  DIACHRON_CHECK(!out.fail(), "cannot write " << path);
}

// The DoD of a free epoch against the reference (eval/dod_map.hpp): its DSM moved into the
// reference's frame, differenced on the reference's grid, with statistics over every cell and
// over stable terrain: the cells within kStableCells reference DSM cells of a final match with the
// reference, ground that looked alike across the decades (the ground filter kept it).
constexpr double kStableCells = 4.0;

struct EpochDod {
  std::size_t epoch = 0;
  std::size_t stable_points = 0;  // matches with the reference placed on its DSM
  DodMapStatistics rough, adjusted;
  bool has_adjusted = false;
  Dsm rough_dz, adjusted_dz;      // the maps (empty: none), kept to draw both in one colour range
  double range_m = 0.0;           // the pictures' colour range
  double nonrigid_rms = std::numeric_limits<double>::quiet_NaN();  // reintersection's bend beyond a similarity
};

// Where the final matches of epoch k with the reference lie on the reference's DSM: the
// reference pixel's ray met with it.
std::vector<Eigen::Vector3d> stable_points(const std::vector<Epoch>& epochs, std::size_t reference,
                                           const std::vector<EpochPair>& pairs, std::size_t k) {
  std::vector<Eigen::Vector3d> out;
  for (const EpochPair& ep : pairs) {
    if (ep.master != k || ep.secondary != reference) continue;
    for (const PrecisePairReport& p : ep.precise.pairs)
      for (const PointMatch& m : p.matches) {
        const std::optional<Ray3> ray = epochs[reference].frames[p.secondary].ray(m.b);
        if (!ray) continue;
        const RayDsmResult hit = intersect_ray_dsm(epochs[reference].folder.dsm, *ray);
        if (hit.success) out.push_back(hit.point);
      }
  }
  return out;
}

// One DoD map: computed, written as DIR/dod/<stem>.tif (float, nodata where either DSM has none),
// kept in `dz`, its statistics returned; `stable` empty: no stable mask (its statistics NaN).
DodMapStatistics compute_dod(const std::string& dir, const std::string& stem, const Dsm& reference, const Dsm& moving,
                             const Helmert3& reference_from_moving, const Raster<std::uint8_t>& stable, Dsm& dz,
                             std::size_t threads) {
  DodMapOptions options;
  options.threads = threads;
  DodMap map = dod_map(reference, moving, reference_from_moving, options);
  if (!map.success) {
    DodMapStatistics none;
    none.reason = map.reason;
    return none;
  }
  write_geotiff_dsm(map.dz, dir + "/" + stem + ".tif");
  dz = std::move(map.dz);
  return dod_map_statistics(dz, stable.empty() ? nullptr : &stable);
}

// The pictures of an epoch's maps, DIR/dod/<name>_rough.png and <name>.png, in one colour range
// (the wider of the two maps' defaults) so that they compare at a glance.
void draw_dods(const std::string& dir, EpochDod& d, const std::string& name, const std::string& reference,
               const Raster<std::uint8_t>& stable) {
  DrawDodOptions picture;
  picture.stable = stable.empty() ? nullptr : &stable;
  d.range_m = 0.0;
  for (const Dsm* dz : {&d.rough_dz, &d.adjusted_dz})
    if (!dz->empty()) d.range_m = std::max(d.range_m, dod_colour_range(*dz, picture));
  picture.range_m = d.range_m;
  if (!d.rough_dz.empty()) {
    picture.title = name + " - " + reference + ", rough co-registration";
    write_dod_png(dir + "/" + name + "_rough.png", d.rough_dz, picture);
  }
  if (!d.adjusted_dz.empty()) {
    picture.title = name + " - " + reference + ", adjusted";
    write_dod_png(dir + "/" + name + ".png", d.adjusted_dz, picture);
  }
}

void dod_statistics_json(std::ostream& o, const ErrorStatistics& e) {
  o << "{\"cells\": " << e.count << ", \"mean\": " << json_number_or_null(e.mean) << ", \"sigma\": "
    << json_number_or_null(e.sigma) << ", \"mean_abs\": " << json_number_or_null(e.mean_abs)
    << ", \"median\": " << json_number_or_null(e.median) << ", \"nmad\": " << json_number_or_null(e.nmad) << "}";
}

// The "dod" section of report.json: per free epoch, the paper's mu, sigma, |mu| plus median and
// NMAD over every valid cell and over stable terrain, rough and adjusted (reference units).
std::string dod_json(const std::vector<EpochDod>& dods, const std::vector<Epoch>& epochs) {
  std::ostringstream o;
  o.precision(6);
  o << "  \"dod\": {\"stable_radius_cells\": " << kStableCells;
  for (const EpochDod& d : dods) {
    o << ",\n    " << quoted(epochs[d.epoch].name) << ": {\"stable_points\": " << d.stable_points
      << ", \"colour_range\": " << json_number_or_null(d.range_m) << ", \"reintersection_nonrigid_rms\": "
      << json_number_or_null(d.nonrigid_rms);
    for (const auto& [name, s] : {std::make_pair("rough", &d.rough), std::make_pair("adjusted", &d.adjusted)}) {
      if (name == std::string("adjusted") && !d.has_adjusted) continue;
      o << ",\n      \"" << name << "\": ";
      if (!s->success) {
        o << "{\"message\": " << quoted(s->reason) << "}";
        continue;
      }
      o << "{\"all\": ";
      dod_statistics_json(o, s->all);
      o << ", \"stable\": ";
      dod_statistics_json(o, s->stable);
      o << "}";
    }
    o << "}";
  }
  o << "},\n";
  return o.str();
}

// The free epochs not tied to the reference through pairs with final matches (a chain of them
// counts), in order; empty when all are.
std::vector<std::size_t> untied_epochs(const std::vector<Epoch>& epochs, std::size_t reference,
                                       const std::vector<EpochPair>& pairs) {
  std::vector<bool> tied(epochs.size(), false);
  tied[reference] = true;
  for (bool grew = true; grew;) {
    grew = false;
    for (const EpochPair& p : pairs)
      if (p.precise.success && tied[p.master] != tied[p.secondary]) tied[p.master] = tied[p.secondary] = grew = true;
  }
  std::vector<std::size_t> out;
  for (std::size_t e = 0; e < epochs.size(); ++e)
    if (!tied[e]) out.push_back(e);
  return out;
}

// A warning: on stderr on its own line, and kept for report.json.
void warn(std::vector<std::string>& warnings, const std::string& text) {
  Progress::break_line();
  std::fprintf(stderr, "warning: %s\n", text.c_str());
  warnings.push_back(text);
}

// The wall-clock time of each stage of the run and in total, for report.json.
class RunClock {
 public:
  RunClock() : start_(std::chrono::steady_clock::now()), last_(start_), started_(std::time(nullptr)) {}
  // Ends the stage under way (its time goes to `name`, added up when a stage comes again).
  void stage(const std::string& name) {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    for (auto& [n, s] : stages_)
      if (n == name) {
        s += seconds;
        return;
      }
    stages_.emplace_back(name, seconds);
  }
  std::string json() const {
    std::ostringstream o;
    o.precision(4);
    o << "{";
    for (const auto& [name, seconds] : stages_) o << quoted(name) << ": " << seconds << ", ";
    o << "\"total\": " << std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count() << "}";
    return o.str();
  }
  std::string started() const {
    char text[32];
    std::tm utc{};
    ::gmtime_r(&started_, &utc);
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
    return text;
  }

 private:
  std::chrono::steady_clock::time_point start_, last_;
  std::time_t started_;
  std::vector<std::pair<std::string, double>> stages_;
};

// What match_epochs writes into --out: replaced as a whole by a rerun, never mixed with its outputs.
bool is_match_epochs_output(const std::string& name) {
  static const std::set<std::string> kOutputs = {"Homol", "adjusted", "pairs", "dod", "report.json", "homol_names.txt"};
  return kOutputs.count(name) > 0 || (name.rfind("rough_helmert_", 0) == 0 && name.size() > 19 &&
                                      name.compare(name.size() - 5, 5, ".json") == 0);
}

// The run's outputs are written into a fresh folder inside --out and moved into place when the run
// ends (commit()), after the outputs of an earlier run are removed: a rerun that finds fewer pairs
// or fails never leaves earlier tie points beside its report. A run stopped by an error (exit 1)
// leaves --out as it was. --out must be new or empty unless `overwrite`.
class OutputFolder {
 public:
  OutputFolder(const std::string& final_dir, bool overwrite) : final_(final_dir) {
    std::vector<std::string> entries;
    if (is_folder(final_))
      for (const std::string& e : folder_entries(final_))
        if (e.rfind(kPartial, 0) != 0) entries.push_back(e);
    if (!entries.empty() && !overwrite) {
      std::string some;
      for (std::size_t k = 0; k < entries.size() && k < 4; ++k) some += (k ? ", " : "") + entries[k];
      DIACHRON_CHECK(false, "--out '" << final_ << "' is not empty (it holds " << some
                                      << (entries.size() > 4 ? ", ..." : "")
                                      << "): give a new or empty folder, or --overwrite to replace the outputs of "
                                         "an earlier run in it");
    }
    created_ = !is_folder(final_);
    make_folders(final_, "--out");
    work_ = final_ + "/" + kPartial + std::to_string(::getpid());
    std::filesystem::remove_all(work_);
    make_folder(work_, "--out");
  }
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;
  ~OutputFolder() {
    std::error_code ignored;
    if (committed_) return;
    std::filesystem::remove_all(work_, ignored);
    if (created_) std::filesystem::remove(final_, ignored);  // only when empty: as it was, absent
  }
  const std::string& work() const { return work_; }
  const std::string& final_dir() const { return final_; }
  // Moves the run's outputs into --out, after removing an earlier run's.
  void commit() {
    if (committed_) return;
    for (const std::string& e : folder_entries(final_))
      if (is_match_epochs_output(e)) std::filesystem::remove_all(final_ + "/" + e);
    for (const std::string& e : folder_entries(work_)) std::filesystem::rename(work_ + "/" + e, final_ + "/" + e);
    std::filesystem::remove(work_);
    committed_ = true;
  }

 private:
  static constexpr const char* kPartial = ".match_epochs-partial-";
  std::string final_, work_;
  bool created_ = false;  // --out did not exist before the run
  bool committed_ = false;
};

}  // namespace

int main(int argc, char** argv) {
  // affine: "" (not given: per image), "image" or "camera".
  std::string out_dir, method = "correlation", matcher_name = "rootsift", model_path, measure, affine, reference_name;
  std::vector<std::string> dirs;
  std::vector<std::string> rough_specs;  // --rough: [NAME=]auto|identity|FILE, in order
  PreciseMatchingOptions options;
  OverlappingPairsOptions overlap_options;
  bool quiet = false, no_pictures = false, adjust = false, one_camera = false, overwrite = false, verbose = false;
  bool no_refine = false, no_ground_filter = false, no_ncc = false;
  std::string fallback = "on";
  std::string hold;  // --hold: the free epochs' intrinsics held, comma-separated names
  std::string prior;  // --prior: the free epochs' intrinsic priors, NAME=SIGMA,...
  std::string gcps;  // --gcps: the control-point file
  std::string checks;  // --check-points: the check-point file
  std::string colmap_format = "text";  // --colmap-format
  MicmacEpochOptions micmac_epochs;    // --micmac-ori, --micmac-homol
  double min_overlap = 0.1;
  std::optional<int> cell;  // unset: the default cell
  std::optional<std::size_t> max_points;  // unset: PreciseCorrelationOptions' bound
  std::optional<double> ground_gsd;     // unset: the method's default threshold
  std::optional<double> nodata;         // --nodata
  std::optional<double> ncc_threshold;  // unset: the validator's default
  std::optional<std::string> sharpen;   // unset: PreciseCorrelationOptions' master_sharpen
  GeoTiffReadOptions dsm_read;
  std::size_t threads = 0;
  RunClock run_clock;
#if DIACHRON_MATCH_EPOCHS_ADJUST
  // Ceres logs through glog on stderr (e.g. a trust-region step it rejected); the adjustment's
  // report and report.json say what matters, so only fatal messages are let through.
  FLAGS_minloglevel = google::GLOG_FATAL;
#endif
  // Whole lines on stdout even into a file, so that they keep their order with stderr's progress.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  CLI::App app{kDescription, "match_epochs"};
  app.get_formatter()->column_width(34);
  app.add_option("EPOCH_DIR", dirs, "epoch folders, two or more")->required();
  app.add_option("--out", out_dir, "output folder (created; it must be new or empty unless --overwrite)")->required();
  app.add_flag("--overwrite", overwrite,
               "replace the outputs of an earlier run in --out (they are removed only when this run ends, "
               "so a failed run leaves them as they were)");
  app.add_option("--reference", reference_name, "the reference epoch by its folder's name (default: the last given)");
  app.add_option("--rough", rough_specs,
                 "[NAME=]auto|identity|FILE: a free epoch -> the reference, co-registered from the DSMs (auto, "
                 "default; through another free epoch when that fails), the identity (one frame already), or a "
                 "helmert.json FILE; for every free epoch or for NAME (repeatable)")
      ->allow_extra_args(false);
  app.add_option("--method", method, "tentative matches: correlation (default), patch or guided")
      ->check(CLI::IsMember({"correlation", "patch", "guided"}));
  app.add_option("--measure", measure, "correlation's similarity: orientation (default), gradient or intensity")
      ->check(CLI::IsMember({"orientation", "gradient", "intensity"}));
  app.add_option("--cell", cell, "correlation: one master point per PX x PX cell (default 6, coarser on large images)")
      ->check(strict_number<int>(2, 4096, "a cell side in [2, 4096] px"));
  app.add_option("--max-points", max_points,
                 "correlation: the cell grows from 6 px on images of more than N cells (default 60000)")
      ->check(strict_number<std::size_t>(1, std::numeric_limits<std::size_t>::max() / 2, "at least 1 point per image"));
  app.add_option("--matcher", matcher_name, "patch/guided features: sift, rootsift (default), akaze or xfeat")
      ->check(CLI::IsMember({"sift", "rootsift", "akaze", "xfeat"}));
  app.add_option("--model", model_path, "XFeat ONNX file (with --matcher xfeat)")->check(CLI::ExistingFile);
  app.add_option("--fallback", fallback,
                 "on|off: dense correlation search of the DSMs when the features find no co-registration "
                 "(default on; graded low trust)")
      ->check(CLI::IsMember({"on", "off"}));
  app.add_option("--nodata", nodata, "also treat DSM heights equal to V as holes (a dsm.tif without a nodata tag)")
      ->check(strict_number<double>(-1e300, 1e300, "a height"));
  app.add_option("--min-overlap", min_overlap, "least overlap of a pair, share of the smaller footprint (default 0.1)")
      ->check(strict_number<double>(0.0, 1.0, "a share in [0, 1]"));
  app.add_option("--ncc-threshold", ncc_threshold, "least NCC of a kept match (default 0.6, MicMac's)")
      ->check(strict_number<double>(-1.0, 1.0, "an NCC in [-1, 1]"));
  app.add_option("--micmac-ori", micmac_epochs.ori,
                 "MicMac epochs: the orientation to read, Ori-NAME (default: the folder's only Ori-*)");
  app.add_option("--micmac-homol", micmac_epochs.homol,
                 "MicMac epochs: their intra-epoch tie points, e.g. Homol-Guided for SH=-Guided (default Homol)");
  app.add_flag("--no-refine", no_refine, "keep the matcher's positions (no least-squares refinement)");
  app.add_option("--ground-gsd", ground_gsd,
                 "the ground filter's threshold, GSD of the secondary image (default 3 for correlation, 10 "
                 "for patch and guided)")
      ->check(strict_number<double>(1e-9, 1e9, "a threshold > 0 (GSD of the secondary image)"));
  app.add_option("--sharpen", sharpen, "A[,S]: correlation: sharpen the master images, amount A, sigma S px (S 1)");
  app.add_flag("--no-ground-filter", no_ground_filter, "skip the 3D Helmert RANSAC");
  app.add_flag("--no-ncc", no_ncc, "skip the NCC validator");
  app.add_flag("--no-pictures", no_pictures, "do not write pairs/ and adjusted/residuals/");
  app.add_flag("--adjust", adjust,
               "then the combined adjustment (the reference fixed, every free epoch self-calibrated): DIR/adjusted/"
#if !DIACHRON_MATCH_EPOCHS_ADJUST
               " (not in this build: no Ceres)"
#endif
  );
  app.add_option("--affine", affine, "with --adjust: B1, B2 per image (default) or per camera (MicMac's)")
      ->check(CLI::IsMember({"image", "camera"}));
  app.add_option("--hold", hold, "with --adjust: intrinsics held, of f,cx,cy,K1,K2,K3,P1,P2 (e.g. K3)");
  app.add_option("--prior", prior, "with --adjust: intrinsics tied to their values with a sigma, NAME=SIGMA,... (f=2,cx=1)");
  app.add_flag("--one-camera", one_camera, "with --adjust: each free epoch's images share one camera");
  app.add_option("--gcps", gcps, "with --adjust: ground control points (io/control_points.hpp)");
  app.add_option("--check-points", checks, "with --adjust: independent check points, the same layout");
  app.add_option("--colmap-format", colmap_format, "with --adjust: adjusted/colmap/ as text (default) or binary")
      ->check(CLI::IsMember({"text", "binary"}));
  app.add_option("--threads", threads, "worker threads, 0 = all cores (default 0)")
      ->check(strict_number<std::size_t>(0, 4096, "a thread count in [0, 4096]"));
  app.add_flag("--quiet", quiet, "no progress on stderr");
  app.add_flag("--verbose", verbose, "errors with the library's internal condition (for bug reports)");
  if (const std::optional<int> status = diachron::programs::parse_options(app, argc, argv, 1)) return *status;
  std::optional<OutputFolder> output;
  try {
    DIACHRON_CHECK(dirs.size() >= 2, "two epoch folders or more are needed, " << dirs.size() << " given");
    if (nodata) {
      dsm_read.assume_untagged_nodata = true;
      dsm_read.untagged_nodata = *nodata;
    }
    if (ncc_threshold) options.ncc.min_ncc = *ncc_threshold;
    options.ncc.refine = !no_refine;
    options.use_ground_filter = !no_ground_filter;
    options.use_ncc = !no_ncc;
    const bool pictures = !no_pictures, use_fallback = fallback == "on";
    // The epochs, named by their folders: a folder given twice, or two folders of one name, would
    // make two epochs that outputs cannot tell apart.
    std::vector<Epoch> epochs(dirs.size());
    for (std::size_t k = 0; k < dirs.size(); ++k) {
      epochs[k].dir = dirs[k];
      epochs[k].name = folder_name(dirs[k]);
      DIACHRON_CHECK(!epochs[k].name.empty() && epochs[k].name != "/" && epochs[k].name != "residuals" &&
                         epochs[k].name != "colmap" && epochs[k].name != "micmac",
                     "epoch folder '" << dirs[k] << "' has no name usable for outputs ('" << epochs[k].name
                                      << "'; residuals, colmap and micmac are taken by adjusted/): give it a folder of its own, e.g. a link named after its year");
      for (std::size_t j = 0; j < k; ++j) {
        DIACHRON_CHECK(dirs[j] != dirs[k] && !same_folder(dirs[j], dirs[k]),
                       "the folder '" << dirs[k] << "' is given twice (as '" << dirs[j] << "')");
        DIACHRON_CHECK(epochs[j].name != epochs[k].name,
                       "two epochs are named '" << epochs[k].name << "' ('" << dirs[j] << "' and '" << dirs[k]
                                                << "'): epochs are named by their folders; link one under another "
                                                   "name");
      }
    }
    // The reference (the last given, or named), then the free epochs in name order after it
    // is chosen: outputs do not depend on the order they were given in.
    if (reference_name.empty()) reference_name = epochs.back().name;
    {
      const auto it = std::find_if(epochs.begin(), epochs.end(), [&](const Epoch& e) { return e.name == reference_name; });
      std::string known;
      for (const Epoch& e : epochs) known += (known.empty() ? "" : ", ") + e.name;
      DIACHRON_CHECK(it != epochs.end(), "--reference: no epoch is named '" << reference_name << "' (" << known << ")");
      std::rotate(it, it + 1, epochs.end());
      std::sort(epochs.begin(), epochs.end() - 1, [](const Epoch& a, const Epoch& b) { return a.name < b.name; });
    }
    const std::size_t reference = epochs.size() - 1;
    // --rough: one mode for every free epoch, or NAME=MODE for one; read before any work, so that a
    // missing or malformed file fails fast.
    for (const std::string& spec : rough_specs) {
      const std::size_t eq = spec.find('=');
      std::string name, mode = spec;
      if (eq != std::string::npos &&
          std::any_of(epochs.begin(), epochs.end(), [&](const Epoch& e) { return e.name == spec.substr(0, eq); })) {
        name = spec.substr(0, eq);
        mode = spec.substr(eq + 1);
        DIACHRON_CHECK(name != epochs[reference].name,
                       "--rough " << spec << ": '" << name << "' is the reference; it is not moved");
      }
      std::optional<Helmert3> given;
      if (mode == "identity") given = Helmert3::identity();
      else if (mode != "auto") {
        DIACHRON_CHECK(!mode.empty(), "--rough wants [NAME=]auto, identity or a helmert.json file");
        DIACHRON_CHECK(is_regular_file(mode), "--rough: '" << mode << "' is neither auto, identity nor a file");
        given = read_helmert_json(mode);
      }
      for (std::size_t k = 0; k < reference; ++k)
        if (name.empty() || epochs[k].name == name) {
          epochs[k].rough_mode = mode;
          epochs[k].given = given;
        }
    }
#if !DIACHRON_MATCH_EPOCHS_ADJUST
    DIACHRON_CHECK(!adjust, "--adjust needs a build with Ceres (diachron::adjustment)");
#endif
    DIACHRON_CHECK(adjust || affine.empty(), "--affine needs --adjust");
    DIACHRON_CHECK(adjust || colmap_format == "text", "--colmap-format needs --adjust");
    DIACHRON_CHECK(adjust || !one_camera, "--one-camera needs --adjust");
    DIACHRON_CHECK(adjust || hold.empty(), "--hold needs --adjust");
    DIACHRON_CHECK(adjust || prior.empty(), "--prior needs --adjust");
    DIACHRON_CHECK(adjust || gcps.empty(), "--gcps needs --adjust");
    // Read before any work: a malformed file fails fast. Its image names are checked below.
    const std::vector<ControlPointRecord> control = gcps.empty() ? std::vector<ControlPointRecord>{} : read_control_points(gcps);
    DIACHRON_CHECK(adjust || checks.empty(), "--check-points needs --adjust");
    const std::vector<ControlPointRecord> check_records =
        checks.empty() ? std::vector<ControlPointRecord>{} : read_control_points(checks);
#if DIACHRON_MATCH_EPOCHS_ADJUST
    const std::vector<Intrinsic> held = parse_intrinsics(hold);  // before any work: a typo fails fast
    const std::vector<IntrinsicPrior> priors = parse_priors(prior);
#endif
    if (measure == "intensity") options.correlation.match.measure = CorrelationMeasure::intensity;
    else if (measure == "gradient") options.correlation.match.measure = CorrelationMeasure::gradient;
    else options.correlation.match.measure = CorrelationMeasure::orientation;
    DIACHRON_CHECK(measure.empty() || method == "correlation", "--measure goes with --method correlation");
    DIACHRON_CHECK(!cell || method == "correlation", "--cell goes with --method correlation");
    if (cell) options.correlation.use_fixed_cell(*cell);
    DIACHRON_CHECK(!max_points || method == "correlation", "--max-points goes with --method correlation");
    DIACHRON_CHECK(!max_points || !cell, "--cell and --max-points both set the cell: give one of them");
    if (max_points) options.correlation.max_points_per_image = *max_points;
    if (ground_gsd) {
      DIACHRON_CHECK(options.use_ground_filter, "--ground-gsd and --no-ground-filter contradict each other");
      ground_threshold_gsd(options, method) = *ground_gsd;
    }
    if (sharpen) {
      DIACHRON_CHECK(method == "correlation", "--sharpen goes with --method correlation");
      UnsharpMaskOptions& u = options.correlation.master_sharpen;
      u.sigma_px = 1.0;
      char rest = 0;
      const int n = std::sscanf(sharpen->c_str(), "%lf,%lf%c", &u.amount, &u.sigma_px, &rest);
      // The ranges are UnsharpMaskOptions::check()'s; the program says them in its own words.
      bool valid = n == (sharpen->find(',') == std::string::npos ? 1 : 2);
      try {
        if (valid) u.check();
      } catch (const Error&) {
        valid = false;
      }
      DIACHRON_CHECK(valid, "--sharpen wants A[,S], an amount in [0, 20] and a sigma in (0, 20] px, got '" << *sharpen
                                                                                                           << "'");
    }
    DIACHRON_CHECK(method != "guided" || matcher_name != "akaze",
                   "--method guided takes sift, rootsift or xfeat features (AKAZE's are binary)");
    DIACHRON_CHECK(matcher_name != "xfeat" || !model_path.empty(), "--matcher xfeat needs --model PATH");
    // The report names what made the matches: the measure for correlation, the features otherwise.
    if (method == "correlation") matcher_name = to_string(options.correlation.match.measure);
    options.threads = threads;
    options.check();
    overlap_options.check();
    const ProgressCallback progress = quiet ? ProgressCallback() : Progress::callback();
    options.progress = progress;
    overlap_options.min_overlap_fraction = min_overlap;
    overlap_options.threads = threads;
    overlap_options.check();

    // Every option is checked; the output folder next (a full --out refuses before any work).
    output.emplace(out_dir, overwrite);
    const std::string work = output->work();
    const auto finish = [&](int status) {
      output->commit();
      return status;
    };
    std::vector<std::string> warnings;  // printed as they come, and in report.json; they lower the trust
    std::vector<std::string> notes;     // the same, without lowering it
    for (Epoch& e : epochs) {
      e.folder = read_epoch_folder(e.dir, dsm_read, {}, micmac_epochs);
      for (const EpochImage& im : e.folder.images) e.frames.push_back(im.epoch_frame());
    }
    // Each epoch's model, DSM and image files against each other, before any matching trusts them.
    std::vector<EpochFolderCheck> input_checks;
    bool refused = false;
    for (const Epoch& e : epochs) {
      input_checks.push_back(check_epoch_folder(e.folder));
      for (const EpochCheckIssue& issue : input_checks.back().issues) {
        if (issue.severity == EpochCheckSeverity::note) {
          notes.push_back(issue.what + " (" + issue.remedy + ")");
          if (!quiet) {
            Progress::break_line();
            std::fprintf(stderr, "note: %s\n", notes.back().c_str());
          }
          continue;
        }
        if (issue.severity == EpochCheckSeverity::warning) {
          warn(warnings, issue.what + " (" + issue.remedy + ")");
          continue;
        }
        Progress::break_line();
        std::fprintf(stderr, "match_epochs: %s\n  remedy: %s\n", issue.what.c_str(), issue.remedy.c_str());
        refused = true;
      }
    }
    if (refused) {
      std::fprintf(stderr, "match_epochs: refused before any matching; --out is left as it was\n");
      return 1;
    }
    run_clock.stage("reading and checking the inputs");
    for (std::size_t k = 0; k < reference; ++k)
      DIACHRON_CHECK(!adjust || !epochs[k].folder.is_ortho(),
                     "epoch " << epochs[k].name << " ('" << epochs[k].dir
                              << "') is an orthophoto epoch: with --adjust an orthophoto can only be the reference "
                                 "(--reference "
                              << epochs[k].name << ")");
    for (const Epoch& e : epochs)
      if (const std::optional<double> v = suspected_untagged_nodata(e.folder.dsm); v && !dsm_read.assume_untagged_nodata) {
        std::ostringstream m;
        m << "'" << e.dir << "/dsm.tif' has heights of " << *v
          << " far below all others and no nodata tag for them: if they are holes, pass --nodata " << *v;
        warn(warnings, m.str());
      }
#if DIACHRON_MATCH_EPOCHS_ADJUST
    const std::vector<EpochsControlPoint> control_points = epochs_control_points(control, epochs, "control point");
    const std::vector<EpochsControlPoint> check_points = epochs_control_points(check_records, epochs, "check point");
#endif
    const bool renamed = set_homol_names(epochs);
    if (renamed && !quiet)
      std::fprintf(stderr, "image names with a folder or shared by two epochs: Homol/ uses e<k>_ names "
                           "(DIR/homol_names.txt)\n");
    if (!quiet)
      for (const Epoch& e : epochs)
        std::fprintf(stderr, "epoch %s%s: %zu %s (%zu masked), DSM %d x %d\n", e.name.c_str(),
                     &e == &epochs[reference] ? " (reference)" : "", e.folder.images.size(),
                     e.folder.is_ortho() ? "orthophoto tiles" : "images", e.folder.masks(), e.folder.dsm.width(),
                     e.folder.dsm.height());

    // 1. Rough co-registration of every free epoch with the reference: from the DSMs (its defaults:
    // SIFT on slope images), or given. An epoch that fails goes through another free epoch already
    // placed, the best-trusted first; the chain may grow as epochs are placed.
    std::vector<EpochPair> pairs;
    std::string trust = "none";  // "high" or "low" once the run has an answer
    std::vector<std::string> trust_reasons;
    const std::string command_line = [&] {
      std::string line;
      for (int i = 0; i < argc; ++i) line += (i ? ", " : "") + quoted(argv[i]);
      return line;
    }();
    // report.json, written again as the run goes: what the run was (command line, version,
    // threads, times), the input checks, the warnings and the trust, then `sections`.
    const auto report = [&](const std::string& sections) {
      std::ostringstream o;
      o.precision(6);
      o << "  \"run\": {\"command_line\": [" << command_line << "], \"version\": " << quoted(DIACHRON_VERSION)
        << ", \"threads\": " << (threads ? threads : std::max(1u, std::thread::hardware_concurrency()))
        << ", \"started\": " << quoted(run_clock.started()) << ", \"inputs\": {\"epochs\": [";
      for (std::size_t k = 0; k < epochs.size(); ++k) o << (k ? ", " : "") << quoted(absolute_path(epochs[k].dir));
      o << "], \"gcps\": " << (gcps.empty() ? std::string("null") : quoted(absolute_path(gcps)))
        << ", \"check_points\": " << (checks.empty() ? std::string("null") : quoted(absolute_path(checks)))
        << "}, \"seconds\": " << run_clock.json() << "},\n"
        << "  \"trust\": {\"level\": " << quoted(trust) << ", \"reasons\": [";
      for (std::size_t k = 0; k < trust_reasons.size(); ++k) o << (k ? ", " : "") << quoted(trust_reasons[k]);
      o << "]},\n  \"warnings\": [";
      for (std::size_t k = 0; k < warnings.size(); ++k) o << (k ? ",\n    " : "\n    ") << quoted(warnings[k]);
      o << "],\n  \"notes\": [";
      for (std::size_t k = 0; k < notes.size(); ++k) o << (k ? ",\n    " : "\n    ") << quoted(notes[k]);
      o << "],\n  \"input_checks\": {";
      for (std::size_t k = 0; k < epochs.size(); ++k) {
        o << (k ? ",\n    " : "\n    ") << quoted(epochs[k].name) << ": ";
        input_check_json(o, input_checks[k]);
      }
      o << "},\n";
      write_report(work + "/report.json", epochs, reference, pairs, options, method, matcher_name, o.str() + sections);
    };
    std::vector<std::optional<Helmert3>> given;
    for (const Epoch& e : epochs) given.push_back(e.given);
    const std::vector<EpochPlacement> placements = place_epochs(
        epochs.size(), reference, given,
        [&](std::size_t from, std::size_t to) {
          RoughCoregistrationOptions rough_options;
          rough_options.threads = threads;
          rough_options.progress = progress;
          rough_options.correlation_fallback = use_fallback;
          return rough_coregistration(epochs[from].folder.dsm, epochs[to].folder.dsm,
                                      ExtractorPairMatcher<SiftExtractor>(SiftExtractor{}), rough_options);
        },
        [&](std::size_t from, std::size_t to, const RoughCoregistrationReport& r) {
          std::printf("rough co-registration %s -> %s: %s\n", epochs[from].name.c_str(), epochs[to].name.c_str(),
                      r.message.c_str());
        });
    for (std::size_t k = 0; k < reference; ++k) {
      Epoch& e = epochs[k];
      const EpochPlacement& p = placements[k];
      e.placed = p.placed;
      e.reference_from_epoch = p.reference_from_epoch;
      e.rough = p.report;
      if (p.given) {
        e.rough.success = true;
        e.rough.epoch2_from_epoch1 = p.reference_from_epoch;
        e.rough.message = e.rough_mode == "identity" ? "given: the identity (--rough identity)"
                                                     : "given: " + e.rough_mode + " (--rough FILE)";
      }
      if (p.via) {
        e.via = epochs[*p.via].name;
        e.rough.message = "through " + e.via + ": " + e.rough.message;
      }
    }
    run_clock.stage("rough co-registration");
    for (std::size_t k = 0; k < reference; ++k) {
      if (epochs[k].placed) continue;
      report("");
      std::printf("no co-registration of %s with %s: %s\n", epochs[k].name.c_str(), epochs[reference].name.c_str(),
                  epochs[k].rough.message.c_str());
      return finish(2);
    }
    for (std::size_t k = 0; k < reference; ++k)
      write_helmert_json(epochs[k].reference_from_epoch, work + "/rough_helmert_" + epochs[k].name + ".json");

    // 2. Overlapping pairs of every two epochs through the DSMs, the master's footprints moved by
    // the transform between them. Photos and orthophoto tiles alike, through EpochFrame.
    for (std::size_t a = 0; a < epochs.size(); ++a)
      for (std::size_t b = a + 1; b < epochs.size(); ++b) {
        EpochPair p;
        p.master = a;
        p.secondary = b;
        // Into the reference: its rough transform as it is (bit for bit what two epochs always used).
        p.secondary_from_master = b == reference ? epochs[a].reference_from_epoch
                                                 : epochs[b].reference_from_epoch.inverse() * epochs[a].reference_from_epoch;
        std::vector<FootprintImage<EpochFrame>> fa, fb;
        for (const EpochFrame& f : epochs[a].frames) fa.push_back({f, f.width(), f.height()});
        for (const EpochFrame& f : epochs[b].frames) fb.push_back({f, f.width(), f.height()});
        p.overlap = overlapping_pairs(fa, epochs[a].folder.dsm, fb, epochs[b].folder.dsm, p.secondary_from_master,
                                      overlap_options);
        std::printf("overlapping pairs %s -- %s: %zu of %zu candidates (%s)\n", epochs[a].name.c_str(),
                    epochs[b].name.c_str(), p.overlap.pairs.size(), p.overlap.candidate_pairs, p.overlap.message.c_str());
        pairs.push_back(std::move(p));
      }
    run_clock.stage("overlapping pairs");
    for (std::size_t k = 0; k < epochs.size(); ++k) {
      if (std::any_of(pairs.begin(), pairs.end(), [&](const EpochPair& p) {
            return (p.master == k || p.secondary == k) && !p.overlap.pairs.empty();
          }))
        continue;
      report("");
      std::printf("no overlapping pair: epoch %s overlaps no other epoch (least overlap %g of the smaller footprint; "
                  "check its DSM and rough co-registration)\n",
                  epochs[k].name.c_str(), min_overlap);
      return finish(2);
    }

    // 3. Precise matching per image pair of every two epochs.
    std::vector<PreciseEpoch<EpochFrame>> precise_epochs;
    for (const Epoch& e : epochs)
      precise_epochs.push_back({e.frames, [&e](std::size_t i) { return e.folder.load_image(i); }, &e.folder.dsm,
                                [&e](std::size_t i) { return e.folder.load_mask(i); }});
    SiftOptions sift_options;
    sift_options.root_sift = matcher_name == "rootsift";
    for (EpochPair& ep : pairs) {
      if (ep.overlap.pairs.empty()) continue;
      const PreciseEpoch<EpochFrame>& p1 = precise_epochs[ep.master];
      const PreciseEpoch<EpochFrame>& p2 = precise_epochs[ep.secondary];
      const Helmert3& h = ep.secondary_from_master;
      const std::vector<ImagePairOverlap>& overlapping = ep.overlap.pairs;
      if (!quiet)
        std::fprintf(stderr, "matching %s -- %s\n", epochs[ep.master].name.c_str(), epochs[ep.secondary].name.c_str());
      if (method == "correlation") {
        ep.precise = precise_matching_correlation(p1, p2, h, overlapping, options);
      } else if (method == "patch") {
        if (matcher_name == "akaze")
          ep.precise = precise_matching_patch(p1, p2, h, overlapping, ExtractorPairMatcher<AkazeExtractor>(AkazeExtractor{}),
                                              options);
        else if (matcher_name == "xfeat")
          ep.precise = precise_matching_patch(p1, p2, h, overlapping, XFeatPairMatcher(model_path), options);
        else
          ep.precise = precise_matching_patch(p1, p2, h, overlapping,
                                              ExtractorPairMatcher<SiftExtractor>(SiftExtractor(sift_options)), options);
      } else {
        if (matcher_name == "xfeat") {
          PreciseMatchingOptions cosine = options;
          cosine.guided.metric = DescriptorDistance::Cosine;
          ep.precise = precise_matching_guided(p1, p2, h, overlapping, XFeatExtractor(model_path), cosine);
        } else {
          ep.precise = precise_matching_guided(p1, p2, h, overlapping, SiftExtractor(sift_options), options);
        }
      }
    }

    run_clock.stage("precise matching");

    // 4. Outputs.
    report("");
    const std::string homol = work + "/Homol";
    make_folder(homol, "match_epochs");
    if (renamed) write_homol_names(work + "/homol_names.txt", epochs);
    if (pictures) make_folder(work + "/pairs", "match_epochs");
    std::vector<PictureImages> picture_images;
    picture_images.reserve(epochs.size());
    for (const Epoch& e : epochs) picture_images.emplace_back(e.folder);
    for (const EpochPair& ep : pairs) {
      const Epoch& ea = epochs[ep.master];
      const Epoch& eb = epochs[ep.secondary];
      for (const PrecisePairReport& p : ep.precise.pairs) {
        const std::string& a = ea.homol[p.master];
        const std::string& b = eb.homol[p.secondary];
        std::printf("%s -- %s: %zu tentative, %zu after the ground filter, %zu final\n",
                    ea.folder.images[p.master].name.c_str(), eb.folder.images[p.secondary].name.c_str(),
                    p.tentative.size(), p.grounded.size(), p.matches.size());
        if (p.matches.empty()) continue;
        write_homol(homol, a, b, p.matches);
        if (pictures) {
          const Picture& pa = picture_images[ep.master][p.master];
          const Picture& pb = picture_images[ep.secondary][p.secondary];
          write_pair_picture(work + "/pairs/" + safe(a) + "__" + safe(b) + ".jpg", pa, pb, p.matches,
                             method == "correlation", ea.folder.images[p.master].name + " (" + ea.name + ") -- " +
                                                          eb.folder.images[p.secondary].name + " (" + eb.name + ")");
        }
      }
      std::printf("%s -- %s: %s (%.1f s)\n", ea.name.c_str(), eb.name.c_str(), ep.precise.message.c_str(),
                  ep.precise.seconds_total);
    }
    run_clock.stage("tie points and pictures");
    // Every free epoch must be tied to the reference by matches, directly or through other epochs.
    const std::vector<std::size_t> untied = untied_epochs(epochs, reference, pairs);
    if (!untied.empty()) {
      std::string names, why;
      for (std::size_t k : untied) names += (names.empty() ? "" : ", ") + epochs[k].name;
      for (const EpochPair& p : pairs)
        if (p.master == untied.front() || p.secondary == untied.front())
          why += (why.empty() ? "" : "; ") + epochs[p.master].name + " -- " + epochs[p.secondary].name + ": " +
                 (p.overlap.pairs.empty() ? std::string("no overlapping pair") : p.precise.message);
      std::printf("no inter-epoch match tying %s to the reference %s: %s\n", names.c_str(),
                  epochs[reference].name.c_str(), why.c_str());
      return finish(2);
    }

    // 5. The DoD of every free epoch after the rough co-registration: DIR/dod/<epoch>_rough.*.
    const std::string dod_dir = work + "/dod";
    make_folder(dod_dir, "match_epochs");
    const Dsm& reference_dsm = epochs[reference].folder.dsm;
    std::vector<EpochDod> dods;
    std::vector<Raster<std::uint8_t>> stable_masks(epochs.size());
    for (std::size_t k = 0; k < reference; ++k) {
      EpochDod d;
      d.epoch = k;
      const std::vector<Eigen::Vector3d> points = stable_points(epochs, reference, pairs, k);
      d.stable_points = points.size();
      // An epoch tied to the reference only through other epochs has no such points: all cells then.
      if (!points.empty())
        stable_masks[k] = stable_mask_near_points(reference_dsm, points, kStableCells * reference_dsm.min_cell_size());
      d.rough = compute_dod(dod_dir, epochs[k].name + "_rough", reference_dsm, epochs[k].folder.dsm,
                            epochs[k].reference_from_epoch, stable_masks[k], d.rough_dz, threads);
      draw_dods(dod_dir, d, epochs[k].name, epochs[reference].name, stable_masks[k]);
      if (d.rough.success)
        std::printf("DoD %s - %s, rough: median %.3f, NMAD %.3f on stable terrain (%zu cells), %.3f, %.3f on all\n",
                    epochs[k].name.c_str(), epochs[reference].name.c_str(), d.rough.stable.median, d.rough.stable.nmad,
                    d.rough.stable.count, d.rough.all.median, d.rough.all.nmad);
      else
        std::printf("DoD %s - %s, rough: none (%s)\n", epochs[k].name.c_str(), epochs[reference].name.c_str(),
                    d.rough.reason.c_str());
      dods.push_back(std::move(d));
    }
    run_clock.stage("DoD maps");
    // The tie points' trust: what the input checks warned about (a run with --adjust adds the
    // adjustment's grade below).
    for (const std::string& w : warnings) trust_reasons.push_back("input: " + w);
    trust = trust_reasons.empty() ? "high" : "low";
    report(dod_json(dods, epochs));
#if DIACHRON_MATCH_EPOCHS_ADJUST
    if (adjust) {
      // 6. The combined adjustment of all epochs, the reference held.
      CombinedAdjustmentOptions adjustment_options;
      if (affine == "camera") adjustment_options.bundle.affine_scope = AffineScope::per_camera;
      EpochFreedom free_epoch = EpochFreedom::all_free();
      free_epoch.fixed_intrinsics = held;
      free_epoch.intrinsic_priors = priors;
      adjustment_options.bundle.epochs.assign(epochs.size(), free_epoch);
      adjustment_options.bundle.epochs[reference] = EpochFreedom::all_fixed();
      const bool ortho_reference = epochs[reference].folder.is_ortho();
      // An orthophoto reference is no image of the adjustment (an epoch without images): its
      // matches become control points observed in the free epochs' images
      // (pipeline/orthophoto_reference.hpp).
      std::vector<CombinedEpoch> combined;
      std::vector<Helmert3> reference_from_epoch;
      for (std::size_t k = 0; k < epochs.size(); ++k) {
        combined.push_back(k == reference && ortho_reference ? CombinedEpoch{}
                                                             : combined_epoch(epochs[k].folder, one_camera && k != reference));
        reference_from_epoch.push_back(k == reference ? Helmert3::identity() : epochs[k].reference_from_epoch);
      }
      std::vector<EpochsControlPoint> all_control = control_points;
      std::vector<EpochLinkMatches> links;
      for (const EpochPair& ep : pairs) {
        if (!ep.precise.success) continue;
        if (ep.secondary == reference && ortho_reference) {
          std::vector<OrthoFrame> tiles;
          for (const EpochImage& t : epochs[reference].folder.images) tiles.push_back(*t.ortho);
          const double sigma = orthophoto_control_sigma(
              combined[ep.master].frames, epochs[ep.master].reference_from_epoch, epochs[reference].folder.dsm.statistics().mean,
              epochs[reference].folder.ortho.cell_size(), adjustment_options.bundle.inter_epoch_sigma_px);
          const OrthophotoControlPoints from_ortho =
              orthophoto_control_points(ep.precise.pairs, tiles, epochs[reference].folder.dsm, sigma);
          for (const CombinedControlPoint& g : from_ortho.points) {
            EpochsControlPoint c{g.position, g.sigma, std::vector<std::vector<ImagePixel>>(epochs.size())};
            c.observations[ep.master] = g.epoch1;
            all_control.push_back(std::move(c));
          }
          std::printf("orthophoto reference: %zu of %zu matches of %s as control points (sigma %.3g reference units), "
                      "%zu without DSM height\n",
                      from_ortho.points.size(), from_ortho.matches, epochs[ep.master].name.c_str(), sigma,
                      from_ortho.off_dsm);
          continue;
        }
        links.push_back({ep.master, ep.secondary, epoch_pair_matches(ep.precise.pairs)});
      }
      const CombinedEpochsResult adjusted = combined_epochs_adjustment(combined, reference_from_epoch, reference, links,
                                                                       adjustment_options, all_control);
      std::vector<std::string> names;
      std::vector<std::size_t> image_epoch;
      for (std::size_t k = 0; k < epochs.size(); ++k)
        for (std::size_t i = 0; i < combined[k].frames.size(); ++i) {
          names.push_back(epochs[k].folder.images[i].name);
          image_epoch.push_back(k);
        }
      const BundleReport& r = adjusted.report;
      run_clock.stage("adjustment");
      std::printf("adjustment: %s\n", r.message.c_str());
      if (!control.empty()) {
        std::size_t used = 0;
        double worst = 0.0;
        for (const ControlPointOutcome& g : adjusted.control_points)
          if (g.used) {
            ++used;
            worst = std::max(worst, g.error.norm());
          }
        std::printf("control points: %zu of %zu used, largest error %.3f (reference units; report.json lists them)\n",
                    used, control.size(), worst);
      }
      // Each free epoch's check points triangulated in its images, after the rough co-registration
      // alone and after the adjustment: the paper's check-point table.
      std::vector<EpochCheckPoints> checked;
      for (std::size_t k = 0; k < reference && !check_points.empty(); ++k) {
        std::vector<ObservedCheckPoint> observed;
        for (const EpochsControlPoint& c : check_points) {
          ObservedCheckPoint p{c.position, {}};
          for (const ImagePixel& o : c.observations[k]) p.observations.push_back({static_cast<std::size_t>(o.image), o.pixel});
          observed.push_back(std::move(p));
        }
        const std::vector<Frame<FraserAffine>> moved = transformed_frames(combined[k].frames, reference_from_epoch[k]);
        EpochCheckPoints c{k, evaluate_check_points(observed, FrameTriangulator<FraserAffine>(moved)), {}};
        if (r.success) c.adjusted = evaluate_check_points(observed, FrameTriangulator<FraserAffine>(adjusted.epochs[k]));
        std::printf("check points of %s (reference units), %zu of %zu triangulated in its images:\n",
                    epochs[k].name.c_str(), c.rough.num_used, observed.size());
        std::printf("| orientation    | axis |    mean |  sigma | mean |e| |    RMS |\n");
        for (const auto& [name, report] : {std::make_pair("rough only", &c.rough), std::make_pair("adjusted", &c.adjusted)}) {
          if (!report->success) continue;
          const char* axis[3] = {"x", "y", "z"};
          for (std::size_t a = 0; a < 3; ++a)
            std::printf("| %-14s | %s    | %7.3f | %6.3f | %8.3f | %6.3f |\n", a == 0 ? name : "", axis[a],
                        report->axes_m[a].mean, report->axes_m[a].sigma, report->axes_m[a].mean_abs,
                        report->axes_m[a].rms);
        }
        if (c.rough.success && c.adjusted.success)
          std::printf("3D RMS of %s: rough only %.3f, adjusted %.3f\n", epochs[k].name.c_str(), c.rough.rms_3d_m,
                      c.adjusted.rms_3d_m);
        checked.push_back(std::move(c));
      }
      if (!r.success) {
        trust = "none";
        trust_reasons.push_back("the adjustment failed: " + r.message);
        report(adjustment_json(adjusted, epochs, image_epoch, names, nullptr,
                                     adjustment_options.bundle.affine_scope, control, checked) +
                         dod_json(dods, epochs));
        std::printf("no adjustment: %s\n", r.message.c_str());
        return finish(2);
      }
      std::vector<CamerasJsonImage> images;
      for (std::size_t k = 0; k < epochs.size(); ++k)
        for (std::size_t i = 0; i < adjusted.epochs[k].size(); ++i)  // none for an orthophoto reference
          images.push_back(CamerasJsonImage::from_frame(epochs[k].folder.images[i].name, epochs[k].name,
                                                        adjusted.epochs[k][i]));
      AdjustedExportOptions export_options;
      for (const Epoch& e : epochs) export_options.protected_folders.push_back(e.dir);
      const AdjustedExportReport exported = write_adjusted_export(images, work, export_options);
      // All epochs in one COLMAP model with the tracks as points3D (io/adjusted_export.hpp):
      // DIR/adjusted/colmap/sparse/ and images/ (links named <epoch>/<image>), for COLMAP's
      // model_analyzer, image_undistorter and dense stereo.
      std::vector<CamerasJsonImage> colmap_images = images;
      std::vector<std::string> colmap_paths;
      {
        std::size_t i = 0;
        for (std::size_t k = 0; k < epochs.size(); ++k)
          for (std::size_t j = 0; j < adjusted.epochs[k].size(); ++j, ++i) {
            colmap_images[i].name = epochs[k].name + "/" + colmap_images[i].name;
            colmap_paths.push_back(epochs[k].folder.images[j].path);
          }
      }
      std::vector<ExportTrack> tracks;
      for (std::size_t t = 0; t < adjusted.track_list.size(); ++t) {
        if (!adjusted.track_used[t] || !adjusted.points[t].allFinite()) continue;
        ExportTrack track{adjusted.points[t], {}};
        for (const TrackObservation& o : adjusted.track_list[t].observations)
          if (o.image >= 0 && static_cast<std::size_t>(o.image) < colmap_images.size())
            track.observations.push_back({static_cast<std::size_t>(o.image), o.pixel});
        if (track.observations.size() >= 2) tracks.push_back(std::move(track));
      }
      AdjustedColmapOptions colmap_options;
      colmap_options.format = colmap_format == "binary" ? ColmapFormat::binary : ColmapFormat::text;
      colmap_options.protected_folders = export_options.protected_folders;
      const AdjustedColmapReport colmap = write_adjusted_colmap(colmap_images, colmap_paths, tracks, work, colmap_options);
      // The same orientation for MicMac (io/micmac_orientation.hpp): DIR/adjusted/micmac/ is a MicMac
      // project with Ori-diachron/, links to the images under their Homol names (the names MicMac's
      // Homol/ and Ori- use) and to DIR/Homol, so that Malt, C3DC or Campari run in it as they are.
      const MicmacExport micmac = write_micmac_export(work + "/adjusted/micmac", epochs, images_homol_named(images, epochs),
                                                      epochs[reference].folder.dsm.statistics().mean);
      if (pictures) write_residual_pictures(work + "/adjusted/residuals", epochs, reference, picture_images, adjusted);
      // The DoD after the adjustment: each free epoch's DSM placed by the similarity that best maps
      // its points onto where the adjusted orientation puts them (eval/dsm_reintersection.hpp):
      // DIR/dod/<epoch>.*, in the rough one's colours.
      for (EpochDod& d : dods) {
        const std::size_t k = d.epoch;
        DsmReintersectionOptions reintersection;
        reintersection.threads = threads;
        const DsmReintersection placed =
            reintersect_dsm(epochs[k].folder.dsm, combined[k].frames, adjusted.epochs[k], reintersection);
        d.has_adjusted = true;
        if (!placed.success) {
          d.adjusted.reason = placed.reason;
          std::printf("DoD %s - %s, adjusted: none (%s)\n", epochs[k].name.c_str(), epochs[reference].name.c_str(),
                      placed.reason.c_str());
          continue;
        }
        d.nonrigid_rms = placed.rms_nonrigid;
        write_helmert_json(placed.reference_from_epoch, dod_dir + "/" + epochs[k].name + "_helmert.json");
        d.adjusted = compute_dod(dod_dir, epochs[k].name, reference_dsm, epochs[k].folder.dsm,
                                 placed.reference_from_epoch, stable_masks[k], d.adjusted_dz, threads);
        draw_dods(dod_dir, d, epochs[k].name, epochs[reference].name, stable_masks[k]);
        if (d.adjusted.success)
          std::printf("DoD %s - %s, adjusted: median %.3f, NMAD %.3f on stable terrain, %.3f, %.3f on all\n",
                      epochs[k].name.c_str(), epochs[reference].name.c_str(), d.adjusted.stable.median,
                      d.adjusted.stable.nmad, d.adjusted.all.median, d.adjusted.all.nmad);
      }
      run_clock.stage("export and DoD maps after the adjustment");
      // The grade: a camera that moved too far, an undetermined one, a wild export (adjustment/
      // adjustment_grade.hpp). A success graded low is reported as such, never as trusted.
      const AdjustmentGrade grade =
          grade_adjustment(r, std::max(exported.max_conversion_error_px, colmap.max_conversion_error_px));
      for (const std::string& reason : grade.reasons) {
        warn(warnings, "adjustment: " + reason);
        trust_reasons.push_back("adjustment: " + reason);
      }
      trust = trust_reasons.empty() ? "high" : "low";
      std::ostringstream exports;
      exports << "  \"colmap_export\": {\"model\": " << quoted("adjusted/colmap/sparse") << ", \"format\": "
              << quoted(colmap_format) << ", \"images\": " << colmap.images << ", \"points\": " << colmap.points
              << ", \"observations\": " << colmap.observations << ", \"cameras\": " << colmap.cameras.size()
              << ", \"max_conversion_error_px\": " << json_number_or_null(colmap.max_conversion_error_px)
              << ", \"mean_reprojection_error_px\": " << json_number_or_null(colmap.mean_reprojection_error_px) << "},\n";
      exports << "  \"micmac_export\": {\"ori\": " << quoted("adjusted/micmac/Ori-diachron") << ", \"calibrations\": "
              << micmac.written.calibrations.size() << ", \"max_conversion_error_px\": "
              << json_number_or_null(micmac.max_conversion_error_px) << "},\n";
      report(adjustment_json(adjusted, epochs, image_epoch, names, &exported, adjustment_options.bundle.affine_scope,
                             control, checked) +
             exports.str() + dod_json(dods, epochs));
      // Against an orthophoto the reference's ties are control points: no inter-epoch RMS of them.
      char inter[96];
      if (ortho_reference && links.empty())
        std::snprintf(inter, sizeof inter, "the orthophoto's matches as control points");
      else
        std::snprintf(inter, sizeof inter, "inter-epoch %.3f -> %.3f px", r.before.inter_epoch.rms_px,
                      r.after.inter_epoch.rms_px);
      std::printf("reprojection RMS %.3f -> %.3f px (%s); wrote %s and %s (largest COLMAP conversion error %.3f px)\n",
                  r.before.all.rms_px, r.after.all.rms_px, inter, (out_dir + "/adjusted/cameras.json").c_str(),
                  (out_dir + "/adjusted/<epoch>").c_str(), exported.max_conversion_error_px);
    }
#endif
    std::printf("trust: %s%s\n", trust.c_str(), trust_reasons.empty() ? "" : " (report.json's \"trust\" says why)");
    return finish(0);
  } catch (const std::exception& e) {
    Progress::break_line();
    std::fprintf(stderr, "match_epochs: %s\n", diachron::programs::error_text(e, verbose).c_str());
    return 1;
  }
}
