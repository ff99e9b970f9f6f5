// match_epochs: inter-epoch tie points between two epochs of aerial images (paper section 3.2):
// rough co-registration from the DSMs, overlapping image pairs, precise matching per pair.
//
//   match_epochs EPOCH1_DIR EPOCH2_DIR --out DIR [options]
//
// Each epoch folder holds a COLMAP text model (cameras.txt, images.txt, points3D.txt), images/ and
// dsm.tif in the model's frame (what make_scene writes), and optionally masks/<image name>.png (COLMAP's
// masks) or images/<stem>_Masq.tif (MicMac's): 0 where no match may be, e.g. the scan's frame and
// fiducial marks; or it is an orthophoto epoch: ortho.tif (north-up geotransform) and dsm.tif in the
// same CRS, cut into tiles (io/epoch_folder.hpp). Epoch 1 is the master (moved onto epoch 2). The
// rough co-registration comes from the DSMs (--rough auto), or is given (--rough identity|FILE).
// Writes
//   DIR/rough_helmert.json  the rough co-registration, X2 = scale R X1 + translation (helmert.json's keys)
//   DIR/Homol/              final inter-epoch tie points, MicMac Homol (both directions; names as in images.txt,
//                           unless a name has a folder or both epochs use it: then DIR/homol_names.txt)
//   DIR/report.json         counts per stage and per pair, timings
//   DIR/pairs/<a>--<b>.png  each pair's final matches
// and with --adjust (the combined adjustment, pipeline/combined_adjustment.hpp: epoch 2 fixed,
// epoch 1's poses, Fraser camera and affine parts free, intra-epoch tie points from points3D.txt
// and the inter-epoch ones above; images whose cameras hold the same values share one, or all of
// epoch 1's with --one-camera; ground control points from --gcps FILE, io/control_points.hpp), in
// epoch 2's frame:
//   DIR/adjusted/cameras.json, DIR/adjusted/<epoch>/  the adjusted orientation (io/adjusted_export.hpp)
//   DIR/adjusted/residuals/<image>.png                 reprojection residuals of epoch 1's tie points
//   the "adjustment" section of report.json (with each control point's error, and with
//   --check-points FILE the check points' errors after the rough co-registration and after it)
// Progress on stderr. Exit status: 0 success, 2 no co-registration, no match or no adjustment
// (reason printed), 1 bad input (one line). The input folders are never written to. The stages are pipeline/rough_coregistration.hpp,
// pipeline/overlapping_pairs.hpp and pipeline/precise_matching.hpp; docs/precise-matching.md says
// how the defaults were chosen.

#include <algorithm>
#include <cmath>
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

#include <diachron/core/progress.hpp>
#include <diachron/io/control_points.hpp>
#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/io/helmert_json.hpp>
#include <diachron/io/homol.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/pipeline/precise_matching.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/draw_matches.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>
#include <diachron/vision/xfeat.hpp>

#include <opencv2/imgproc.hpp>
#if DIACHRON_MATCH_EPOCHS_ADJUST
#include <diachron/adjustment/triangulation.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/distortion_precision.hpp>
#include <diachron/io/adjusted_export.hpp>
#include <diachron/pipeline/combined_adjustment.hpp>
#include <diachron/pipeline/orthophoto_reference.hpp>
#include <diachron/vision/draw_residuals.hpp>
#include <glog/logging.h>
#endif

