#pragma once
// match_epochs (examples/match_epochs/main.cpp): the options that decide the results. The plan
// records them as a canonical argument list (plan.json's "arguments"); run-pair and merge parse
// that list again, so that every stage runs with the same settings, and the plan's id hashes it.

namespace match_epochs {

using namespace diachron;
using diachron::programs::strict_number;

// Every option that changes what match_epochs computes (not --out, --threads, --quiet, ...).
struct Settings {
  std::vector<std::string> dirs;
  std::string method = "correlation", matcher_name = "rootsift", model_path, measure, affine, reference_name;
  std::vector<std::string> rough_specs;  // --rough: [NAME=]auto|identity|FILE, in order
  bool no_pictures = false, adjust = false, one_camera = false;
  bool no_refine = false, no_ground_filter = false, no_ncc = false;
  std::string fallback = "on";
  std::string hold, prior, gcps, checks;
  std::string colmap_format = "text";
  MicmacEpochOptions micmac_epochs;
  double min_overlap = 0.1;
  std::optional<int> cell;
  std::optional<std::size_t> max_points;
  std::optional<double> ground_gsd, nodata, ncc_threshold;
  std::optional<std::string> sharpen;

  // Derived by prepare().
  PreciseMatchingOptions options;
  OverlappingPairsOptions overlap_options;
  GeoTiffReadOptions dsm_read;
  bool pictures = true, use_fallback = true;
  std::vector<ControlPointRecord> control, check_records;
};

// The options of Settings on `app` (the positional EPOCH_DIR included).
void add_run_options(CLI::App& app, Settings& s) {
  app.add_option("EPOCH_DIR", s.dirs, "epoch folders, two or more")->required();
  app.add_option("--reference", s.reference_name, "the reference epoch by its folder's name (default: the last given)");
  app.add_option("--rough", s.rough_specs,
                 "[NAME=]auto|identity|FILE: a free epoch -> the reference, co-registered from the DSMs (auto, "
                 "default; through another free epoch when that fails), the identity (one frame already), or a "
                 "helmert.json FILE; for every free epoch or for NAME (repeatable)")
      ->allow_extra_args(false);
  app.add_option("--method", s.method, "tentative matches: correlation (default), patch or guided")
      ->check(CLI::IsMember({"correlation", "patch", "guided"}));
  app.add_option("--measure", s.measure, "correlation's similarity: orientation (default), gradient or intensity")
      ->check(CLI::IsMember({"orientation", "gradient", "intensity"}));
  app.add_option("--cell", s.cell, "correlation: one master point per PX x PX cell (default 6, coarser on large images)")
      ->check(strict_number<int>(2, 4096, "a cell side in [2, 4096] px"));
  app.add_option("--max-points", s.max_points,
                 "correlation: the cell grows from 6 px on images of more than N cells (default 60000)")
      ->check(strict_number<std::size_t>(1, std::numeric_limits<std::size_t>::max() / 2, "at least 1 point per image"));
  app.add_option("--matcher", s.matcher_name, "patch/guided features: sift, rootsift (default), akaze or xfeat")
      ->check(CLI::IsMember({"sift", "rootsift", "akaze", "xfeat"}));
  app.add_option("--model", s.model_path, "XFeat ONNX file (with --matcher xfeat)")->check(CLI::ExistingFile);
  app.add_option("--fallback", s.fallback,
                 "on|off: dense correlation search of the DSMs when the features find no co-registration "
                 "(default on; graded low trust)")
      ->check(CLI::IsMember({"on", "off"}));
  app.add_option("--nodata", s.nodata, "also treat DSM heights equal to V as holes (a dsm.tif without a nodata tag)")
      ->check(strict_number<double>(-1e300, 1e300, "a height"));
  app.add_option("--min-overlap", s.min_overlap, "least overlap of a pair, share of the smaller footprint (default 0.1)")
      ->check(strict_number<double>(0.0, 1.0, "a share in [0, 1]"));
  app.add_option("--ncc-threshold", s.ncc_threshold, "least NCC of a kept match (default 0.6, MicMac's)")
      ->check(strict_number<double>(-1.0, 1.0, "an NCC in [-1, 1]"));
  app.add_option("--micmac-ori", s.micmac_epochs.ori,
                 "MicMac epochs: the orientation to read, Ori-NAME (default: the folder's only Ori-*)");
  app.add_option("--micmac-homol", s.micmac_epochs.homol,
                 "MicMac epochs: their intra-epoch tie points, e.g. Homol-Guided for SH=-Guided (default Homol)");
  app.add_flag("--no-refine", s.no_refine, "keep the matcher's positions (no least-squares refinement)");
  app.add_option("--ground-gsd", s.ground_gsd,
                 "the ground filter's threshold, GSD of the secondary image (default 3 for correlation, 10 "
                 "for patch and guided)")
      ->check(strict_number<double>(1e-9, 1e9, "a threshold > 0 (GSD of the secondary image)"));
  app.add_option("--sharpen", s.sharpen, "A[,S]: correlation: sharpen the master images, amount A, sigma S px (S 1)");
  app.add_flag("--no-ground-filter", s.no_ground_filter, "skip the 3D Helmert RANSAC");
  app.add_flag("--no-ncc", s.no_ncc, "skip the NCC validator");
  app.add_flag("--no-pictures", s.no_pictures, "do not write pairs/ and adjusted/residuals/");
  app.add_flag("--adjust", s.adjust,
               "then the combined adjustment (the reference fixed, every free epoch self-calibrated): DIR/adjusted/"
#if !DIACHRON_MATCH_EPOCHS_ADJUST
               " (not in this build: no Ceres)"
#endif
  );
  app.add_option("--affine", s.affine, "with --adjust: B1, B2 per image (default) or per camera (MicMac's)")
      ->check(CLI::IsMember({"image", "camera"}));
  app.add_option("--hold", s.hold, "with --adjust: intrinsics held, of f,cx,cy,K1,K2,K3,P1,P2 (e.g. K3)");
  app.add_option("--prior", s.prior, "with --adjust: intrinsics tied to their values with a sigma, NAME=SIGMA,... (f=2,cx=1)");
  app.add_flag("--one-camera", s.one_camera, "with --adjust: each free epoch's images share one camera");
  app.add_option("--gcps", s.gcps, "with --adjust: ground control points (io/control_points.hpp)");
  app.add_option("--check-points", s.checks, "with --adjust: independent check points, the same layout");
  app.add_option("--colmap-format", s.colmap_format, "with --adjust: adjusted/colmap/ as text (default) or binary")
      ->check(CLI::IsMember({"text", "binary"}));
}

// The names of the options add_run_options() adds, but EPOCH_DIR.
bool is_run_option(const CLI::Option& o) {
  static const std::set<std::string> kRun = {
      "--reference", "--rough", "--method", "--measure", "--cell", "--max-points", "--matcher", "--model",
      "--fallback", "--nodata", "--min-overlap", "--ncc-threshold", "--micmac-ori", "--micmac-homol", "--no-refine",
      "--ground-gsd", "--sharpen", "--no-ground-filter", "--no-ncc", "--no-pictures", "--adjust", "--affine", "--hold",
      "--prior", "--one-camera", "--gcps", "--check-points", "--colmap-format"};
  return kRun.count(o.get_name()) > 0;
}

// The settings as one canonical argument list: the epoch folders as absolute paths (the jobs may
// run elsewhere), then every run option given, in the order add_run_options() defines them, with
// the paths of files absolute. The same settings give the same list whatever order they were given in.
std::vector<std::string> canonical_arguments(const CLI::App& app, const Settings& s) {
  std::vector<std::string> out;
  for (const std::string& d : s.dirs) out.push_back(absolute_path(d));
  static const std::set<std::string> kFiles = {"--model", "--gcps", "--check-points"};
  for (const CLI::Option* o : app.get_options()) {
    if (!is_run_option(*o) || o->count() == 0) continue;
    static const std::set<std::string> kFlags = {"--no-refine", "--no-ground-filter", "--no-ncc", "--no-pictures",
                                                 "--adjust", "--one-camera"};
    if (kFlags.count(o->get_name())) {
      out.push_back(o->get_name());
      continue;
    }
    for (const std::string& r : o->results()) {
      out.push_back(o->get_name());
      std::string value = r;
      if (kFiles.count(o->get_name())) value = absolute_path(r);
      // --rough NAME=FILE or FILE: a file's path absolute, the modes as they are.
      if (o->get_name() == "--rough") {
        const std::size_t eq = value.find('=');
        const std::string mode = eq == std::string::npos ? value : value.substr(eq + 1);
        if (mode != "auto" && mode != "identity" && is_regular_file(mode))
          value = (eq == std::string::npos ? "" : value.substr(0, eq + 1)) + absolute_path(mode);
      }
      out.push_back(value);
    }
  }
  return out;
}

// The checks of the settings against each other and the options they derive. Throws
// diachron::Error with a message for people.
void prepare(Settings& s) {
  DIACHRON_CHECK(s.dirs.size() >= 2, "two epoch folders or more are needed, " << s.dirs.size() << " given");
  if (s.nodata) {
    s.dsm_read.assume_untagged_nodata = true;
    s.dsm_read.untagged_nodata = *s.nodata;
  }
  PreciseMatchingOptions& options = s.options;
  if (s.ncc_threshold) options.ncc.min_ncc = *s.ncc_threshold;
  options.ncc.refine = !s.no_refine;
  options.use_ground_filter = !s.no_ground_filter;
  options.use_ncc = !s.no_ncc;
  s.pictures = !s.no_pictures;
  s.use_fallback = s.fallback == "on";
#if !DIACHRON_MATCH_EPOCHS_ADJUST
  DIACHRON_CHECK(!s.adjust, "--adjust needs a build with Ceres (diachron::adjustment)");
#endif
  DIACHRON_CHECK(s.adjust || s.affine.empty(), "--affine needs --adjust");
  DIACHRON_CHECK(s.adjust || s.colmap_format == "text", "--colmap-format needs --adjust");
  DIACHRON_CHECK(s.adjust || !s.one_camera, "--one-camera needs --adjust");
  DIACHRON_CHECK(s.adjust || s.hold.empty(), "--hold needs --adjust");
  DIACHRON_CHECK(s.adjust || s.prior.empty(), "--prior needs --adjust");
  DIACHRON_CHECK(s.adjust || s.gcps.empty(), "--gcps needs --adjust");
  // Read before any work: a malformed file fails fast. Its image names are checked later.
  if (!s.gcps.empty()) s.control = read_control_points(s.gcps);
  DIACHRON_CHECK(s.adjust || s.checks.empty(), "--check-points needs --adjust");
  if (!s.checks.empty()) s.check_records = read_control_points(s.checks);
  const std::string& measure = s.measure;
  const std::string& method = s.method;
  if (measure == "intensity") options.correlation.match.measure = CorrelationMeasure::intensity;
  else if (measure == "gradient") options.correlation.match.measure = CorrelationMeasure::gradient;
  else options.correlation.match.measure = CorrelationMeasure::orientation;
  DIACHRON_CHECK(measure.empty() || method == "correlation", "--measure goes with --method correlation");
  DIACHRON_CHECK(!s.cell || method == "correlation", "--cell goes with --method correlation");
  if (s.cell) options.correlation.use_fixed_cell(*s.cell);
  DIACHRON_CHECK(!s.max_points || method == "correlation", "--max-points goes with --method correlation");
  DIACHRON_CHECK(!s.max_points || !s.cell, "--cell and --max-points both set the cell: give one of them");
  if (s.max_points) options.correlation.max_points_per_image = *s.max_points;
  if (s.ground_gsd) {
    DIACHRON_CHECK(options.use_ground_filter, "--ground-gsd and --no-ground-filter contradict each other");
    ground_threshold_gsd(options, method) = *s.ground_gsd;
  }
  if (s.sharpen) {
    DIACHRON_CHECK(method == "correlation", "--sharpen goes with --method correlation");
    UnsharpMaskOptions& u = options.correlation.master_sharpen;
    u.sigma_px = 1.0;
    char rest = 0;
    const int n = std::sscanf(s.sharpen->c_str(), "%lf,%lf%c", &u.amount, &u.sigma_px, &rest);
    // The ranges are UnsharpMaskOptions::check()'s; the program says them in its own words.
    bool valid = n == (s.sharpen->find(',') == std::string::npos ? 1 : 2);
    try {
      if (valid) u.check();
    } catch (const Error&) {
      valid = false;
    }
    DIACHRON_CHECK(valid, "--sharpen wants A[,S], an amount in [0, 20] and a sigma in (0, 20] px, got '"
                              << *s.sharpen << "'");
  }
  DIACHRON_CHECK(method != "guided" || s.matcher_name != "akaze",
                 "--method guided takes sift, rootsift or xfeat features (AKAZE's are binary)");
  DIACHRON_CHECK(s.matcher_name != "xfeat" || !s.model_path.empty(), "--matcher xfeat needs --model PATH");
  // The report names what made the matches: the measure for correlation, the features otherwise.
  if (method == "correlation") s.matcher_name = to_string(options.correlation.match.measure);
  options.check();
  s.overlap_options.min_overlap_fraction = s.min_overlap;
  s.overlap_options.check();
}

}  // namespace match_epochs
