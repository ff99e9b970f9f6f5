// Evaluation of the rough co-registration over many cases made from the real DEMs in
// ../shared/data: each case moves a window of a DEM into an arbitrary frame (rotation 0-360 deg,
// scale 0.5-2, shift, small tilt), crops it to a random partial overlap, adds holes and noise
// (eval/coregistration_case.hpp), runs one configuration, and checks the recovered Helmert against
// the truth. Success: RMS Helmert error below 2 secondary DSM cells over the overlap (with --gaps,
// 2 cells of the coarser DSM).
//
// With --gaps F1,F2,... (e.g. 2,4,8), the cases have resolution gaps: each source's master or
// secondary DEM (alternately) is first coarsened F times (block means, matching/scale_hypotheses.hpp),
// and the real pair Mount St. Helens 2000 (10 m, whole crater) / 2004-10-13 (2 m, dome area only),
// each whole, joins the sources (alternately as master and as secondary).
//
// --verbose prints a line per case and configuration: the scale hypotheses, and for the correlation
// fallback where its winner puts the master's centre against the truth and why it was refused.
//
// --null turns every case into one without an answer, to calibrate the correlation fallback's
// margin: each source DEM is cut in a west and an east half, and a case drawn on one half gets the
// secondary of a case drawn on the other (the same kind of terrain, moved, noised and holed as the
// cases with an answer, but elsewhere). The real pair, used whole, keeps the 10 m DEM without the
// 2 m DEM's footprint and a margin of a tenth of its size (skipped where nothing is left).
// Every success reported on them is wrong. With or without --null, a table at the end takes the
// fallback's winners that pass min_score and the gain test and says, for margins from 0 to 0.25,
// how many of them each margin would accept and how many of those are right; then the margins
// themselves.
//
// --pair NAME=MASTER.tif,SECONDARY.tif (repeatable) replaces the built-in sources by the given DEM
// pairs (paths relative to --data unless absolute): each case cuts windows with the drawn overlap
// from the two DEMs' common footprint, as for the built-in sources; a DEM in degrees is first made
// metric. E.g. the Mount St. Helens dates among themselves, whose dome grew between them.
//
// --tilt DEG sets the largest tilt between the frames (CoregistrationCaseOptions::tilt_max_deg, 2 by
// default); the other draws of each case stay the same. --scale MIN MAX and --rotation DEG narrow the
// frames' scale (0.5-2) and rotation (0-360 degrees) the same way, to tell what a failure depends on.
//
// With --synthetic, the cases are instead synthetic two-epoch scenes (synth/): each epoch's DSM as
// an SfM delivers it (own frame, noise, holes, changed buildings), truth epoch2_from_epoch1.
//
//   rough_coregistration_eval [--data DIR] [--models DIR] [--cases N] [--overlap MIN MAX]
//                             [--configs C1,C2,...] [--threads N] [--seed S] [--max-features N]
//                             [--gaps F1,F2,...] [--only SOURCE] [--tilt DEG] [--null] [--verbose]
//                             [--pair NAME=MASTER.tif,SECONDARY.tif ...] [--scale MIN MAX] [--rotation DEG]
//
// A configuration is IMAGE/MATCHER/TILING/ROTATIONS, e.g. relief/sift/tiles/rot:
//   IMAGE     stretch2 stretch5 wallis2 wallis5 hillshade multihillshade slope relief
//   MATCHER   sift rootsift akaze xfeat orb, or any of them + "-nomask" (pass_masks off: the
//             matcher gets no validity mask, as before masks existed)
//   TILING    tiles (640 x 480, no buffer, the paper's) | whole
//   ROTATIONS rot (0/90/180/270, always) | norot
// or default/MATCHER/default/default: RoughCoregistrationOptions{} as shipped, and
// noscale/MATCHER/default/default: the same without scale hypotheses (small images are still
// enlarged; up0 turns that off), nofallback/MATCHER/default/default: the same without the dense
// correlation fallback, norefine and noconfirm: the same without the surface refinement or without
// the surfaces' confirmation of a refused fallback winner, upN[mK][xF], minscoreS and corr...: see
// parse_config.
// The paper's plain SIFT baseline is stretch2/sift/whole/norot. Prints a Markdown table.

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <diachron/eval/coregistration_case.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/matching/scale_hypotheses.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/cv_features.hpp>
#include <diachron/vision/image.hpp>
#include <diachron/vision/sift.hpp>
#include <diachron/vision/xfeat.hpp>

