// The whole of Algorithm 1 on decades-apart scenes, judged at the check points: for each seed of
// SceneOptions::decades_apart(), the rough co-registration of the DSMs, the overlapping pairs, precise
// matching (match_epochs' default method) and then, side by side on the same tracks,
//   rough        epoch 1 (estimated orientation) moved by the rough Helmert, nothing adjusted
//   intra only   epoch 1 adjusted alone with its own tie points (self-calibration, no inter-epoch
//                link), then moved by the rough Helmert: the control
//   no affine    the combined adjustment without B1, B2
//   full         the combined adjustment as shipped (pipeline/combined_adjustment.hpp)
//   e2 camera free   the same with epoch 2's camera (not its poses) free too
//   both free    both epochs free, the datum then put back on epoch 2's input centres by a similarity
//   inter sigma 1    inter-epoch matches weighted as 1 px observations, as the tie points (the
//                    default weights them as 6 px)
//   inter sigma X    the same weighted as X px observations, X from --inter-sigma (default 3, the
//                    former default)
//   affine per camera   one B1, B2 per camera instead of per image (BundleOptions::affine_scope;
//                    the scenes' film deformation is one per epoch)
//   staged       the intrinsics freed in three solves as Tapas/Campari do (f and principal point,
//                then + K1-K3, then all; BundleOptions::staged_intrinsics)
//   cauchy       Cauchy's loss instead of Huber's (same 1 px scale): large residuals weigh less
//   cauchy per camera   both of the two above
//   shuffled errors   the truth's matches at the same master points, each given the error vector of
//                another real match (a seeded shuffle): the matches' error without its structure
//   pair bias removed   the real matches, each pair's mean true error (over its matches within 3
//                px) taken off all its matches: an oracle of a free offset per pair
//   relief bias removed the same taken apart for the matches on relief (epoch 2's DSM not a plane
//                to 2 GSD around the match) and the others: an oracle of a free offset per pair for
//                the matches on relief, which the other matches would anchor
//   K3 held      epoch 1's K3 held at the SfM's value (EpochFreedom::fixed_intrinsics); the scenes'
//                SfM has K3 = 0, as the truth, so this holds the true value
//   K3 P1 P2 held   the same with P1, P2 held too, at the SfM's values: half the truth's
//   certificate free   epoch 1's cameras start from a calibration certificate instead of the SfM's
//                values: the true K1-K3, P1, P2, the true focal length + 1.5 px and principal point
//                + (1, -1) px (each image keeps its SfM's B1, B2 and pose); everything free
//   certificate prior  the same with f, cx and cy tied to the certificate by priors of 2 px
//                (EpochFreedom::intrinsic_priors)
//   certificate held   the same with f, cx and cy held at the certificate's values
//   colmap       Debian's COLMAP 3.8 bundle_adjuster on the same images and tracks (nearest COLMAP
//                cameras, no affine term; everything free, so its result is brought back onto epoch
//                2's fixed orientation by the similarity of its epoch-2 centres onto the input's)
// Check points: their true pixels in the epoch-1 images triangulated with each orientation, against
// their true position; in world metres and in epoch-1 GSD. Intrinsics: epoch 1's recovered focal
// length, principal point and distortion (eval/distortion_difference.hpp) against the true camera,
// and the whole camera with the focal length and principal point refitted (refit_*) and beyond
// what a change of pose absorbs over flat ground (beyond_pose_*), and the distortion's 1-sigma the
// adjustment predicts from its covariance (eval/distortion_precision.hpp). The distortion is also
// split in its owners: the camera's lens part (K1-K3, P1, P2) and each image's affine part (B1, B2).
// The sparse DoD (eval/dod.hpp): epoch 1's tie points triangulated with each orientation against
// epoch 2's DSM, in metres (it includes the real change of the landscape, as the paper's does).
// Two oracles bound what the matches and the reference cost: "oracle e2 frames" holds the true
// epoch-2 orientation fixed, "oracle matches" matches the same master points by the truth.
//
//   adjustment_eval [--seeds N] [--first-seed S] [--threads N] [--no-colmap] [--colmap-work DIR]
//                   [--max-relief G] [--cell PX] [--e1-block RxC] [--e1-ties N] [--e2-block RxC]
//                   [--matches-cache DIR] [--affine-step PX] [--inter-sigma PX] [--e2-scale K]
//                   [--ground-floor G] [--sharpen A,S] [--dem PATH] [--flying-height M]
//
// --max-relief G: precise matching skips master points whose ground is not locally a plane to G
// secondary GSD (PreciseCorrelationOptions::max_relief_gsd; default off, as match_epochs).
// --cell PX: correlation master points per PX px cell (default 6, as match_epochs).
// --e1-block RxC: epoch 1 flown as R strips of C images (default 2x2, SceneOptions::decades_apart()),
// at the same overlaps: how much the block's size, not the matches, limits the self-calibration.
// --e1-ties N: epoch 1's SfM hands over N intra-epoch tie point attempts (EpochOptions::tie_points,
// default 1500 in SceneOptions::decades_apart()): how much the density of the film block's own tie
// points limits the self-calibration.
// --e2-block RxC: epoch 2 (the fixed reference) flown as R strips of C images (default 3x3), at the
// same overlaps and centre. The default 3 x 3 block covers about 1.4 x 1.4 km, less than the film
// block's 2.2 x 2.0 km, so the film images' outer parts get no inter-epoch match; 5x6 covers the whole
// film block, as the reference epochs of the paper's datasets cover their historical ones.
// --e2-scale K: epoch 2's images K times larger on the same footprints (focal length times K, GSD
// divided by K; its DSM keeps 2 GSD): a resolution gap of 2 K between the epochs instead of 2.
// --ground-floor G: the correlation ground filter's floor in master GSD
// (PreciseCorrelationOptions::ground_floor_master_gsd, default 1.5; 0 = the threshold in secondary GSD alone).
// --sharpen A,S: PreciseCorrelationOptions::master_sharpen (amount A, Gaussian sigma S master px).
// --matches-cache DIR: precise matching's inter-epoch matches are read from DIR when a Homol folder
// for the seed and the options that shape them (blocks, tie points, cell, relief, affine step, epoch
// 2's scale, the ground filter's floor, the sharpening) is
// there, and written there otherwise (full precision). Precise matching is most of a seed's time (3 to 6 min
// with a 5 x 6 reference); the adjustment variants then run on the same matches in seconds. The file
// name does not know the code: empty DIR after changing the matcher or the scenes.
// --affine-step PX: the correlation's local-affine step (CorrelationMatchOptions::affine_step_px;
// default 1 px, 0 = half the window).
// --inter-sigma PX: the inter-epoch weight of the variant "inter sigma X" (px, > 0; default 3).
// --dem PATH: the scenes over this real DEM instead of the procedural relief (dsm_in_metres:
// a DEM in degrees goes to its UTM zone first). --flying-height M: every epoch M metres above the mean
// ground at the preset's GSDs (the preset: 1056 m for epoch 1, 840 m for epoch 2), for rugged
// terrain.
//
// Prints one line per seed and variant on stderr (with the solve's final Ceres cost, sigma0 and
// observations, from which nested variants can be compared by an F-test) and a Markdown table
// (medians over the seeds) on stdout. Not a test: docs/adjustment.md holds its output.

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <diachron/adjustment/bundle_adjustment.hpp>
#include <diachron/adjustment/reprojection_error.hpp>
#include <diachron/adjustment/tracks.hpp>
#include <diachron/adjustment/triangulation.hpp>
#include <diachron/core/random.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/distortion_difference.hpp>
#include <diachron/eval/distortion_precision.hpp>
#include <diachron/eval/dod.hpp>
#include <diachron/eval/match_truth.hpp>
#include <diachron/io/dsm_reproject.hpp>
#include <diachron/eval/scene_check_points.hpp>
#include <diachron/geometry/procrustes.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/homol.hpp>
#include <diachron/pipeline/combined_adjustment.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/pipeline/precise_matching.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>