namespace {

using namespace diachron;

const char* kUsage =
    "usage: match_epochs EPOCH1_DIR EPOCH2_DIR --out DIR [options]\n"
    "  each EPOCH_DIR: cameras.txt images.txt points3D.txt images/ dsm.tif, optionally masks/<image name>.png\n"
    "  or images/<stem>_Masq.tif (0 where no match may be: the scan's frame, fiducial marks, clouds); or an\n"
    "  orthophoto epoch: ortho.tif (grey or colour, north-up geotransform) and dsm.tif in the same CRS,\n"
    "  matched in tiles of up to 1536 px named ortho_x<X>_y<Y>.tif after their top-left orthophoto pixel\n"
    "  --rough auto|identity|FILE             epoch 1 -> epoch 2: co-registered from the DSMs (auto,\n"
    "                                         default), the identity (both epochs in one frame already:\n"
    "                                         GNSS, GCPs, a previous run), or a helmert.json FILE as\n"
    "                                         rough_coregistration writes it\n"
    "  --method correlation|patch|guided      tentative matches: interest points correlated around their\n"
    "                                         DSM + Helmert prediction (default), one-to-one transfer-\n"
    "                                         guided tiles, or keypoints guided by DSM + Helmert\n"
    "  --measure orientation|gradient|intensity  correlation's similarity (default orientation)\n"
    "  --cell PX                              correlation: one master point per PX x PX cell (default 6,\n"
    "                                         coarser on images of more than 60000 such cells: 12 on\n"
    "                                         3200 x 2400 px; time per pair grows as 1 / PX^2)\n"
    "  --max-points N                         correlation: the cell grows from 6 px on images of more\n"
    "                                         than N cells (default 60000, about 1600 x 1200 px at 6 px)\n"
    "  --matcher sift|rootsift|akaze|xfeat    patch/guided features (default rootsift; guided:\n"
    "                                         sift|rootsift|xfeat)\n"
    "  --model PATH                           XFeat ONNX file (with --matcher xfeat)\n"
    "  --fallback on|off                      dense correlation search of the DSMs when the features\n"
    "                                         find no co-registration (default on; its answers are\n"
    "                                         graded low trust; off makes failures fast)\n"
    "  --nodata V                             also treat DSM heights equal to V as holes (a dsm.tif\n"
    "                                         without a nodata tag, e.g. -9999)\n"
    "  --min-overlap F                        least overlap of a pair, share of the smaller footprint\n"
    "                                         (default 0.1)\n"
    "  --ncc-threshold T                      least NCC of a kept match (default 0.6, MicMac's; the\n"
    "                                         correlation method runs no intensity NCC)\n"
    "  --no-refine                            keep the matcher's positions (no least-squares refinement)\n"
    "  --ground-gsd G                         the ground filter's inlier threshold, GSD of the secondary\n"
    "                                         image (default 3 for correlation, 10 for patch and\n"
    "                                         guided, the paper's; correlation's is at least 1.5 GSD\n"
    "                                         of the epoch-1 image); larger for scans much finer than\n"
    "                                         their DSMs' errors (docs/precise-matching.md)\n"
    "  --sharpen A[,S]                        correlation: sharpen the epoch-1 images before matching,\n"
    "                                         an unsharp mask of amount A and Gaussian sigma S px\n"
    "                                         (default S 1; A 0 = off): for film scans blurred\n"
    "                                         beyond their grain (docs/correlation-matching.md)\n"
    "  --no-ground-filter                     skip the 3D Helmert RANSAC\n"
    "  --no-ncc                               skip the NCC validator\n"
    "  --no-pictures                          do not write pairs/*.png\n"
    "  --adjust                               then the combined adjustment (epoch 2 fixed, epoch 1\n"
    "                                         self-calibrated): DIR/adjusted/"
#if !DIACHRON_MATCH_EPOCHS_ADJUST
    " (not in this build: no Ceres)"
#endif
    "\n"
    "  --affine image|camera                  with --adjust: B1, B2 per image (default) or one pair\n"
    "                                         per camera (MicMac's Fraser calibration)\n"
    "  --hold LIST                            with --adjust: epoch 1's intrinsics held at their values\n"
    "                                         in cameras.txt, of f,cx,cy,K1,K2,K3,P1,P2 (e.g. K3 on a\n"
    "                                         block too weak to tell it from K1, K2 and f)\n"
    "  --prior LIST                           with --adjust: epoch 1's intrinsics tied to their values\n"
    "                                         in cameras.txt with a standard deviation, e.g. from a\n"
    "                                         calibration certificate: NAME=SIGMA,... of f,cx,cy (px),\n"
    "                                         K1,K2,K3,P1,P2 (e.g. f=2,cx=1,cy=1); between --hold and free\n"
    "  --one-camera                           with --adjust: epoch 1's images share one camera (the\n"
    "                                         first image's values), e.g. one film camera whose SfM\n"
    "                                         gave each scan its own; without it images share a\n"
    "                                         camera when cameras.txt gives them the same values\n"
    "  --gcps FILE                            with --adjust: ground control points, lines 'point NAME\n"
    "                                         X Y Z SIGMA' (epoch 2's frame) and 'obs NAME IMAGE X Y'\n"
    "                                         (IMAGE of either images.txt, diachron pixels; io/\n"
    "                                         control_points.hpp); report.json gives their errors\n"
    "  --check-points FILE                    with --adjust: independent check points, the same layout\n"
    "                                         (SIGMA ignored; observations in epoch 1's images): their\n"
    "                                         errors after the rough co-registration and after the\n"
    "                                         adjustment (the paper's table) on stdout and report.json\n"
    "  --threads N                            worker threads, 0 = all cores (default 0)\n"
    "  --quiet                                no progress on stderr\n";

std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') q += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    q += c;
  }
  return q + "\"";
}

// A file name for a pair picture: the image names with '/' made safe.
std::string safe(std::string name) {
  for (char& c : name)
    if (c == '/' || c == '\\' || c == ' ') c = '_';
  return name;
}


// The names of the images in Homol/. MicMac names tie-point files after the images, without
// folders, and one name must mean one image. The names of images.txt are kept when they allow that;
// when a name has a folder ("1954/0001.tif", as COLMAP allows) or both epochs use the same name
// (both numbered from 0001), every name becomes "e1_" or "e2_" + the name with '/' turned into '_',
// and DIR/homol_names.txt says which is which. Decided before any work, so that a clash stops the
// run at once instead of after the matching.
struct HomolNames {
  std::vector<std::string> e1, e2;
  bool renamed = false;
};

HomolNames homol_names(const EpochFolder& e1, const EpochFolder& e2) {
  HomolNames out;
  std::set<std::string> seen;
  bool plain = true;
  for (const EpochFolder* e : {&e1, &e2})
    for (const EpochImage& image : e->images)
      plain = plain && image.name.find('/') == std::string::npos && seen.insert(image.name).second;
  out.renamed = !plain;
  seen.clear();
  for (int k = 0; k < 2; ++k) {
    const EpochFolder& e = k == 0 ? e1 : e2;
    std::vector<std::string>& names = k == 0 ? out.e1 : out.e2;
    for (const EpochImage& image : e.images) {
      std::string name = image.name;
      if (out.renamed) {
        for (char& c : name)
          if (c == '/') c = '_';
        name = (k == 0 ? "e1_" : "e2_") + name;
      }
      DIACHRON_CHECK(seen.insert(name).second, "two images of epoch " << k + 1 << " would share the Homol name '"
                                                                       << name << "' (one is '" << image.name
                                                                       << "'): rename one of them");
      names.push_back(name);
    }
  }
  return out;
}

void write_homol_names(const std::string& path, const EpochFolder& e1, const EpochFolder& e2, const HomolNames& n) {
  std::ofstream out(path);
  DIACHRON_CHECK(out.good(), "cannot write " << path);
  out << "# epoch, image name in images.txt, its name in Homol/\n";
  for (std::size_t i = 0; i < e1.images.size(); ++i) out << "1 " << e1.images[i].name << ' ' << n.e1[i] << '\n';
  for (std::size_t i = 0; i < e2.images.size(); ++i) out << "2 " << e2.images[i].name << ' ' << n.e2[i] << '\n';
  DIACHRON_CHECK(out.good(), "cannot write " << path);
}

