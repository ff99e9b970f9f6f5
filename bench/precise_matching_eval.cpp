// precise_matching_eval: precise matching (pipeline/precise_matching.hpp) on decades-apart synthetic
// scenes, every stage scored with the truth (docs/precise-matching.md).
//
//   precise_matching_eval [--seeds N] [--first-seed S] [--methods LIST] [--max-pairs N] [--threads N]
//                         [--models DIR] [--warp corners|grid|piecewise] [--ncc-threshold T]
//                         [--min-overlap F] [--radius PX] [--measure intensity|gradient|orientation]
//                         [--corr-radius PX] [--corr-window PX] [--min-score S] [--min-margin M]
//                         [--second-pass PX] [--cell PX] [--ground-gsd G] [--no-ncc] [--no-refine]
//                         [--ncc-correlation] [--calm] [--calm-only changes,sun,cover,film,...]
//                         [--max-relief G] [--relief-radius PX] [--preblur S1,S2] [--dump FILE]
//                         [--affine-step PX] [--scan-scale K] [--e2-scale K] [--sharpen A,S]
//                         [--scan-frame PX [--no-masks]] [--dem PATH] [--flying-height M]
//
// --calm (a diagnostic): the same scenes without their decades, i.e. no landscape change between
// the epochs and epoch 1 rendered with epoch 2's look (sun, land-cover response, no film defects);
// cameras, resolutions and orientations as usual. What error remains is the matcher's and the
// geometry's, not the landscape's. --calm-only LIST takes away only some of the decades, to tell
// their costs apart: changes (landscape change between the epochs), sun (epoch 1 under epoch 2's
// sun), cover (epoch 2's land-cover response), film (epoch 2's tone, grain, scanner and dust, blur
// and no JPEG), or one part of the film: tone (its S curve), blur (epoch 2's blur), grain, defects
// (scanner lines and stripes, scratches, dust). --sharpen A,S sets
// PreciseCorrelationOptions::master_sharpen (amount A, sigma S master px). --preblur S1,S2 blurs
// each epoch's images (Gaussian sigma in its own px) before matching. --scan-scale K (> 0) renders every epoch's images K times larger on the same footprints
// (focal length times K, GSD divided by K), as a finer scan of the same photographs; the DSMs keep
// their cell of 2 GSD and their errors in metres. --e2-scale K does so for epoch 2 alone (on top of
// --scan-scale), widening the resolution gap between the epochs from the preset's 2 to 2 K.
// --scan-frame PX draws a scan's film frame, a band of PX px (synth/scan_frame.hpp), over epoch 1's
// images and hands their masks to precise matching; --no-masks keeps the frame but not the masks.
// --dem PATH generates the scenes over this real DEM instead of the procedural relief
// (dsm_in_metres: a DEM in degrees goes to its UTM zone first); --flying-height M flies every
// epoch M metres above the mean ground at the preset's GSDs (the preset: 1056 m for epoch 1, 840 m for
// epoch 2), for rugged terrain.
// --dump FILE writes every final match of the methods run: positions, score, true error
// and its vector (epoch-2 px, NaN when the truth cannot decide), the truth's status, its residual
// to the rough transfer's prediction, the correlation surface's second derivatives at the match
// (hxx hxy hyy, per master px^2, from a quadratic fitted to the scores over +-2 master px) and the
// transfer's local affine there (a00 a01 a10 a11, secondary px per master px), and the relief of each
// epoch's DSM around the match (relief1 relief2: plane-fit RMS over the relief filter's disc, in GSD
// of that epoch's image; NaN where the disc is mostly hole).
//
// Methods (comma-separated; default all but xfeat when the model is absent):
//   baseline        whole-image SIFT (8000 strongest keypoints), ratio 0.8 + mutual, F-RANSAC 3 px
//   guided-rootsift guided matching of RootSIFT keypoints, then the ground filter and NCC
//   guided-sift     the same with plain SIFT descriptors
//   patch-sift, patch-akaze, patch-xfeat   one-to-one transfer-guided tiles, then the filters
//   correlation     grid interest points correlated around their prediction (docs/correlation-matching.md);
//                   correlation-intensity|gradient|orientation: the same with that measure. The
//                   adaptive threshold unless --min-score S sets a fixed one.
// For every seed of SceneOptions::decades_apart(): the rough co-registration of the two epoch DSMs
// (today's defaults) gives the Helmert; overlapping_pairs() gives the pairs (estimated frames and
// the epoch DSMs, as a user has them); every method runs on the same pairs. Stages: tentative,
// after the ground filter, after NCC (matcher positions), after refinement (refined positions).
// Everything is deterministic; times are wall clock of this machine (the progress lines also give the
// process CPU time of each method, which other jobs on a shared machine disturb much less).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/eval/match_truth.hpp>
#include <diachron/io/dsm_reproject.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/pipeline/precise_matching.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/synth/scan_frame.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/image.hpp>
#include <diachron/vision/sift.hpp>
#include <diachron/vision/xfeat.hpp>

