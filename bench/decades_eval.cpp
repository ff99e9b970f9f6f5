// decades_eval: how hard the decades-apart synthetic scenes are, measured with the truth
// (docs/synthetic-scenes.md, "How hard the decades preset is").
//
//   decades_eval [--seeds N] [--first-seed S] [--methods sift,rootsift,akaze,xfeat,xfeat-mnn]
//                [--ablation] [--ablation-seeds N] [--coreg-seeds N] [--max-features N]
//                [--oracle-max-features N] [--max-pairs N] [--variants "a,b"] [--threads N] [--models DIR]
//
// For every seed of SceneOptions::decades_apart() and every overlapping epoch-1 x epoch-2 image
// pair (overlap: at least 10 % of a 16 x 12 grid of the epoch-1 image lands in the epoch-2 image
// through the true cameras and surface), it scores:
//  - whole-image matching: features on the whole images, Lowe's ratio 0.8 and mutual nearest
//    neighbour (cv::BFMatcher; `xfeat-mnn`: XFeat's own mutual cosine >= 0.82 instead), then a
//    fundamental-matrix RANSAC (3 px, OpenCV): tentative
//    matches and inliers, the share correct within 1 / 3 / 6 / 10 px among those the truth can
//    score (eval/match_truth.hpp);
//  - oracle-guided SIFT (all keypoints: guided matching is local and needs no cap, while the
//    whole-image baselines keep the --max-features strongest, 8000 by default, to stay tractable):
//    each epoch-1 keypoint's true position in the epoch-2 image, candidates
//    within 10 px of it, ratio 0.8 among them, mutual nearest neighbour through the truth the
//    other way: an upper bound of what guided matching can reach;
//  - the rough co-registration (today's defaults, SIFT) of the two epoch DSMs: success when the
//    RMS error at the check points is below 2 cells of the epoch-2 DSM.
// --ablation repeats SIFT, the oracle and the co-registration with each effect of the preset
// turned off in turn. Everything is deterministic; times are wall-clock of this machine.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>

#include <diachron/eval/match_truth.hpp>
#include <diachron/matching/point_index_2d.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>
#include <diachron/vision/xfeat.hpp>

#include "match_scoring.hpp"

#ifndef DIACHRON_BENCH_MODELS_DIR
#define DIACHRON_BENCH_MODELS_DIR ""
#endif

using namespace diachron;
using diachron::bench::median;
using diachron::bench::Scored;
using diachron::bench::split_list;
using diachron::bench::seconds_since;

namespace {

struct Arguments {
  int seeds = 5;
  std::uint64_t first_seed = 0;
  std::vector<std::string> methods = {"sift", "rootsift", "akaze", "xfeat"};
  bool ablation = false;
  int ablation_seeds = 3;
  std::vector<std::string> variants;  // ablation rows to run; empty = all
  int coreg_seeds = 12;
  int max_features = 8000;
  int oracle_max_features = 0;  // guided matching is local: it needs no cap
  int max_pairs = 0;  // per seed; 0 = all overlapping pairs
  std::size_t threads = 0;
  std::string models = DIACHRON_BENCH_MODELS_DIR;
};

[[noreturn]] void usage(const std::string& message) {
  std::fprintf(stderr,
               "decades_eval: %s\nusage: decades_eval [--seeds N] [--first-seed S] [--methods a,b,...] [--ablation]\n"
               "                    [--ablation-seeds N] [--coreg-seeds N] [--max-features N] [--oracle-max-features N]\n"
               "                    [--max-pairs N] [--variants NAME,NAME] [--threads N]\n"
               "                    [--models DIR]\n",
               message.c_str());
  std::exit(1);
}

Arguments parse(int argc, char** argv) {
  Arguments a;
  if (const char* env = std::getenv("DIACHRON_MODELS_DIR")) a.models = env;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--ablation") {
      a.ablation = true;
      continue;
    }
    if (i + 1 >= argc) usage("missing value for " + arg);
    const std::string v = argv[++i];
    try {
      if (arg == "--seeds") a.seeds = std::stoi(v);
      else if (arg == "--first-seed") a.first_seed = std::stoull(v);
      else if (arg == "--methods") a.methods = split_list(v);
      else if (arg == "--ablation-seeds") a.ablation_seeds = std::stoi(v);
      else if (arg == "--variants") a.variants = split_list(v);
      else if (arg == "--coreg-seeds") a.coreg_seeds = std::stoi(v);
      else if (arg == "--max-features") a.max_features = std::stoi(v);
      else if (arg == "--max-pairs") a.max_pairs = std::stoi(v);
      else if (arg == "--oracle-max-features") a.oracle_max_features = std::stoi(v);
      else if (arg == "--threads") a.threads = static_cast<std::size_t>(std::stoul(v));
      else if (arg == "--models") a.models = v;
      else usage("unknown option " + arg);
    } catch (const std::logic_error&) {
      usage("bad value '" + v + "' for " + arg);
    }
  }
  for (const std::string& m : a.methods)
    if (m != "sift" && m != "rootsift" && m != "akaze" && m != "xfeat" && m != "xfeat-mnn") usage("unknown method " + m);
  if (a.seeds < 0 || a.coreg_seeds < 0 || a.ablation_seeds < 0) usage("seed counts must be >= 0");
  return a;
}