namespace {

using namespace diachron;

struct Source {
  std::string name;
  Dsm master, secondary;
  bool crop = true;
};

// Geographic DEMs (degrees) become metric with a local equirectangular projection, so that a
// similarity of the frame is a similarity of the ground.
Dsm to_metric(const Dsm& dsm) {
  if (dsm.min_cell_size() > 0.01) return dsm;
  GeoTransform gt = dsm.transform();
  const WorldBounds b = dsm.bounds();
  const double lat0 = 0.5 * (b.min_y + b.max_y), lon0 = 0.5 * (b.min_x + b.max_x);
  const double ky = 110540.0, kx = 111320.0 * std::cos(deg_to_rad(lat0));
  GeoTransform m;
  m.c = {500000.0 + (gt.c[0] - lon0) * kx, gt.c[1] * kx, gt.c[2] * kx,
         4000000.0 + (gt.c[3] - lat0) * ky, gt.c[4] * ky, gt.c[5] * ky};
  return Dsm(dsm.heights(), m, "local equirectangular");
}

std::vector<Source> load_sources(const std::string& data) {
  std::vector<Source> s;
  auto read = [&](const std::string& rel) { return read_geotiff_dsm(data + "/" + rel); };
  const Dsm lyr = read("longyearbyen-1990/dem_1990.tif");
  s.push_back({"longyearbyen", lyr, lyr, true});
  const Dsm srtm = to_metric(read("srtm-demcompare/srtm_ref.tif"));
  s.push_back({"srtm", srtm, srtm, true});
  s.push_back({"msh2000-2007", read("mount-st-helens/1_msh00_83.tif"),
               read("mount-st-helens/msh_2007_07_05_merged.tif"), true});
  return s;
}

// The --pair sources: "NAME=MASTER,SECONDARY", paths relative to `data` unless absolute.
std::vector<Source> pair_sources(const std::string& data, const std::vector<std::string>& pairs) {
  std::vector<Source> s;
  for (const std::string& p : pairs) {
    const std::size_t eq = p.find('='), comma = p.find(',', eq == std::string::npos ? 0 : eq);
    DIACHRON_CHECK(eq != std::string::npos && eq > 0 && comma != std::string::npos && comma > eq + 1 &&
                       comma + 1 < p.size(),
                   "--pair wants NAME=MASTER.tif,SECONDARY.tif, got '" << p << "'");
    const auto path = [&](const std::string& f) { return f.front() == '/' ? f : data + "/" + f; };
    s.push_back({p.substr(0, eq), to_metric(read_geotiff_dsm(path(p.substr(eq + 1, comma - eq - 1)))),
                 to_metric(read_geotiff_dsm(path(p.substr(comma + 1)))), true});
  }
  return s;
}

struct Config {
  std::string name;
  RoughCoregistrationOptions options;
  std::string matcher;
};

Config parse_config(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string p; std::getline(ss, p, '/');) parts.push_back(p);
  DIACHRON_CHECK(parts.size() == 4, "configuration '" << text << "' is not IMAGE/MATCHER/TILING/ROTATIONS");
  Config c{text, {}, parts[1]};
  std::string image = parts[0];
  auto& o = c.options;
  const std::string nomask = "-nomask";
  if (c.matcher.size() > nomask.size() && c.matcher.compare(c.matcher.size() - nomask.size(), nomask.size(), nomask) == 0) {
    c.matcher.resize(c.matcher.size() - nomask.size());
    o.pass_masks = false;
  }
  DIACHRON_CHECK(c.matcher == "sift" || c.matcher == "rootsift" || c.matcher == "akaze" || c.matcher == "xfeat" ||
                     c.matcher == "orb",
                 "unknown matcher '" << c.matcher << "'");
  if (image == "default") return c;
  // upN: the default with small DSM images enlarged below N px (ScaleHypothesesOptions::
  // upsample_below_px; up0 never enlarges); upNmK: also min_side_cells K; upNxF (or upNmKxF): also
  // max_upsample F.
  if (image.rfind("up", 0) == 0 && image.size() > 2 && std::isdigit(static_cast<unsigned char>(image[2]))) {
    std::size_t end = image.size();
    for (const char key : {'x', 'm'}) {  // upNmKxF: suffixes parsed from the end
      const std::size_t at = image.find(key, 2);
      if (at == std::string::npos) continue;
      const int value = std::stoi(image.substr(at + 1, end - at - 1));
      (key == 'x' ? o.scale_hypotheses.max_upsample : o.scale_hypotheses.min_side_cells) = value;
      end = std::min(end, at);
    }
    o.scale_hypotheses.upsample_below_px = std::stoi(image.substr(2, end - 2));
    return c;
  }
  // nofallback: the default without the dense correlation fallback (RoughCoregistrationOptions::
  // correlation_fallback, on by default), which runs when every feature hypothesis fails.
  if (image == "nofallback") {
    o.correlation_fallback = false;
    return c;
  }
  // corr: the default with the fallback on (the default since it is on; the name predates it);
  // corrgrad: the same correlating the heights' gradient (CorrelationSignal::gradient, the
  // search's default); corrgradN: also coarse_size_px N. A suffix -samples (corr-samples,
  // corrgrad-samples) weighs peaks by CorrelationStrength::samples (the search's default).
  const std::string gradient = "corrgrad";
  const std::string samples = "-samples";
  if (image.rfind("corr", 0) == 0 && image.size() > samples.size() &&
      image.compare(image.size() - samples.size(), samples.size(), samples) == 0) {
    o.correlation_search.strength = CorrelationStrength::samples;
    image.resize(image.size() - samples.size());
  }
  if (image == "corr" || image.rfind(gradient, 0) == 0) {
    o.correlation_fallback = true;
    if (image != "corr") o.correlation_search.signal = CorrelationSignal::gradient;
    if (image.size() > gradient.size()) o.correlation_search.coarse_size_px = std::stod(image.substr(gradient.size()));
    return c;
  }
  // minscoreS: the default with the fallback's DsmCorrelationSearchOptions::min_score at S (0.5).
  if (image.rfind("minscore", 0) == 0 && image.size() > 8) {
    o.correlation_search.min_score = std::stod(image.substr(8));
    return c;
  }
  // norefine: the default without the surface refinement (RoughCoregistrationOptions::refine_surface).
  if (image == "norefine") {
    o.refine_surface = false;
    return c;
  }
  // noconfirm: the default without the confirmation of refused fallback winners by the surfaces
  // (RoughCoregistrationOptions::surface_confirmation).
  if (image == "noconfirm") {
    o.surface_confirmation = false;
    return c;
  }
  if (image == "noscale") {
    o.scale_hypotheses.enabled = false;
    return c;
  }
  if (image == "stretch2" || image == "stretch5") {
    o.image_kind = DsmImageKind::kStretch;
    o.dsm_image.k_sigma = image == "stretch2" ? 2.0 : 5.0;
  } else if (image == "wallis2" || image == "wallis5") {
    o.image_kind = DsmImageKind::kStretchWallis;
    o.dsm_image.k_sigma = image == "wallis2" ? 2.0 : 5.0;
  } else if (image == "hillshade") {
    o.image_kind = DsmImageKind::kHillshade;
  } else if (image == "multihillshade") {
    o.image_kind = DsmImageKind::kMultiHillshade;
  } else if (image == "slope") {
    o.image_kind = DsmImageKind::kSlope;
  } else if (image == "relief") {
    o.image_kind = DsmImageKind::kLocalRelief;
  } else {
    DIACHRON_CHECK(false, "unknown DSM image '" << image << "'");
  }
  DIACHRON_CHECK(parts[2] == "tiles" || parts[2] == "whole", "TILING must be tiles or whole");
  DIACHRON_CHECK(parts[3] == "rot" || parts[3] == "norot", "ROTATIONS must be rot or norot");
  o.use_tiling = parts[2] == "tiles";
  o.master_tiles = o.secondary_tiles = GridTilerOptions{640, 480, 0, 0};
  o.rotation_hypotheses = parts[3] == "rot";
  o.skip_rotations_if_invariant = false;
  return c;
}