#include "calm_scene.hpp"
#include "match_scoring.hpp"
#include "peak_shape.hpp"

#ifndef DIACHRON_BENCH_MODELS_DIR
#define DIACHRON_BENCH_MODELS_DIR ""
#endif

using namespace diachron;
using diachron::bench::median;
using diachron::bench::Scored;
using diachron::bench::split_list;
using diachron::bench::seconds_since;
using diachron::bench::peak_shape;
using diachron::bench::calm_scene;
using diachron::bench::require_calm_parts;
using diachron::bench::scale_images;

namespace {

struct Arguments {
  int seeds = 5;
  std::uint64_t first_seed = 0;
  std::vector<std::string> methods;
  int max_pairs = 0;
  std::size_t threads = 0;
  std::string models = DIACHRON_BENCH_MODELS_DIR;
  std::string warp;
  double ncc_threshold = std::nan("");  // unset: the default
  double min_overlap = 0.1;
  double radius = std::nan("");  // unset: the default
  std::string measure;            // correlation: unset = the default
  int corr_radius = -1, corr_window = -1, second_pass = -1, cell = -1;
  double min_score = std::nan(""), min_margin = std::nan("");
  double ground_gsd = std::nan("");
  double scan_scale = 1.0, e2_scale = 1.0;
  double max_relief = std::nan(""), relief_radius = std::nan(""), affine_step = std::nan("");
  bool no_ncc = false, no_refine = false, ncc_correlation = false, calm = false;
  std::vector<std::string> calm_only;
  std::string dump;
  double preblur[2] = {0.0, 0.0};
  UnsharpMaskOptions sharpen;
  int scan_frame = 0;
  bool no_masks = false;
  std::string dem;
  double flying_height = 0.0;  // 0: the preset's
};

Arguments parse(int argc, char** argv) {
  Arguments a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "missing value after %s\n", s.c_str());
        std::exit(1);
      }
      return argv[++i];
    };
    if (s == "--seeds") a.seeds = std::stoi(value());
    else if (s == "--first-seed") a.first_seed = std::stoull(value());
    else if (s == "--methods") a.methods = split_list(value());
    else if (s == "--max-pairs") a.max_pairs = std::stoi(value());
    else if (s == "--threads") a.threads = std::stoul(value());
    else if (s == "--models") a.models = value();
    else if (s == "--warp") a.warp = value();
    else if (s == "--ncc-threshold") a.ncc_threshold = std::stod(value());
    else if (s == "--min-overlap") a.min_overlap = std::stod(value());
    else if (s == "--radius") a.radius = std::stod(value());
    else if (s == "--measure") a.measure = value();
    else if (s == "--corr-radius") a.corr_radius = std::stoi(value());
    else if (s == "--corr-window") a.corr_window = std::stoi(value());
    else if (s == "--second-pass") a.second_pass = std::stoi(value());
    else if (s == "--cell") a.cell = std::stoi(value());
    else if (s == "--min-score") a.min_score = std::stod(value());
    else if (s == "--min-margin") a.min_margin = std::stod(value());
    else if (s == "--ground-gsd") a.ground_gsd = std::stod(value());
    else if (s == "--e2-scale") {
      a.e2_scale = std::stod(value());
      if (!(a.e2_scale > 0.0) || !std::isfinite(a.e2_scale)) {
        std::fprintf(stderr, "--e2-scale wants a factor > 0\n");
        std::exit(1);
      }
    }
    else if (s == "--scan-scale") {
      a.scan_scale = std::stod(value());
      if (!(a.scan_scale > 0.0) || !std::isfinite(a.scan_scale)) {
        std::fprintf(stderr, "--scan-scale wants a factor > 0\n");
        std::exit(1);
      }
    }
    else if (s == "--max-relief") a.max_relief = std::stod(value());
    else if (s == "--relief-radius") a.relief_radius = std::stod(value());
    else if (s == "--affine-step") a.affine_step = std::stod(value());
    else if (s == "--no-ncc") a.no_ncc = true;
    else if (s == "--ncc-correlation") a.ncc_correlation = true;
    else if (s == "--no-refine") a.no_refine = true;
    else if (s == "--calm") a.calm = true;
    else if (s == "--calm-only") {
      a.calm_only = split_list(value());
      require_calm_parts(a.calm_only, "--calm-only");
    }
    else if (s == "--dump") a.dump = value();
    else if (s == "--scan-frame") {
      a.scan_frame = std::atoi(value().c_str());
      if (a.scan_frame <= 0) {
        std::fprintf(stderr, "--scan-frame wants a band width > 0 px\n");
        std::exit(1);
      }
    } else if (s == "--no-masks") a.no_masks = true;
    else if (s == "--dem") a.dem = value();
    else if (s == "--flying-height") {
      a.flying_height = std::stod(value());
      if (!(a.flying_height > 0.0) || !std::isfinite(a.flying_height)) {
        std::fprintf(stderr, "--flying-height wants a height > 0 m\n");
        std::exit(1);
      }
    }
    else if (s == "--sharpen") {
      if (std::sscanf(value().c_str(), "%lf,%lf", &a.sharpen.amount, &a.sharpen.sigma_px) != 2) {
        std::fprintf(stderr, "--sharpen wants A,S (amount, sigma in master px)\n");
        std::exit(1);
      }
    } else if (s == "--preblur") {
      if (std::sscanf(value().c_str(), "%lf,%lf", &a.preblur[0], &a.preblur[1]) != 2 || !(a.preblur[0] >= 0) ||
          !(a.preblur[1] >= 0)) {
        std::fprintf(stderr, "--preblur wants S1,S2 (sigmas >= 0)\n");
        std::exit(1);
      }
    }
    else {
      std::fprintf(stderr, "unknown argument %s\n", s.c_str());
      std::exit(1);
    }
  }
  if (a.methods.empty()) {
    a.methods = {"baseline", "guided-rootsift", "guided-sift", "patch-sift", "patch-akaze", "correlation"};
    if (!a.models.empty()) a.methods.push_back("patch-xfeat");
  }
  return a;
}