/// An overlapping inter-epoch pair: epoch-1 image i, epoch-2 image j.
struct ImagePair {
  int i = 0, j = 0;
  double overlap = 0.0;
};

// The pairs the truth says overlap (the true cameras and surface), not overlapping_pairs() of the
// library, which works from the estimated frames and DSMs: this bench judges matchers, not that.
std::vector<ImagePair> truly_overlapping_pairs(const Scene& scene, const MatchTruthScorer& truth) {
  std::vector<ImagePair> out;
  const SyntheticEpoch& e1 = scene.epochs[0];
  for (std::size_t i = 0; i < e1.images.size(); ++i)
    for (std::size_t j = 0; j < scene.epochs[1].images.size(); ++j) {
      int inside = 0, total = 0;
      for (int gy = 0; gy < 12; ++gy)
        for (int gx = 0; gx < 16; ++gx) {
          const Vec2 p((gx + 0.5) * e1.camera.width() / 16.0, (gy + 0.5) * e1.camera.height() / 12.0);
          const MatchTruth t = truth.transfer({0, static_cast<int>(i)}, {1, static_cast<int>(j)}, p);
          ++total;
          if (t.status != MatchTruthStatus::off_image && t.status != MatchTruthStatus::no_surface) ++inside;
        }
      const double share = static_cast<double>(inside) / total;
      if (share >= 0.1) out.push_back({static_cast<int>(i), static_cast<int>(j), share});
    }
  return out;
}

/// What one method gave over all pairs of all seeds.
struct MethodResult {
  Scored tentative, inliers;
  std::vector<double> tentative_per_pair, inliers_per_pair, correct3_per_pair, seconds_per_pair;
  std::size_t pairs = 0, usable_pairs = 0;
};

struct OracleResult {
  Scored matches;
  std::size_t keypoints = 0, predicted = 0;  // epoch-1 keypoints, and those the truth could place
  std::size_t repeated = 0;  // placed ones with an epoch-2 keypoint within 3 px of the true position
  std::vector<double> correct3_per_pair;
  std::size_t pairs = 0;
};

struct CoregResult {
  int runs = 0, successes = 0;
  std::vector<double> rms_cells;  // per run, NaN when it returned no Helmert
};

Features extract(const std::string& method, const Raster<std::uint8_t>& image, int max_features,
                 const std::unique_ptr<XFeatExtractor>& xfeat) {
  if (method == "sift" || method == "rootsift") {
    SiftOptions o;
    o.max_features = max_features;
    o.root_sift = method == "rootsift";
    return SiftExtractor(o).extract(image);
  }
  if (method == "akaze") {
    AkazeOptions o;
    o.max_features = max_features;
    return AkazeExtractor(o).extract(image);
  }
  return xfeat->extract(image);  // xfeat and xfeat-mnn
}

DescriptorMetric metric_of(const std::string& method) {
  if (method == "akaze") return DescriptorMetric::Hamming;
  if (method == "xfeat" || method == "xfeat-mnn") return DescriptorMetric::Cosine;
  return DescriptorMetric::L2;
}