// The pictures are drawn on copies of the images at most kPictureSidePx on their longer side:
// full-resolution archive scans (12000 px and more) would make PNGs of hundreds of MB per pair and
// keep gigabytes of images in this cache. Images up to that size are drawn as they are.
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

// An epoch's name in adjusted/: its folder's name ("/data/1954/" -> "1954").
std::string folder_name(std::string dir) {
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  const std::size_t slash = dir.find_last_of('/');
  return slash == std::string::npos ? dir : dir.substr(slash + 1);
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

std::string json_number_or_null(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream o;
  o.precision(10);
  o << v;
  return o.str();
}

// The control points of a control-point file with their image names resolved in the two epochs:
// each name must be an image of exactly one of them.
// `what` names them in messages ("control point", "check point").
std::vector<CombinedControlPoint> combined_control_points(const std::vector<ControlPointRecord>& records,
                                                          const EpochFolder& e1, const EpochFolder& e2,
                                                          const char* what) {
  std::map<std::string, std::pair<int, int>> where;  // name -> (epoch 1 or 2, index)
  for (int epoch : {1, 2}) {
    const EpochFolder& e = epoch == 1 ? e1 : e2;
    for (std::size_t i = 0; i < e.images.size(); ++i) {
      const auto [it, inserted] = where.emplace(e.images[i].name, std::make_pair(epoch, static_cast<int>(i)));
      if (!inserted && it->second.first != epoch) it->second.first = 0;  // in both epochs
    }
  }
  std::vector<CombinedControlPoint> out;
  for (const ControlPointRecord& r : records) {
    CombinedControlPoint g{r.position, r.sigma, {}, {}};
    for (const auto& [image, pixel] : r.observations) {
      const auto it = where.find(image);
      DIACHRON_CHECK(it != where.end(), what << " " << r.name << ": no image '" << image << "' in either epoch");
      DIACHRON_CHECK(it->second.first != 0,
                     what << " " << r.name << ": image '" << image << "' is in both epochs; rename one of them");
      (it->second.first == 1 ? g.epoch1 : g.epoch2).push_back({it->second.second, pixel});
    }
    out.push_back(std::move(g));
  }
  return out;
}

// The "adjustment" section of report.json.
// `names`: the images' names, epoch 1's then epoch 2's (CombinedAdjustmentResult::image_camera's order).
std::string adjustment_json(const CombinedAdjustmentResult& a, const std::vector<std::string>& names,
                            const AdjustedExportReport* exported, AffineScope affine_scope,
                            const std::vector<ControlPointRecord>& control,
                            const std::optional<std::pair<CheckPointReport, CheckPointReport>>& checked) {
  const BundleReport& r = a.report;
  std::ostringstream o;
  o << "  \"adjustment\": {\"success\": " << (r.success ? "true" : "false") << ", \"message\": " << quoted(r.message)
    << ", \"affine_scope\": " << quoted(affine_scope == AffineScope::per_camera ? "per_camera" : "per_image")
    << ",\n    \"tracks\": {\"input\": " << r.tracks_input << ", \"used\": " << r.tracks_used
    << ", \"inter_epoch\": " << r.inter_epoch_tracks << ", \"rejected\": " << r.tracks_rejected
    << ", \"dropped_conflicting\": " << a.tracks.dropped_conflicting << "}, \"observations\": {\"used\": "
    << r.observations_used << ", \"rejected\": " << r.observations_rejected << "},\n    \"before\": {\"all\": "
    << json_rms(r.before.all) << ", \"intra_epoch\": " << json_rms(r.before.intra_epoch)
    << ", \"inter_epoch\": " << json_rms(r.before.inter_epoch) << "},\n    \"after\": {\"all\": "
    << json_rms(r.after.all) << ", \"intra_epoch\": " << json_rms(r.after.intra_epoch)
    << ", \"inter_epoch\": " << json_rms(r.after.inter_epoch) << "},\n    \"sigma0\": " << json_number_or_null(r.sigma0)
    << ", \"covariance\": " << quoted(r.covariance_available ? "available" : r.covariance_message)
    << ",\n    \"cameras\": [";
  const std::size_t n1 = a.epoch1.size();
  for (std::size_t c = 0; c < r.cameras.size(); ++c) {
    // The camera's first image (epoch 1's images first, then epoch 2's).
    const auto at = std::find(a.image_camera.begin(), a.image_camera.end(), r.cameras[c].camera);
    const auto first = static_cast<std::size_t>(at - a.image_camera.begin());
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
    o << "}, \"epoch\": " << (first < n1 ? 1 : 2) << ", \"images\": [";
    for (std::size_t i = 0, k = 0; i < a.image_camera.size(); ++i)
      if (a.image_camera[i] == r.cameras[c].camera) o << (k++ ? ", " : "") << quoted(names[i]);
    o << "], \"distortion_sigma\": ";
    // The covariance carried to the distortion over the image (eval/distortion_precision.hpp): what
    // the block determines, without the truth.
    const Frame<FraserAffine>* frame =
        first < n1 ? &a.epoch1[first] : first < n1 + a.epoch2.size() ? &a.epoch2[first - n1] : nullptr;
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
  if (checked) {
    // Per axis mu, sigma, |mu| (mean of |e|) and RMS of e = triangulated - given, epoch-2 units.
    const auto stats = [&o](const CheckPointReport& c) {
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
    };
    o << "{\"rough\": ";
    stats(checked->first);
    o << ",\n      \"adjusted\": ";
    stats(checked->second);
    o << "}";
  } else {
    o << "null";
  }
  o << ",\n    \"max_conversion_error_px\": "
    << (exported ? json_number_or_null(exported->max_conversion_error_px) : std::string("null"))
    << ", \"seconds\": " << r.seconds << "},\n";
  return o.str();
}

// One picture per epoch-1 image: its tie-point observations and their reprojection residuals
// after the adjustment (observed - projected), magnified.
void write_residual_pictures(const std::string& dir, const EpochFolder& e1, PictureImages& images,
                             const CombinedAdjustmentResult& a) {
  make_folder(dir, "match_epochs");
  const std::size_t n1 = e1.images.size();
  std::vector<std::vector<Vec2>> pixels(n1), residuals(n1);
  for (std::size_t t = 0; t < a.track_list.size(); ++t) {
    if (!a.track_used[t]) continue;
    for (const TrackObservation& o : a.track_list[t].observations) {
      if (o.image < 0 || static_cast<std::size_t>(o.image) >= n1) continue;
      const std::optional<Vec2> p = a.epoch1[static_cast<std::size_t>(o.image)].project(a.points[t]);
      if (!p) continue;
      pixels[static_cast<std::size_t>(o.image)].push_back(images[static_cast<std::size_t>(o.image)].at(o.pixel));
      residuals[static_cast<std::size_t>(o.image)].push_back(o.pixel - *p);
    }
  }
  for (std::size_t i = 0; i < n1; ++i) {
    std::string name = safe(e1.images[i].name);
    const std::size_t dot = name.find_last_of('.');
    if (dot != std::string::npos && dot > 0) name.erase(dot);  // "a.tif" -> "a.png"
    write_residuals_png(dir + "/" + name + ".png", images[i].image, pixels[i], residuals[i]);
  }
}
#endif

// The ground filter's threshold (GSD of the secondary image) that `method` uses: correlation matches
// have their own, tighter one (PreciseCorrelationOptions); the descriptor methods the shared one.
template <class Options>
auto& ground_threshold_gsd(Options& options, const std::string& method) {
  return method == "correlation" ? options.correlation.ground_threshold_gsd : options.ground.threshold_gsd;
}

void write_report(const std::string& path, const EpochFolder& e1, const EpochFolder& e2,
                  const RoughCoregistrationReport& rough, const std::string& rough_source,
                  const OverlappingPairsResult& overlap,
                  const PreciseMatchingReport& precise, const PreciseMatchingOptions& options,
                  const std::string& method, const std::string& matcher, const std::string& adjustment_section = "") {
  std::ofstream out(path);
  DIACHRON_CHECK(out.good(), "cannot write " << path);
  out.precision(10);
  out << "{\n  \"method\": " << quoted(method) << ",\n  \"matcher\": " << quoted(matcher) << ",\n";
  out << adjustment_section;
  out << "  \"epochs\": [{\"kind\": " << quoted(e1.is_ortho() ? "orthophoto" : "photos") << ", \"images\": "
      << e1.images.size() << "}, {\"kind\": " << quoted(e2.is_ortho() ? "orthophoto" : "photos")
      << ", \"images\": " << e2.images.size() << "}],\n";
  out << "  \"rough_coregistration\": {\"source\": " << quoted(rough_source)
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
      << ", \"seconds\": " << rough.seconds.total << "},\n";
  out << "  \"overlapping_pairs\": {\"candidates\": " << overlap.candidate_pairs
      << ", \"overlapping\": " << overlap.overlapping_pairs << ", \"kept\": " << overlap.pairs.size()
      << ", \"invalid_footprints\": [" << overlap.invalid_master_footprints << ", "
      << overlap.invalid_secondary_footprints << "], \"message\": " << quoted(overlap.message) << "},\n";
  out << "  \"ground_filter\": {\"on\": " << (options.use_ground_filter ? "true" : "false")
      << ", \"threshold_gsd\": " << ground_threshold_gsd(options, method);
  if (method == "correlation") out << ", \"floor_master_gsd\": " << options.correlation.ground_floor_master_gsd;
  out << "},\n";
  if (method == "correlation")
    out << "  \"master_sharpen\": {\"amount\": " << options.correlation.master_sharpen.amount
        << ", \"sigma_px\": " << options.correlation.master_sharpen.sigma_px << "},\n";
  out << "  \"masks\": {\"epoch1\": " << e1.masks() << ", \"epoch2\": " << e2.masks() << "},\n";
  out << "  \"precise_matching\": {\"success\": " << (precise.success ? "true" : "false")
      << ", \"message\": " << quoted(precise.message) << ", \"tentative\": " << precise.tentative
      << ", \"after_ground_filter\": " << precise.grounded << ", \"final\": " << precise.final_matches
      << ", \"seconds_features\": " << precise.seconds_features << ", \"seconds\": " << precise.seconds_total
      << ",\n    \"pairs\": [";
  for (std::size_t k = 0; k < precise.pairs.size(); ++k) {
    const PrecisePairReport& p = precise.pairs[k];
    const ImagePairOverlap& o = overlap.pairs[k];
    out << (k ? ",\n      " : "\n      ") << "{\"master\": " << quoted(e1.images[p.master].name)
        << ", \"secondary\": " << quoted(e2.images[p.secondary].name) << ", \"overlap_fraction\": " << o.fraction_of_smaller
        << ", \"tentative\": " << p.tentative.size() << ", \"masked\": " << p.masked
        << ", \"after_ground_filter\": " << p.grounded.size() << ", \"final\": " << p.matches.size()
        << ", \"message\": " << quoted(p.message)
        << ", \"seconds\": {\"images\": " << p.seconds.images << ", \"tentative\": " << p.seconds.tentative
        << ", \"ground\": " << p.seconds.ground << ", \"ncc\": " << p.seconds.ncc << ", \"total\": " << p.seconds.total
        << "}}";
  }
  out << "]}\n}\n";
  out.close();
  DIACHRON_CHECK(!out.fail(), "cannot write " << path);
}

}  // namespace

int main(int argc, char** argv) {
  // affine: "" (not given: per image), "image" or "camera".
  std::string dir1, dir2, out_dir, method = "correlation", matcher_name = "rootsift", model_path, measure, affine;
  PreciseMatchingOptions options;
  OverlappingPairsOptions overlap_options;
  bool quiet = false, pictures = true, adjust = false, fallback = true, one_camera = false;
  std::string hold;  // --hold: epoch 1's intrinsics held, comma-separated names
  std::string prior;  // --prior: epoch 1's intrinsic priors, NAME=SIGMA,...
  std::string gcps;  // --gcps: the control-point file
  std::string checks;  // --check-points: the check-point file
  std::string rough_mode = "auto";  // --rough: auto, identity or a helmert.json
  double min_overlap = 0.1;
  std::optional<int> cell;  // unset: the default cell
  std::optional<long long> max_points;  // unset: PreciseCorrelationOptions' bound
  std::optional<double> ground_gsd;     // unset: the method's default threshold
  std::optional<std::string> sharpen;   // unset: PreciseCorrelationOptions' master_sharpen
  GeoTiffReadOptions dsm_read;
  std::size_t threads = 0;
#if DIACHRON_MATCH_EPOCHS_ADJUST
  // Ceres logs through glog on stderr (e.g. a trust-region step it rejected); the adjustment's
  // report and report.json say what matters, so only fatal messages are let through.
  FLAGS_minloglevel = google::GLOG_FATAL;
#endif
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        DIACHRON_CHECK(i + 1 < argc, "missing value after " << a);
        return argv[++i];
      };
      if (a == "--out") out_dir = value();
      else if (a == "--method") method = value();
      else if (a == "--matcher") matcher_name = value();
      else if (a == "--measure") measure = value();
      else if (a == "--cell") cell = std::stoi(value());
      else if (a == "--max-points") max_points = std::stoll(value());
      else if (a == "--model") model_path = value();
      else if (a == "--min-overlap") min_overlap = std::stod(value());
      else if (a == "--rough") rough_mode = value();
      else if (a == "--nodata") {
        dsm_read.assume_untagged_nodata = true;
        dsm_read.untagged_nodata = std::stod(value());
      }
      else if (a == "--fallback") {
        const std::string f = value();
        DIACHRON_CHECK(f == "on" || f == "off", "--fallback wants on or off, got '" << f << "'");
        fallback = f == "on";
      }
      else if (a == "--ncc-threshold") options.ncc.min_ncc = std::stod(value());
      else if (a == "--no-refine") options.ncc.refine = false;
      else if (a == "--ground-gsd") ground_gsd = std::stod(value());
      else if (a == "--sharpen") sharpen = value();
      else if (a == "--no-ground-filter") options.use_ground_filter = false;
      else if (a == "--no-ncc") options.use_ncc = false;
      else if (a == "--no-pictures") pictures = false;
      else if (a == "--threads") threads = std::stoul(value());
      else if (a == "--adjust") adjust = true;
      else if (a == "--affine") affine = value();
      else if (a == "--one-camera") one_camera = true;
      else if (a == "--hold") hold = value();
      else if (a == "--prior") prior = value();
      else if (a == "--gcps") gcps = value();
      else if (a == "--check-points") checks = value();
      else if (a == "--quiet") quiet = true;
      else if (a == "--help" || a == "-h") {
        std::cout << kUsage;
        return 0;
      } else if (!a.empty() && a[0] == '-') DIACHRON_CHECK(false, "unknown option " << a);
      else if (dir1.empty()) dir1 = a;
      else if (dir2.empty()) dir2 = a;
      else DIACHRON_CHECK(false, "unexpected argument " << a);
    }
    DIACHRON_CHECK(!dir1.empty() && !dir2.empty() && !out_dir.empty(), "two epoch folders and --out DIR are required");
    // A given transform is read before any work: a missing or malformed file fails fast.
    std::optional<Helmert3> given_rough;
    if (rough_mode == "identity") given_rough = Helmert3::identity();
    else if (rough_mode != "auto") {
      DIACHRON_CHECK(!rough_mode.empty(), "--rough wants auto, identity or a helmert.json file");
      DIACHRON_CHECK(is_regular_file(rough_mode), "--rough: '" << rough_mode
                                                                << "' is neither auto, identity nor a file");
      given_rough = read_helmert_json(rough_mode);
    }
