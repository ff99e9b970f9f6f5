// real_pairs_eval: every matcher on the real inter-epoch pairs of ../shared/data/real-pairs, scored
// against chance (docs/precise-matching.md, "Real inter-epoch pairs"; long logs in docs/benchmarks.md).
//
//   real_pairs_eval [--data DIR] [--pairs LIST] [--methods LIST] [--threads N] [--iterations N]
//                   [--draws N] [--seed S] [--stats-points N] [--no-stats] [--json FILE]
//                   [--decades N] [--decades-first-seed S] [--decades-pairs N] [--decades-calm LIST]
//                   [--pictures DIR] [--write-epochs DIR [--dsm flat|grey] [--dsm-metres-per-level M]
//                   [--dsm-cell U]]
//
// There is no ground truth on these pairs. The map old -> new is close to a 2D similarity whose scale
// is the ratio of the widths (no rotation, no translation), plus a few px of local deviation; that
// similarity is the "rough" transfer the guided and correlation methods start from. Each method's
// final matches (old = master, new = secondary) are scored the same way: a homography RANSAC at 3 px
// (ransac_homography2, --iterations at most), its inliers, their share, and the cells of a 4 x 4
// grid over the master image holding an inlier (a composition filtered by a model of its own:
// from its tentative matches, see MethodOutput::null_source). The null model gives the same master points random
// partners within the method's reach (whole-image methods: uniform over the secondary image; guided:
// uniform in the search disc around the prediction; correlation: uniform in the search square),
// --draws times with fixed seeds, scored identically. A method beats chance when its inliers are at
// least 3 x the null's maximum and 20 more.
//
// Statistics (unless --no-stats), per correlation measure and pair: against a reference homography
// (the RANSAC model of the method with most inliers among those that beat chance), the best score
// within +-2 master px of the reference position and of a random position farther than twice the
// window from it, as quantiles over up to --stats-points grid points; and, of the method
// corr-<measure>/cells6-min0, the share of grid points matched and the matches within 3 px of the
// reference. Then the same on --decades N (1; 0: none) decades-apart synthetic scenes
// (SceneOptions::decades_apart(), seeds from --decades-first-seed, --decades-pairs image pairs each)
// against the true transfer, correlation_match predicting through the epoch DSMs and the true
// Helmert, all side by side. --decades-calm LIST takes parts of the decades away from those scenes
// (changes, sun, cover, film, tone, blur, grain, defects: bench/calm_scene.hpp), to tell which part
// makes their statistics differ from the real pairs'.
//
// --pictures DIR: per pair and method DIR/<pair>_<method>.jpg: the master in grey with the secondary
// warped in through the fitted homography as a 64 px checkerboard (each stretched between its 1st
// and 99th percentiles), inliers green, outliers red. --write-epochs DIR:
// DIR/<pair>/{old,new}/{ortho.tif,dsm.tif}, orthophoto epochs in one frame (new: 1 unit per px;
// old: cell = the similarity's scale, same top-left corner; no CRS); the DSM has cells of
// --dsm-cell units (4) and is flat (0 m), or with --dsm grey the pair's *_dsm-grey.png times
// --dsm-metres-per-level (1 m per grey level; the rendering's scale is unknown).
//
// Deterministic: every random draw comes from --seed (0). Times are wall clock of this machine.

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/camera/ortho_frame.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/eval/match_truth.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/geometry/similarity2.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/io/json.hpp>
#include <diachron/matching/correlation_matcher.hpp>
#include <diachron/matching/descriptor_matching.hpp>
#include <diachron/matching/grid_interest_points.hpp>
#include <diachron/matching/guided_matcher.hpp>
#include <diachron/pipeline/correlation_pair.hpp>
#include <diachron/pipeline/precise_matching.hpp>
#include <diachron/robust/robust_estimation.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/vision/image.hpp>
#include <diachron/vision/sift.hpp>

#include "bench_common.hpp"
#include "calm_scene.hpp"

#ifndef DIACHRON_BENCH_DATA_DIR
#define DIACHRON_BENCH_DATA_DIR "../shared/data"
#endif

using namespace diachron;
using diachron::bench::calm_scene;
using diachron::bench::require_calm_parts;
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// The non-empty items of a comma-separated list.
std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

constexpr double kInlierPx = 3.0;  // the scoring threshold, secondary px
constexpr int kCoverageGrid = 4;   // coverage: cells of a 4 x 4 grid over the master image

struct Arguments {
  std::string data = DIACHRON_BENCH_DATA_DIR;
  std::vector<std::string> pairs = {"appearance-change", "poorly-textured"};
  std::vector<std::string> methods;  // empty: all
  std::size_t threads = 0;
  std::size_t iterations = 10000;
  int draws = 10;
  std::uint64_t seed = 0;
  std::size_t stats_points = 3000;
  bool stats = true;
  int decades = 1;                   // decades seeds for the side-by-side statistics (0: none)
  std::uint64_t decades_first_seed = 0;
  std::size_t decades_pairs = 3;     // image pairs per decades seed
  std::vector<std::string> decades_calm;  // parts of the decades taken away (calm_scene.hpp)
  std::string json, pictures, write_epochs;
  std::string dsm = "flat";
  double dsm_metres_per_level = 1.0;
  double dsm_cell = 4.0;
};

Arguments parse(int argc, char** argv) {
  Arguments a;
  if (const char* env = std::getenv("DIACHRON_DATA_DIR")) a.data = env;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "missing value after %s\n", s.c_str());
        std::exit(1);
      }
      return argv[++i];
    };
    if (s == "--data") a.data = value();
    else if (s == "--pairs") a.pairs = split_list(value());
    else if (s == "--methods") a.methods = split_list(value());
    else if (s == "--threads") a.threads = std::stoul(value());
    else if (s == "--iterations") a.iterations = std::stoul(value());
    else if (s == "--draws") a.draws = std::stoi(value());
    else if (s == "--seed") a.seed = std::stoull(value());
    else if (s == "--stats-points") a.stats_points = std::stoul(value());
    else if (s == "--no-stats") a.stats = false;
    else if (s == "--decades") a.decades = std::stoi(value());
    else if (s == "--decades-first-seed") a.decades_first_seed = std::stoull(value());
    else if (s == "--decades-pairs") a.decades_pairs = std::stoul(value());
    else if (s == "--decades-calm") {
      a.decades_calm = split_list(value());
      require_calm_parts(a.decades_calm, "--decades-calm");
    }
    else if (s == "--json") a.json = value();
    else if (s == "--pictures") a.pictures = value();
    else if (s == "--write-epochs") a.write_epochs = value();
    else if (s == "--dsm") a.dsm = value();
    else if (s == "--dsm-metres-per-level") a.dsm_metres_per_level = std::stod(value());
    else if (s == "--dsm-cell") a.dsm_cell = std::stod(value());
    else {
      std::fprintf(stderr, "unknown argument %s (see the comment at the top of bench/real_pairs_eval.cpp)\n",
                   s.c_str());
      std::exit(1);
    }
  }
  if (a.dsm != "flat" && a.dsm != "grey") {
    std::fprintf(stderr, "--dsm wants flat or grey\n");
    std::exit(1);
  }
  if (a.draws < 1 || a.iterations < 1 || !(a.dsm_cell > 0.0) || !std::isfinite(a.dsm_metres_per_level)) {
    std::fprintf(stderr, "--draws and --iterations want >= 1, --dsm-cell > 0, --dsm-metres-per-level finite\n");
    std::exit(1);
  }
  return a;
}