/// Whole-image matching of one pair, scored.
void whole_image(const Scene& scene, const MatchTruthScorer& truth, const ImagePair& pair, const Features& a,
                 const Features& b, DescriptorMetric metric, bool own_xfeat_matcher, MethodResult& out) {
  const auto t0 = std::chrono::steady_clock::now();
  // XFeat's own matcher (mutual nearest neighbour, cosine >= 0.82, no ratio test) beside the
  // common ratio-0.8 protocol, which a learned descriptor's flatter distances rarely pass.
  const std::vector<FeatureIndexMatch> matches =
      own_xfeat_matcher ? match_mutual_cosine(a, b, XFeatMatchOptions{}) : match_features(a, b, metric);
  std::vector<uchar> mask;
  if (matches.size() >= 8) {
    std::vector<cv::Point2f> p1, p2;
    for (const FeatureIndexMatch& m : matches) {
      const Vec2& x1 = a.keypoints[m.a].position;
      const Vec2& x2 = b.keypoints[m.b].position;
      p1.emplace_back(static_cast<float>(x1.x()), static_cast<float>(x1.y()));
      p2.emplace_back(static_cast<float>(x2.x()), static_cast<float>(x2.y()));
    }
    cv::setRNGSeed(static_cast<int>(scene.seed));
    const cv::Mat f = cv::findFundamentalMat(p1, p2, cv::FM_RANSAC, 3.0, 0.99, mask);
    if (f.empty()) mask.assign(matches.size(), 0);
  } else {
    mask.assign(matches.size(), 0);
  }
  const double seconds = seconds_since(t0);
  Scored tentative, inliers;
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const MatchTruth t = truth.score({0, pair.i}, {1, pair.j}, a.keypoints[matches[k].a].position,
                                     b.keypoints[matches[k].b].position);
    tentative.add(t);
    if (mask[k]) inliers.add(t);
  }
  out.tentative.add(tentative);
  out.inliers.add(inliers);
  out.tentative_per_pair.push_back(static_cast<double>(tentative.matches));
  out.inliers_per_pair.push_back(static_cast<double>(inliers.matches));
  out.correct3_per_pair.push_back(static_cast<double>(inliers.within[1]));
  out.seconds_per_pair.push_back(seconds);
  ++out.pairs;
  // A pair is usable when the RANSAC kept at least 16 inliers, at least half of them right.
  if (inliers.matches >= 16 && inliers.scored > 0 && inliers.within[1] * 2 >= inliers.scored) ++out.usable_pairs;
}

/// Oracle-guided SIFT on one pair.
void oracle_guided(const MatchTruthScorer& truth, const ImagePair& pair, const Features& a, const Features& b,
                   OracleResult& out) {
  constexpr double kRadius = 10.0, kRatio = 0.8;
  std::vector<Vec2> positions_b;
  for (const Keypoint& k : b.keypoints) positions_b.push_back(k.position);
  const PointIndex2D index_b(positions_b);
  // The true position of every epoch-1 keypoint in the epoch-2 image.
  std::vector<std::optional<Vec2>> predicted(a.size());
  std::vector<Vec2> predicted_points;
  std::vector<std::size_t> predicted_rows;
  for (std::size_t k = 0; k < a.size(); ++k) {
    const MatchTruth t = truth.transfer({0, pair.i}, {1, pair.j}, a.keypoints[k].position);
    if (!t.scored()) continue;
    predicted[k] = t.true_pixel;
    predicted_points.push_back(t.true_pixel);
    predicted_rows.push_back(k);
  }
  const PointIndex2D index_a(predicted_points);
  out.keypoints += a.size();
  out.predicted += predicted_points.size();
  const auto distance = [&](std::size_t ka, std::size_t kb) {
    return static_cast<double>((a.descriptors.row(static_cast<Eigen::Index>(ka)) - b.descriptors.row(static_cast<Eigen::Index>(kb))).norm());
  };
  Scored scored;
  for (std::size_t k = 0; k < a.size(); ++k) {
    if (!predicted[k]) continue;
    double d1 = std::numeric_limits<double>::infinity(), d2 = d1;
    std::size_t best = 0;
    const std::vector<IndexedNeighbor> candidates = index_b.radius_search(*predicted[k], kRadius);
    if (!candidates.empty() && candidates.front().distance < 3.0) ++out.repeated;
    for (const IndexedNeighbor& n : candidates) {
      const double d = distance(k, n.index);
      if (d < d1) {
        d2 = d1;
        d1 = d;
        best = n.index;
      } else if (d < d2) {
        d2 = d;
      }
    }
    if (!std::isfinite(d1) || !(d1 < kRatio * d2 || !std::isfinite(d2))) continue;
    // Mutual: among the epoch-1 keypoints predicted near `best`, k must be the nearest.
    bool mutual = true;
    for (const IndexedNeighbor& n : index_a.radius_search(b.keypoints[best].position, kRadius)) {
      const std::size_t other = predicted_rows[n.index];
      if (other != k && distance(other, best) < d1) {
        mutual = false;
        break;
      }
    }
    if (!mutual) continue;
    scored.add(truth.score({0, pair.i}, {1, pair.j}, a.keypoints[k].position, b.keypoints[best].position));
  }
  out.matches.add(scored);
  out.correct3_per_pair.push_back(static_cast<double>(scored.within[1]));
  ++out.pairs;
}