/// The stages of one method over all pairs of all seeds.
struct StageResult {
  Scored scored;
  std::vector<double> matches_per_pair, correct3_per_pair;
};

struct MethodResult {
  static constexpr int kStages = 4;  // tentative, ground, ncc, refined
  StageResult stages[kStages];
  std::vector<double> seconds_per_pair;
  std::size_t pairs = 0;
};

const char* kStageNames[MethodResult::kStages] = {"tentative", "after ground filter", "after NCC",
                                                  "after refinement"};

void add_stage(StageResult& stage, const MatchTruthScorer& truth, const PrecisePairReport& pair,
               const PointMatches& matches) {
  Scored s;
  for (const PointMatch& m : matches)
    s.add(truth.score({0, static_cast<int>(pair.master)}, {1, static_cast<int>(pair.secondary)}, m.a, m.b));
  stage.matches_per_pair.push_back(static_cast<double>(s.matches));
  stage.correct3_per_pair.push_back(static_cast<double>(s.within[1]));
  stage.scored.add(s);
}

void score_pair(MethodResult& result, const MatchTruthScorer& truth, const PrecisePairReport& pair) {
  add_stage(result.stages[0], truth, pair, pair.tentative);
  add_stage(result.stages[1], truth, pair, pair.grounded);
  // After NCC at the matcher's positions: the NCC verdict applied to the grounded matches.
  add_stage(result.stages[2], truth, pair,
            pair.ncc.size() == pair.grounded.size() ? select_kept(pair.grounded, pair.ncc) : pair.matches);
  add_stage(result.stages[3], truth, pair, pair.matches);
  result.seconds_per_pair.push_back(pair.seconds.total);
  ++result.pairs;
}