// ORB (oriented FAST + rotated BRIEF), binary descriptors unpacked one float per bit, features
// only where the mask allows (cv::Feature2D's mask).
struct OrbExtractor {
  int max_features = 2000;
  static constexpr DescriptorMetric descriptor_metric() { return DescriptorMetric::Hamming; }
  static constexpr bool rotation_invariant() { return true; }
  Features extract(const Raster<std::uint8_t>& image) const { return run(image, cv::Mat()); }
  Features extract(const Raster<std::uint8_t>& image, const Raster<std::uint8_t>& mask) const {
    return run(image, as_mat(mask));
  }
  Features run(const Raster<std::uint8_t>& image, const cv::Mat& mask) const {
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat desc;
    cv::ORB::create(max_features)->detectAndCompute(as_mat(image), mask, keypoints, desc);
    Features f;
    for (const cv::KeyPoint& kp : keypoints) f.keypoints.push_back(detail::to_keypoint(kp));
    f.descriptors = keypoints.empty() ? DescriptorMatrix(0, 256) : unpack_bits(desc);
    return f;
  }
};

struct Outcome {
  bool success = false;
  bool reported = false;  // the pipeline said success (right or wrong)
  diachron::RoughCoregistrationTrust trust = diachron::RoughCoregistrationTrust::kNone;
  double rms_3d_cells = 0.0;
  double error_cells = 0.0;
  std::size_t inliers = 0, matches = 0;
  double seconds = 0.0;
};