bool file_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

void make_directories(const std::string& path) {
  std::string partial;
  std::stringstream in(path);
  if (!path.empty() && path[0] == '/') partial = "/";
  for (std::string part; std::getline(in, part, '/');) {
    if (part.empty()) continue;
    partial += part + "/";
    ::mkdir(partial.c_str(), 0755);
  }
  DIACHRON_CHECK(file_exists(path), "cannot create the folder " << path);
}

// ---- One pair, and the methods --------------------------------------------------------------------

/// A pair as every method sees it: old = master, new = secondary, grey (luma), and the rough
/// similarity old px -> new px.
struct PairData {
  std::string name;
  Raster<std::uint8_t> master, secondary;
  Similarity2 rough;
  std::size_t threads = 0;
  // Features, extracted once per pair (the seconds go into every method that uses them).
  struct Cached {
    Features master, secondary;
    double seconds = 0.0;
    bool done = false;
  };
  mutable Cached sift, root_sift;

  const Cached& features(bool root) const {
    Cached& c = root ? root_sift : sift;
    if (!c.done) {
      const auto t0 = std::chrono::steady_clock::now();
      SiftOptions o;
      o.root_sift = root;
      const SiftExtractor extractor(o);
      c.master = extractor.extract(master);
      c.secondary = extractor.extract(secondary);
      c.seconds = seconds_since(t0);
      c.done = true;
    }
    return c;
  }
};

/// Where a method may put a master point's partner: what the null model draws from.
enum class ReachKind { whole_image, disc, square };

/// A method's final matches, with its reach (secondary px, around the rough prediction of each
/// master point) and how many master points it tried (correlation: grid points).
struct MethodOutput {
  PointMatches matches;
  ReachKind reach = ReachKind::whole_image;
  double reach_px = 0.0;  ///< disc radius or square half-side, secondary px
  std::size_t candidates = 0;
  double extra_seconds = 0.0;  ///< shared work (feature extraction) charged to this method
  /// The matches whose master points the null model draws partners for, when not `matches`: a
  /// composition whose final filter is itself a geometric RANSAC (the ground filter, a homography)
  /// keeps only what agrees with one model, so its null starts from its tentative matches, where
  /// that selection has not been made yet; scored by the same RANSAC, the null's inliers are what
  /// such a filter would find in random partners.
  PointMatches null_source;
};

struct Method {
  std::string name;
  std::string what;
  std::function<MethodOutput(const PairData&)> run;
};

MethodOutput whole_image(const PairData& p, bool root) {
  const PairData::Cached& f = p.features(root);
  DescriptorMatchOptions o;  // ratio 0.8, mutual, L2
  o.threads = p.threads;
  MethodOutput out;
  out.matches = to_point_matches(match_descriptors(f.master.descriptors, f.secondary.descriptors, o), f.master,
                                 f.secondary);
  out.reach = ReachKind::whole_image;
  out.candidates = f.master.size();
  out.extra_seconds = f.seconds;
  return out;
}

MethodOutput guided(const PairData& p, bool root) {
  const PairData::Cached& f = p.features(root);
  GuidedMatchOptions o;  // MicMac's: 100 master px, scale 0.2, angle 30 deg, ratio 0.8, mutual
  o.threads = p.threads;
  const Similarity2 inverse = p.rough.inverse();
  const GuidedMatchResult r = guided_match(f.master, f.secondary, make_map_transfer(p.rough),
                                           make_map_transfer(inverse), o);
  MethodOutput out;
  out.matches = r.matches;
  out.reach = ReachKind::disc;
  out.reach_px = o.search_radius_px * p.rough.scale;
  out.candidates = f.master.size();
  out.extra_seconds = f.seconds;
  return out;
}

/// The settings of correlation matching as the composition uses them: 6 px cells, points kept the
/// window's margin from the edge, every distinct peak kept (the fixed min_score 0, no adaptive
/// threshold). Otherwise the components' defaults (the adaptive threshold since 2026-11-29).
struct CorrelationSetting {
  GridInterestOptions interest;
  CorrelationMatchOptions match;
};

CorrelationSetting correlation_setting(CorrelationMeasure measure, bool composition, std::size_t threads) {
  CorrelationSetting s;
  s.match.measure = measure;
  s.match.threads = threads;
  if (composition) {
    s.interest.cell_px = 6;
    s.interest.border_px = s.match.window_px / 2 + 2;
    s.match.min_score = 0.0;
    s.match.adaptive_threshold = false;
  }
  return s;
}

std::vector<Eigen::Vector2d> grid_points(const Raster<std::uint8_t>& image, const GridInterestOptions& o) {
  std::vector<Eigen::Vector2d> points;
  for (const InterestPoint& ip : grid_interest_points(image, o)) points.push_back(ip.position);
  return points;
}

MethodOutput correlation(const PairData& p, const CorrelationSetting& s) {
  const std::vector<Eigen::Vector2d> points = grid_points(p.master, s.interest);
  const CorrelationMatchResult r =
      correlation_match(p.master, p.secondary, points, make_map_transfer(p.rough), s.match);
  MethodOutput out;
  out.matches = r.matches;
  out.reach = ReachKind::square;
  out.reach_px = s.match.search_radius_px * p.rough.scale;
  out.candidates = points.size();
  return out;
}