#if !DIACHRON_MATCH_EPOCHS_ADJUST
    DIACHRON_CHECK(!adjust, "--adjust needs a build with Ceres (diachron::adjustment)");
#endif
    DIACHRON_CHECK(affine.empty() || affine == "image" || affine == "camera",
                   "unknown --affine '" << affine << "' (image or camera)");
    DIACHRON_CHECK(adjust || affine.empty(), "--affine needs --adjust");
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
    DIACHRON_CHECK(method == "patch" || method == "guided" || method == "correlation",
                   "unknown --method '" << method << "' (correlation, patch or guided)");
    if (measure == "intensity") options.correlation.match.measure = CorrelationMeasure::intensity;
    else if (measure == "gradient") options.correlation.match.measure = CorrelationMeasure::gradient;
    else if (measure == "orientation" || measure.empty()) options.correlation.match.measure = CorrelationMeasure::orientation;
    else DIACHRON_CHECK(false, "unknown --measure '" << measure << "' (orientation, gradient or intensity)");
    DIACHRON_CHECK(measure.empty() || method == "correlation", "--measure goes with --method correlation");
    DIACHRON_CHECK(!cell || method == "correlation", "--cell goes with --method correlation");
    if (cell) {
      DIACHRON_CHECK(*cell >= 2, "--cell wants a side of at least 2 px, got " << *cell);
      options.correlation.use_fixed_cell(*cell);
    }
    DIACHRON_CHECK(!max_points || method == "correlation", "--max-points goes with --method correlation");
    DIACHRON_CHECK(!max_points || !cell, "--cell and --max-points both set the cell: give one of them");
    if (max_points) {
      DIACHRON_CHECK(*max_points >= 1, "--max-points wants at least 1 point per image, got " << *max_points);
      options.correlation.max_points_per_image = static_cast<std::size_t>(*max_points);
    }
    if (ground_gsd) {
      DIACHRON_CHECK(std::isfinite(*ground_gsd) && *ground_gsd > 0.0,
                     "--ground-gsd wants a threshold > 0 (GSD of the secondary image), got " << *ground_gsd);
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
    DIACHRON_CHECK(matcher_name == "sift" || matcher_name == "rootsift" || matcher_name == "akaze" ||
                       matcher_name == "xfeat",
                   "unknown --matcher '" << matcher_name << "'");
    DIACHRON_CHECK(method != "guided" || matcher_name != "akaze",
                   "--method guided takes sift, rootsift or xfeat features (AKAZE's are binary)");
    DIACHRON_CHECK(matcher_name != "xfeat" || !model_path.empty(), "--matcher xfeat needs --model PATH");
    // The report names what made the matches: the measure for correlation, the features otherwise.
    if (method == "correlation") matcher_name = to_string(options.correlation.match.measure);
    options.threads = threads;
    options.check();
    overlap_options.check();
    ProgressCallback progress;
    if (!quiet)
      progress = [clock = std::make_shared<ProgressClock>()](const ProgressEvent& e) {
        // Padded: a line shorter than the one it overwrites leaves no tail behind.
        std::fprintf(stderr, "\r%-72s", progress_line(e, (*clock)(e)).c_str());
        if (e.done >= e.total) std::fprintf(stderr, "\n");
      };
    options.progress = progress;

    const EpochFolder e1 = read_epoch_folder(dir1, dsm_read);
    const EpochFolder e2 = read_epoch_folder(dir2, dsm_read);
    DIACHRON_CHECK(!adjust || !e1.is_ortho(),
                   "epoch 1 ('" << dir1 << "') is an orthophoto epoch: with --adjust an orthophoto can only be the "
                                   "reference, epoch 2; give the photo epoch first");
    for (const EpochFolder* e : {&e1, &e2})
      if (const std::optional<double> v = suspected_untagged_nodata(e->dsm); v && !dsm_read.assume_untagged_nodata)
        std::fprintf(stderr, "warning: '%s/dsm.tif' has heights of %g far below all others and no nodata tag for "
                             "them: if they are holes, pass --nodata %g\n", e->directory.c_str(), *v, *v);
#if DIACHRON_MATCH_EPOCHS_ADJUST
    const std::vector<CombinedControlPoint> control_points = combined_control_points(control, e1, e2, "control point");
    // Check points: the same resolution of names; only their epoch-1 observations count.
    std::vector<ObservedCheckPoint> check_points;
    for (const CombinedControlPoint& c : combined_control_points(check_records, e1, e2, "check point")) {
      ObservedCheckPoint p{c.position, {}};
      for (const ImagePixel& o : c.epoch1) p.observations.push_back({static_cast<std::size_t>(o.image), o.pixel});
      check_points.push_back(std::move(p));
    }
#endif
    const HomolNames names = homol_names(e1, e2);
    make_folder(out_dir, "match_epochs");
    if (names.renamed && !quiet)
      std::fprintf(stderr, "image names with a folder or shared by both epochs: Homol/ uses e1_/e2_ names "
                           "(DIR/homol_names.txt)\n");
    if (!quiet)
      for (const EpochFolder* e : {&e1, &e2})
        std::fprintf(stderr, "epoch %d: %zu %s (%zu masked), DSM %d x %d\n", e == &e1 ? 1 : 2, e->images.size(),
                     e->is_ortho() ? "orthophoto tiles" : "images", e->masks(), e->dsm.width(), e->dsm.height());

    // 1. Rough co-registration: from the DSMs (its defaults: SIFT on slope images), or given.
    RoughCoregistrationReport rough;
    if (given_rough) {
      rough.success = true;
      rough.epoch2_from_epoch1 = *given_rough;
      rough.message = rough_mode == "identity" ? "given: the identity (--rough identity)"
                                               : "given: " + rough_mode + " (--rough FILE)";
    } else {
      RoughCoregistrationOptions rough_options;
      rough_options.threads = threads;
      rough_options.progress = progress;
      rough_options.correlation_fallback = fallback;
      rough = rough_coregistration(e1.dsm, e2.dsm, ExtractorPairMatcher<SiftExtractor>(SiftExtractor{}), rough_options);
    }
    const std::string rough_source = rough_mode == "auto" ? "dsm" : rough_mode == "identity" ? "identity" : "file";
    std::printf("rough co-registration: %s\n", rough.message.c_str());
    OverlappingPairsResult overlap;
    overlap_options.min_overlap_fraction = min_overlap;
    PreciseMatchingReport precise;
    if (!rough.success) {
      write_report(out_dir + "/report.json", e1, e2, rough, rough_source, overlap, precise, options, method, matcher_name);
      std::printf("no co-registration: %s\n", rough.message.c_str());
      return 2;
    }
    write_helmert_json(rough.epoch2_from_epoch1, out_dir + "/rough_helmert.json");

    // 2. Overlapping pairs through the DSMs, epoch 1's footprints moved by the Helmert. Photos and
    // orthophoto tiles alike, through EpochFrame.
    std::vector<EpochFrame> frames1, frames2;
    std::vector<FootprintImage<EpochFrame>> footprints1, footprints2;
    for (const EpochImage& im : e1.images) frames1.push_back(im.epoch_frame());
    for (const EpochImage& im : e2.images) frames2.push_back(im.epoch_frame());
    for (const EpochFrame& f : frames1) footprints1.push_back({f, f.width(), f.height()});
    for (const EpochFrame& f : frames2) footprints2.push_back({f, f.width(), f.height()});
    overlap_options.threads = threads;
    overlap = overlapping_pairs(footprints1, e1.dsm, footprints2, e2.dsm, rough.epoch2_from_epoch1, overlap_options);
    std::printf("overlapping pairs: %zu of %zu candidates (%s)\n", overlap.pairs.size(), overlap.candidate_pairs,
                overlap.message.c_str());
    if (overlap.pairs.empty()) {
      write_report(out_dir + "/report.json", e1, e2, rough, rough_source, overlap, precise, options, method, matcher_name);
      std::printf("no overlapping pair: %s\n", overlap.message.c_str());
      return 2;
    }

    // 3. Precise matching per pair.
    PreciseEpoch<EpochFrame> p1{frames1, [&e1](std::size_t i) { return e1.load_image(i); }, &e1.dsm,
                                [&e1](std::size_t i) { return e1.load_mask(i); }};
    PreciseEpoch<EpochFrame> p2{frames2, [&e2](std::size_t i) { return e2.load_image(i); }, &e2.dsm,
                                [&e2](std::size_t i) { return e2.load_mask(i); }};
    SiftOptions sift_options;
    sift_options.root_sift = matcher_name == "rootsift";
    if (method == "correlation") {
      precise = precise_matching_correlation(p1, p2, rough.epoch2_from_epoch1, overlap.pairs, options);
    } else if (method == "patch") {
      if (matcher_name == "akaze")
        precise = precise_matching_patch(p1, p2, rough.epoch2_from_epoch1, overlap.pairs,
                                         ExtractorPairMatcher<AkazeExtractor>(AkazeExtractor{}), options);
      else if (matcher_name == "xfeat")
        precise = precise_matching_patch(p1, p2, rough.epoch2_from_epoch1, overlap.pairs, XFeatPairMatcher(model_path),
                                         options);
      else
        precise = precise_matching_patch(p1, p2, rough.epoch2_from_epoch1, overlap.pairs,
                                         ExtractorPairMatcher<SiftExtractor>(SiftExtractor(sift_options)), options);
    } else {
      if (matcher_name == "xfeat") {
        options.guided.metric = DescriptorDistance::Cosine;
        precise = precise_matching_guided(p1, p2, rough.epoch2_from_epoch1, overlap.pairs, XFeatExtractor(model_path),
                                          options);
      } else {
        precise = precise_matching_guided(p1, p2, rough.epoch2_from_epoch1, overlap.pairs, SiftExtractor(sift_options),
                                          options);
      }
    }

    // 4. Outputs.
    write_report(out_dir + "/report.json", e1, e2, rough, rough_source, overlap, precise, options, method, matcher_name);
    const std::string homol = out_dir + "/Homol";
    make_folder(homol, "match_epochs");
    if (names.renamed) write_homol_names(out_dir + "/homol_names.txt", e1, e2, names);
    if (pictures) make_folder(out_dir + "/pairs", "match_epochs");
    PictureImages pictures1(e1), pictures2(e2);
    for (const PrecisePairReport& p : precise.pairs) {
      const std::string& a = e1.images[p.master].name;
      const std::string& b = e2.images[p.secondary].name;
      std::printf("%s -- %s: %zu tentative, %zu after the ground filter, %zu final\n", a.c_str(), b.c_str(),
                  p.tentative.size(), p.grounded.size(), p.matches.size());
      if (p.matches.empty()) continue;
      write_homol(homol, names.e1[p.master], names.e2[p.secondary], p.matches);
      if (pictures) {
        const Picture& pa = pictures1[p.master];
        const Picture& pb = pictures2[p.secondary];
        PointMatches drawn = p.matches;
        for (PointMatch& m : drawn) {
          m.a = pa.at(m.a);
          m.b = pb.at(m.b);
        }
        write_matches_png(out_dir + "/pairs/" + safe(a) + "--" + safe(b) + ".png", pa.image, pb.image, drawn);
      }
    }
    std::printf("%s (%.1f s)\n", precise.message.c_str(), precise.seconds_total);
    if (!precise.success) {
      std::printf("no inter-epoch match: %s\n", precise.message.c_str());
      return 2;
    }
#if DIACHRON_MATCH_EPOCHS_ADJUST
    if (adjust) {
      // 5. The combined adjustment, epoch 2 as the reference.
      CombinedAdjustmentOptions adjustment_options;
      if (affine == "camera") adjustment_options.bundle.affine_scope = AffineScope::per_camera;
      if (!held.empty() || !priors.empty()) {
        EpochFreedom epoch1 = EpochFreedom::all_free();
        epoch1.fixed_intrinsics = held;
        epoch1.intrinsic_priors = priors;
        adjustment_options.bundle.epochs = {epoch1, EpochFreedom::all_fixed()};  // the stage's default, K's held
      }
      const CombinedEpoch combined1 = combined_epoch(e1, one_camera);
      // An orthophoto reference is no image of the adjustment: its matches become control points
      // observed in epoch 1's images (pipeline/orthophoto_reference.hpp).
      std::vector<CombinedControlPoint> all_control = control_points;
      if (e2.is_ortho()) {
        std::vector<OrthoFrame> tiles;
        for (const EpochImage& t : e2.images) tiles.push_back(*t.ortho);
        const double sigma =
            orthophoto_control_sigma(combined1.frames, rough.epoch2_from_epoch1, e2.dsm.statistics().mean,
                                     e2.ortho.cell_size(), adjustment_options.bundle.inter_epoch_sigma_px);
        const OrthophotoControlPoints from_ortho = orthophoto_control_points(precise.pairs, tiles, e2.dsm, sigma);
        all_control.insert(all_control.end(), from_ortho.points.begin(), from_ortho.points.end());
        std::printf("orthophoto reference: %zu of %zu matches as control points (sigma %.3g epoch-2 units), %zu "
                    "without DSM height\n",
                    from_ortho.points.size(), from_ortho.matches, sigma, from_ortho.off_dsm);
      }
      const CombinedAdjustmentResult adjusted =
          combined_adjustment(combined1, e2.is_ortho() ? CombinedEpoch{} : combined_epoch(e2, false),
                              e2.is_ortho() ? std::vector<EpochPairMatches>{} : epoch_pair_matches(precise.pairs),
                              rough.epoch2_from_epoch1, adjustment_options, all_control);
      std::vector<std::string> names;
      for (const EpochFolder* e : {&e1, &e2})
        if (!e->is_ortho())
          for (const EpochImage& image : e->images) names.push_back(image.name);
      const BundleReport& r = adjusted.report;
      std::printf("adjustment: %s\n", r.message.c_str());
      if (!control.empty()) {
        std::size_t used = 0;
        double worst = 0.0;
        for (const ControlPointOutcome& g : adjusted.control_points)
          if (g.used) {
            ++used;
            worst = std::max(worst, g.error.norm());
          }
        std::printf("control points: %zu of %zu used, largest error %.3f (epoch-2 units; report.json lists them)\n",
                    used, control.size(), worst);
      }
      // The check points triangulated in epoch 1's images, after the rough co-registration alone and
      // after the adjustment: the paper's check-point table.
      std::optional<std::pair<CheckPointReport, CheckPointReport>> checked;
      if (!check_records.empty()) {
        const std::vector<Frame<FraserAffine>> moved =
            transformed_frames(combined1.frames, rough.epoch2_from_epoch1);
        checked.emplace(evaluate_check_points(check_points, FrameTriangulator<FraserAffine>(moved)),
                        r.success ? evaluate_check_points(check_points, FrameTriangulator<FraserAffine>(adjusted.epoch1))
                                  : CheckPointReport{});
        std::printf("check points (epoch-2 units), %zu of %zu triangulated in epoch 1's images:\n",
                    checked->first.num_used, check_points.size());
        std::printf("| orientation    | axis |    mean |  sigma | mean |e| |    RMS |\n");
        for (const auto& [name, c] : {std::make_pair("rough only", &checked->first), std::make_pair("adjusted", &checked->second)}) {
          if (!c->success) continue;
          const char* axis[3] = {"x", "y", "z"};
          for (std::size_t k = 0; k < 3; ++k)
            std::printf("| %-14s | %s    | %7.3f | %6.3f | %8.3f | %6.3f |\n", k == 0 ? name : "", axis[k],
                        c->axes_m[k].mean, c->axes_m[k].sigma, c->axes_m[k].mean_abs, c->axes_m[k].rms);
        }
        if (checked->first.success && checked->second.success)
          std::printf("3D RMS: rough only %.3f, adjusted %.3f\n", checked->first.rms_3d_m, checked->second.rms_3d_m);
      }
      if (!r.success) {
        write_report(out_dir + "/report.json", e1, e2, rough, rough_source, overlap, precise, options, method, matcher_name,
                     adjustment_json(adjusted, names, nullptr, adjustment_options.bundle.affine_scope, control, checked));
        std::printf("no adjustment: %s\n", r.message.c_str());
        return 2;
      }
      // adjusted/<epoch>/ takes each folder's name; two folders of the same name become epoch1, epoch2.
      std::string name1 = folder_name(dir1), name2 = folder_name(dir2);
      if (name1 == name2 || name1.empty() || name2.empty() || name1 == "." || name2 == "." || name1 == ".." ||
          name2 == ".." || name1 == "residuals" || name2 == "residuals") {
        name1 = "epoch1";
        name2 = "epoch2";
      }
      std::vector<CamerasJsonImage> images;
      for (std::size_t i = 0; i < e1.images.size(); ++i)
        images.push_back(CamerasJsonImage::from_frame(e1.images[i].name, name1, adjusted.epoch1[i]));
      for (std::size_t i = 0; i < adjusted.epoch2.size(); ++i)  // none for an orthophoto reference
        images.push_back(CamerasJsonImage::from_frame(e2.images[i].name, name2, adjusted.epoch2[i]));
      AdjustedExportOptions export_options;
      export_options.protected_folders = {dir1, dir2};
      const AdjustedExportReport exported = write_adjusted_export(images, out_dir, export_options);
      if (pictures) write_residual_pictures(out_dir + "/adjusted/residuals", e1, pictures1, adjusted);
      write_report(out_dir + "/report.json", e1, e2, rough, rough_source, overlap, precise, options, method, matcher_name,
                   adjustment_json(adjusted, names, &exported, adjustment_options.bundle.affine_scope, control, checked));
      // Against an orthophoto the inter-epoch ties are control points: no inter-epoch RMS to give.
      char inter[96];
      if (e2.is_ortho())
        std::snprintf(inter, sizeof inter, "the orthophoto's matches as control points");
      else
        std::snprintf(inter, sizeof inter, "inter-epoch %.3f -> %.3f px", r.before.inter_epoch.rms_px,
                      r.after.inter_epoch.rms_px);
      std::printf("reprojection RMS %.3f -> %.3f px (%s); wrote %s and %s (largest COLMAP conversion error %.3f px)\n",
                  r.before.all.rms_px, r.after.all.rms_px, inter, exported.cameras_json_path.c_str(),
                  (out_dir + "/adjusted/<epoch>").c_str(), exported.max_conversion_error_px);
    }
#endif
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "match_epochs: %s\n", e.what());
    return 1;
  }
}