/// Whole-image SIFT on one pair (the baseline), as a PrecisePairReport whose later stages are
/// the F-RANSAC inliers, so that it fills the same table.
PrecisePairReport whole_image_sift(const Features& a, const Features& b, std::uint64_t seed) {
  PrecisePairReport r;
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<FeatureIndexMatch> matches = match_features(a, b, DescriptorMetric::L2);
  for (const FeatureIndexMatch& m : matches) r.tentative.push_back({a.keypoints[m.a].position, b.keypoints[m.b].position, 0.0});
  if (matches.size() >= 8) {
    std::vector<cv::Point2f> p1, p2;
    for (const PointMatch& m : r.tentative) {
      p1.emplace_back(static_cast<float>(m.a.x()), static_cast<float>(m.a.y()));
      p2.emplace_back(static_cast<float>(m.b.x()), static_cast<float>(m.b.y()));
    }
    std::vector<uchar> mask;
    cv::setRNGSeed(static_cast<int>(seed));
    const cv::Mat f = cv::findFundamentalMat(p1, p2, cv::FM_RANSAC, 3.0, 0.99, mask);
    if (!f.empty())
      for (std::size_t k = 0; k < mask.size(); ++k)
        if (mask[k]) r.grounded.push_back(r.tentative[k]);
  }
  r.matches = r.grounded;
  r.seconds.total = seconds_since(t0);
  return r;
}