/// correlation_match_pair (pipeline/correlation_pair.hpp) through the rough similarity, the
/// homography as its refit and final model. Its reach is the first pass's search square.
MethodOutput pair_2d(const PairData& p, CorrelationMeasure measure) {
  CorrelationPairOptions options;
  options.match.measure = measure;
  options.model = PairRefitModel::homography;
  options.threads = p.threads;
  const CorrelationPairReport r = correlation_match_pair(p.master, p.secondary, make_map_transfer(p.rough), options);
  MethodOutput out;
  out.matches = r.matches;
  out.null_source = r.tentative();
  out.reach = ReachKind::square;
  out.reach_px = options.match.search_radius_px * p.rough.scale;
  out.candidates = r.points;
  return out;
}

/// The pair as match_epochs sees it when each image is an orthophoto epoch in one frame
/// (--write-epochs' geotransforms: new 1 unit per px, old the similarity's scale, the same top-left
/// corner; a flat DSM under both) and --rough identity: precise_match_pair_correlation on the two
/// OrthoFrames with PreciseMatchingOptions' defaults but the measure. Its reach is the first
/// pass's search square.
MethodOutput orthophoto_epochs(const PairData& p, CorrelationMeasure measure) {
  const double top = p.secondary.height();
  const OrthoFrame old_frame(GeoTransform::north_up(0.0, top, p.rough.scale), p.master.width(), p.master.height());
  const OrthoFrame new_frame(GeoTransform::north_up(0.0, top, 1.0), p.secondary.width(), p.secondary.height());
  // A flat DSM of 4-unit cells over both images with a margin.
  const double cell = 4.0;
  const double extent = std::max(p.master.width() * p.rough.scale, static_cast<double>(p.secondary.width())) + 8 * cell;
  const double depth = std::max(p.master.height() * p.rough.scale, static_cast<double>(p.secondary.height())) + 8 * cell;
  Raster<float> heights(static_cast<int>(std::ceil(extent / cell)), static_cast<int>(std::ceil(depth / cell)));
  std::fill(heights.begin(), heights.end(), 0.0f);
  const Dsm flat(std::move(heights), GeoTransform::north_up(-4 * cell, top + 4 * cell, cell));
  PreciseMatchingOptions options;
  options.correlation.match.measure = measure;
  options.threads = p.threads;
  options.correlation.match.threads = p.threads;
  options.ground.threads = p.threads;
  const PreciseImage<OrthoFrame> master{&old_frame, &p.master, nullptr};
  const PreciseImage<OrthoFrame> secondary{&new_frame, &p.secondary, nullptr};
  const PrecisePairReport r =
      precise_match_pair_correlation(master, flat, secondary, flat, Helmert3::identity(), options);
  MethodOutput out;
  out.matches = r.matches;
  out.null_source = r.tentative;
  out.reach = ReachKind::square;
  out.reach_px = options.correlation.match.search_radius_px * p.rough.scale;
  out.candidates = r.tentative.size();
  return out;
}

const CorrelationMeasure kMeasures[] = {CorrelationMeasure::intensity, CorrelationMeasure::gradient,
                                        CorrelationMeasure::orientation};

std::string correlation_name(CorrelationMeasure m, bool composition) {
  return std::string("corr-") + to_string(m) + (composition ? "/cells6-min0" : "/defaults");
}

/// The methods, in table order. Adding one is one entry here.
std::vector<Method> all_methods() {
  std::vector<Method> m;
  m.push_back({"sift-whole", "whole-image SIFT, ratio 0.8 + mutual",
               [](const PairData& p) { return whole_image(p, false); }});
  m.push_back({"rootsift-whole", "whole-image RootSIFT, ratio 0.8 + mutual",
               [](const PairData& p) { return whole_image(p, true); }});
  m.push_back({"sift-guided", "guided SIFT under the rough similarity (guided_match defaults)",
               [](const PairData& p) { return guided(p, false); }});
  m.push_back({"rootsift-guided", "guided RootSIFT under the rough similarity (guided_match defaults)",
               [](const PairData& p) { return guided(p, true); }});
  for (const bool composition : {false, true})
    for (const CorrelationMeasure measure : kMeasures)
      m.push_back({correlation_name(measure, composition),
                   composition ? "grid points (6 px cells, window margin) + correlation_match, min_score 0"
                               : "grid_interest_points + correlation_match, the components' defaults",
                   [measure, composition](const PairData& p) {
                     return correlation(p, correlation_setting(measure, composition, p.threads));
                   }});
  // ---- The 2D composition (pipeline/correlation_pair.hpp) under the rough similarity ----
  for (const CorrelationMeasure measure : kMeasures)
    m.push_back({std::string("pair2d-") + to_string(measure),
                 "correlation_match_pair, homography refit, its defaults but the measure",
                 [measure](const PairData& p) { return pair_2d(p, measure); }});
  // ---- match_epochs' own composition, the pair made into two orthophoto epochs ----
  for (const CorrelationMeasure measure : kMeasures)
    m.push_back({std::string("epochs-") + to_string(measure),
                 "match_epochs OLD NEW --rough identity on orthophoto epochs (flat DSM): "
                 "precise_match_pair_correlation, its defaults but the measure",
                 [measure](const PairData& p) { return orthophoto_epochs(p, measure); }});
  return m;
}

// ---- Scoring ----------------------------------------------------------------------------------------

struct Score {
  std::size_t matches = 0, inliers = 0;
  int cells = 0;
  bool fitted = false;
  Homography2 model;
  std::vector<char> inlier_mask;
  double share() const { return matches ? static_cast<double>(inliers) / static_cast<double>(matches) : 0.0; }
};

Score score(const std::vector<PointPair2>& pairs, const Raster<std::uint8_t>& master, const RansacOptions& o) {
  Score s;
  s.matches = pairs.size();
  if (pairs.size() < 5) return s;  // a homography needs 4, and one more to be evidence
  const RansacReport<Homography2> r = ransac_homography2(pairs, o);
  if (!r.success) return s;
  s.fitted = true;
  s.model = r.model;
  s.inliers = r.inliers.size();
  s.inlier_mask = r.inlier_mask;
  bool cell[kCoverageGrid * kCoverageGrid] = {};
  for (const std::size_t i : r.inliers) {
    const Eigen::Vector2d& a = pairs[i].source;
    const int cx = std::clamp(static_cast<int>((a.x() + 0.5) * kCoverageGrid / master.width()), 0, kCoverageGrid - 1);
    const int cy = std::clamp(static_cast<int>((a.y() + 0.5) * kCoverageGrid / master.height()), 0, kCoverageGrid - 1);
    cell[cy * kCoverageGrid + cx] = true;
  }
  s.cells = static_cast<int>(std::count(std::begin(cell), std::end(cell), true));
  return s;
}