CoregResult coregister(const Scene& scene, CoregResult result) {
  const SyntheticEpoch& e1 = scene.epochs[0];
  const SyntheticEpoch& e2 = scene.epochs[1];
  const ExtractorPairMatcher<SiftExtractor> sift{SiftExtractor{}};
  const RoughCoregistrationReport report = rough_coregistration(e1.dsm, e2.dsm, sift, RoughCoregistrationOptions{});
  ++result.runs;
  double rms_cells = std::nan("");
  if (report.success) {
    double sum2 = 0.0;
    for (const CheckPoint& cp : scene.check_points)
      sum2 += (report.epoch2_from_epoch1(e1.epoch_from_world()(cp.world)) - e2.epoch_from_world()(cp.world)).squaredNorm();
    rms_cells = std::sqrt(sum2 / static_cast<double>(std::max<std::size_t>(scene.check_points.size(), 1))) /
                e2.dsm.min_cell_size();
    if (rms_cells < 2.0) ++result.successes;
  }
  result.rms_cells.push_back(rms_cells);
  std::fprintf(stderr, "    rough co-registration: %s; RMS %.2f epoch-2 DSM cells\n", report.message.c_str(), rms_cells);
  return result;
}

/// One variant of the preset (an ablation row).
struct Variant {
  std::string name;
  std::function<void(SceneOptions&)> change;
};

std::vector<Variant> ablations() {
  return {
      {"all effects", [](SceneOptions&) {}},
      {"no cast shadows", [](SceneOptions& o) {
         for (EpochOptions& e : o.epochs) e.look.cast_shadow = 0.0;
       }},
      {"no trees", [](SceneOptions& o) { o.terrain.vegetation = VegetationOptions{}; }},
      {"changes of a few years", [](SceneOptions& o) {
         o.changes = ChangeOptions{};
         o.texture.bush_removal_probability = TextureOptions{}.bush_removal_probability;
       }},
      {"no film radiometry", [](SceneOptions& o) {
         for (EpochOptions& e : o.epochs) {
           const LookOptions plain = e.name == "e1" ? EpochOptions::historical().look : EpochOptions::recent().look;
           e.look.land_cover = LandCoverResponse{};
           e.look.tone_curve = plain.tone_curve;
           e.look.exposure_unevenness = plain.exposure_unevenness;
           e.look.grain_sigma = plain.grain_sigma;
           e.look.grain_size_px = plain.grain_size_px;
           e.look.scan_line_sigma = plain.scan_line_sigma;
           e.look.scan_stripes = plain.scan_stripes;
           e.look.scratches = plain.scratches;
           e.look.dust_per_megapixel = plain.dust_per_megapixel;
           e.look.jpeg_quality = plain.jpeg_quality;
         }
       }},
      {"same GSD (e2 at 1.0 m)", [](SceneOptions& o) {
         o.epochs[1].focal_px *= 0.5;
         o.epochs[1].rows = 2;
         o.epochs[1].columns = 2;
       }},
      {"clean e1 DSM", [](SceneOptions& o) { o.epochs[0].dsm = SfmDsmOptions{}; }},
      {"every effect off", [](SceneOptions& o) {
         // The plain scene's land and looks at the preset's image sizes and GSDs: what the
         // benchmark measured before the preset existed.
         const SceneOptions plain;
         o.terrain = plain.terrain;
         o.changes = plain.changes;
         o.texture.bush_removal_probability = plain.texture.bush_removal_probability;
         o.epochs[0].look = EpochOptions::historical().look;
         o.epochs[1].look = EpochOptions::recent().look;
         o.epochs[0].dsm = SfmDsmOptions{};
         o.epochs[1].focal_px *= 0.5;
         o.epochs[1].rows = 2;
         o.epochs[1].columns = 2;
       }},
  };
}

struct Features4 {
  std::map<std::string, std::vector<Features>> e1, e2;
};

