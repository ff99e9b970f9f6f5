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
// Every option is parsed strictly (CLI11: whole numbers, ranges, sizes WxH) before any work.
// Progress on stderr (lines when it is not a terminal). Errors name the option or the file; --verbose
// adds the library's internal condition.
// Exit status: 0 success, 2 no co-registration found (reason printed), 1 bad input or options.
// The composition it runs is pipeline/rough_coregistration.hpp; docs/rough-coregistration.md says
// how its defaults were chosen.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "program_support.hpp"

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

using diachron::programs::add_pair_option;
using diachron::programs::error_text;
using diachron::programs::Progress;
using diachron::programs::strict_number;

const char* kDescription =
    "rough_coregistration: co-registers two epochs from their DSMs (GeoTIFF) and writes the 3D Helmert\n"
    "that moves the master's frame into the secondary's, X2 = scale R X1 + translation: DIR/helmert.json,\n"
    "DIR/report.json (counts per hypothesis and stage, timings), DIR/matches.png. DSMs in degrees need\n"
    "--reproject. Exit status: 0 success, 2 no co-registration found (the reason is printed), 1 bad input\n"
    "or options.\n";

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

constexpr DsmImageKind kImageKinds[] = {DsmImageKind::kLocalRelief, DsmImageKind::kSlope, DsmImageKind::kStretch,
                                        DsmImageKind::kStretchWallis, DsmImageKind::kHillshade,
                                        DsmImageKind::kMultiHillshade};

// Tile sides and buffers, DSM pixels: GridTilerOptions::check() wants sides > 0 and buffers >= 0;
// the bound keeps 2 * buffer within an int (a DSM of a million pixels a side is far beyond any).
constexpr int kMaxTilePx = 1000000;

}  // namespace