std::vector<PointPair2> as_pairs(const PointMatches& matches) {
  std::vector<PointPair2> pairs;
  pairs.reserve(matches.size());
  for (const PointMatch& m : matches) pairs.push_back(PointPair2{m.a, m.b});
  return pairs;
}

/// The null model's draw `draw`: the same master points, partners uniform within the reach.
std::vector<PointPair2> null_pairs(const PointMatches& matches, const MethodOutput& out, const PairData& p,
                                   std::uint64_t seed, int draw) {
  RandomStream random(seed, 0x4e11'0000ULL + static_cast<std::uint64_t>(draw));
  const double w = p.secondary.width(), h = p.secondary.height();
  std::vector<PointPair2> pairs;
  pairs.reserve(matches.size());
  for (const PointMatch& m : matches) {
    Eigen::Vector2d b;
    if (out.reach == ReachKind::whole_image) {
      const double y = random.uniform(-0.5, h - 0.5);  // one draw per statement (docs/conventions.md)
      b = Eigen::Vector2d(random.uniform(-0.5, w - 0.5), y);
    } else if (out.reach == ReachKind::square) {
      const double dy = random.uniform(-out.reach_px, out.reach_px);
      b = p.rough(m.a) + Eigen::Vector2d(random.uniform(-out.reach_px, out.reach_px), dy);
    } else {
      const double angle = random.uniform(-kPi, kPi);
      const double r = out.reach_px * std::sqrt(random.uniform(0.0, 1.0));  // uniform over the disc
      b = p.rough(m.a) + r * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
    pairs.push_back(PointPair2{m.a, b});
  }
  return pairs;
}

struct MethodRow {
  std::string name;
  Score score;
  std::size_t candidates = 0;
  double null_mean = 0.0, null_max = 0.0;
  double seconds = 0.0;
  PointMatches matches;
  bool beats_chance() const {
    const double n = static_cast<double>(score.inliers);
    return n >= 3.0 * null_max && n >= null_max + 20.0;
  }
};

// ---- Peak-score statistics against a reference homography -----------------------------------------

struct Quantiles {
  double p10 = std::nan(""), p50 = std::nan(""), p90 = std::nan("");
  std::size_t n = 0;
};

Quantiles quantiles(std::vector<double> v) {
  Quantiles q;
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  q.n = v.size();
  if (v.empty()) return q;
  std::sort(v.begin(), v.end());
  const auto at = [&v](double f) {
    return v[static_cast<std::size_t>(std::lround(f * static_cast<double>(v.size() - 1)))];
  };
  q.p10 = at(0.1);
  q.p50 = at(0.5);
  q.p90 = at(0.9);
  return q;
}

/// The min_score thresholds the matches are also counted at (peak score >= each).
constexpr double kMinScores[] = {0.0, 0.1, 0.2, 0.3, 0.5};
constexpr std::size_t kNumMinScores = std::size(kMinScores);

struct MeasureStats {
  CorrelationMeasure measure{};
  Quantiles at_reference, at_random;
  std::size_t grid_points = 0, matched = 0, within = 0;
  /// Per kMinScores threshold: the matches whose peak score reaches it, and those within 3 px.
  std::array<std::size_t, kNumMinScores> kept_at{}, within_at{};

  void count(const PointMatch& m, bool within_3px) {
    within += within_3px ? 1 : 0;
    for (std::size_t t = 0; t < kNumMinScores; ++t)
      if (m.score >= kMinScores[t]) {
        ++kept_at[t];
        within_at[t] += within_3px ? 1 : 0;
      }
  }
};

/// Up to `max_points` of `all`, taken evenly (every k-th).
std::vector<Eigen::Vector2d> evenly(const std::vector<Eigen::Vector2d>& all, std::size_t max_points) {
  const std::size_t bound = std::max<std::size_t>(max_points, 1);
  const std::size_t stride = std::max<std::size_t>(1, (all.size() + bound - 1) / bound);
  std::vector<Eigen::Vector2d> points;
  for (std::size_t i = 0; i < all.size(); i += stride) points.push_back(all[i]);
  return points;
}

/// For each point: the best score within +-2 master px of its position through `reference` (the
/// correct position, up to the reference's error), and of a random position whose every offset from
/// it exceeds `far_px` secondary px (twice the window at the pair's scale); both windows resampled
/// through the local affine of `shape` (smooth, unlike a truth traced on trees and roofs). NaN where
/// a window leaves an image or a transfer gives nothing. Appended to `at_reference` and `at_random`.
template <class Transfer, class ShapeTransfer>
void peak_scores(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                 const std::vector<Eigen::Vector2d>& points, const Transfer& reference, const ShapeTransfer& shape,
                 const CorrelationMatchOptions& match, double far_px, std::size_t threads, std::uint64_t seed,
                 std::vector<double>& at_reference, std::vector<double>& at_random) {
  CorrelationMatchOptions near = match;
  near.search_radius_px = 2;
  near.exclusion_px = 1;
  const double w = secondary.width(), h = secondary.height();
  std::vector<double> ref(points.size(), std::nan("")), rnd(points.size(), std::nan(""));
  const auto best = [](const Eigen::MatrixXd& surface) {
    double b = std::nan("");
    for (Eigen::Index i = 0; i < surface.size(); ++i)
      if (std::isfinite(surface(i)) && !(surface(i) <= b)) b = surface(i);
    return b;
  };
  parallel_for(points.size(), threads, [&](std::size_t k) {
    const Eigen::Vector2d& a = points[k];
    const std::optional<Eigen::Vector2d> b = reference(a);
    const std::optional<Eigen::Matrix2d> affine = local_affine(shape, a, match.affine_step());
    if (!b || !affine) return;
    ref[k] = best(correlation_surface(master, a, secondary, *b, *affine, near));
    RandomStream random(seed, 0x57a7'0000ULL + k);
    for (int attempt = 0; attempt < 50; ++attempt) {
      const double y = random.uniform(0.0, h - 1.0);  // one draw per statement (docs/conventions.md)
      const Eigen::Vector2d c(random.uniform(0.0, w - 1.0), y);
      if ((c - *b).lpNorm<Eigen::Infinity>() < far_px) continue;
      const Eigen::MatrixXd surface = correlation_surface(master, a, secondary, c, *affine, near);
      if (surface.size() == 0) continue;  // a window leaves an image: draw again
      rnd[k] = best(surface);
      break;
    }
  });
  at_reference.insert(at_reference.end(), ref.begin(), ref.end());
  at_random.insert(at_random.end(), rnd.begin(), rnd.end());
}

/// peak_scores on a real pair against the reference homography, over at most `max_points` of the
/// composition's grid points; and, of the method corr-<measure>/cells6-min0 (`composition_row`), the
/// grid points matched and those within 3 px of the reference.
MeasureStats peak_statistics(const PairData& p, const Homography2& reference, CorrelationMeasure measure,
                             const MethodRow& composition_row, std::size_t max_points, std::uint64_t seed) {
  MeasureStats st;
  st.measure = measure;
  const CorrelationSetting s = correlation_setting(measure, true, p.threads);
  const std::vector<Eigen::Vector2d> points = evenly(grid_points(p.master, s.interest), max_points);
  std::vector<double> ref, rnd;
  const auto transfer = make_map_transfer(reference);
  peak_scores(p.master, p.secondary, points, transfer, transfer, s.match,
              2.0 * s.match.window_px * p.rough.scale, p.threads, seed, ref, rnd);
  st.at_reference = quantiles(ref);
  st.at_random = quantiles(rnd);
  st.grid_points = composition_row.candidates;
  st.matched = composition_row.matches.size();
  for (const PointMatch& m : composition_row.matches) {
    const std::optional<Eigen::Vector2d> b = reference(m.a);
    st.count(m, b && (*b - m.b).norm() <= kInlierPx);
  }
  return st;
}

/// The same statistics on decades-apart synthetic scenes (SceneOptions::decades_apart(), seeds
/// first_seed ...), against the true transfer (eval/match_truth.hpp): on up to `pairs_per_seed`
/// overlapping image pairs per seed, the peak scores at the true and at random positions; and
/// correlation_match (the composition's settings) on the same points, predicted through the epoch
/// DSMs and the TRUE Helmert (a perfect rough co-registration), its matches that the truth can score
/// counted within 3 px of the truth, out of the points the truth can score. One MeasureStats per
/// measure, over all pairs.
std::vector<MeasureStats> decades_statistics(int seeds, std::uint64_t first_seed, std::size_t pairs_per_seed,
                                             std::size_t max_points, std::size_t threads, std::uint64_t seed,
                                             const std::vector<std::string>& calm) {
  std::vector<MeasureStats> out;
  std::vector<std::vector<double>> ref(std::size(kMeasures)), rnd(std::size(kMeasures));
  for (const CorrelationMeasure m : kMeasures) {
    MeasureStats st;
    st.measure = m;
    out.push_back(st);
  }
  for (int si = 0; si < seeds; ++si) {
    SceneOptions options = SceneOptions::decades_apart();
    options.seed = first_seed + static_cast<std::uint64_t>(si);
    options.threads = threads;
    calm_scene(options, calm);
    const auto t0 = std::chrono::steady_clock::now();
    const Scene scene = generate_scene(options);
    const SyntheticEpoch& e1 = scene.epochs[0];
    const SyntheticEpoch& e2 = scene.epochs[1];
    const MatchTruthScorer truth(scene);
    const Helmert3 true_helmert = e2.epoch_from_world() * e1.epoch_from_world().inverse();
    const std::vector<Frame<FraserAffine>> frames1 = e1.estimated_frames(), frames2 = e2.estimated_frames();
    // Pairs whose master centre is seen in the secondary image, the first per master image.
    std::vector<std::pair<int, int>> pairs;
    for (std::size_t i = 0; i < e1.images.size() && pairs.size() < pairs_per_seed; ++i) {
      const Raster<std::uint8_t>& img = e1.images[i].pixels;
      const Eigen::Vector2d centre(0.5 * (img.width() - 1), 0.5 * (img.height() - 1));
      for (std::size_t j = 0; j < e2.images.size(); ++j)
        if (truth.transfer({0, static_cast<int>(i)}, {1, static_cast<int>(j)}, centre).scored()) {
          pairs.emplace_back(static_cast<int>(i), static_cast<int>(j));
          break;
        }
    }
    std::fprintf(stderr, "decades seed %llu: scene in %.1f s, %zu pairs\n",
                 static_cast<unsigned long long>(options.seed), seconds_since(t0), pairs.size());
    for (const auto& [i, j] : pairs) {
      const Raster<std::uint8_t>& master = e1.images[static_cast<std::size_t>(i)].pixels;
      const Raster<std::uint8_t>& secondary = e2.images[static_cast<std::size_t>(j)].pixels;
      const auto true_transfer = [&truth, i = i, j = j](const Eigen::Vector2d& a) -> std::optional<Eigen::Vector2d> {
        const MatchTruth t = truth.transfer({0, i}, {1, j}, a);
        if (!t.scored()) return std::nullopt;
        return t.true_pixel;
      };
      const auto predicted = make_dsm_transfer(frames1[static_cast<std::size_t>(i)], e1.dsm,
                                               frames2[static_cast<std::size_t>(j)], true_helmert);
      const Eigen::Vector2d centre(0.5 * (master.width() - 1), 0.5 * (master.height() - 1));
      const std::optional<Eigen::Matrix2d> a0 = local_affine(true_transfer, centre, 1.0);
      const double scale = a0 ? affine_scale(*a0) : 1.0;
      for (std::size_t k = 0; k < std::size(kMeasures); ++k) {
        const CorrelationSetting s = correlation_setting(kMeasures[k], true, threads);
        const std::vector<Eigen::Vector2d> points = evenly(grid_points(master, s.interest), max_points);
        peak_scores(master, secondary, points, true_transfer, predicted, s.match, 2.0 * s.match.window_px * scale,
                    threads, seed, ref[k], rnd[k]);
        const CorrelationMatchResult r = correlation_match(master, secondary, points, predicted, s.match);
        // The denominator: the points the truth can score (in the overlap, on unchanged ground), as
        // every point of a real pair is in its overlap.
        for (const Eigen::Vector2d& a : points) out[k].grid_points += true_transfer(a) ? 1 : 0;
        for (const PointMatch& m : r.matches) {
          // Only the matches the truth can score (not on changed, occluded or unseen ground).
          const std::optional<Eigen::Vector2d> b = true_transfer(m.a);
          if (!b) continue;
          ++out[k].matched;
          out[k].count(m, (*b - m.b).norm() <= kInlierPx);
        }
      }
    }
  }
  for (std::size_t k = 0; k < out.size(); ++k) {
    out[k].at_reference = quantiles(ref[k]);
    out[k].at_random = quantiles(rnd[k]);
  }
  return out;
}

// ---- Pictures and epochs -----------------------------------------------------------------------------

/// `image` stretched linearly so that its 1st and 99th percentiles become 0 and 255: the epochs'
/// tones differ (the new orthophoto is dark), and a person compares shapes, not grey levels.
cv::Mat stretched(const Raster<std::uint8_t>& image) {
  std::vector<std::uint8_t> v(image.begin(), image.end());
  std::sort(v.begin(), v.end());
  const double lo = v[v.size() / 100], hi = std::max<double>(lo + 1.0, v[v.size() - 1 - v.size() / 100]);
  cv::Mat out;
  as_mat(image).convertTo(out, CV_8U, 255.0 / (hi - lo), -255.0 * lo / (hi - lo));
  return out;
}

void write_picture(const std::string& path, const PairData& p, const MethodRow& row) {
  const cv::Mat master = stretched(p.master), secondary = stretched(p.secondary);
  cv::Mat warped(master.size(), CV_8U, cv::Scalar(0));
  const bool fitted = row.score.fitted;
  if (fitted) {
    cv::Mat h(3, 3, CV_64F);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) h.at<double>(r, c) = row.score.model.matrix(r, c);
    // The homography maps master px to secondary px: sample the secondary there.
    cv::warpPerspective(secondary, warped, h, master.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
  }
  cv::Mat grey = master.clone();
  constexpr int kSquare = 64;
  for (int y = 0; y < grey.rows; ++y)
    for (int x = 0; x < grey.cols; ++x)
      if (fitted && ((x / kSquare + y / kSquare) % 2 == 1)) grey.at<std::uint8_t>(y, x) = warped.at<std::uint8_t>(y, x);
  cv::Mat colour;
  cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
  for (std::size_t i = 0; i < row.matches.size(); ++i) {
    const bool inlier = i < row.score.inlier_mask.size() && row.score.inlier_mask[i];
    const Eigen::Vector2d& a = row.matches[i].a;
    const cv::Point c(static_cast<int>(std::lround(a.x())), static_cast<int>(std::lround(a.y())));
    const int r = row.matches.size() > 2000 ? 1 : 2;  // dense matches: small dots
    cv::circle(colour, c, inlier ? r + 1 : r, inlier ? cv::Scalar(0, 220, 0) : cv::Scalar(0, 0, 255), cv::FILLED);
  }
  std::ostringstream line1, line2;
  line1 << p.name << ", " << row.name;
  line2 << row.score.inliers << " of " << row.score.matches << " within 3 px, null max " << row.null_max
        << (row.beats_chance() ? ": beats chance" : ": chance");
  int y = 20;
  for (const std::string& text : {line1.str(), line2.str()}) {
    cv::putText(colour, text, cv::Point(8, y), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 4);
    cv::putText(colour, text, cv::Point(8, y), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(255, 255, 255), 1);
    y += 22;
  }
  DIACHRON_CHECK(cv::imwrite(path, colour, {cv::IMWRITE_JPEG_QUALITY, 85}), "cannot write " << path);
}

void write_ortho(const Raster<std::uint8_t>& image, const GeoTransform& geo, const std::string& path) {
  detail::gdal_register_once();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  DIACHRON_CHECK(driver != nullptr, "GDAL has no GTiff driver");
  detail::GdalDatasetPtr ds(driver->Create(path.c_str(), image.width(), image.height(), 1, GDT_Byte, nullptr));
  DIACHRON_CHECK(ds != nullptr, "cannot create " << path);
  std::array<double, 6> c = geo.c;
  ds->SetGeoTransform(c.data());
  const CPLErr err = ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, image.width(), image.height(),
                                                    const_cast<std::uint8_t*>(image.data()), image.width(),
                                                    image.height(), GDT_Byte, 0, 0, nullptr);
  DIACHRON_CHECK(err == CE_None, "cannot write " << path);
  detail::close_written(ds, path);
}

/// One orthophoto epoch: the image with geotransform `geo`, and a DSM of `cell`-unit cells over the
/// image's extent, flat (0) or from the grey rendering `dsm_grey` (metres_per_level per grey level).
void write_epoch(const std::string& folder, const Raster<std::uint8_t>& image, const GeoTransform& geo, double cell,
                 const Raster<std::uint8_t>* dsm_grey, double metres_per_level) {
  make_directories(folder);
  write_ortho(image, geo, folder + "/ortho.tif");
  const double x0 = geo.c[0], y0 = geo.c[3];
  const double width_units = image.width() * geo.c[1], height_units = image.height() * -geo.c[5];
  const int dw = static_cast<int>(std::ceil(width_units / cell)), dh = static_cast<int>(std::ceil(height_units / cell));
  const GeoTransform dsm_geo = GeoTransform::north_up(x0, y0, cell);
  Raster<float> heights(dw, dh);
  for (int y = 0; y < dh; ++y)
    for (int x = 0; x < dw; ++x) {
      float z = 0.0f;
      if (dsm_grey) {
        // The cell centre's image pixel, then the rendering's (nearest; it has about the image's size).
        const Eigen::Vector2d px = geo.world_to_pixel(dsm_geo.pixel_to_world(Eigen::Vector2d(x, y)));
        const double fx = static_cast<double>(dsm_grey->width()) / image.width();
        const double fy = static_cast<double>(dsm_grey->height()) / image.height();
        const int gx = std::clamp(static_cast<int>(std::lround((px.x() + 0.5) * fx - 0.5)), 0, dsm_grey->width() - 1);
        const int gy = std::clamp(static_cast<int>(std::lround((px.y() + 0.5) * fy - 0.5)), 0, dsm_grey->height() - 1);
        z = static_cast<float>((*dsm_grey)(gx, gy) * metres_per_level);
      }
      heights(x, y) = z;
    }
  write_geotiff_dsm(Dsm(std::move(heights), dsm_geo), folder + "/dsm.tif");
}

// ---- Output -------------------------------------------------------------------------------------------

std::string fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

/// 100 part / whole with one decimal (0 for an empty whole).
std::string percent(std::size_t part, std::size_t whole) {
  return fixed(whole ? 100.0 * static_cast<double>(part) / static_cast<double>(whole) : 0.0, 1);
}

std::string verdict(const MethodRow& r) {
  if (!r.beats_chance()) return "chance";
  return "beats (" + (r.null_max > 0 ? fixed(r.score.inliers / r.null_max, 1) + " x" : std::string("inf x")) +
         " null max)";
}

/// JSON text of a number, null when it is not finite (JSON has no NaN).
std::string json_value(double v) { return std::isfinite(v) ? json_number(v) : std::string("null"); }

std::string stats_json(const MeasureStats& s) {
  const auto q = [](const Quantiles& v) {
    return "[" + json_value(v.p10) + ", " + json_value(v.p50) + ", " + json_value(v.p90) + "]";
  };
  std::ostringstream out;
  out << "{\"measure\": " << json_quoted(to_string(s.measure)) << ", \"at_reference\": " << q(s.at_reference)
      << ", \"at_random\": " << q(s.at_random) << ", \"points\": " << s.at_reference.n
      << ", \"grid_points\": " << s.grid_points << ", \"matched\": " << s.matched << ", \"within_3px\": " << s.within
      << ", \"by_min_score\": [";
  for (std::size_t t = 0; t < kNumMinScores; ++t)
    out << (t ? ", " : "") << "{\"min_score\": " << json_number(kMinScores[t]) << ", \"kept\": " << s.kept_at[t]
        << ", \"within_3px\": " << s.within_at[t] << "}";
  out << "]}";
  return out.str();
}

std::string quantile_text(const Quantiles& q) {
  return fixed(q.p10, 2) + " / " + fixed(q.p50, 2) + " / " + fixed(q.p90, 2);
}

}  // namespace

int main(int argc, char** argv) {
  const Arguments args = parse(argc, argv);
  try {
    const std::string folder = args.data + "/real-pairs";
    if (!file_exists(folder)) {
      std::printf("real_pairs_eval: skipped, no %s (set --data DIR or DIACHRON_DATA_DIR)\n", folder.c_str());
      return 0;
    }
    std::vector<Method> methods;
    for (Method& m : all_methods())
      if (args.methods.empty() || std::find(args.methods.begin(), args.methods.end(), m.name) != args.methods.end())
        methods.push_back(std::move(m));
    for (const std::string& name : args.methods)
      if (std::none_of(methods.begin(), methods.end(), [&](const Method& m) { return m.name == name; }))
        throw Error("unknown method " + name);
    if (!args.pictures.empty()) make_directories(args.pictures);
    RansacOptions ransac;
    ransac.threshold = kInlierPx;
    ransac.max_iterations = args.iterations;
    ransac.seed = args.seed;
    ransac.threads = args.threads;

    std::printf("real_pairs_eval: homography RANSAC at %.0f px (at most %zu iterations, seed %llu), %d null draws, "
                "load %s\n",
                kInlierPx, args.iterations, static_cast<unsigned long long>(args.seed), args.draws,
                bench::load_average().c_str());
    std::ostringstream json;
    json << "{\"threshold_px\": " << kInlierPx << ", \"iterations\": " << args.iterations
         << ", \"draws\": " << args.draws << ", \"seed\": " << args.seed << ", \"pairs\": [";
    std::vector<std::pair<std::string, std::vector<MeasureStats>>> all_stats;  // side by side at the end
    for (std::size_t pi = 0; pi < args.pairs.size(); ++pi) {
      const std::string& name = args.pairs[pi];
      PairData p;
      p.name = name;
      p.threads = args.threads;
      p.master = load_gray8(folder + "/" + name + "_old.png");
      p.secondary = load_gray8(folder + "/" + name + "_new.png");
      p.rough.scale = static_cast<double>(p.secondary.width()) / p.master.width();
      std::printf("\n## %s: old %d x %d (master) -> new %d x %d, rough similarity: scale %.5f, no rotation, no "
                  "translation\n\n",
                  name.c_str(), p.master.width(), p.master.height(), p.secondary.width(), p.secondary.height(),
                  p.rough.scale);

      if (!args.write_epochs.empty()) {
        const std::string base = args.write_epochs + "/" + name;
        Raster<std::uint8_t> grey_old, grey_new;
        if (args.dsm == "grey") {
          grey_old = load_gray8(folder + "/" + name + "_old_dsm-grey.png");
          grey_new = load_gray8(folder + "/" + name + "_new_dsm-grey.png");
        }
        const double top = p.secondary.height();
        write_epoch(base + "/old", p.master, GeoTransform::north_up(0.0, top, p.rough.scale), args.dsm_cell,
                    args.dsm == "grey" ? &grey_old : nullptr, args.dsm_metres_per_level);
        write_epoch(base + "/new", p.secondary, GeoTransform::north_up(0.0, top, 1.0), args.dsm_cell,
                    args.dsm == "grey" ? &grey_new : nullptr, args.dsm_metres_per_level);
        std::fprintf(stderr, "%s: epochs written to %s/{old,new}\n", name.c_str(), base.c_str());
      }

      std::vector<MethodRow> rows;
      for (const Method& m : methods) {
        const auto t0 = std::chrono::steady_clock::now();
        MethodOutput out = m.run(p);
        MethodRow row;
        row.name = m.name;
        row.seconds = seconds_since(t0) + out.extra_seconds;
        row.candidates = out.candidates;
        row.score = score(as_pairs(out.matches), p.master, ransac);
        double sum = 0.0;
        for (int d = 0; d < args.draws; ++d) {
          const PointMatches& source = out.null_source.empty() ? out.matches : out.null_source;
          const Score null = score(null_pairs(source, out, p, args.seed, d), p.master, ransac);
          sum += static_cast<double>(null.inliers);
          row.null_max = std::max(row.null_max, static_cast<double>(null.inliers));
        }
        row.null_mean = sum / args.draws;
        row.matches = std::move(out.matches);
        std::fprintf(stderr, "  %s: %zu matches, %zu within 3 px, null max %.0f (%.1f s)\n", m.name.c_str(),
                     row.score.matches, row.score.inliers, row.null_max, row.seconds);
        if (!args.pictures.empty()) {
          std::string file = name + "_" + m.name + ".jpg";
          std::replace(file.begin(), file.end(), '/', '_');
          write_picture(args.pictures + "/" + file, p, row);
        }
        rows.push_back(std::move(row));
      }

      bench::Table table(
          {"method", "matches", "within 3 px", "share", "cells of 16", "null mean / max", "verdict", "s"});
      for (const MethodRow& r : rows)
        table.add({r.name, std::to_string(r.score.matches), std::to_string(r.score.inliers),
                   fixed(100.0 * r.score.share(), 1) + " %", std::to_string(r.score.cells),
                   fixed(r.null_mean, 1) + " / " + fixed(r.null_max, 0), verdict(r), fixed(r.seconds, 1)});
      table.print(std::cout);

      // The reference: the RANSAC model of the method with most inliers among those beating chance.
      const MethodRow* best = nullptr;
      for (const MethodRow& r : rows)
        if (r.beats_chance() && r.score.fitted && (!best || r.score.inliers > best->score.inliers)) best = &r;
      std::vector<MeasureStats> stats;
      if (args.stats && best) {
        std::printf("\nPeak scores (best within +-2 master px) at the reference position and at a random one, "
                    "reference = %s's homography (%zu inliers):\n\n",
                    best->name.c_str(), best->score.inliers);
        bench::Table st({"measure", "at reference p10 / median / p90", "at random p10 / median / p90", "points",
                         "grid points matched (cells6-min0)", "of them within 3 px"});
        for (const CorrelationMeasure measure : kMeasures) {
          const std::string composition = correlation_name(measure, true);
          const auto it =
              std::find_if(rows.begin(), rows.end(), [&](const MethodRow& r) { return r.name == composition; });
          MethodRow empty;
          const MeasureStats s =
              peak_statistics(p, best->score.model, measure, it != rows.end() ? *it : empty, args.stats_points,
                              args.seed);
          stats.push_back(s);
          const bool ran = it != rows.end();
          st.add({to_string(measure), quantile_text(s.at_reference), quantile_text(s.at_random),
                  std::to_string(s.at_reference.n),
                  ran ? std::to_string(s.matched) + " of " + std::to_string(s.grid_points) + " (" +
                            percent(s.matched, s.grid_points) + " %)"
                      : "-",
                  ran ? std::to_string(s.within) + " (" + percent(s.within, s.matched) + " %)" : "-"});
        }
        st.print(std::cout);
      } else if (args.stats) {
        std::printf("\nNo method beats chance on %s: no reference, no peak-score statistics.\n", name.c_str());
      }

      if (!stats.empty()) all_stats.emplace_back(name + " (reference: " + best->name + ")", stats);
      json << (pi ? ", " : "") << "{\"name\": " << json_quoted(name) << ", \"master\": [" << p.master.width() << ", "
           << p.master.height() << "], \"secondary\": [" << p.secondary.width() << ", " << p.secondary.height()
           << "], \"rough_scale\": " << json_number(p.rough.scale) << ", \"methods\": [";
      for (std::size_t k = 0; k < rows.size(); ++k) {
        const MethodRow& r = rows[k];
        json << (k ? ", " : "") << "{\"name\": " << json_quoted(r.name) << ", \"matches\": " << r.score.matches
             << ", \"inliers\": " << r.score.inliers << ", \"share\": " << json_number(r.score.share())
             << ", \"cells\": " << r.score.cells << ", \"null_mean\": " << json_number(r.null_mean)
             << ", \"null_max\": " << json_number(r.null_max)
             << ", \"beats_chance\": " << (r.beats_chance() ? "true" : "false")
             << ", \"seconds\": " << json_number(r.seconds) << "}";
      }
      json << "], \"reference\": " << (best ? json_quoted(best->name) : std::string("null")) << ", \"statistics\": [";
      for (std::size_t k = 0; k < stats.size(); ++k) json << (k ? ", " : "") << stats_json(stats[k]);
      json << "]}";
    }
    json << "]";
    if (args.stats && args.decades > 0) {
      std::vector<MeasureStats> d = decades_statistics(args.decades, args.decades_first_seed, args.decades_pairs,
                                                       args.stats_points, args.threads, args.seed, args.decades_calm);
      std::ostringstream label;
      label << "decades seeds " << args.decades_first_seed << ".." << args.decades_first_seed + args.decades - 1;
      if (!args.decades_calm.empty()) {
        label << " without";
        for (const std::string& part : args.decades_calm) label << ' ' << part;
      }
      label << " (truth; matches predicted through the DSMs and the true Helmert)";
      all_stats.emplace_back(label.str(), d);
      json << ", \"decades\": {\"seeds\": " << args.decades << ", \"first_seed\": " << args.decades_first_seed
           << ", \"calm\": [";
      for (std::size_t k = 0; k < args.decades_calm.size(); ++k)
        json << (k ? ", " : "") << json_quoted(args.decades_calm[k]);
      json << "]"
           << ", \"statistics\": [";
      for (std::size_t k = 0; k < d.size(); ++k) json << (k ? ", " : "") << stats_json(d[k]);
      json << "]}";
    }
    json << "}\n";
    if (!all_stats.empty()) {
      std::printf("\n## Peak scores side by side (best within +-2 master px; correct = at the reference or true "
                  "position, random = farther than twice the window)\n\n");
      bench::Table side({"measure", "data", "correct p10 / median / p90", "random p10 / median / p90",
                         "grid points matched", "matches within 3 px"});
      for (std::size_t k = 0; k < std::size(kMeasures); ++k)
        for (const auto& [label, st] : all_stats) {
          const MeasureStats& s = st[k];
          side.add({to_string(s.measure), label, quantile_text(s.at_reference), quantile_text(s.at_random),
                    percent(s.matched, s.grid_points) + " % of " + std::to_string(s.grid_points),
                    std::to_string(s.within) + " (" + percent(s.within, s.matched) + " %)"});
        }
      side.print(std::cout);
      std::printf("\n## The composition's matches by peak score (min_score): kept, within 3 px (share)\n\n");
      std::vector<std::string> header = {"measure", "data"};
      for (const double t : kMinScores) header.push_back(">= " + fixed(t, 1));
      bench::Table by_score(header);
      for (std::size_t k = 0; k < std::size(kMeasures); ++k)
        for (const auto& [label, st] : all_stats) {
          const MeasureStats& s = st[k];
          std::vector<std::string> cells = {to_string(s.measure), label};
          for (std::size_t t = 0; t < kNumMinScores; ++t)
            cells.push_back(std::to_string(s.kept_at[t]) + ", " + std::to_string(s.within_at[t]) + " (" +
                            fixed(s.kept_at[t] ? 100.0 * s.within_at[t] / s.kept_at[t] : 0.0, 0) + " %)");
          by_score.add(cells);
        }
      by_score.print(std::cout);
    }
    if (!args.json.empty()) {
      std::FILE* f = std::fopen(args.json.c_str(), "w");
      DIACHRON_CHECK(f != nullptr, "cannot write " << args.json);
      std::fputs(json.str().c_str(), f);
      std::fclose(f);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "real_pairs_eval: %s\n", e.what());
    return 1;
  }
}