void print_method_table(const std::vector<std::string>& methods, const std::map<std::string, MethodResult>& results) {
  std::printf("\n| whole-image method | pairs | tentative / pair | correct < 1 / 3 / 6 / 10 px | undecidable (changed surface) | F inliers / pair | inliers correct < 3 / 10 px | correct inliers < 3 px / pair | usable pairs | s / pair |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& m : methods) {
    if (results.count(m) == 0) continue;
    const MethodResult& r = results.at(m);
    const double unscorable = r.tentative.matches ? 100.0 * static_cast<double>(r.tentative.matches - r.tentative.scored) /
                                                        static_cast<double>(r.tentative.matches)
                                                  : std::nan("");
    std::printf("| %s | %zu | %.0f | %.1f / %.1f / %.1f / %.1f %% | %.0f %% | %.0f | %.1f / %.1f %% | %.0f | %zu of %zu | %.2f |\n",
                m.c_str(), r.pairs, median(r.tentative_per_pair), r.tentative.share(0), r.tentative.share(1),
                r.tentative.share(2), r.tentative.share(3), unscorable, median(r.inliers_per_pair), r.inliers.share(1),
                r.inliers.share(3), median(r.correct3_per_pair), r.usable_pairs, r.pairs, median(r.seconds_per_pair));
  }
}

}  // namespace

