// rough_coregistration: co-registers two epochs from their DSMs (paper section 3.2.1) and writes the
// 3D Helmert that moves the first DSM's frame into the second's.
//
//   rough_coregistration MASTER_DSM.tif SECONDARY_DSM.tif --out DIR [options]
//
// MASTER is epoch 1 (the one moved), SECONDARY epoch 2 (the reference). Writes
//   DIR/helmert.json  {"scale", "rotation" (3x3 row-major), "translation"}: X2 = scale R X1 + translation
//   DIR/report.json   counts per rotation hypothesis and stage, timings
//   DIR/matches.png   the DSM images side by side, 2D inliers green, other tentative matches red
// DSMs in a geographic CRS (degrees) are refused unless --reproject names a projected CRS for
// both; the Helmert then maps between the reprojected frames (report.json's "frame").
// Exit status: 0 success, 2 no co-registration found (reason printed), 1 bad input.
// The composition it runs is pipeline/rough_coregistration.hpp; docs/rough-coregistration.md says
// how its defaults were chosen.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <diachron/core/progress.hpp>
#include <diachron/io/dsm_reproject.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/draw_matches.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>
#include <diachron/vision/xfeat.hpp>

namespace {

using namespace diachron;

const char* kUsage =
    "usage: rough_coregistration MASTER_DSM.tif SECONDARY_DSM.tif --out DIR [options]\n"
    "  --matcher sift|rootsift|akaze|xfeat   pair matcher (default sift)\n"
    "  --model PATH                          XFeat ONNX file (with --matcher xfeat)\n"
    "  --image relief|slope|stretch|wallis|hillshade|multihillshade   DSM image (default slope)\n"
    "  --k-sigma K                           stretch range for stretch/wallis (default 2, the paper)\n"
    "  --tile WxH                            tile size in DSM pixels, buffers included\n"
    "                                        (default 1920x1440, MicMac's; the paper's was 640x480)\n"
    "  --buffer BXxBY                        margin around each tile core, DSM pixels (default 0x0)\n"
    "                                        (tiles overlap by 2 * buffer; a match is kept in its\n"
    "                                        master tile's core only)\n"
    "  --no-tiling                           match the whole DSM images\n"
    "  --no-rotations                        try 0 degrees only\n"
    "  --no-scales                           no scale hypotheses (coarsened DSMs for resolution gaps)\n"
    "  --fallback off|heights|gradient       dense correlation search when the features find nothing\n"
    "                                        (small coarse DSMs against fine ones; default gradient,\n"
    "                                        the measured best; heights the earlier search)\n"
    "  --no-refine-surface                   keep the Helmert of the matches, without the robust\n"
    "                                        least-squares matching of the two surfaces after it\n"
    "  --no-surface-confirmation             a winner the fallback's search refuses stays refused,\n"
    "                                        even when the two surfaces confirm it\n"
    "  --nodata V                            also treat heights equal to V as holes (DSMs without a\n"
    "                                        nodata tag, e.g. -9999)\n"
    "  --reproject utm|CRS                   warp both DSMs to this CRS first (utm: the WGS 84 UTM\n"
    "                                        zone of the master's centre); needed for geographic DSMs\n"
    "  --threshold PX                        2D RANSAC threshold, DSM pixels (default 10)\n"
    "  --threads N                           worker threads, 0 = all cores (default 0)\n"
    "  --seed S                              random seed (default 0)\n"
    "  --quiet                               no progress on stderr\n";

void write_helmert(const std::string& path, const Helmert3& h) {
  std::ofstream out(path);
  DIACHRON_CHECK(out, "cannot write " << path);
  out.precision(17);
  out << "{\n  \"scale\": " << h.scale << ",\n  \"rotation\": [";
  for (int r = 0; r < 3; ++r)
    out << (r ? ", " : "") << "[" << h.rotation(r, 0) << ", " << h.rotation(r, 1) << ", " << h.rotation(r, 2) << "]";
  out << "],\n  \"translation\": [" << h.translation.x() << ", " << h.translation.y() << ", " << h.translation.z()
      << "]\n}\n";
}

void write_report(const std::string& path, const RoughCoregistrationReport& r, const std::string& matcher,
                  const std::string& frame) {
  std::ofstream out(path);
  DIACHRON_CHECK(out, "cannot write " << path);
  auto quoted = [](const std::string& s) {
    std::string q = "\"";
    for (char c : s) q += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
    return q + "\"";
  };
  out << "{\n  \"success\": " << (r.success ? "true" : "false") << ",\n  \"message\": " << quoted(r.message)
      << ",\n  \"matcher\": " << quoted(matcher) << ",\n  \"frame\": " << quoted(frame) << ",\n  \"best_rotation_deg\": " << r.best_rotation_deg
      << ",\n  \"tile_pairs_per_hypothesis\": " << r.tile_pairs << ",\n  \"hypotheses\": [";
  for (std::size_t i = 0; i < r.hypotheses.size(); ++i) {
    const auto& h = r.hypotheses[i];
    out << (i ? ", " : "") << "{\"rotation_deg\": " << h.rotation_deg << ", \"matches\": " << h.matches
        << ", \"inliers\": " << h.inliers << ", \"iterations\": " << h.iterations << "}";
  }
  out << "],\n  \"best_scale_hypothesis\": " << r.best_scale_hypothesis << ",\n  \"scale_hypotheses\": [";
  for (std::size_t i = 0; i < r.scale_hypotheses.size(); ++i) {
    const auto& h = r.scale_hypotheses[i];
    out << (i ? ", " : "") << "{\"name\": " << quoted(h.hypothesis.name())
        << ", \"master_factor\": " << h.hypothesis.master_factor()
        << ", \"secondary_factor\": " << h.hypothesis.secondary_factor() << ", \"success\": "
        << (h.success ? "true" : "false") << ", \"matches\": " << h.matches << ", \"inliers\": " << h.inliers
        << ", \"required_inliers\": " << h.required_inliers << ", \"seconds\": " << h.seconds << "}";
  }
  out << "],\n  \"stages\": {\"tentative_2d\": " << r.matches_2d << ", \"required_inliers_2d\": " << r.required_inliers_2d
      << ", \"inliers_2d\": " << r.inliers_2d.size() << ", \"lifted_3d\": " << r.lifted.size()
      << ", \"inliers_3d\": " << r.inliers_3d.size() << ", \"rms_3d\": " << r.rms_3d << "},\n";
  // The dense correlation fallback, when it ran: its winner and the tests that judged it.
  const auto number = [](double v) { return std::isfinite(v) ? std::to_string(v) : std::string("null"); };
  if (r.correlation_ran) {
    const DsmCorrelationResult& c = r.correlation;
    out << "  \"correlation_fallback\": {\"used\": " << (r.correlation_used ? "true" : "false")
        << ", \"message\": " << quoted(c.message) << ", \"score\": " << number(c.score)
        << ", \"strength\": " << number(c.strength) << ", \"runner_up_strength\": " << number(c.runner_up_strength)
        << ", \"height_gain\": " << number(c.height_gain) << ", \"expected_gain\": " << number(c.expected_gain)
        << ", \"tiles\": " << c.tiles.tiles << ", \"tiles_agreeing\": " << c.tiles.agree
        << ", \"tile_chance\": " << number(c.tile_chance) << ", \"competitor_tile_chance\": "
        << number(c.competitor_tile_chance) << ", \"by_tiles\": " << (c.by_tiles ? "true" : "false")
        << ", \"hypotheses\": " << c.hypotheses << ", \"confirmed_by_surface\": "
        << (r.confirmed_by_surface ? "true" : "false") << ", \"seconds\": " << r.seconds.correlation << "},\n";
  }
  // How closely the surfaces agree under the answer (or under the refused winner the confirmation
  // measured), against the DSMs' own noise.
  if (r.agreement.valid) {
    const SurfaceAgreement& g = r.agreement;
    out << "  \"surface_agreement\": {\"misfit\": " << number(g.misfit) << ", \"master_noise\": " << number(g.master_noise)
        << ", \"secondary_noise\": " << number(g.secondary_noise) << ", \"noise_ratio\": " << number(g.noise_ratio)
        << ", \"points\": " << g.points << ", \"overlap_cells\": " << g.overlap_cells << "},\n";
  }
  // The surface refinement, when it ran (after a success, or for the confirmation): accepted or why not.
  if (r.surface.message != "not run") {
    const SurfaceAlignmentResult& a = r.surface;
    out << "  \"surface_refinement\": {\"accepted\": " << (a.accepted ? "true" : "false")
        << ", \"message\": " << quoted(a.message) << ", \"iterations\": " << a.iterations
        << ", \"points\": " << a.points << ", \"sigma_before\": " << number(a.sigma_before)
        << ", \"sigma_after\": " << number(a.sigma_after) << ", \"agreeing_before\": " << a.agreeing_before
        << ", \"agreeing_after\": " << a.agreeing_after << ", \"moved\": " << a.moved
        << ", \"seconds\": " << a.seconds << "},\n";
  }
  out << "  \"seconds\": {\"images\": "
      << r.seconds.images << ", \"matching\": " << r.seconds.matching << ", \"ransac_2d\": " << r.seconds.ransac_2d
      << ", \"lift\": " << r.seconds.lift << ", \"helmert\": " << r.seconds.helmert << ", \"total\": " << r.seconds.total
      << "}\n}\n";
}

DsmImageKind parse_image(const std::string& s) {
  for (DsmImageKind k : {DsmImageKind::kStretch, DsmImageKind::kStretchWallis, DsmImageKind::kHillshade,
                         DsmImageKind::kMultiHillshade, DsmImageKind::kSlope, DsmImageKind::kLocalRelief})
    if (s == to_string(k)) return k;
  DIACHRON_CHECK(false, "unknown --image '" << s << "'");
  return DsmImageKind::kLocalRelief;
}

}  // namespace