// A winner of the correlation fallback that passed min_score and the gain test, so that its margin
// over the runner-up decided: the margin, and whether the winner is right.
struct MarginRecord {
  double margin = 0.0;
  bool right = false;
};

// The columns of a north-up DSM west (or east) of world X `split`.
Dsm half_of(const Dsm& dsm, double split, bool west) {
  const GeoTransform& t = dsm.transform();
  DIACHRON_CHECK(t.c[2] == 0.0 && t.c[4] == 0.0 && t.c[1] > 0.0, "--null needs north-up DEMs");
  const int cut = std::clamp(static_cast<int>(std::lround(t.world_to_pixel(Eigen::Vector2d(split, t.c[3])).x())), 1,
                             dsm.width() - 1);
  const int x0 = west ? 0 : cut, w = west ? cut : dsm.width() - cut;
  Raster<float> h(w, dsm.height());
  for (int y = 0; y < dsm.height(); ++y)
    for (int x = 0; x < w; ++x) h(x, y) = dsm.heights()(x0 + x, y);
  GeoTransform shifted = t;
  shifted.c[0] += x0 * t.c[1];
  return Dsm(std::move(h), shifted, dsm.crs());
}

// The case's secondary without the ground near the master's true footprint (see --null); false
// when less than a quarter of its valid cells is left.
bool remove_true_overlap(CoregistrationCase& c) {
  const Helmert3 master_from_secondary = c.secondary_from_master.inverse();
  const double margin = 0.1 * std::max(c.master.width(), c.master.height());
  Raster<float> h = c.secondary.heights();
  std::size_t before = 0, after = 0;
  for (int y = 0; y < h.height(); ++y)
    for (int x = 0; x < h.width(); ++x) {
      if (std::isnan(h(x, y))) continue;
      ++before;
      const Eigen::Vector2d w = c.secondary.pixel_to_world(Eigen::Vector2d(x, y));
      const Eigen::Vector3d x1 = master_from_secondary(Eigen::Vector3d(w.x(), w.y(), h(x, y)));
      const Eigen::Vector2d p = c.master.world_to_pixel(x1.head<2>());
      if (p.x() >= -margin && p.y() >= -margin && p.x() <= c.master.width() - 1 + margin &&
          p.y() <= c.master.height() - 1 + margin)
        h(x, y) = std::numeric_limits<float>::quiet_NaN();
      else
        ++after;
    }
  if (4 * after < before) return false;
  c.secondary = Dsm(std::move(h), c.secondary.transform(), c.secondary.crs());
  c.overlap = 0.0;
  return true;
}

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  std::string data = "../shared/data", models = "../shared/models";
  std::size_t cases = 20, threads = 0;
  int max_features = 2000;
  double overlap_min = 0.3, overlap_max = 1.0;
  std::uint64_t seed = 1;
  bool verbose = false, synthetic = false, null_cases = false;
  std::vector<int> gaps;  // resolution-gap factors; empty: no gap cases
  std::string only;       // run only the cases whose source name contains this (same seeds as the full run)
  std::string configs_text = "stretch2/sift/whole/norot,relief/sift/tiles/rot";
  std::vector<std::string> pairs;  // --pair NAME=MASTER,SECONDARY
  double tilt_max_deg = CoregistrationCaseOptions{}.tilt_max_deg;
  double scale_min = CoregistrationCaseOptions{}.scale_min, scale_max = CoregistrationCaseOptions{}.scale_max;
  double rotation_max_deg = CoregistrationCaseOptions{}.rotation_max_deg;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "missing value after " << a << "\n";
        std::exit(1);
      }
      return argv[++i];
    };
    if (a == "--data") data = next();
    else if (a == "--models") models = next();
    else if (a == "--cases") cases = std::stoul(next());
    else if (a == "--overlap") { overlap_min = std::stod(next()); overlap_max = std::stod(next()); }
    else if (a == "--configs") configs_text = next();
    else if (a == "--threads") threads = std::stoul(next());
    else if (a == "--seed") seed = std::stoull(next());
    else if (a == "--max-features") max_features = std::stoi(next());
    else if (a == "--verbose") verbose = true;
    else if (a == "--only") only = next();
    else if (a == "--synthetic") synthetic = true;
    else if (a == "--null") null_cases = true;
    else if (a == "--tilt") tilt_max_deg = std::stod(next());
    else if (a == "--pair") pairs.push_back(next());
    else if (a == "--scale") { scale_min = std::stod(next()); scale_max = std::stod(next()); }
    else if (a == "--rotation") rotation_max_deg = std::stod(next());
    else if (a == "--gaps") {
      std::stringstream gs(next());
      for (std::string g; std::getline(gs, g, ',');) gaps.push_back(std::stoi(g));
    }
    else {
      std::cerr << "usage: rough_coregistration_eval [--data DIR] [--models DIR] [--cases N] [--overlap MIN MAX]\n"
                   "       [--configs IMAGE/MATCHER/TILING/ROTATIONS,...] [--threads N] [--seed S] [--gaps F1,F2,...]\n"
                   "       [--only SOURCE] [--tilt DEG] [--synthetic] [--null] [--verbose]\n"
                   "       [--pair NAME=MASTER.tif,SECONDARY.tif ...] [--scale MIN MAX] [--rotation DEG]\n";
      return 1;
    }
  }
  try {
    std::vector<Source> sources =
        synthetic ? std::vector<Source>{} : pairs.empty() ? load_sources(data) : pair_sources(data, pairs);
    if (!gaps.empty() && !synthetic) {
      // Each source with its master (even rounds) or secondary (odd rounds) coarsened by each
      // factor, then the real 10 m / 2 m pair both ways round; cases cycle through the list.
      std::vector<Source> gapped;
      for (int round = 0; round < 2; ++round) {
        for (int f : gaps)
          for (const Source& src : sources) {
            Source g = src;
            g.name = src.name + (round == 0 ? " m/" : " s/") + std::to_string(f);
            (round == 0 ? g.master : g.secondary) = coarsen_dsm(round == 0 ? src.master : src.secondary, f);
            gapped.push_back(std::move(g));
          }
        const Dsm msh2000 = read_geotiff_dsm(data + "/mount-st-helens/1_msh00_83.tif");
        const Dsm msh2004 = read_geotiff_dsm(data + "/mount-st-helens/4_msh1013_83.tif");
        if (round == 0) gapped.push_back({"msh2000-2004 (10 m / 2 m)", msh2000, msh2004, false});
        else gapped.push_back({"msh2004-2000 (2 m / 10 m)", msh2004, msh2000, false});
      }
      // Interleave so that any prefix of the cases covers sources, factors and sides evenly.
      sources.clear();
      const std::size_t half = gapped.size() / 2;
      for (std::size_t i = 0; i < half; ++i) {
        sources.push_back(gapped[i]);
        sources.push_back(gapped[half + i]);
      }
      for (const Source& src : sources)
        std::fprintf(stderr, "gap source %s: master %d x %d, secondary %d x %d\n", src.name.c_str(), src.master.width(),
                     src.master.height(), src.secondary.width(), src.secondary.height());
    }
    std::vector<Config> configs;
    std::stringstream ss(configs_text);
    for (std::string c; std::getline(ss, c, ',');) configs.push_back(parse_config(c));

    // Features per tile are capped (strongest first): brute-force matching of every master tile with
    // every secondary tile is quadratic in them.
    SiftOptions so;
    so.max_features = max_features;
    const ExtractorPairMatcher<SiftExtractor> sift{SiftExtractor{so}};
    so.root_sift = true;
    const ExtractorPairMatcher<SiftExtractor> rootsift{SiftExtractor{so}};
    AkazeOptions ao;
    ao.max_features = max_features;
    const ExtractorPairMatcher<AkazeExtractor> akaze{AkazeExtractor{ao}};
    const ExtractorPairMatcher<OrbExtractor> orb{OrbExtractor{max_features}};
    std::unique_ptr<XFeatPairMatcher> xfeat;
    for (const auto& c : configs)
      if (c.matcher == "xfeat" && !xfeat) {
        XFeatOptions xo;
        xo.top_k = max_features;
        xfeat = std::make_unique<XFeatPairMatcher>(models + "/xfeat/xfeat.onnx", xo);
      }

    CoregistrationCaseOptions case_options;
    case_options.overlap_min = overlap_min;
    case_options.overlap_max = overlap_max;
    case_options.tilt_max_deg = tilt_max_deg;
    case_options.scale_min = scale_min;
    case_options.scale_max = scale_max;
    case_options.rotation_max_deg = rotation_max_deg;
    case_options.check();
    std::map<std::string, std::vector<Outcome>> results;
    std::map<std::string, std::map<std::string, std::pair<int, int>>> per_source;
    std::map<std::string, std::vector<MarginRecord>> margins;
    std::size_t skipped = 0;
    for (std::size_t k = 0; k < cases; ++k) {
      CoregistrationCase c;
      std::string source_name = "synthetic";
      if (synthetic) {
        SceneOptions scene_options;
        scene_options.seed = seed + k;
        scene_options.check_points = 0;
        const Scene scene = generate_scene(scene_options);
        c.master = scene.epochs[0].dsm;
        c.secondary = scene.epochs[1].dsm;
        c.secondary_from_master = scene.epoch2_from_epoch1();
        c.scale = c.secondary_from_master.scale;
        c.rotation_deg = rad_to_deg(std::atan2(c.secondary_from_master.rotation(1, 0), c.secondary_from_master.rotation(0, 0)));
      } else {
        const Source& src = sources[k % sources.size()];
        if (!only.empty() && src.name.find(only) == std::string::npos) continue;
        source_name = src.name;
        case_options.crop_windows = src.crop;
        if (!(null_cases && src.crop)) c = make_coregistration_case(src.master, src.secondary, case_options, seed + k);
        if (null_cases && src.crop) {
          // Two draws on the two halves of the source (west and east of the middle of the master DEM):
          // this case's master and the other half's secondary show the same kind of terrain, apart.
          const double split = src.master.pixel_to_world(Eigen::Vector2d(0.5 * (src.master.width() - 1), 0.0)).x();
          const bool west = k % 2 == 0;
          const CoregistrationCase a = make_coregistration_case(half_of(src.master, split, west),
                                                                half_of(src.secondary, split, west), case_options, seed + k);
          const CoregistrationCase b = make_coregistration_case(half_of(src.master, split, !west),
                                                                half_of(src.secondary, split, !west), case_options,
                                                                seed + k + 100000);
          c = a;
          c.secondary = b.secondary;
          c.overlap = 0.0;
        } else if (null_cases && !remove_true_overlap(c)) {
          ++skipped;
          continue;
        }
      }
      // Success is judged in secondary cells; with a resolution gap, in cells of the coarser DSM
      // (the master's cell brought to world units by the frame's scale): a match is no more precise
      // than the coarser image, and 2 fine cells of a 2 m DSM are a fifth of a 10 m cell.
      const double cell = gaps.empty() ? c.secondary.min_cell_size()
                                       : std::max(c.secondary.min_cell_size(), c.master.min_cell_size() / c.scale);
      for (auto& config : configs) {
        config.options.threads = threads;
        config.options.ransac_2d.seed = seed + k;
        const auto start = std::chrono::steady_clock::now();
        RoughCoregistrationReport r;
        if (config.matcher == "sift") r = rough_coregistration(c.master, c.secondary, sift, config.options);
        else if (config.matcher == "rootsift") r = rough_coregistration(c.master, c.secondary, rootsift, config.options);
        else if (config.matcher == "akaze") r = rough_coregistration(c.master, c.secondary, akaze, config.options);
        else if (config.matcher == "orb") r = rough_coregistration(c.master, c.secondary, orb, config.options);
        else r = rough_coregistration(c.master, c.secondary, *xfeat, config.options);
        Outcome o;
        o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        o.inliers = r.inliers_2d.size();
        o.matches = r.matches_2d;
        const HelmertError e = helmert_error_on_overlap(r.epoch2_from_epoch1, c);
        o.error_cells = e.valid ? e.rms / cell : std::numeric_limits<double>::infinity();
        o.success = !null_cases && r.success && e.valid && e.rms < 2.0 * cell;
        o.reported = r.success;
        o.trust = r.trust;
        o.rms_3d_cells = r.rms_3d_cells;
        results[config.name].push_back(o);
        // Where the fallback's winner puts the master's centre, against the truth (secondary px): tells a
        // right answer the tests refused from a wrong one they stopped. A hole at the centre takes the
        // mean height: the truth's tilt moves X/Y with the height (2 degrees at 2000 m: 70 m).
        double fallback_off = std::numeric_limits<double>::quiet_NaN();
        if (r.correlation_ran) {
          const Eigen::Vector2d centre(0.5 * (c.master.width() - 1), 0.5 * (c.master.height() - 1));
          const Eigen::Vector2d w1 = c.master.pixel_to_world(centre);
          const double z1 = c.master.height_at_pixel(centre);
          const Eigen::Vector3d x2 =
              c.secondary_from_master(Eigen::Vector3d(w1.x(), w1.y(), std::isnan(z1) ? c.master.statistics().mean : z1));
          fallback_off = (c.secondary.world_to_pixel(x2.head<2>()) - r.correlation(centre)).norm();
          // Right: within 2 coarse cells of the truth.
          const DsmCorrelationSearchOptions& so = config.options.correlation_search;
          const DsmCorrelationResult& cr = r.correlation;
          const bool score_ok = cr.score >= so.min_score;
          const bool gain_ok = std::abs(std::log(cr.height_gain / cr.expected_gain)) <= std::log(so.max_gain_factor);
          if (score_ok && gain_ok)
            margins[config.name].push_back({cr.strength - cr.runner_up_strength,
                                            !null_cases && fallback_off <= 2.0 * cell / c.secondary.min_cell_size()});
        }
        auto& ps = per_source[config.name][source_name];
        ps.first += o.success;
        ps.second += 1;
        if (verbose) {
          std::string hyps;
          for (const auto& h : r.scale_hypotheses)
            hyps += " " + h.hypothesis.name() + ":" + std::to_string(h.inliers) + "/" + std::to_string(h.required_inliers) +
                    (h.success ? "+" : "") + "@" + std::to_string(h.seconds).substr(0, 4) + "s";
          std::fprintf(stderr, "  scale hypotheses (inliers/required@time):%s\n", hyps.c_str());
          if (r.correlation_ran) {
            std::fprintf(stderr, "  correlation fallback: %s, ZNCC %.3f, runner-up %.3f, %zu hypotheses, %.2f s (coarse %.2f, refine %.2f); winner %.1f secondary px from the truth; %s\n",
                         r.correlation_used ? "used" : "not used", r.correlation.score, r.correlation.runner_up,
                         r.correlation.hypotheses, r.seconds.correlation, r.correlation.seconds.coarse,
                         r.correlation.seconds.refine, fallback_off, r.correlation.message.c_str());
            std::fprintf(stderr, "  correlation tiles: %d of %d agree, chance %.3g, other candidates %.3g, %s, %.3f s\n",
                         r.correlation.tiles.agree, r.correlation.tiles.tiles, r.correlation.tile_chance,
                         r.correlation.competitor_tile_chance, r.correlation.by_tiles ? "by tiles" : "not by tiles",
                         r.correlation.seconds.tiles);
          }
          if (r.agreement.valid)
            std::fprintf(stderr, "  surfaces agree: misfit %.3g = %.2f x the DSMs' noise (%.3g, %.3g), %zu cells, %.0f coarse cells%s\n",
                         r.agreement.misfit, r.agreement.noise_ratio, r.agreement.master_noise,
                         r.agreement.secondary_noise, r.agreement.points, r.agreement.overlap_cells,
                         r.success ? (r.confirmed_by_surface ? ", confirmed the fallback's refused winner" : "")
                                   : ", the fallback's refused winner not confirmed");
          if (r.success && config.options.refine_surface)
            std::fprintf(stderr, "  surface refinement: %s, %s, %.2f s\n", r.surface.accepted ? "accepted" : "refused",
                         r.surface.message.c_str(), r.surface.seconds);
          std::fprintf(stderr, "case %zu %-13s overlap %.2f rot %6.1f scale %.2f | %-32s %s err %8.2f cells, %4zu/%5zu in %.1f s | rms3d %.2f cells, 3D inliers %zu/%zu, trust %s | %s\n",
                       k, source_name.c_str(), c.overlap, c.rotation_deg, c.scale, config.name.c_str(),
                       o.success ? "OK  " : "FAIL", o.error_cells, o.inliers, o.matches, o.seconds, r.rms_3d_cells,
                       r.inliers_3d.size(), r.lifted.size(), to_string(r.trust), r.message.c_str());
        }
      }
    }
    std::printf("| configuration | success | per source | median 2D inliers | median inlier ratio | median time (s) |\n");
    std::printf("|---|---|---|---|---|---|\n");
    for (const auto& config : configs) {
      const auto& v = results[config.name];
      int ok = 0;
      std::vector<double> inl, ratio, sec;
      for (const auto& o : v) {
        ok += o.success;
        inl.push_back(static_cast<double>(o.inliers));
        ratio.push_back(o.matches ? double(o.inliers) / double(o.matches) : 0.0);
        sec.push_back(o.seconds);
      }
      std::string ps_text;
      for (const auto& [name, counts] : per_source[config.name])
        ps_text += name + " " + std::to_string(counts.first) + "/" + std::to_string(counts.second) + " ";
      std::printf("| %s | %d/%zu (%.0f %%) | %s| %.0f | %.2f | %.2f |\n", config.name.c_str(), ok, v.size(),
                  100.0 * ok / std::max<std::size_t>(v.size(), 1), ps_text.c_str(), median(inl), median(ratio), median(sec));
    }
    // How far a reported success can be trusted: wrong = reported success with an error of 2 cells
    // or more; the trust grade should be low for those and high for the right ones.
    std::printf("\n| configuration | reported successes | right | wrong | wrong graded low (caught) | right graded low (lost) | error of the reported, median / 90th percentile (cells) |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    for (const auto& config : configs) {
      int reported = 0, right = 0, wrong = 0, caught = 0, lost = 0;
      std::vector<double> errors;
      for (const auto& o : results[config.name]) {
        if (!o.reported) continue;
        ++reported;
        errors.push_back(o.error_cells);
        const bool high = o.trust == RoughCoregistrationTrust::kHigh;
        if (o.success) {
          ++right;
          lost += !high;
        } else {
          ++wrong;
          caught += !high;
        }
      }
      std::sort(errors.begin(), errors.end());
      const double p90 = errors.empty() ? 0.0 : errors[static_cast<std::size_t>(0.9 * static_cast<double>(errors.size() - 1))];
      std::printf("| %s | %d | %d | %d | %d | %d | %.2f / %.2f |\n", config.name.c_str(), reported, right, wrong, caught,
                  lost, median(errors), p90);
    }
    // The correlation fallback's margin test: how many of the winners that pass min_score and the
    // gain test each margin would accept, and how many of them are right.
    if (null_cases) std::printf("\n%zu cases skipped (too little ground left without the overlap)\n", skipped);
    std::printf("\n| configuration | fallback winners passing score and gain | margin >= 0 right / wrong | >= 0.05 | >= 0.10 | >= 0.15 | >= 0.20 | >= 0.25 | largest margin of a wrong winner |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    for (const auto& config : configs) {
      const auto& v = margins[config.name];
      std::printf("| %s | %zu |", config.name.c_str(), v.size());
      double worst = -std::numeric_limits<double>::infinity();
      for (const MarginRecord& m : v)
        if (!m.right) worst = std::max(worst, m.margin);
      for (double t : {0.0, 0.05, 0.10, 0.15, 0.20, 0.25}) {
        int right = 0, wrong = 0;
        for (const MarginRecord& m : v)
          if (m.margin >= t) (m.right ? right : wrong) += 1;
        std::printf(" %d / %d |", right, wrong);
      }
      std::printf(" %.3f |\n", worst);
    }
    // The margins themselves, largest first (another margin scale than the table's may be wanted).
    for (const auto& config : configs) {
      std::vector<MarginRecord> v = margins[config.name];
      std::sort(v.begin(), v.end(), [](const MarginRecord& a, const MarginRecord& b) { return a.margin > b.margin; });
      std::string right_text, wrong_text;
      for (const MarginRecord& m : v)
        if (m.margin >= 0.0) (m.right ? right_text : wrong_text) += " " + std::to_string(m.margin).substr(0, 5);
      std::printf("\n%s margins >= 0, right:%s; wrong:%s\n", config.name.c_str(), right_text.c_str(), wrong_text.c_str());
    }
  } catch (const std::exception& e) {
    std::cerr << "rough_coregistration_eval: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