int main(int argc, char** argv) {
  const Arguments args = parse(argc, argv);
  try {
    std::unique_ptr<XFeatExtractor> xfeat;
    if (std::find(args.methods.begin(), args.methods.end(), "xfeat") != args.methods.end() ||
        std::find(args.methods.begin(), args.methods.end(), "xfeat-mnn") != args.methods.end())
      xfeat = std::make_unique<XFeatExtractor>(args.models + "/xfeat/xfeat.onnx");

    const std::vector<Variant> variants = ablations();
    const std::size_t variant_count = args.ablation ? variants.size() : 1;
    std::printf("decades_eval: %d seeds from %llu, methods", args.seeds, static_cast<unsigned long long>(args.first_seed));
    for (const std::string& m : args.methods) std::printf(" %s", m.c_str());
    std::printf(", at most %d features per image (XFeat: its top_k), rough co-registration on %d seeds\n",
                args.max_features, args.coreg_seeds);

    struct Row {
      std::string name;
      MethodResult sift;
      OracleResult oracle;
      CoregResult coreg;
      std::vector<double> generation_seconds;
    };
    std::vector<Row> rows;
    std::map<std::string, MethodResult> main_results;
    OracleResult main_oracle;
    for (std::size_t v = 0; v < variant_count; ++v) {
      const Variant& variant = variants[v];
      if (!args.variants.empty() &&
          std::find(args.variants.begin(), args.variants.end(), variant.name) == args.variants.end())
        continue;
      Row row;
      row.name = variant.name;
      const int match_seeds = v == 0 ? args.seeds : args.ablation_seeds;
      const int seeds = std::max(match_seeds, v == 0 ? args.coreg_seeds : args.ablation_seeds);
      for (int s = 0; s < seeds; ++s) {
        SceneOptions options = SceneOptions::decades_apart();
        variant.change(options);
        options.seed = args.first_seed + static_cast<std::uint64_t>(s);
        options.threads = args.threads;
        const auto t0 = std::chrono::steady_clock::now();
        const Scene scene = generate_scene(options);
        row.generation_seconds.push_back(seconds_since(t0));
        std::fprintf(stderr, "[%s] seed %llu: scene in %.1f s\n", variant.name.c_str(),
                     static_cast<unsigned long long>(options.seed), row.generation_seconds.back());
        row.coreg = coregister(scene, row.coreg);
        if (s >= match_seeds) continue;

        const MatchTruthScorer truth(scene);
        std::vector<ImagePair> pairs = truly_overlapping_pairs(scene, truth);
        if (args.max_pairs > 0 && pairs.size() > static_cast<std::size_t>(args.max_pairs)) {
          // Keep an even spread of the pairs rather than the first image's.
          std::vector<ImagePair> kept;
          for (int k = 0; k < args.max_pairs; ++k) kept.push_back(pairs[static_cast<std::size_t>(k) * pairs.size() / static_cast<std::size_t>(args.max_pairs)]);
          pairs = kept;
        }
        const std::vector<std::string> methods = v == 0 ? args.methods : std::vector<std::string>{"sift"};
        for (const std::string& m : methods) {
          const auto extract_epoch = [&](std::size_t e, int max_features) {
            std::vector<Features> out;
            for (const SyntheticImage& image : scene.epochs[e].images) out.push_back(extract(m, image.pixels, max_features, xfeat));
            return out;
          };
          std::vector<Features> f1 = extract_epoch(0, args.max_features), f2 = extract_epoch(1, args.max_features);
          std::size_t n1 = 0, n2 = 0;
          for (const Features& f : f1) n1 += f.size();
          for (const Features& f : f2) n2 += f.size();
          std::fprintf(stderr, "    %s: %zu keypoints per epoch-1 image, %zu per epoch-2 image\n", m.c_str(), n1 / f1.size(), n2 / f2.size());
          MethodResult& result = v == 0 ? main_results[m] : row.sift;
          for (const ImagePair& pair : pairs)
            whole_image(scene, truth, pair, f1[static_cast<std::size_t>(pair.i)], f2[static_cast<std::size_t>(pair.j)],
                        metric_of(m), m == "xfeat-mnn", result);
          if (m == "sift") {
            if (args.oracle_max_features != args.max_features) {
              f1 = extract_epoch(0, args.oracle_max_features);
              f2 = extract_epoch(1, args.oracle_max_features);
            }
            OracleResult& oracle = v == 0 ? main_oracle : row.oracle;
            for (const ImagePair& pair : pairs)
              oracle_guided(truth, pair, f1[static_cast<std::size_t>(pair.i)], f2[static_cast<std::size_t>(pair.j)], oracle);
            std::fprintf(stderr, "    oracle-guided SIFT: median %.0f correct (< 3 px) per pair so far; whole-image SIFT %.1f %% correct < 10 px\n",
                         median(oracle.correct3_per_pair), result.tentative.share(3));
          }
          std::fprintf(stderr, "    %s: %zu pairs so far\n", m.c_str(), result.pairs);
        }
      }
      if (v == 0) {
        // The first row of the ablation table is the main run's SIFT and oracle.
        if (main_results.count("sift")) row.sift = main_results.at("sift");
        row.oracle = main_oracle;
      }
      rows.push_back(std::move(row));
    }

    if (!rows.empty() && rows.front().name == variants.front().name) {
    std::printf("\n## Whole-image baselines on the decades preset (%d seeds)\n", args.seeds);
    print_method_table(args.methods, main_results);
    std::printf("\n## Oracle-guided SIFT (10 px around the true position, ratio 0.8, mutual)\n");
    std::printf("\n| pairs | epoch-1 keypoints the truth places | of those, repeated in epoch 2 (< 3 px) | matches / pair | correct < 1 / 3 / 6 / 10 px | correct < 3 px per pair: median, min |\n|---|---|---|---|---|---|\n");
    {
      const OracleResult& o = rows.front().oracle;
      std::vector<double> per_pair = o.correct3_per_pair;
      std::printf("| %zu | %.0f %% | %.0f %% | %.0f | %.1f / %.1f / %.1f / %.1f %% | %.0f, %.0f |\n", o.pairs,
                  o.keypoints ? 100.0 * static_cast<double>(o.predicted) / static_cast<double>(o.keypoints) : 0.0,
                  o.predicted ? 100.0 * static_cast<double>(o.repeated) / static_cast<double>(o.predicted) : 0.0,
                  o.pairs ? static_cast<double>(o.matches.matches) / static_cast<double>(o.pairs) : 0.0, o.matches.share(0),
                  o.matches.share(1), o.matches.share(2), o.matches.share(3), median(per_pair),
                  per_pair.empty() ? std::nan("") : *std::min_element(per_pair.begin(), per_pair.end()));
    }
    }
    std::printf("\n## Ablation: each effect off in turn (SIFT and oracle on the first seeds, co-registration on every seed)\n");
    std::printf("\n| variant | scene s (median) | SIFT tentative / pair | SIFT correct < 10 px | oracle correct < 3 px / pair (median) | rough co-registration | RMS cells (median) |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    for (const Row& r : rows) {
      std::vector<double> rms;
      for (double x : r.coreg.rms_cells)
        if (std::isfinite(x)) rms.push_back(x);
      std::printf("| %s | %.1f | %.0f | %.1f %% | %.0f | %d of %d | %.2f |\n", r.name.c_str(), median(r.generation_seconds),
                  median(r.sift.tentative_per_pair), r.sift.tentative.share(3), median(r.oracle.correct3_per_pair),
                  r.coreg.successes, r.coreg.runs, median(rms));
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "decades_eval: %s\n", e.what());
    return 1;
  }
}