void print_table(const std::vector<std::string>& methods, const std::map<std::string, MethodResult>& results) {
  std::printf("\n| method | stage | matches / pair (median) | correct < 1 / 3 / 6 / 10 px | correct < 3 px / pair (median) | median error px | s / pair (median) |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (const std::string& m : methods) {
    if (!results.count(m)) continue;
    const MethodResult& r = results.at(m);
    for (int s = 0; s < MethodResult::kStages; ++s) {
      if (m == "baseline" && s >= 2) continue;
      const StageResult& st = r.stages[s];
      std::printf("| %s | %s | %.0f | %.1f / %.1f / %.1f / %.1f %% | %.0f | %.2f | %s |\n", m.c_str(),
                  m == "baseline" ? (s == 0 ? "ratio + mutual" : "F-RANSAC inliers") : kStageNames[s],
                  median(st.matches_per_pair), st.scored.share(0), st.scored.share(1), st.scored.share(2),
                  st.scored.share(3), median(st.correct3_per_pair), median(st.scored.errors),
                  s == 0 ? std::to_string(median(r.seconds_per_pair)).substr(0, 5).c_str() : "");
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const Arguments args = parse(argc, argv);
  try {
    const bool want_xfeat = std::find(args.methods.begin(), args.methods.end(), "patch-xfeat") != args.methods.end();
    std::unique_ptr<XFeatPairMatcher> xfeat;
    if (want_xfeat) xfeat = std::make_unique<XFeatPairMatcher>(args.models + "/xfeat/xfeat.onnx");
    PreciseMatchingOptions options;
    options.threads = args.threads;
    if (std::isfinite(args.ncc_threshold)) options.ncc.min_ncc = args.ncc_threshold;
    if (std::isfinite(args.radius)) options.guided.search_radius_px = args.radius;
    if (args.warp == "corners") options.patch.warp.kind = PatchWarpKind::homography_corners;
    else if (args.warp == "grid") options.patch.warp.kind = PatchWarpKind::homography_grid;
    else if (args.warp == "piecewise") options.patch.warp.kind = PatchWarpKind::piecewise_affine;
    else if (!args.warp.empty()) throw Error("unknown --warp " + args.warp);
    if (args.measure == "intensity") options.correlation.match.measure = CorrelationMeasure::intensity;
    else if (args.measure == "gradient") options.correlation.match.measure = CorrelationMeasure::gradient;
    else if (args.measure == "orientation") options.correlation.match.measure = CorrelationMeasure::orientation;
    else if (!args.measure.empty()) throw Error("unknown --measure " + args.measure);
    if (args.corr_radius > 0) options.correlation.match.search_radius_px = args.corr_radius;
    if (args.corr_window > 0) options.correlation.match.window_px = args.corr_window;
    if (args.second_pass >= 0) options.correlation.second_pass_radius_px = args.second_pass;
    if (args.cell > 0) options.correlation.use_fixed_cell(args.cell);
    if (std::isfinite(args.min_score)) {  // a fixed threshold: the adaptive one would ignore it
      options.correlation.match.min_score = args.min_score;
      options.correlation.match.adaptive_threshold = false;
    }
    if (std::isfinite(args.min_margin)) options.correlation.match.min_margin = args.min_margin;
    // --ground-gsd sets the correlation method's threshold (the descriptor methods keep the paper's).
    if (std::isfinite(args.ground_gsd)) options.correlation.ground_threshold_gsd = args.ground_gsd;
    if (std::isfinite(args.max_relief)) options.correlation.max_relief_gsd = args.max_relief;
    if (std::isfinite(args.relief_radius)) options.correlation.relief_radius_px = args.relief_radius;
    if (std::isfinite(args.affine_step)) options.correlation.match.affine_step_px = args.affine_step;
    options.correlation.master_sharpen = args.sharpen;
    if (args.no_ncc) options.use_ncc = false;
    if (args.ncc_correlation) options.correlation.use_ncc = true;
    if (args.no_refine) options.ncc.refine = false;
    std::optional<Dsm> dem;
    if (!args.dem.empty()) {
      GeoTiffReadOptions untagged;  // the merged Mount St. Helens DEMs use -9999 without a tag
      untagged.assume_untagged_nodata = true;
      std::string utm;
      dem = dsm_in_metres(read_geotiff_dsm(args.dem, untagged), &utm);
      if (!utm.empty()) std::fprintf(stderr, "%s is in degrees; reprojected to %s\n", args.dem.c_str(), utm.c_str());
    }

    std::printf("precise_matching_eval: %d decades seeds from %llu, methods", args.seeds,
                static_cast<unsigned long long>(args.first_seed));
    for (const std::string& m : args.methods) std::printf(" %s", m.c_str());
    std::printf("\n");
    std::map<std::string, MethodResult> results;
    std::FILE* dump = nullptr;
    if (!args.dump.empty() && !(dump = std::fopen(args.dump.c_str(), "w"))) throw Error("cannot write " + args.dump);
    if (dump) std::fprintf(dump, "# method seed master secondary ax ay bx by score error_px status ex ey rx ry hxx hxy hyy a00 a01 a10 a11 relief1 relief2\n");
    std::vector<double> coreg_rms_cells;
    int coreg_failures = 0;
    std::size_t total_pairs = 0;
    for (int s = 0; s < args.seeds; ++s) {
      SceneOptions scene_options = SceneOptions::decades_apart();
      scene_options.seed = args.first_seed + static_cast<std::uint64_t>(s);
      scene_options.threads = args.threads;
      calm_scene(scene_options, args.calm_only, args.calm);
      for (std::size_t e = 0; e < scene_options.epochs.size(); ++e)
        scale_images(scene_options.epochs[e], args.scan_scale * (e == 1 ? args.e2_scale : 1.0));
      if (args.flying_height > 0.0)
        for (EpochOptions& epoch : scene_options.epochs) epoch.set_flying_height_keeping_gsd(args.flying_height);
      scene_options.real_dem = dem;
      auto t0 = std::chrono::steady_clock::now();
      Scene scene = generate_scene(scene_options);
      // Epoch 1's scans with their film frame; its masks are handed over unless --no-masks.
      std::vector<Raster<std::uint8_t>> masks1;
      if (args.scan_frame > 0)
        for (SyntheticImage& image : scene.epochs[0].images) {
          ScanFrameOptions frame;
          frame.band_px = args.scan_frame;
          frame.seed = scene.seed * 1000 + masks1.size();
          masks1.push_back(draw_scan_frame(image.pixels, frame));
        }
      std::fprintf(stderr, "seed %llu: scene in %.1f s\n", static_cast<unsigned long long>(scene_options.seed),
                   seconds_since(t0));
      const SyntheticEpoch& e1 = scene.epochs[0];
      const SyntheticEpoch& e2 = scene.epochs[1];

      RoughCoregistrationOptions rough_options;
      rough_options.threads = args.threads;
      const RoughCoregistrationReport rough =
          rough_coregistration(e1.dsm, e2.dsm, ExtractorPairMatcher<SiftExtractor>(SiftExtractor{}), rough_options);
      if (!rough.success) {
        ++coreg_failures;
        std::fprintf(stderr, "  rough co-registration failed: %s\n", rough.message.c_str());
        continue;
      }
      double sum2 = 0.0;
      for (const CheckPoint& cp : scene.check_points)
        sum2 += (rough.epoch2_from_epoch1(e1.epoch_from_world()(cp.world)) - e2.epoch_from_world()(cp.world)).squaredNorm();
      coreg_rms_cells.push_back(std::sqrt(sum2 / static_cast<double>(std::max<std::size_t>(scene.check_points.size(), 1))) /
                                e2.dsm.min_cell_size());
      std::fprintf(stderr, "  rough co-registration: RMS %.2f epoch-2 DSM cells\n", coreg_rms_cells.back());

      const std::vector<Frame<FraserAffine>> frames1 = e1.estimated_frames(), frames2 = e2.estimated_frames();
      OverlappingPairsOptions overlap_options;
      overlap_options.min_overlap_fraction = args.min_overlap;
      overlap_options.threads = args.threads;
      const OverlappingPairsResult overlap =
          overlapping_pairs(make_footprint_images(frames1), e1.dsm, make_footprint_images(frames2), e2.dsm,
                            rough.epoch2_from_epoch1, overlap_options);
      std::vector<ImagePairOverlap> pairs = overlap.pairs;
      std::sort(pairs.begin(), pairs.end(), [](const ImagePairOverlap& a, const ImagePairOverlap& b) {
        return a.master != b.master ? a.master < b.master : a.secondary < b.secondary;
      });
      if (args.max_pairs > 0 && pairs.size() > static_cast<std::size_t>(args.max_pairs)) {
        std::vector<ImagePairOverlap> kept;
        for (int k = 0; k < args.max_pairs; ++k)
          kept.push_back(pairs[static_cast<std::size_t>(k) * pairs.size() / static_cast<std::size_t>(args.max_pairs)]);
        pairs = kept;
      }
      total_pairs += pairs.size();
      std::fprintf(stderr, "  %zu overlapping pairs\n", pairs.size());
      const double* blur = args.preblur;
      const auto blurred = [](Raster<std::uint8_t> r, double sigma) {
        if (sigma > 0) {
          cv::Mat m = as_mat(r);
          cv::GaussianBlur(m.clone(), m, cv::Size(0, 0), sigma);
        }
        return r;
      };
      PreciseEpoch<Frame<FraserAffine>> p1{frames1, [&](std::size_t i) { return blurred(e1.images[i].pixels, blur[0]); }, &e1.dsm};
      if (!masks1.empty() && !args.no_masks) p1.load_mask = [&masks1](std::size_t i) { return masks1[i]; };
      PreciseEpoch<Frame<FraserAffine>> p2{frames2, [&](std::size_t i) { return blurred(e2.images[i].pixels, blur[1]); }, &e2.dsm};
      const MatchTruthScorer truth(scene);

      for (const std::string& m : args.methods) {
        t0 = std::chrono::steady_clock::now();
        // The process's CPU time over the method: on a shared machine the wall clock also counts
        // other jobs, the CPU time (of all our threads) much less.
        const std::clock_t cpu0 = std::clock();
        PreciseMatchingReport report;
        if (m == "baseline") {
          SiftOptions so;
          so.max_features = 8000;
          const SiftExtractor sift(so);
          std::vector<Features> f1(e1.images.size()), f2(e2.images.size());
          parallel_for(f1.size() + f2.size(), args.threads, [&](std::size_t k) {
            if (k < f1.size()) f1[k] = sift.extract(e1.images[k].pixels);
            else f2[k - f1.size()] = sift.extract(e2.images[k - f1.size()].pixels);
          });
          for (const ImagePairOverlap& p : pairs) {
            PrecisePairReport r = whole_image_sift(f1[p.master], f2[p.secondary], scene.seed);
            r.master = p.master;
            r.secondary = p.secondary;
            report.pairs.push_back(std::move(r));
          }
        } else if (m == "guided-rootsift" || m == "guided-sift") {
          SiftOptions so;
          so.root_sift = m == "guided-rootsift";
          report = precise_matching_guided(p1, p2, rough.epoch2_from_epoch1, pairs, SiftExtractor(so), options);
        } else if (m.rfind("correlation", 0) == 0) {
          // "correlation" with the options given; "correlation-<measure>" overrides the measure.
          PreciseMatchingOptions o = options;
          if (m == "correlation-intensity") o.correlation.match.measure = CorrelationMeasure::intensity;
          else if (m == "correlation-gradient") o.correlation.match.measure = CorrelationMeasure::gradient;
          else if (m == "correlation-orientation") o.correlation.match.measure = CorrelationMeasure::orientation;
          else if (m != "correlation") throw Error("unknown method " + m);
          report = precise_matching_correlation(p1, p2, rough.epoch2_from_epoch1, pairs, o);
        } else if (m == "patch-sift") {
          report = precise_matching_patch(p1, p2, rough.epoch2_from_epoch1, pairs,
                                          ExtractorPairMatcher<SiftExtractor>(SiftExtractor{}), options);
        } else if (m == "patch-akaze") {
          report = precise_matching_patch(p1, p2, rough.epoch2_from_epoch1, pairs,
                                          ExtractorPairMatcher<AkazeExtractor>(AkazeExtractor{}), options);
        } else if (m == "patch-xfeat") {
          report = precise_matching_patch(p1, p2, rough.epoch2_from_epoch1, pairs, *xfeat, options);
        } else {
          throw Error("unknown method " + m);
        }
        MethodResult& result = results[m];
        if (std::getenv("DIACHRON_EVAL_VERBOSE"))
          for (const PrecisePairReport& r : report.pairs)
            std::fprintf(stderr, "    %zu-%zu: %s\n", r.master, r.secondary, r.message.c_str());
        for (const PrecisePairReport& r : report.pairs) score_pair(result, truth, r);
        if (dump)
          for (const PrecisePairReport& r : report.pairs) {
            const auto transfer = make_dsm_transfer(frames1[r.master], e1.dsm, frames2[r.secondary], rough.epoch2_from_epoch1);
            const Raster<std::uint8_t> img1 = p1.load_image(r.master), img2 = p2.load_image(r.secondary);
            // The ground's relief around the match in each epoch's DSM (plane-fit RMS over the disc
            // the relief filter uses), each in GSD of its image.
            const double g1 = detail::image_gsd(frames1[r.master], e1.dsm, img1.width(), img1.height());
            const double g2 = detail::image_gsd(frames2[r.secondary], e2.dsm, img2.width(), img2.height());
            const double radius_px = options.correlation.relief_radius_px;
            for (const PointMatch& pm : r.matches) {
              const MatchTruth t = truth.score({0, static_cast<int>(r.master)}, {1, static_cast<int>(r.secondary)}, pm.a, pm.b);
              const Eigen::Vector2d e = pm.b - t.true_pixel;
              const Eigen::Vector2d res = pm.b - transfer(pm.a).value_or(Eigen::Vector2d::Constant(std::nan("")));
              double hxx = std::nan(""), hxy = std::nan(""), hyy = std::nan("");
              double a00 = std::nan(""), a01 = std::nan(""), a10 = std::nan(""), a11 = std::nan("");
              if (const auto shape = peak_shape(img1, img2, pm.a, pm.b, transfer, options.correlation.match)) {
                // The surface's second derivatives (the negated curvature) and the affine.
                hxx = -shape->curvature(0, 0); hxy = -shape->curvature(0, 1); hyy = -shape->curvature(1, 1);
                a00 = shape->affine(0, 0); a01 = shape->affine(0, 1); a10 = shape->affine(1, 0); a11 = shape->affine(1, 1);
              }
              const double relief1 = bench::relief_gsd(e1.dsm, transfer.master_point(pm.a), radius_px, g1);
              const double relief2 = bench::relief_gsd(e2.dsm, transfer.secondary_point(pm.a), radius_px, g2);
              std::fprintf(dump, "%s %llu %zu %zu %.3f %.3f %.3f %.3f %.5f %.4f %d %.4f %.4f %.4f %.4f %.5f %.5f %.5f %.4f %.4f %.4f %.4f %.3f %.3f\n", m.c_str(),
                           static_cast<unsigned long long>(scene_options.seed), r.master, r.secondary, pm.a.x(), pm.a.y(),
                           pm.b.x(), pm.b.y(), pm.score, t.scored() ? t.error_px : std::nan(""),
                           static_cast<int>(t.status), e.x(), e.y(), res.x(), res.y(), hxx, hxy, hyy, a00, a01, a10, a11,
                           relief1, relief2);
            }
          }
        std::fprintf(stderr, "  %s: %.1f s (CPU %.1f s), median %.0f final correct (< 3 px) per pair so far\n",
                     m.c_str(), seconds_since(t0), static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC,
                     median(result.stages[3].correct3_per_pair));
      }
    }
    std::printf("\nrough co-registration: %zu of %d seeds, RMS %.2f epoch-2 DSM cells (median); %zu pairs\n",
                coreg_rms_cells.size(), args.seeds, median(coreg_rms_cells), total_pairs);
    (void)coreg_failures;
    print_table(args.methods, results);
    if (results.count("baseline")) {
      const double base = static_cast<double>(results.at("baseline").stages[1].scored.within[1]);
      std::printf("\n| method | correct final matches (< 3 px), all pairs | ratio to whole-image SIFT inliers |\n|---|---|---|\n");
      for (const std::string& m : args.methods) {
        if (m == "baseline" || !results.count(m)) continue;
        const double ours = static_cast<double>(results.at(m).stages[3].scored.within[1]);
        std::printf("| %s | %.0f | %.1f |\n", m.c_str(), ours, base > 0 ? ours / base : std::nan(""));
      }
      std::printf("(whole-image SIFT: %.0f correct F-RANSAC inliers on the same pairs)\n", base);
    }
    if (dump) std::fclose(dump);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "precise_matching_eval: %s\n", e.what());
    return 1;
  }
}