#include "match_scoring.hpp"
#include "peak_shape.hpp"
#include "peers/colmap_bundle_adjuster.hpp"

using namespace diachron;
using bench::median;
using bench::seconds_since;
using bench::peak_shape;
using bench::scale_images;
using bench::PeakShape;

namespace {

using Frames = std::vector<Frame<FraserAffine>>;

// One variant's result on one seed.
struct Outcome {
  bool ran = false;
  std::string note;
  CheckPointReport check;
  double focal_error_px = std::nan("");
  double pp_error_px = std::nan("");
  // Epoch 1's camera against the truth over the image (worst, RMS, and the whole mapping with the
  // focal length and principal point refitted, refit_*, and beyond a change of pose, beyond_pose_*).
  DistortionDifference distortion;
  // The same over the pixels of epoch 1 that carry observations (tie points and inter-epoch matches):
  // what the data determine, without the corners no observation reaches.
  DistortionDifference on_observed;
  // The adjustment's own prediction: epoch 1's distortion 1-sigma over the image from the covariance
  // of its camera (eval/distortion_precision.hpp); not valid without a covariance.
  DistortionPrecision predicted;
  // The distortion split in its two owners: the camera's lens part (radial and decentring, B1 = B2 = 0
  // on both sides) and each image's affine part (the truth's lens part with that image's B1, B2),
  // worst over the image; the affine part's worst image and its median over the images.
  double lens_max_px = std::nan("");
  double affine_worst_image_px = std::nan("");
  double affine_median_image_px = std::nan("");
  double seconds = 0.0;
  DodReport dod;  ///< epoch 1's tie points against epoch 2's DSM, world metres
};

const char* const kVariants[] = {"rough",          "intra only",   "no affine",         "full",
                                 "e2 camera free", "both free",    "oracle e2 frames", "oracle matches",
                                 "inter sigma 1",  "inter sigma X", "affine per camera", "staged", "cauchy", "cauchy per camera", "shuffled errors",
                                 "peak weighted", "peak weighted X", "K3 held", "K3 P1 P2 held",
                                 "pair bias removed", "relief bias removed", "certificate free", "certificate prior",
                                 "certificate held", "colmap"};

// Check points of epoch 1 triangulated with `frames` (epoch-2 frame), errors in world metres.
CheckPointReport check_points(const Scene& scene, const Frames& frames) {
  return evaluate_scene_check_points(scene, 0, 1, FrameTriangulator<FraserAffine>(frames));
}

void judge(Outcome& o, const Scene& scene, const Frames& epoch1, const std::vector<Vec2>& observed) {
  const Camera<FraserAffine>& truth = scene.epochs[0].camera;
  const Camera<FraserAffine>& camera = epoch1.front().camera();
  o.ran = true;
  o.check = check_points(scene, epoch1);
  o.focal_error_px = std::abs(camera.focal() - truth.focal());
  o.pp_error_px = (camera.principal_point() - truth.principal_point()).norm();
  o.distortion = distortion_difference(camera, truth);
  // `lens`'s f, principal point and lens part with the affine block `affine` (B1, B2, px).
  const auto with_affine = [](const Camera<FraserAffine>& lens, const std::array<double, kAffineBlockSize>& affine) {
    return camera_from_blocks(fraser_camera_block(lens).data(), affine.data(), lens.width(), lens.height());
  };
  o.lens_max_px = distortion_difference(with_affine(camera, {}), with_affine(truth, {})).max_px;
  std::vector<double> affine;
  for (const Frame<FraserAffine>& frame : epoch1)
    affine.push_back(distortion_difference(with_affine(truth, affine_block(frame.camera())), truth).max_px);
  o.affine_worst_image_px = *std::max_element(affine.begin(), affine.end());
  o.affine_median_image_px = median(affine);
  o.on_observed = distortion_difference_at(camera, truth, observed);
  // The sparse DoD: epoch 1's tie points triangulated with these frames against epoch 2's DSM (the
  // SfM's, in its frame), heights brought to metres by the frame's scale.
  std::vector<Vec3> points;
  const FrameTriangulator<FraserAffine> triangulate(epoch1);
  for (const TiePoint& t : scene.epochs[0].tie_points)
    if (const std::optional<Vec3> p = triangulate(t.observations)) points.push_back(*p);
  o.dod = sparse_dod(points, scene.epochs[1].dsm);
  o.dod.statistics = o.dod.statistics.scaled(scene.epochs[1].world_from_epoch.scale);
}

// COLMAP's bundle_adjuster on the combined problem (epoch 1 moved by the rough Helmert, then epoch
// 2) with the tracks the combined adjustment built (`tracks`, over that image list), then the
// similarity that puts its epoch-2 centres back on the input's.
Outcome run_colmap(const Scene& scene, const Frames& e1_moved, const Frames& frames2, const std::vector<Track>& tracks,
                   const std::vector<Vec2>& observed, const std::string& work) {
  Outcome o;
  Frames all = e1_moved;
  all.insert(all.end(), frames2.begin(), frames2.end());
  const int n1 = static_cast<int>(e1_moved.size());

  bench::BaProblem problem;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const bool first = static_cast<int>(i) < n1;
    const SyntheticImage& image = scene.epochs[first ? 0 : 1].images[first ? i : i - n1];
    problem.images.push_back(CamerasJsonImage::from_frame(image.name, first ? "e1" : "e2", all[i]));
  }
  for (const Track& t : tracks) {
    const TriangulationResult p = triangulate_track(all, t);
    if (!p.success) continue;
    bench::BaTrack bt;
    bt.point = p.point;
    for (const TrackObservation& ob : t.observations) bt.observations.push_back({static_cast<std::size_t>(ob.image), ob.pixel});
    problem.tracks.push_back(std::move(bt));
  }
  const bench::ColmapBundleAdjusterRun run = bench::run_colmap_bundle_adjuster(problem, work);
  o.seconds = run.seconds;
  if (!run.success) {
    o.note = run.reason;
    return o;
  }
  // COLMAP fixes its own gauge (the first image and one coordinate of the second); epoch 2 is the
  // reference, so its adjusted centres are fitted back onto the input ones.
  std::vector<PointPair3> centres;
  for (std::size_t i = static_cast<std::size_t>(n1); i < all.size(); ++i)
    centres.push_back({run.images[i].centre, all[i].pose().centre()});
  const std::optional<Helmert3> back = fit_helmert3(centres);
  if (!back) {
    o.note = "epoch-2 centres of COLMAP's result do not determine a similarity";
    return o;
  }
  Frames e1;
  for (int i = 0; i < n1; ++i) e1.push_back(run.images[static_cast<std::size_t>(i)].frame().transformed(*back));
  judge(o, scene, e1, observed);
  o.seconds = run.seconds;
  return o;
}