int main(int argc, char** argv) {
  std::string master_path, secondary_path, out_dir, matcher_name = "sift", model_path, reproject;
  GeoTiffReadOptions read_options;
  RoughCoregistrationOptions options;
  bool quiet = false;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        DIACHRON_CHECK(i + 1 < argc, "missing value after " << a);
        return argv[++i];
      };
      if (a == "--out") out_dir = value();
      else if (a == "--matcher") matcher_name = value();
      else if (a == "--model") model_path = value();
      else if (a == "--image") options.image_kind = parse_image(value());
      else if (a == "--k-sigma") options.dsm_image.k_sigma = std::stod(value());
      else if (a == "--tile") {
        const std::string t = value();
        const auto x = t.find('x');
        DIACHRON_CHECK(x != std::string::npos, "--tile wants WxH, got '" << t << "'");
        options.master_tiles.tile_width = options.secondary_tiles.tile_width = std::stoi(t.substr(0, x));
        options.master_tiles.tile_height = options.secondary_tiles.tile_height = std::stoi(t.substr(x + 1));
      } else if (a == "--buffer") {
        const std::string b = value();
        const auto x = b.find('x');
        DIACHRON_CHECK(x != std::string::npos, "--buffer wants BXxBY, got '" << b << "'");
        options.master_tiles.buffer_x = options.secondary_tiles.buffer_x = std::stoi(b.substr(0, x));
        options.master_tiles.buffer_y = options.secondary_tiles.buffer_y = std::stoi(b.substr(x + 1));
      } else if (a == "--no-tiling") options.use_tiling = false;
      else if (a == "--no-rotations") options.rotation_hypotheses = false;
      else if (a == "--no-scales") options.scale_hypotheses.enabled = false;
      else if (a == "--no-refine-surface") options.refine_surface = false;
      else if (a == "--no-surface-confirmation") options.surface_confirmation = false;
      else if (a == "--fallback") {
        const std::string f = value();
        DIACHRON_CHECK(f == "off" || f == "heights" || f == "gradient",
                       "--fallback wants off, heights or gradient, got '" << f << "'");
        options.correlation_fallback = f != "off";
        // heights: the earlier search (peaks weighed by their share); gradient: the library's defaults.
        if (f == "heights") {
          options.correlation_search.signal = CorrelationSignal::heights;
          options.correlation_search.strength = CorrelationStrength::share;
        }
      }
      else if (a == "--reproject") reproject = value();
      else if (a == "--nodata") {
        read_options.assume_untagged_nodata = true;
        read_options.untagged_nodata = std::stod(value());
      }
      else if (a == "--threshold") options.ransac_2d.threshold = std::stod(value());
      else if (a == "--threads") options.threads = std::stoul(value());
      else if (a == "--seed") options.ransac_2d.seed = std::stoull(value());
      else if (a == "--quiet") quiet = true;
      else if (a == "--help" || a == "-h") {
        std::cout << kUsage;
        return 0;
      } else if (!a.empty() && a[0] == '-') DIACHRON_CHECK(false, "unknown option " << a);
      else if (master_path.empty()) master_path = a;
      else if (secondary_path.empty()) secondary_path = a;
      else DIACHRON_CHECK(false, "unexpected argument " << a);
    }
    DIACHRON_CHECK(!master_path.empty() && !secondary_path.empty() && !out_dir.empty(),
                   "two DSM files and --out DIR are required");
    options.check();
    if (options.use_tiling) {
      options.master_tiles.check();
      options.secondary_tiles.check();
    }
    if (!quiet)
      options.progress = [clock = std::make_shared<ProgressClock>()](const ProgressEvent& e) {
        // Padded: a line shorter than the one it overwrites leaves no tail behind.
        std::fprintf(stderr, "\r%-72s", progress_line(e, (*clock)(e)).c_str());
        if (e.done >= e.total) std::fprintf(stderr, "\n");
      };
    Dsm master = read_geotiff_dsm(master_path, read_options);
    Dsm secondary = read_geotiff_dsm(secondary_path, read_options);
    for (const auto& [dsm, path] : {std::pair<const Dsm*, std::string>{&master, master_path}, {&secondary, secondary_path}})
      if (const std::optional<double> v = suspected_untagged_nodata(*dsm); v && !read_options.assume_untagged_nodata)
        std::fprintf(stderr, "warning: '%s' has heights of %g far below all others and no nodata tag for them: "
                             "if they are holes, pass --nodata %g\n", path.c_str(), *v, *v);
    // "frame": what the Helmert's coordinates are, for the reader of report.json.
    std::string frame = "the DSMs' own CRSs";
    if (!reproject.empty()) {
      const std::string target = reproject == "utm" ? utm_crs_of(master) : reproject;
      if (!quiet) std::fprintf(stderr, "reprojecting both DSMs to %s\n", target.substr(0, 60).c_str());
      master = reproject_dsm(master, target);
      secondary = reproject_dsm(secondary, target);
      frame = target;
    } else {
      for (const auto& [dsm, path] : {std::pair<const Dsm*, std::string>{&master, master_path}, {&secondary, secondary_path}})
        DIACHRON_CHECK(crs_kind(dsm->crs()) != CrsKind::geographic,
                       "'" << path << "' is in a geographic CRS (degrees horizontally, heights in metres): "
                           "pass --reproject utm (or a projected CRS) to warp both DSMs first");
    }
    make_folders(out_dir, "rough_coregistration");

    RoughCoregistrationReport report;
    if (matcher_name == "sift" || matcher_name == "rootsift") {
      SiftOptions so;
      so.root_sift = matcher_name == "rootsift";
      report = rough_coregistration(master, secondary, ExtractorPairMatcher<SiftExtractor>(SiftExtractor(so)), options);
    } else if (matcher_name == "akaze") {
      report = rough_coregistration(master, secondary, ExtractorPairMatcher<AkazeExtractor>(AkazeExtractor{}), options);
    } else if (matcher_name == "xfeat") {
      DIACHRON_CHECK(!model_path.empty(), "--matcher xfeat needs --model PATH (the XFeat ONNX file)");
      report = rough_coregistration(master, secondary, XFeatPairMatcher(model_path), options);
    } else {
      DIACHRON_CHECK(false, "unknown --matcher '" << matcher_name << "'");
    }

    write_report(out_dir + "/report.json", report, matcher_name, frame);
    std::vector<bool> mask(report.tentative_2d.size(), false);
    for (std::size_t i : report.inlier_indices_2d) mask[i] = true;
    // The winner's pixels are those of its (possibly coarsened or enlarged) images: image pixel i is
    // centred on full-resolution pixel f i + (f - 1) / 2, f = the image factor (a fraction when enlarged).
    PointMatches drawn = report.tentative_2d;
    const double fm = report.master_image_factor, fs = report.secondary_image_factor;
    for (PointMatch& m : drawn) {
      m.a = fm * m.a + Eigen::Vector2d::Constant(0.5 * (fm - 1.0));
      m.b = fs * m.b + Eigen::Vector2d::Constant(0.5 * (fs - 1.0));
    }
    write_matches_png(out_dir + "/matches.png", make_dsm_image(master, options), make_dsm_image(secondary, options),
                      drawn, mask);
    for (const auto& h : report.scale_hypotheses)
      std::printf("scale %-4s (master %4d x %4d, secondary %4d x %4d): %5zu matches, %5zu inliers, %zu needed, %.2f s%s\n",
                  h.hypothesis.name().c_str(), h.master_width, h.master_height, h.secondary_width, h.secondary_height,
                  h.matches, h.inliers, h.required_inliers, h.seconds, h.success ? ", success" : "");
    for (const auto& h : report.hypotheses)
      std::printf("rotation %3d deg: %5zu matches, %5zu inliers\n", h.rotation_deg, h.matches, h.inliers);
    std::printf("%s\n", report.message.c_str());
    if (!report.success) return 2;
    write_helmert(out_dir + "/helmert.json", report.epoch2_from_epoch1);
    const Helmert3& h = report.epoch2_from_epoch1;
    std::printf("scale %.6f, rotation about Z %.3f deg, 3D RMS %.3f (secondary units), %.2f s\n", h.scale,
                rad_to_deg(std::atan2(h.rotation(1, 0), h.rotation(0, 0))), report.rms_3d, report.seconds.total);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rough_coregistration: %s\n%s", e.what(), kUsage);
    return 1;
  }
}