int main(int argc, char** argv) {
  std::string master_path, secondary_path, out_dir, matcher_name = "sift", model_path, reproject;
  std::string image = to_string(RoughCoregistrationOptions{}.image_kind), fallback = "gradient";
  GeoTiffReadOptions read_options;
  RoughCoregistrationOptions options;
  std::pair<int, int> tile{options.master_tiles.tile_width, options.master_tiles.tile_height};
  std::pair<int, int> buffer{options.master_tiles.buffer_x, options.master_tiles.buffer_y};
  std::optional<double> nodata;
  bool quiet = false, verbose = false, no_tiling = false, no_rotations = false, no_scales = false;
  bool no_refine_surface = false, no_surface_confirmation = false;
  std::vector<std::string> image_names;
  for (DsmImageKind k : kImageKinds) image_names.push_back(to_string(k));

  CLI::App app{kDescription, "rough_coregistration"};
  app.get_formatter()->column_width(34);
  app.add_option("MASTER_DSM", master_path, "epoch 1's DSM, the one moved")->required();
  app.add_option("SECONDARY_DSM", secondary_path, "epoch 2's DSM, the reference")->required();
  app.add_option("--out", out_dir, "output folder (created)")->required()->type_name("DIR");
  app.add_option("--matcher", matcher_name, "pair matcher: sift (default), rootsift, akaze or xfeat")
      ->check(CLI::IsMember({"sift", "rootsift", "akaze", "xfeat"}));
  app.add_option("--model", model_path, "XFeat ONNX file (with --matcher xfeat)")
      ->check(CLI::ExistingFile)
      ->type_name("PATH");
  app.add_option("--image", image, "DSM image: relief, slope (default), stretch, wallis, hillshade or multihillshade")
      ->check(CLI::IsMember(image_names));
  app.add_option("--k-sigma", options.dsm_image.k_sigma, "stretch range for stretch/wallis, sigmas (default 2, the paper)")
      ->check(strict_number<double>(std::numeric_limits<double>::min(), std::numeric_limits<double>::max(),
                                    "a stretch range > 0 (standard deviations of the heights)"))
      ->type_name("K");
  add_pair_option<int>(app, "--tile", tile, 1, kMaxTilePx, 'x', "WxH",
                       "tile sides in [1, " + std::to_string(kMaxTilePx) + "] px",
                       "tile size in DSM pixels, buffers included (default 1920x1440, MicMac's; the paper's was 640x480)");
  add_pair_option<int>(app, "--buffer", buffer, 0, kMaxTilePx, 'x', "BXxBY",
                       "margins in [0, " + std::to_string(kMaxTilePx) + "] px",
                       "margin around each tile core, DSM pixels (default 0x0; tiles overlap by 2 * buffer; a match "
                       "is kept in its master tile's core only)");
  app.add_flag("--no-tiling", no_tiling, "match the whole DSM images");
  app.add_flag("--no-rotations", no_rotations, "try 0 degrees only");
  app.add_flag("--no-scales", no_scales, "no scale hypotheses (coarsened DSMs for resolution gaps)");
  app.add_option("--fallback", fallback,
                 "dense correlation search when the features find nothing (small coarse DSMs against fine ones): "
                 "off, heights (the earlier search) or gradient (default, the measured best)")
      ->check(CLI::IsMember({"off", "heights", "gradient"}));
  app.add_flag("--no-refine-surface", no_refine_surface,
               "keep the Helmert of the matches, without the robust least-squares matching of the two surfaces "
               "after it");
  app.add_flag("--no-surface-confirmation", no_surface_confirmation,
               "a winner the fallback's search refuses stays refused, even when the two surfaces confirm it");
  app.add_option("--nodata", nodata, "also treat heights equal to V as holes (DSMs without a nodata tag, e.g. -9999)")
      ->check(strict_number<double>(-1e300, 1e300, "a height"))
      ->type_name("V");
  app.add_option("--reproject", reproject,
                 "warp both DSMs to this CRS first (utm: the WGS 84 UTM zone of the master's centre); "
                 "needed for geographic DSMs")
      ->type_name("utm|CRS");
  app.add_option("--threshold", options.ransac_2d.threshold, "2D RANSAC threshold, DSM pixels (default 10)")
      ->check(strict_number<double>(std::numeric_limits<double>::min(), std::numeric_limits<double>::max(),
                                    "a threshold > 0 (DSM pixels)"))
      ->type_name("PX");
  app.add_option("--threads", options.threads, "worker threads, 0 = all cores (default 0)")
      ->check(strict_number<std::size_t>(0, 4096, "a thread count in [0, 4096]"))
      ->type_name("N");
  app.add_option("--seed", options.ransac_2d.seed, "random seed (default 0)")
      ->check(strict_number<std::uint64_t>(0, std::numeric_limits<std::uint64_t>::max(), "a whole number >= 0"))
      ->type_name("S");
  app.add_flag("--quiet", quiet, "no progress on stderr");
  app.add_flag("--verbose", verbose, "errors with the library's internal condition (for bug reports)");
  if (const std::optional<int> status = diachron::programs::parse_options(app, argc, argv, 1)) return *status;
  try {
    for (DsmImageKind k : kImageKinds)
      if (image == to_string(k)) options.image_kind = k;
    options.master_tiles.tile_width = options.secondary_tiles.tile_width = tile.first;
    options.master_tiles.tile_height = options.secondary_tiles.tile_height = tile.second;
    options.master_tiles.buffer_x = options.secondary_tiles.buffer_x = buffer.first;
    options.master_tiles.buffer_y = options.secondary_tiles.buffer_y = buffer.second;
    options.use_tiling = !no_tiling;
    options.rotation_hypotheses = !no_rotations;
    options.scale_hypotheses.enabled = !no_scales;
    options.refine_surface = !no_refine_surface;
    options.surface_confirmation = !no_surface_confirmation;
    options.correlation_fallback = fallback != "off";
    // heights: the earlier search (peaks weighed by their share); gradient: the library's defaults.
    if (fallback == "heights") {
      options.correlation_search.signal = CorrelationSignal::heights;
      options.correlation_search.strength = CorrelationStrength::share;
    }
    if (nodata) {
      read_options.assume_untagged_nodata = true;
      read_options.untagged_nodata = *nodata;
    }
    // Before any work, in the options' words: the tiles must keep a core, and xfeat needs its model.
    if (options.use_tiling) {
      const GridTilerOptions& t = options.master_tiles;
      DIACHRON_CHECK(t.core_width() > 0 && t.core_height() > 0,
                     "--tile " << t.tile_width << "x" << t.tile_height << " --buffer " << t.buffer_x << "x"
                               << t.buffer_y << ": the tile core (tile - 2 * buffer) must be positive, got "
                               << t.core_width() << " x " << t.core_height());
    }
    DIACHRON_CHECK(matcher_name != "xfeat" || !model_path.empty(),
                   "--matcher xfeat needs --model PATH (the XFeat ONNX file)");
    options.check();
    if (options.use_tiling) {
      options.master_tiles.check();
      options.secondary_tiles.check();
    }
    if (!quiet) options.progress = Progress::callback();
    Dsm master = read_geotiff_dsm(master_path, read_options);
    Dsm secondary = read_geotiff_dsm(secondary_path, read_options);
    for (const auto& [dsm, path] : {std::pair<const Dsm*, std::string>{&master, master_path}, {&secondary, secondary_path}})
      if (const std::optional<double> v = suspected_untagged_nodata(*dsm); v && !read_options.assume_untagged_nodata) {
        Progress::break_line();
        std::fprintf(stderr, "warning: '%s' has heights of %g far below all others and no nodata tag for them: "
                             "if they are holes, pass --nodata %g\n", path.c_str(), *v, *v);
      }
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
      report = rough_coregistration(master, secondary, XFeatPairMatcher(model_path), options);
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
    Progress::break_line();
    std::fprintf(stderr, "rough_coregistration: %s\n", error_text(e, verbose).c_str());
    return 1;
  }
}