std::string fmt(double v, const char* f = "%.2f") {
  if (!std::isfinite(v)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// A block's size as --e1-block / --e2-block give it ("RxC": R strips of C images); 0 keeps the scene's.
struct BlockSize {
  int rows = 0, columns = 0;
  // Parses `text` for the option `option`; throws with the option's name on anything else.
  static BlockSize parse(const std::string& option, const std::string& text) {
    BlockSize b;
    if (std::sscanf(text.c_str(), "%dx%d", &b.rows, &b.columns) != 2 || b.rows < 1 || b.columns < 1)
      throw std::runtime_error(option + " needs RxC, e.g. 3x3, got " + text);
    return b;
  }
  void apply(EpochOptions& epoch) const {
    if (rows == 0) return;
    epoch.rows = rows;
    epoch.columns = columns;
  }
};

// The matches cache (--matches-cache): a Homol folder (io/homol.hpp, no pixel shift, so the
// coordinates read back to the same doubles; scores are not kept, and the adjustment does not use
// them), images named e1_<i> and e2_<j>, and a file "complete" written last. Pairs are read back in
// `pairs`' order, the order precise matching reported them in, so the tracks come out the same.
std::string cache_image(int epoch, std::size_t index) { return "e" + std::to_string(epoch) + "_" + std::to_string(index); }

void write_matches(const std::string& folder, const std::vector<EpochPairMatches>& matches) {
  for (const EpochPairMatches& pair : matches)
    write_homol(folder, cache_image(1, pair.master), cache_image(2, pair.secondary), pair.matches, 0.0);
  std::ofstream done(folder + "/complete");
  if (!done) throw std::runtime_error("cannot write " + folder + "/complete");
}

// std::nullopt when `folder` holds no complete cache.
std::optional<std::vector<EpochPairMatches>> read_matches(const std::string& folder,
                                                          const std::vector<ImagePairOverlap>& pairs) {
  if (!is_regular_file(folder + "/complete")) return std::nullopt;
  std::vector<EpochPairMatches> matches;
  for (const ImagePairOverlap& pair : pairs) {
    const std::string path = homol_file_path(folder, cache_image(1, pair.master), cache_image(2, pair.secondary));
    if (is_regular_file(path)) matches.push_back({pair.master, pair.secondary, read_homol(path, 0.0)});
  }
  return matches;
}

// A table cell "a / b" of two medians over the seeds (worst / RMS, or worst image / median image).
struct MedianPair {
  std::vector<double> first, second;
  void add(double a, double b) {
    first.push_back(a);
    second.push_back(b);
  }
  std::string cell() const { return fmt(median(first)) + " / " + fmt(median(second)); }
};

// "peak weighted": each match's secondary pixel weighted by its correlation peak's shape
// (peak_shape.hpp). Along each principal direction of the peak's curvature the information is
// (curvature / the seed's median curvature)^0.5, clamped to [1/4, 4]: on the final matches of
// seeds 0-1 the squared error fell about as the square root of the curvature (docs/adjustment.md).
// A match without a shape gets a quarter of the median information.
std::vector<EpochPairMatches> peak_weighted(const std::vector<EpochPairMatches>& matches, const Scene& scene,
                                            const Frames& frames1, const Frames& frames2, const Helmert3& helmert,
                                            const CorrelationMatchOptions& correlation) {
  struct Shape {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> curvature;  // principal curvatures and directions
    Eigen::Matrix2d affine;
  };
  const SyntheticEpoch& e1 = scene.epochs[0];
  const SyntheticEpoch& e2 = scene.epochs[1];
  std::vector<std::vector<std::optional<Shape>>> shapes(matches.size());
  std::vector<double> curvatures;
  for (std::size_t q = 0; q < matches.size(); ++q) {
    const EpochPairMatches& pair = matches[q];
    const auto transfer = make_dsm_transfer(frames1[pair.master], e1.dsm, frames2[pair.secondary], helmert);
    for (const PointMatch& m : pair.matches) {
      const std::optional<PeakShape> shape =
          peak_shape(e1.images[pair.master].pixels, e2.images[pair.secondary].pixels, m.a, m.b, transfer, correlation);
      if (!shape) {
        shapes[q].emplace_back();
        continue;
      }
      shapes[q].push_back(Shape{Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(shape->curvature), shape->affine});
      for (int j = 0; j < 2; ++j)
        if (shapes[q].back()->curvature.eigenvalues()(j) > 0.0) curvatures.push_back(shapes[q].back()->curvature.eigenvalues()(j));
    }
  }
  const double reference = curvatures.empty() ? 1.0 : median(curvatures);
  std::vector<EpochPairMatches> out = matches;
  for (std::size_t q = 0; q < matches.size(); ++q) {
    std::vector<Eigen::Matrix2d>& weights = out[q].weights;
    weights.clear();
    for (const std::optional<Shape>& shape : shapes[q]) {
      if (!shape) {
        weights.push_back(0.5 * Eigen::Matrix2d::Identity());
        continue;
      }
      const auto& es = shape->curvature;
      Eigen::Vector2d root;  // the square root of the information per direction
      for (int j = 0; j < 2; ++j)
        root(j) = std::pow(std::clamp(es.eigenvalues()(j) / reference, 1.0 / 16.0, 16.0), 0.25);
      const Eigen::Matrix2d master_weight = es.eigenvectors() * root.asDiagonal() * es.eigenvectors().transpose();
      // Into secondary px, at the same overall scale: a residual r_b is A r_a.
      const Eigen::Matrix2d& A = shape->affine;
      weights.push_back(master_weight * A.inverse() * std::sqrt(std::abs(A.determinant())));
    }
  }
  return out;
}

// The whole run; main() turns what it throws (a bad argument, a failed scene) into one line and exit 1.
int run(int argc, char** argv) {
  int seeds = 5;
  std::uint64_t first_seed = 0;
  std::size_t threads = 0;
  bool colmap = true;
  std::string colmap_work = "adjustment_eval_colmap";
  double max_relief = 0.0;
  int cell = 0;  // 0: the library's default
  BlockSize e1_block, e2_block;
  int e1_ties = -1;  // < 0: the scene's default
  std::string matches_cache;
  double affine_step = -1.0;  // < 0: the library's default
  double inter_sigma = 3.0;   // the variant "inter sigma X"
  double e2_scale = 1.0;
  double ground_floor = -1.0;  // < 0: the library's default
  UnsharpMaskOptions sharpen;
  std::string dem_path;
  double flying_height = 0.0;  // 0: the preset's
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
      return argv[++i];
    };
    if (a == "--seeds") seeds = std::stoi(value());
    else if (a == "--first-seed") first_seed = std::stoull(value());
    else if (a == "--threads") threads = std::stoul(value());
    else if (a == "--no-colmap") colmap = false;
    else if (a == "--colmap-work") colmap_work = value();
    else if (a == "--max-relief") max_relief = std::stod(value());
    else if (a == "--cell") cell = std::stoi(value());
    else if (a == "--e1-block") e1_block = BlockSize::parse(a, value());
    else if (a == "--e2-block") e2_block = BlockSize::parse(a, value());
    else if (a == "--matches-cache") matches_cache = value();
    else if (a == "--dem") dem_path = value();
    else if (a == "--flying-height") {
      flying_height = std::stod(value());
      if (!(flying_height > 0.0) || !std::isfinite(flying_height)) throw std::runtime_error("--flying-height needs a height > 0 m");
    }
    else if (a == "--affine-step") affine_step = std::stod(value());
    else if (a == "--inter-sigma") {
      inter_sigma = std::stod(value());
      if (!(inter_sigma > 0.0) || !std::isfinite(inter_sigma)) throw std::runtime_error("--inter-sigma needs a finite sigma > 0");
    }
    else if (a == "--ground-floor") {
      ground_floor = std::stod(value());
      if (!(ground_floor >= 0.0) || !std::isfinite(ground_floor)) throw std::runtime_error("--ground-floor needs a floor >= 0");
    }
    else if (a == "--sharpen") {
      if (std::sscanf(value().c_str(), "%lf,%lf", &sharpen.amount, &sharpen.sigma_px) != 2)
        throw std::runtime_error("--sharpen needs A,S (amount, sigma in master px)");
      sharpen.check();
    }
    else if (a == "--e2-scale") {
      e2_scale = std::stod(value());
      if (!(e2_scale > 0.0) || !std::isfinite(e2_scale)) throw std::runtime_error("--e2-scale needs a factor > 0");
    }
    else if (a == "--e1-ties") {
      e1_ties = std::stoi(value());
      if (e1_ties < 0) throw std::runtime_error("--e1-ties needs a count >= 0");
    } else {
      std::fprintf(stderr,
                   "usage: adjustment_eval [--seeds N] [--first-seed S] [--threads N] [--no-colmap] [--colmap-work DIR] "
                   "[--max-relief G] [--cell PX] [--e1-block RxC] [--e1-ties N] [--e2-block RxC] [--matches-cache DIR] [--affine-step PX] [--inter-sigma PX] [--e2-scale K] [--ground-floor G] [--sharpen A,S] [--dem PATH] [--flying-height M]\n");
      return 1;
    }
  }
  if (colmap) make_folder(colmap_work, "adjustment_eval");  // run_colmap_bundle_adjuster makes one level below it
  if (!matches_cache.empty()) make_folder(matches_cache, "adjustment_eval");
  std::optional<Dsm> dem;
  if (!dem_path.empty()) {
    GeoTiffReadOptions untagged;  // the merged Mount St. Helens DEMs use -9999 without a tag
    untagged.assume_untagged_nodata = true;
    std::string utm;
    dem = dsm_in_metres(read_geotiff_dsm(dem_path, untagged), &utm);
    if (!utm.empty()) std::fprintf(stderr, "%s is in degrees; reprojected to %s\n", dem_path.c_str(), utm.c_str());
  }
  std::map<std::string, std::vector<Outcome>> results;
  std::vector<double> inter_matches, inter_correct;
  int coregistered = 0;
  for (int s = 0; s < seeds; ++s) {
    SceneOptions scene_options = SceneOptions::decades_apart();
    scene_options.seed = first_seed + static_cast<std::uint64_t>(s);
    scene_options.threads = threads;
    e1_block.apply(scene_options.epochs[0]);
    e2_block.apply(scene_options.epochs[1]);
    if (e1_ties >= 0) scene_options.epochs[0].tie_points = e1_ties;
    scale_images(scene_options.epochs[1], e2_scale);
    if (flying_height > 0.0)
      for (EpochOptions& epoch : scene_options.epochs) epoch.set_flying_height_keeping_gsd(flying_height);
    scene_options.real_dem = dem;
    auto t0 = std::chrono::steady_clock::now();
    const Scene scene = generate_scene(scene_options);
    const SyntheticEpoch& e1 = scene.epochs[0];
    const SyntheticEpoch& e2 = scene.epochs[1];
    std::fprintf(stderr, "seed %llu: scene %.1f s\n", static_cast<unsigned long long>(scene_options.seed), seconds_since(t0));

    // Algorithm 1: rough co-registration, overlapping pairs, precise matching.
    RoughCoregistrationOptions rough_options;
    rough_options.threads = threads;
    const RoughCoregistrationReport rough =
        rough_coregistration(e1.dsm, e2.dsm, ExtractorPairMatcher<SiftExtractor>(SiftExtractor{}), rough_options);
    if (!rough.success) {
      std::fprintf(stderr, "  rough co-registration failed: %s\n", rough.message.c_str());
      Outcome none;
      none.note = "no rough co-registration";
      for (const char* v : kVariants) results[v].push_back(none);
      continue;
    }
    ++coregistered;
    const Helmert3& helmert = rough.epoch2_from_epoch1;
    const Frames frames1 = e1.estimated_frames(), frames2 = e2.estimated_frames();
    OverlappingPairsOptions overlap_options;
    overlap_options.min_overlap_fraction = 0.1;
    overlap_options.threads = threads;
    const OverlappingPairsResult overlap = overlapping_pairs(make_footprint_images(frames1), e1.dsm,
                                                             make_footprint_images(frames2), e2.dsm, helmert, overlap_options);
    const PreciseEpoch<Frame<FraserAffine>> p1{frames1, [&e1](std::size_t i) { return e1.images[i].pixels; }, &e1.dsm};
    const PreciseEpoch<Frame<FraserAffine>> p2{frames2, [&e2](std::size_t i) { return e2.images[i].pixels; }, &e2.dsm};
    PreciseMatchingOptions precise_options;
    precise_options.correlation.max_relief_gsd = max_relief;
    if (cell > 0) precise_options.correlation.use_fixed_cell(cell);
    if (affine_step >= 0.0) precise_options.correlation.match.affine_step_px = affine_step;
    if (ground_floor >= 0.0) precise_options.correlation.ground_floor_master_gsd = ground_floor;
    precise_options.correlation.master_sharpen = sharpen;
    precise_options.threads = threads;
    t0 = std::chrono::steady_clock::now();
    // The options left at their defaults stay out of the name, so that earlier caches still match.
    std::string optional_keys;
    if (e2_scale != 1.0) optional_keys += "-e2x" + std::to_string(e2_scale);
    if (ground_floor >= 0.0) optional_keys += "-floor" + std::to_string(ground_floor);
    if (!dem_path.empty()) optional_keys += "-dem" + std::filesystem::path(dem_path).stem().string();
    if (flying_height > 0.0) optional_keys += "-height" + std::to_string(flying_height);
    if (sharpen.enabled())
      optional_keys += "-sharpen" + std::to_string(sharpen.amount) + "," + std::to_string(sharpen.sigma_px);
    char cache_name[200];
    std::snprintf(cache_name, sizeof cache_name, "/seed%llu-e1%dx%d-e2%dx%d-ties%d-cell%d-relief%g-step%g%s",
                  static_cast<unsigned long long>(scene_options.seed), scene_options.epochs[0].rows,
                  scene_options.epochs[0].columns, scene_options.epochs[1].rows, scene_options.epochs[1].columns,
                  scene_options.epochs[0].tie_points, cell, max_relief, precise_options.correlation.match.affine_step(),
                  optional_keys.c_str());
    const std::string cache_path = matches_cache.empty() ? std::string() : matches_cache + cache_name;
    std::optional<std::vector<EpochPairMatches>> cached;
    if (!cache_path.empty()) cached = read_matches(cache_path, overlap.pairs);
    if (cached) std::fprintf(stderr, "  matches read from %s\n", cache_path.c_str());
    const std::vector<EpochPairMatches> matches =
        cached ? *cached
               : epoch_pair_matches(precise_matching_correlation(p1, p2, helmert, overlap.pairs, precise_options).pairs);
    if (!cache_path.empty() && !cached) write_matches(cache_path, matches);
    const double matching_seconds = seconds_since(t0);
    const MatchTruthScorer truth(scene);
    std::size_t count = 0, correct = 0;
    Vec2 bias = Vec2::Zero();  // mean error of the correct matches, epoch-2 px: a systematic shift shows here
    // Each match's truth, per pair in the matches' order, kept for the oracles below.
    std::vector<std::vector<MatchTruth>> match_truths;
    for (const EpochPairMatches& pair : matches) {
      match_truths.emplace_back();
      for (const PointMatch& m : pair.matches) {
        ++count;
        const MatchTruth t = truth.score({0, static_cast<int>(pair.master)}, {1, static_cast<int>(pair.secondary)}, m.a, m.b);
        match_truths.back().push_back(t);
        if (t.scored() && t.error_px < 3.0) {
          ++correct;
          bias += m.b - t.true_pixel;
        }
      }
    }
    inter_matches.push_back(static_cast<double>(count));
    inter_correct.push_back(static_cast<double>(correct));
    if (correct > 0) bias /= static_cast<double>(correct);
    std::fprintf(stderr, "  %zu pairs, %zu inter-epoch matches (%zu within 3 px, mean error (%.3f, %.3f) px) in %.1f s\n",
                 overlap.pairs.size(), count, correct, bias.x(), bias.y(), matching_seconds);

    const Frames e1_moved = transformed_frames(frames1, helmert);
    const CombinedEpoch c1{frames1, e1.tie_point_observations()}, c2{frames2, e2.tie_point_observations()};
    // Epoch 1 as a calibration certificate would start it (see "certificate free" above).
    CombinedEpoch c1_certificate = c1;
    for (Frame<FraserAffine>& frame : c1_certificate.frames) {
      Camera<FraserAffine>::Params params = e1.camera.params();
      params[5] = frame.camera().params()[5];  // B1, B2: the scan's, not the lens's
      params[6] = frame.camera().params()[6];
      frame = Frame<FraserAffine>(Camera<FraserAffine>(e1.camera.focal() + 1.5, e1.camera.cx() + 1.0, e1.camera.cy() - 1.0,
                                                       frame.camera().width(), frame.camera().height(), params),
                                  frame.pose());
    }
    // Epoch 1's observed pixels (all its images share one camera): its tie points and the master
    // side of the inter-epoch matches.
    std::vector<Vec2> observed;
    for (const std::vector<ImagePixel>& t : c1.tie_points)
      for (const ImagePixel& obs : t) observed.push_back(obs.pixel);
    for (const EpochPairMatches& pair : matches)
      for (const PointMatch& m : pair.matches) observed.push_back(m.a);
    {
      Outcome o;
      judge(o, scene, e1_moved, observed);
      results["rough"].push_back(o);
    }
    {
      // The control: epoch 1 self-calibrated with its own tie points only, then placed by the Helmert.
      Outcome o;
      t0 = std::chrono::steady_clock::now();
      BundleInput input;
      input.frames = frames1;
      TrackSet tracks = build_tracks(c1.tie_points, {}, static_cast<int>(frames1.size()));
      input.tracks = std::move(tracks.tracks);
      const BundleResult r = bundle_adjust(input, BundleOptions{});
      o.seconds = seconds_since(t0);
      if (r.report.success) judge(o, scene, transformed_frames(r.frames, helmert), observed);
      else o.note = r.report.message;
      results["intra only"].push_back(o);
    }
    // The same master points matched by the truth (their true pixel in the secondary image): what the
    // adjustment gives when the inter-epoch matches carry no error of their own.
    std::vector<EpochPairMatches> true_matches;
    std::vector<Vec2> errors;  // each scored match's error vector, in the same order
    for (const EpochPairMatches& pair : matches) {
      EpochPairMatches t{pair.master, pair.secondary, {}};
      for (const PointMatch& m : pair.matches) {
        const MatchTruth mt = truth.transfer({0, static_cast<int>(pair.master)}, {1, static_cast<int>(pair.secondary)}, m.a);
        if (!mt.scored()) continue;
        t.matches.push_back({m.a, mt.true_pixel});
        errors.push_back(m.b - mt.true_pixel);
      }
      true_matches.push_back(std::move(t));
    }
    // The same true matches carrying the real matches' error vectors, shuffled among them: the same
    // size of error without its structure (its correlation between neighbours and per pair). If the
    // camera comes back as with exact matches, the structure is what costs, not the size.
    std::vector<EpochPairMatches> shuffled_matches;
    {
      RandomStream random(scene_options.seed, 0x5bu);
      for (std::size_t i = errors.size(); i > 1; --i) std::swap(errors[i - 1], errors[random.uniform_index(i)]);
      std::size_t next = 0;
      for (const EpochPairMatches& pair : true_matches) {
        EpochPairMatches t{pair.master, pair.secondary, {}};
        for (const PointMatch& m : pair.matches) t.matches.push_back({m.a, m.b + errors[next++], 0.0});
        shuffled_matches.push_back(std::move(t));
      }
    }
    // Oracles of a bias per pair: each pair's mean true error (over its matches within 3 px) taken
    // off all its matches ("pair bias removed"), or apart for the matches on relief (epoch 2's DSM
    // not a plane to kReliefGsd around the match) and the others ("relief bias removed"). What a
    // free offset per pair, or per pair and kind of ground, could win at best.
    constexpr double kReliefGsd = 2.0;
    std::vector<EpochPairMatches> pair_debiased, relief_debiased;
    for (std::size_t p = 0; p < matches.size(); ++p) {
      const EpochPairMatches& pair = matches[p];
      const auto transfer = make_dsm_transfer(frames1[pair.master], e1.dsm, frames2[pair.secondary], helmert);
      const Raster<std::uint8_t>& img2 = e2.images[pair.secondary].pixels;
      const double g2 = detail::image_gsd(frames2[pair.secondary], e2.dsm, img2.width(), img2.height());
      std::vector<int> kind(pair.matches.size(), 0);  // 1: on relief
      Vec2 sum_all = Vec2::Zero(), sum_kind[2] = {Vec2::Zero(), Vec2::Zero()};
      int n_all = 0, n_kind[2] = {0, 0};
      for (std::size_t k = 0; k < pair.matches.size(); ++k) {
        const PointMatch& m = pair.matches[k];
        if (bench::relief_gsd(e2.dsm, transfer.secondary_point(m.a), precise_options.correlation.relief_radius_px, g2) >=
            kReliefGsd)
          kind[k] = 1;
        const MatchTruth& t = match_truths[p][k];
        if (!t.scored() || t.error_px >= 3.0) continue;
        sum_all += m.b - t.true_pixel;
        ++n_all;
        sum_kind[kind[k]] += m.b - t.true_pixel;
        ++n_kind[kind[k]];
      }
      const auto mean = [](const Vec2& sum, int n) { return n > 0 ? Vec2(sum / n) : Vec2(Vec2::Zero()); };
      const Vec2 bias_all = mean(sum_all, n_all), bias_kind[2] = {mean(sum_kind[0], n_kind[0]), mean(sum_kind[1], n_kind[1])};
      EpochPairMatches by_pair{pair.master, pair.secondary, {}}, by_kind{pair.master, pair.secondary, {}};
      for (std::size_t k = 0; k < pair.matches.size(); ++k) {
        PointMatch a = pair.matches[k], b = pair.matches[k];
        a.b -= bias_all;
        b.b -= bias_kind[kind[k]];
        by_pair.matches.push_back(a);
        by_kind.matches.push_back(b);
      }
      const Vec2& r = bias_kind[1];
      const Vec2& f = bias_kind[0];
      std::fprintf(stderr, "    pair %zu-%zu: mean error of the correct matches on relief (%d) (%.2f, %.2f), elsewhere (%d) (%.2f, %.2f) px\n",
                   pair.master, pair.secondary, n_kind[1], r.x(), r.y(), n_kind[0], f.x(), f.y());
      pair_debiased.push_back(std::move(by_pair));
      relief_debiased.push_back(std::move(by_kind));
    }
    const std::vector<EpochPairMatches> weighted_matches =
        peak_weighted(matches, scene, frames1, frames2, helmert, precise_options.correlation.match);
    std::vector<Track> full_tracks;  // the tracks of the shipped adjustment, for COLMAP's run
    for (const char* variant : kVariants) {
      const std::string v = variant;
      if (v == "rough" || v == "intra only" || v == "colmap") continue;  // judged above and below
      Outcome o;
      CombinedAdjustmentOptions options;
      CombinedEpoch reference = c2;
      if (v == "no affine") options.bundle.epochs = {EpochFreedom{true, true, false}, EpochFreedom::all_fixed()};
      if (v == "e2 camera free") options.bundle.epochs = {EpochFreedom::all_free(), EpochFreedom{false, true, true}};
      if (v == "both free") options.fix_reference_epoch = false;
      if (v == "inter sigma 1") options.bundle.inter_epoch_sigma_px = options.bundle.intra_epoch_sigma_px;
      if (v == "inter sigma X" || v == "peak weighted X") options.bundle.inter_epoch_sigma_px = inter_sigma;
      if (v == "affine per camera") options.bundle.affine_scope = AffineScope::per_camera;
      if (v == "staged") options.bundle.staged_intrinsics = true;
      if (v == "cauchy" || v == "cauchy per camera") options.bundle.loss = RobustLoss::cauchy;
      if (v == "cauchy per camera") options.bundle.affine_scope = AffineScope::per_camera;
      if (v == "K3 held" || v == "K3 P1 P2 held") {
        // Held at the SfM's values: K3 = 0 as in the truth, P1, P2 at half the truth's.
        EpochFreedom e1_freedom = EpochFreedom::all_free();
        e1_freedom.fixed_intrinsics = {Intrinsic::k3};
        if (v == "K3 P1 P2 held") e1_freedom.fixed_intrinsics = {Intrinsic::k3, Intrinsic::p1, Intrinsic::p2};
        options.bundle.epochs = {e1_freedom, EpochFreedom::all_fixed()};
      }
      if (v == "certificate prior" || v == "certificate held") {
        EpochFreedom e1_freedom = EpochFreedom::all_free();
        if (v == "certificate prior")
          e1_freedom.intrinsic_priors = {{Intrinsic::f, 2.0}, {Intrinsic::cx, 2.0}, {Intrinsic::cy, 2.0}};
        else
          e1_freedom.fixed_intrinsics = {Intrinsic::f, Intrinsic::cx, Intrinsic::cy};
        options.bundle.epochs = {e1_freedom, EpochFreedom::all_fixed()};
      }
      if (v == "oracle e2 frames")
        for (std::size_t i = 0; i < e2.images.size(); ++i) reference.frames[i] = e2.epoch_frame(i);
      t0 = std::chrono::steady_clock::now();
      const CombinedAdjustmentResult r =
          combined_adjustment(v.rfind("certificate", 0) == 0 ? c1_certificate : c1, reference,
                              v == "oracle matches"    ? true_matches
                              : v == "shuffled errors" ? shuffled_matches
                              : v == "pair bias removed" ? pair_debiased
                              : v == "relief bias removed" ? relief_debiased
                              : v.rfind("peak weighted", 0) == 0 ? weighted_matches
                                                       : matches,
                              helmert, options);
      o.seconds = seconds_since(t0);
      if (r.report.success) {
        Frames e1_adjusted = r.epoch1;
        if (v == "both free") {
          // The datum: the similarity that puts epoch 2's adjusted centres back on its input ones.
          std::vector<PointPair3> centres;
          for (std::size_t i = 0; i < frames2.size(); ++i) centres.push_back({r.epoch2[i].pose().centre(), frames2[i].pose().centre()});
          e1_adjusted = transformed_frames(r.epoch1, *fit_helmert3(centres));
        }
        judge(o, scene, e1_adjusted, observed);
        if (!r.report.cameras.empty() && !r.report.cameras.front().covariance.empty()) {  // camera 0: epoch 1's
          o.predicted = distortion_precision(e1_adjusted.front().camera(), r.report.cameras.front().covariance);
        }
      } else {
        o.note = r.report.message;
      }
      results[v].push_back(o);
      std::fprintf(stderr, "  %s: %zu tracks (%zu inter-epoch), reprojection RMS %.2f -> %.2f px, sigma0 %.4f, cost %.3f, obs %zu rejected %zu\n", variant,
                   r.report.tracks_used, r.report.inter_epoch_tracks, r.report.before.all.rms_px, r.report.after.all.rms_px,
                   r.report.sigma0, r.report.solves.empty() ? -1.0 : r.report.solves.back().final_cost,
                   r.report.observations_used, r.report.observations_rejected);
      if (v != "full") continue;
      full_tracks = r.track_list;
      for (const SolveSummary& solve : r.report.solves)
        std::fprintf(stderr, "    solve %s: %s, %d iterations, cost %.4g -> %.4g, %.1f s\n", solve.stage.c_str(),
                     solve.termination.c_str(), solve.iterations, solve.initial_cost, solve.final_cost, solve.seconds);
      for (const CameraReport& c : r.report.cameras)
        for (const ParameterChange& pc : c.values)
          std::fprintf(stderr, "    camera %d %s: %.6g -> %.6g (sigma %.2g)\n", c.camera, pc.name.c_str(), pc.before, pc.after, pc.sigma);
    }
    std::fprintf(stderr, "  truth e1: f %.2f pp (%.2f, %.2f) params", e1.camera.focal(), e1.camera.cx(), e1.camera.cy());
    for (double p : e1.camera.params()) std::fprintf(stderr, " %.6g", p);
    std::fprintf(stderr, "\n  e2 as the SfM had it: distortion %.2f px off, f %+.2f px\n",
                 distortion_difference(e2.estimated_camera, e2.camera).max_px, e2.estimated_camera.focal() - e2.camera.focal());
    if (colmap && !full_tracks.empty())  // COLMAP gets the shipped adjustment's tracks; none if it failed
      results["colmap"].push_back(run_colmap(scene, e1_moved, frames2, full_tracks, observed,
                                             colmap_work + "/seed" + std::to_string(scene_options.seed)));
    for (const char* v : kVariants) {
      if (results[v].size() <= static_cast<std::size_t>(s) || !results[v].back().ran) {
        if (results[v].size() > static_cast<std::size_t>(s))
          std::fprintf(stderr, "  %-10s  no result: %s\n", v, results[v].back().note.c_str());
        continue;
      }
      const Outcome& o = results[v].back();
      std::fprintf(stderr,
                   "  %-10s  check points %zu: RMS %.2f m = %.2f GSD, |mu| X %.2f Y %.2f Z %.2f m; f %+.2f, pp %.2f, "
                   "distortion %.2f px (RMS %.2f), over the observed pixels %.2f (RMS %.2f), with f and pp refitted %.2f (RMS %.2f), beyond a pose %.2f (RMS %.2f), predicted 1-sigma %.2f (RMS %.2f), lens part %.2f, affine part worst image %.2f median image %.2f; DoD mu %.2f sigma %.2f mean |dz| %.2f m; %.2f s\n",
                   v, o.check.num_used, o.check.rms_3d_m, o.check.rms_3d_gsd, o.check.axes_m[0].mean_abs,
                   o.check.axes_m[1].mean_abs, o.check.axes_m[2].mean_abs, o.focal_error_px, o.pp_error_px,
                   o.distortion.max_px, o.distortion.rms_px, o.on_observed.max_px, o.on_observed.rms_px,
                   o.distortion.refit_max_px, o.distortion.refit_rms_px, o.distortion.beyond_pose_max_px,
                   o.distortion.beyond_pose_rms_px, o.predicted.max_sigma_px, o.predicted.rms_sigma_px, o.lens_max_px,
                   o.affine_worst_image_px, o.affine_median_image_px, o.dod.statistics.mean, o.dod.statistics.sigma,
                   o.dod.statistics.mean_abs, o.seconds);
    }
  }

  std::printf("%d seeds (first %llu), %d co-registered; inter-epoch matches per seed: median %.0f, within 3 px %.0f; "
              "\"inter sigma X\": X = %g px\n\n",
              seeds, static_cast<unsigned long long>(first_seed), coregistered, median(inter_matches), median(inter_correct),
              inter_sigma);
  std::printf("| variant | seeds | check-point RMS 3D (m) | in GSD | mean abs error X / Y / Z (m) | sigma X / Y / Z (m) | "
              "focal error (px) | principal point error (px) | distortion, worst over the image (px) | distortion over the "
              "observed pixels, worst / RMS (px) | camera with f and pp refitted, worst / RMS (px) | camera beyond a pose, worst / RMS (px) | distortion 1-sigma predicted, worst / RMS (px) | lens part, worst (px) | affine part, worst image / median image (px) | DoD mu / sigma / mean abs (m) | time (s) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const char* v : kVariants) {
    const auto it = results.find(v);
    if (it == results.end()) continue;
    std::vector<double> rms, gsd, mx, my, mz, sx, sy, sz, f, pp, d, t, dm, ds, da, lens;
    MedianPair observed_distortion, refitted, beyond_pose, predicted;  // worst / RMS
    MedianPair affine_part;                                            // worst image / median image
    for (const Outcome& o : it->second) {
      if (!o.ran || !o.check.success) continue;
      rms.push_back(o.check.rms_3d_m);
      gsd.push_back(o.check.rms_3d_gsd);
      mx.push_back(o.check.axes_m[0].mean_abs);
      my.push_back(o.check.axes_m[1].mean_abs);
      mz.push_back(o.check.axes_m[2].mean_abs);
      sx.push_back(o.check.axes_m[0].sigma);
      sy.push_back(o.check.axes_m[1].sigma);
      sz.push_back(o.check.axes_m[2].sigma);
      f.push_back(o.focal_error_px);
      pp.push_back(o.pp_error_px);
      d.push_back(o.distortion.max_px);
      observed_distortion.add(o.on_observed.max_px, o.on_observed.rms_px);
      refitted.add(o.distortion.refit_max_px, o.distortion.refit_rms_px);
      beyond_pose.add(o.distortion.beyond_pose_max_px, o.distortion.beyond_pose_rms_px);
      // Only the combined adjustments have a covariance.
      if (o.predicted.valid) predicted.add(o.predicted.max_sigma_px, o.predicted.rms_sigma_px);
      lens.push_back(o.lens_max_px);
      affine_part.add(o.affine_worst_image_px, o.affine_median_image_px);
      t.push_back(o.seconds);
      dm.push_back(o.dod.statistics.mean);
      ds.push_back(o.dod.statistics.sigma);
      da.push_back(o.dod.statistics.mean_abs);
    }
    std::printf("| %s | %zu | %s | %s | %s / %s / %s | %s / %s / %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s / %s / %s | %s |\n", v, rms.size(),
                fmt(median(rms)).c_str(), fmt(median(gsd)).c_str(), fmt(median(mx)).c_str(), fmt(median(my)).c_str(),
                fmt(median(mz)).c_str(), fmt(median(sx)).c_str(), fmt(median(sy)).c_str(), fmt(median(sz)).c_str(),
                fmt(median(f)).c_str(), fmt(median(pp)).c_str(), fmt(median(d)).c_str(), observed_distortion.cell().c_str(),
                refitted.cell().c_str(), beyond_pose.cell().c_str(), predicted.cell().c_str(), fmt(median(lens)).c_str(),
                affine_part.cell().c_str(), fmt(median(dm)).c_str(),
                fmt(median(ds)).c_str(), fmt(median(da)).c_str(), fmt(median(t)).c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "adjustment_eval: %s\n", e.what());
    return 1;
  }
}
