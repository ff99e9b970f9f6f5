#pragma once
/// @file
/// Precise matching (paper section 3.2.2) as named stages: per overlapping inter-epoch image pair,
/// tentative matches (patch matching on transfer-guided tiles, or guided matching of keypoints),
/// then the ground filter (3D Helmert RANSAC on the matches lifted through both DSMs), then the NCC
/// validator (with optional sub-pixel refinement). Every stage is a component of its own
/// (tiling/one_to_one.hpp, matching/guided_matcher.hpp, validation/); this header only composes
/// them per pair (precise_match_pair) and over the pairs of two epochs (precise_matching_patch,
/// precise_matching_guided), parallel over pairs and deterministic whatever the thread count.
///
/// Frames: the master image (epoch 1) is oriented in epoch 1's frame, the secondary (epoch 2) in
/// epoch 2's; `epoch2_from_epoch1` (the rough co-registration's Helmert) links them. Pixels follow
/// docs/conventions.md.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/progress.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/matching/correlation_matcher.hpp>
#include <diachron/terrain/local_relief.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/matching/grid_interest_points.hpp>
#include <diachron/matching/guided_matcher.hpp>
#include <diachron/matching/image_mask.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/matching/unsharp_mask.hpp>
#include <diachron/pipeline/correlation_pair.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/gsd.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/tiling/one_to_one.hpp>
#include <diachron/tiling/pair_matcher.hpp>
#include <diachron/validation/ground_filter.hpp>
#include <diachron/validation/match_filter.hpp>
#include <diachron/validation/ncc_validator.hpp>

namespace diachron {

/// How the tentative matches of a pair are found.
enum class TentativeMethod {
  patch,   ///< one-to-one transfer-guided tiling with any PairMatcher (MicMac's SuperGlue path)
  guided,  ///< keypoints of the whole images matched under DSM + Helmert prediction (MicMac's GuidedSIFT)
  correlation,  ///< grid interest points correlated around their DSM + Helmert prediction (no descriptor)
};

/// "patch", "guided" or "correlation".
inline const char* to_string(TentativeMethod method) {
  return method == TentativeMethod::patch ? "patch" : method == TentativeMethod::guided ? "guided" : "correlation";
}

/// Options of correlation matching inside precise matching. Defaults: measured on the decades
/// scenes (docs/correlation-matching.md).
struct PreciseCorrelationOptions {
  /// The master points: the strongest structure tensor per 6 px cell (about 53000 candidates on a
  /// 1600 x 1200 image, of which those in the overlap are correlated). Their 21 px windows overlap,
  /// so neighbouring matches are not independent, but each is a tie point checked on its own. Denser
  /// cells give more correct matches per pair at proportional cost (decades scenes, 30 pairs, median
  /// correct final matches per pair: 10 px cells 67, 8 px 95, 6 px 144). max_points_per_image may
  /// coarsen the cell on a large image, also below a cell set here: use_fixed_cell() asks for one
  /// whatever the image's size.
  GridInterestOptions interest = [] {
    GridInterestOptions o;
    o.cell_px = 6;
    // The structure tensor over 15 px, as every figure of docs/precise-matching.md was measured
    // (GridInterestOptions' own default became the correlation window, 21 px, later).
    o.window_px = 15;
    return o;
  }();
  /// At most about this many master points per image (0: no bound). On a master image of more than
  /// max_points_per_image cells of interest.cell_px, the cell grows to
  /// ceil(sqrt(width * height / max_points_per_image)) px (effective_cell_px), so that the work per
  /// pair of a fine scan stays about that of a 1600 x 1200 image at 6 px (53000 cells): a
  /// 3200 x 2400 image gets 12 px cells, a 12000 x 12000 scan 49 px, instead of 4 million points.
  /// The cell depends on the master image only, so every pair of one master image has the same
  /// points and the adjustment's tracks join them.
  std::size_t max_points_per_image = 60000;
  /// The correlation search: orientation measure, 21 px window, +-12 master px.
  CorrelationMatchOptions match{};
  /// A second pass around predictions corrected by the ground filter's Helmert on the first pass's
  /// matches, searching +-second_pass_radius_px master px (0: no second pass). Once the ground
  /// filter has fitted the matches the prediction is better than the rough Helmert's, and a small
  /// search admits fewer false peaks (decades seed 0: 67 % of the tentative matches within 3 px
  /// instead of 46 %).
  int second_pass_radius_px = 6;
  /// The ground filter's threshold for correlation matches, in GSD of the secondary image (> 0).
  /// Correlation peaks are mostly within a pixel or two, so the paper's 10 GSD (kept for the
  /// descriptor methods) lets wrong peaks through: 3 GSD kept 96 % within 3 px instead of 69 %.
  double ground_threshold_gsd = 3.0;
  /// ... but never below this many GSD of the master image (its GSD at its centre, in the secondary
  /// frame's units; >= 0, 0 = no floor), which becomes the ground filter's min_threshold. The window
  /// lives in master pixels, so a match is precise to a fraction of a master pixel however fine the
  /// secondary image is: with epoch 2 eight times finer than epoch 1, 3 secondary GSD is 0.4 master
  /// GSD, and the filter kept 18 matches per pair instead of 216 (docs/precise-matching.md,
  /// "Resolution gaps"). 1.5 is what 3 secondary GSD is on the decades preset (epoch 1 twice as
  /// coarse), so it binds only where the gap is wider than 2.
  double ground_floor_master_gsd = 1.5;
  /// Run the intensity NCC validator on the correlation matches. Off: the correlation score already
  /// is the validation, and an intensity NCC >= 0.6 rejects the matches on land cover whose contrast
  /// inverted between the epochs, which the orientation measure keeps (3/4 of them on seed 0).
  bool use_ncc = false;
  /// Correlate only master points whose ground is locally a plane: the RMS of the plane residuals of
  /// each epoch's DSM (terrain/local_relief.hpp) over a disc of relief_radius_px master px around the
  /// point, in the secondary frame's units, at most max_relief_gsd GSD of the secondary image. Trees,
  /// buildings and banks in a window give several parallaxes and shadows that move with the sun
  /// (docs/correlation-matching.md). 0: off.
  double max_relief_gsd = 0.0;
  /// Radius of that disc, master px (> 0): the correlation window's size reaches the shadows cast
  /// into a window by what stands just outside it.
  double relief_radius_px = 21.0;
  /// Sharpening of the master image before its points are chosen and correlated (off by default).
  /// A scanned film's blur leaves its finest detail weak against the grain (matching/unsharp_mask.hpp,
  /// docs/correlation-matching.md "The film's parts, and sharpening the film").
  UnsharpMaskOptions master_sharpen{};

  /// Cells of px master px on every image, whatever its size (the point bound off): what the
  /// programs' --cell asks for.
  void use_fixed_cell(int px) {
    interest.cell_px = px;
    max_points_per_image = 0;
  }

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    interest.check();
    match.check();
    master_sharpen.check();
    DIACHRON_CHECK(std::isfinite(max_relief_gsd) && max_relief_gsd >= 0.0,
                   "PreciseCorrelationOptions::max_relief_gsd must be finite and >= 0, got " << max_relief_gsd);
    DIACHRON_CHECK(std::isfinite(relief_radius_px) && relief_radius_px > 0.0,
                   "PreciseCorrelationOptions::relief_radius_px must be finite and > 0, got " << relief_radius_px);
    DIACHRON_CHECK(second_pass_radius_px >= 0 && second_pass_radius_px <= 128,
                   "PreciseCorrelationOptions::second_pass_radius_px must be in [0, 128], got "
                       << second_pass_radius_px);
    DIACHRON_CHECK(std::isfinite(ground_threshold_gsd) && ground_threshold_gsd > 0.0,
                   "PreciseCorrelationOptions::ground_threshold_gsd must be finite and > 0, got "
                       << ground_threshold_gsd);
    DIACHRON_CHECK(std::isfinite(ground_floor_master_gsd) && ground_floor_master_gsd >= 0.0,
                   "PreciseCorrelationOptions::ground_floor_master_gsd must be finite and >= 0, got "
                       << ground_floor_master_gsd);
  }
};

/// The side of the grid cell, master px, that precise_match_pair_correlation uses on a master image
/// of width x height px: options.interest.cell_px, or larger so that the image has at most
/// options.max_points_per_image cells.
inline int effective_cell_px(const PreciseCorrelationOptions& options, int width, int height) {
  return effective_cell_px(options.interest.cell_px, options.max_points_per_image, width, height);
}

/// Options of precise matching. Defaults: the paper's and MicMac's, except where
/// docs/precise-matching.md measured better (each field says so).
struct PreciseMatchingOptions {
  /// Patch matching: MicMac's 1920 x 1440 tiles with a 10 % buffer, displacement bound 100 px.
  OneToOneOptions patch{};
  /// Guided matching: radius 100 px, scale ratio 0.8-1.2, angle +-30 degrees, ratio 0.8, mutual.
  GuidedMatchOptions guided{};
  /// Correlation matching (docs/correlation-matching.md): points, search, second pass, and its own
  /// ground-filter threshold and NCC switch.
  PreciseCorrelationOptions correlation{};
  /// The 3D Helmert RANSAC on the lifted matches (1000 iterations, 10 x GSD of the secondary image).
  bool use_ground_filter = true;
  GroundFilterOptions ground{};
  /// The NCC validator (32 x 32 px, NCC >= 0.6, MicMac today; the paper used 0.5), with the
  /// sub-pixel refinement of the secondary positions on (least-squares matching; MicMac only filters).
  bool use_ncc = true;
  NccOptions ncc = [] {
    NccOptions o;
    o.refine = true;
    return o;
  }();
  /// Worker threads over pairs (0 = all cores). Results do not depend on it.
  std::size_t threads = 0;
  /// Called as pairs finish ("precise matching": done of total pairs).
  ProgressCallback progress;

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    patch.check();
    guided.check();
    correlation.check();
    ground.check();
    ncc.check();
  }
};

/// Seconds spent per stage of one pair (wall clock of the thread that ran the pair).
struct PrecisePairSeconds {
  double images = 0.0;     ///< reading the two images
  double tentative = 0.0;  ///< patch, guided or correlation matching (guided: without the shared feature extraction)
  double ground = 0.0;     ///< ground filter
  double ncc = 0.0;        ///< NCC validation and refinement
  double total = 0.0;
};

/// What precise matching did with one image pair. The match lists of every stage are kept, so a
/// user (or a bench with the truth) can judge each stage; the filter results are index-aligned with
/// the list they judged. Default: not run (success == false).
struct PrecisePairReport {
  std::size_t master = 0;     ///< index of the master image (epoch 1)
  std::size_t secondary = 0;  ///< index of the secondary image (epoch 2)
  bool success = false;       ///< at least one final match
  std::string message;        ///< what happened, or why there is no match
  PointMatches tentative;     ///< the tentative matches (master px, secondary px), none on masked pixels
  std::size_t masked = 0;     ///< tentative matches dropped because they touch a masked pixel (PreciseImage::mask)
  GroundFilterResult ground;  ///< the ground filter's verdict on `tentative` (empty when not used)
  PointMatches grounded;      ///< `tentative` kept by the ground filter (all of them when not used)
  NccResult ncc;              ///< the NCC verdict on `grounded` (empty when not used)
  PointMatches matches;       ///< the final matches (refined secondary positions when refinement is on)
  PrecisePairSeconds seconds;
};

/// What precise matching did with all pairs. Default: nothing ran (success == false).
struct PreciseMatchingReport {
  bool success = false;  ///< at least one pair has final matches
  std::string message;
  std::vector<PrecisePairReport> pairs;  ///< in the order of the pairs given
  std::size_t tentative = 0, grounded = 0, final_matches = 0;  ///< totals over pairs
  double seconds_features = 0.0;  ///< guided: extracting the features of every image involved
  double seconds_total = 0.0;
};

/// One oriented image as precise matching needs it: its frame in its epoch's frame, its pixels,
/// and optionally its mask (matching/image_mask.hpp; null or empty: every pixel usable). No match
/// keeps a point on a masked pixel; correlation also keeps masked pixels out of its windows.
template <class Frame>
struct PreciseImage {
  const Frame* frame = nullptr;
  const Raster<std::uint8_t>* pixels = nullptr;
  const ImageMask* mask = nullptr;
};

namespace detail {

inline double precise_seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// GSD of an image (the secondary for the ground filter, the master for its floor) at its centre on
// its DSM, or over the DSM's mean height where the centre ray misses the DSM (a hole), as MicMac
// measures the secondary's (at AltiSol).
template <class Frame>
double image_gsd(const Frame& frame, const Dsm& dsm, int width, int height) {
  const Eigen::Vector2d centre(0.5 * (width - 1), 0.5 * (height - 1));
  if (const std::optional<double> g = gsd_on_dsm(frame, dsm, centre); g && *g > 0.0) return *g;
  const double z = dsm.statistics().mean;
  if (std::isfinite(z))
    if (const std::optional<double> g = gsd_at_height(frame, z, centre); g && *g > 0.0) return *g;
  return std::numeric_limits<double>::quiet_NaN();
}

/// The points whose ground both DSMs show as locally a plane (PreciseCorrelationOptions::max_relief_gsd).
template <class Transfer, class MasterFrame, class SecondaryFrame>
std::vector<Eigen::Vector2d> points_on_plane_ground(const std::vector<Eigen::Vector2d>& points, const Transfer& transfer,
                                                    const PreciseImage<MasterFrame>& master, const Dsm& master_dsm,
                                                    const PreciseImage<SecondaryFrame>& secondary,
                                                    const Dsm& secondary_dsm, const Helmert3& epoch2_from_epoch1,
                                                    const PreciseCorrelationOptions& options) {
  const double master_gsd = image_gsd(*master.frame, master_dsm, master.pixels->width(), master.pixels->height());
  const double gsd2 = image_gsd(*secondary.frame, secondary_dsm, secondary.pixels->width(), secondary.pixels->height());
  if (!std::isfinite(master_gsd) || !std::isfinite(gsd2)) return points;  // no scale to judge by: keep all
  const double radius1 = options.relief_radius_px * master_gsd;          // master frame units
  const double radius2 = radius1 * epoch2_from_epoch1.scale;             // secondary frame units
  const double bound = options.max_relief_gsd * gsd2;                   // secondary frame units
  std::vector<Eigen::Vector2d> kept;
  for (const Eigen::Vector2d& p : points) {
    const std::optional<Eigen::Vector3d> x1 = transfer.master_point(p), x2 = transfer.secondary_point(p);
    if (!x1 || !x2) continue;
    const LocalRelief r1 = local_relief(master_dsm, x1->head<2>(), radius1);
    const LocalRelief r2 = local_relief(secondary_dsm, x2->head<2>(), radius2);
    if (r1.valid && r2.valid && r1.rms * epoch2_from_epoch1.scale <= bound && r2.rms <= bound) kept.push_back(p);
  }
  return kept;
}

}  // namespace detail

/// The matches `ncc` kept, each at its refined secondary position when the refinement moved it
/// (NccRefinement::applied), else as it was.
inline PointMatches ncc_final_matches(const PointMatches& matches, const NccResult& ncc) {
  DIACHRON_CHECK(ncc.size() == matches.size(),
                 "ncc_final_matches: " << matches.size() << " matches but the validator judged " << ncc.size());
  PointMatches out;
  out.reserve(ncc.kept());
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (!ncc.keep[i]) continue;
    PointMatch m = matches[i];
    if (i < ncc.refinement.size() && ncc.refinement[i].applied()) m.b = ncc.refinement[i].b;
    out.push_back(m);
  }
  return out;
}

namespace detail {

// Drops the matches whose support touches a masked pixel: the square of half side master_half_px
// around the master point, of secondary_half_px around the secondary one (0: the point's pixel, as
// COLMAP keeps features out of masks). Returns how many were dropped; keeps the order.
inline std::size_t drop_masked(PointMatches& matches, const ImageMask* master, int master_half_px,
                               const ImageMask* secondary, int secondary_half_px) {
  const bool m = master && !master->empty(), s = secondary && !secondary->empty();
  if (!m && !s) return 0;
  const std::size_t before = matches.size();
  matches.erase(std::remove_if(matches.begin(), matches.end(),
                               [&](const PointMatch& pm) {
                                 return (m && !master->box_usable(pm.a, master_half_px)) ||
                                        (s && !secondary->box_usable(pm.b, secondary_half_px));
                               }),
                matches.end());
  return before - matches.size();
}

// The features whose keypoint lies on a usable pixel of `mask`, in their order: masked keypoints are
// kept out before matching, so that they do not take part in the ratio and mutual tests.
inline Features usable_features(const Features& features, const ImageMask& mask) {
  if (mask.empty()) return features;
  std::vector<Eigen::Index> rows;
  for (std::size_t i = 0; i < features.keypoints.size(); ++i)
    if (mask.usable(features.keypoints[i].position)) rows.push_back(static_cast<Eigen::Index>(i));
  Features out;
  for (const Eigen::Index r : rows) out.keypoints.push_back(features.keypoints[static_cast<std::size_t>(r)]);
  // Descriptor-less features (no rows) stay so.
  if (features.descriptors.rows() > 0) {
    out.descriptors.resize(static_cast<Eigen::Index>(rows.size()), features.descriptors.cols());
    for (std::size_t k = 0; k < rows.size(); ++k)
      out.descriptors.row(static_cast<Eigen::Index>(k)) = features.descriptors.row(rows[k]);
  }
  return out;
}

template <class MasterFrame, class SecondaryFrame>
void check_mask_sizes(const PreciseImage<MasterFrame>& master, const PreciseImage<SecondaryFrame>& secondary) {
  if (master.mask) master.mask->check_size(master.pixels->width(), master.pixels->height(), "the master image");
  if (secondary.mask)
    secondary.mask->check_size(secondary.pixels->width(), secondary.pixels->height(), "the secondary image");
}

// The half side, secondary px, of a window of half side master_half_px master px seen in the
// secondary image: times the ratio of the images' GSDs (through the Helmert's scale); master_half_px
// itself where a GSD cannot be measured. Computed only when the secondary has a mask.
template <class MasterFrame, class SecondaryFrame>
int secondary_half_px(const PreciseImage<MasterFrame>& master, const Dsm& master_dsm,
                      const PreciseImage<SecondaryFrame>& secondary, const Dsm& secondary_dsm,
                      const Helmert3& epoch2_from_epoch1, int master_half_px) {
  if (master_half_px == 0 || !secondary.mask || secondary.mask->empty()) return master_half_px;
  const double g1 = image_gsd(*master.frame, master_dsm, master.pixels->width(), master.pixels->height());
  const double g2 = image_gsd(*secondary.frame, secondary_dsm, secondary.pixels->width(), secondary.pixels->height());
  const double ratio = g1 * epoch2_from_epoch1.scale / g2;  // secondary px per master px
  if (!std::isfinite(ratio) || ratio <= 0.0) return master_half_px;
  return static_cast<int>(std::ceil(std::min(ratio, 64.0) * master_half_px));
}

// Masked matches out of the tentative ones of a descriptor method (patch, guided): the points'
// pixels, and the NCC validator's windows when it runs, so that it never correlates a mask.
template <class MasterFrame, class SecondaryFrame>
std::size_t drop_masked_tentative(PointMatches& matches, const PreciseImage<MasterFrame>& master, const Dsm& master_dsm,
                                  const PreciseImage<SecondaryFrame>& secondary, const Dsm& secondary_dsm,
                                  const Helmert3& epoch2_from_epoch1, const PreciseMatchingOptions& options) {
  const int half = options.use_ncc ? options.ncc.window_px / 2 : 0;
  return drop_masked(matches, master.mask, half, secondary.mask,
                     secondary_half_px(master, master_dsm, secondary, secondary_dsm, epoch2_from_epoch1, half));
}

}  // namespace detail

/// The two filters of precise matching on one pair's tentative matches: the ground filter, then
/// the NCC validator on what it kept. Fills `report.ground`, `grounded`, `ncc`, `matches`, the
/// filter timings, `success` and `message`; `report.tentative` must hold the tentative matches.
template <class MasterFrame, class SecondaryFrame>
void filter_precise_pair(PrecisePairReport& report, const PreciseImage<MasterFrame>& master, const Dsm& master_dsm,
                         const PreciseImage<SecondaryFrame>& secondary, const Dsm& secondary_dsm,
                         const Helmert3& epoch2_from_epoch1, const PreciseMatchingOptions& options) {
  const auto transfer = make_dsm_transfer(*master.frame, master_dsm, *secondary.frame, epoch2_from_epoch1);
  auto start = std::chrono::steady_clock::now();
  if (report.tentative.empty()) {
    report.message = "no tentative match";
    return;
  }
  if (options.use_ground_filter) {
    const DsmLift<SecondaryFrame> secondary_lift(*secondary.frame, secondary_dsm);
    const auto master_lift = [&transfer](const Eigen::Vector2d& px) { return transfer.secondary_point(px); };
    const double gsd = detail::image_gsd(*secondary.frame, secondary_dsm, secondary.pixels->width(),
                                             secondary.pixels->height());
    if (!std::isfinite(gsd)) {
      report.message = "the secondary image's GSD cannot be measured (its centre ray misses the DSM plane)";
      report.seconds.ground = detail::precise_seconds_since(start);
      return;
    }
    report.ground = ground_filter(report.tentative, master_lift, secondary_lift, gsd, options.ground);
    report.seconds.ground = detail::precise_seconds_since(start);
    if (!report.ground.success) {
      report.message = "ground filter: " + report.ground.message;
      return;
    }
    report.grounded = select_kept(report.tentative, report.ground);
  } else {
    report.grounded = report.tentative;
  }
  start = std::chrono::steady_clock::now();
  if (options.use_ncc && !report.grounded.empty()) {
    report.ncc = ncc_validate(*master.pixels, *secondary.pixels, report.grounded, transfer, options.ncc);
    report.matches = ncc_final_matches(report.grounded, report.ncc);
  } else {
    report.matches = report.grounded;
  }
  report.seconds.ncc = detail::precise_seconds_since(start);
  report.success = !report.matches.empty();
  report.message = std::to_string(report.tentative.size()) + " tentative, " + std::to_string(report.grounded.size()) +
                   " after the ground filter, " + std::to_string(report.matches.size()) + " final";
}

/// Precise matching of one pair by patch matching: one-to-one transfer-guided tiles matched with
/// `matcher` (any PairMatcher), then the filters.
template <class MasterFrame, class SecondaryFrame, class Matcher>
PrecisePairReport precise_match_pair_patch(const PreciseImage<MasterFrame>& master, const Dsm& master_dsm,
                                           const PreciseImage<SecondaryFrame>& secondary, const Dsm& secondary_dsm,
                                           const Helmert3& epoch2_from_epoch1, const Matcher& matcher,
                                           const PreciseMatchingOptions& options = {}) {
  static_assert(check_pair_matcher<Matcher>());
  options.check();
  DIACHRON_CHECK(master.frame && master.pixels && secondary.frame && secondary.pixels,
                 "precise_match_pair_patch: an image without frame or pixels");
  detail::check_mask_sizes(master, secondary);
  PrecisePairReport report;
  const auto start = std::chrono::steady_clock::now();
  const auto transfer = make_dsm_transfer(*master.frame, master_dsm, *secondary.frame, epoch2_from_epoch1);
  OneToOneResult tiles = match_one_to_one(*master.pixels, *secondary.pixels, transfer, matcher, options.patch);
  report.tentative = std::move(tiles.matches);
  report.masked = detail::drop_masked_tentative(report.tentative, master, master_dsm, secondary, secondary_dsm,
                                                epoch2_from_epoch1, options);
  report.seconds.tentative = detail::precise_seconds_since(start);
  filter_precise_pair(report, master, master_dsm, secondary, secondary_dsm, epoch2_from_epoch1, options);
  if (report.tentative.empty()) report.message = "no tentative match: " + tiles.message;
  report.seconds.total = detail::precise_seconds_since(start);
  return report;
}

/// Precise matching of one pair by guided matching of precomputed features (keypoints of the
/// whole master and secondary images), then the filters.
template <class MasterFrame, class SecondaryFrame>
PrecisePairReport precise_match_pair_guided(const PreciseImage<MasterFrame>& master, const Features& master_features,
                                            const Dsm& master_dsm, const PreciseImage<SecondaryFrame>& secondary,
                                            const Features& secondary_features, const Dsm& secondary_dsm,
                                            const Helmert3& epoch2_from_epoch1,
                                            const PreciseMatchingOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(master.frame && master.pixels && secondary.frame && secondary.pixels,
                 "precise_match_pair_guided: an image without frame or pixels");
  detail::check_mask_sizes(master, secondary);
  PrecisePairReport report;
  const auto start = std::chrono::steady_clock::now();
  const auto forward = make_dsm_transfer(*master.frame, master_dsm, *secondary.frame, epoch2_from_epoch1);
  const auto inverse = make_dsm_transfer(*secondary.frame, secondary_dsm, *master.frame, epoch2_from_epoch1.inverse());
  GuidedMatchResult guided = guided_match(master_features, secondary_features, forward, inverse, options.guided);
  report.tentative = std::move(guided.matches);
  report.masked = detail::drop_masked_tentative(report.tentative, master, master_dsm, secondary, secondary_dsm,
                                                epoch2_from_epoch1, options);
  report.seconds.tentative = detail::precise_seconds_since(start);
  filter_precise_pair(report, master, master_dsm, secondary, secondary_dsm, epoch2_from_epoch1, options);
  report.seconds.total = detail::precise_seconds_since(start);
  return report;
}

/// Precise matching of one pair by correlation (options.correlation): the master's grid interest
/// points correlated around their DSM + Helmert prediction, an optional second pass around
/// predictions corrected by the ground filter, then the filters (the ground filter with the
/// correlation's threshold; NCC only when both options.use_ncc and options.correlation.use_ncc).
/// The points and the two passes are pipeline/correlation_pair.hpp's (correlation_points,
/// correlation_two_passes), whose refit policy here is the ground filter's 3D Helmert; without
/// DSMs, correlation_match_pair composes the same parts around a 2D map.
template <class MasterFrame, class SecondaryFrame>
PrecisePairReport precise_match_pair_correlation(const PreciseImage<MasterFrame>& master, const Dsm& master_dsm,
                                                 const PreciseImage<SecondaryFrame>& secondary,
                                                 const Dsm& secondary_dsm, const Helmert3& epoch2_from_epoch1,
                                                 const PreciseMatchingOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(master.frame && master.pixels && secondary.frame && secondary.pixels,
                 "precise_match_pair_correlation: an image without frame or pixels");
  PrecisePairReport report;
  const auto start = std::chrono::steady_clock::now();
  const PreciseCorrelationOptions& co = options.correlation;
  // The correlation filters use their own ground threshold and NCC switch.
  PreciseMatchingOptions filters = options;
  filters.ground.threshold_gsd = co.ground_threshold_gsd;
  // The floor in master GSD, in the secondary frame (none when the master's GSD cannot be measured).
  if (co.ground_floor_master_gsd > 0.0) {
    const double gsd1 =
        detail::image_gsd(*master.frame, master_dsm, master.pixels->width(), master.pixels->height());
    if (std::isfinite(gsd1))
      filters.ground.min_threshold =
          std::max(filters.ground.min_threshold, co.ground_floor_master_gsd * gsd1 * epoch2_from_epoch1.scale);
  }
  filters.use_ncc = options.use_ncc && co.use_ncc;
  // The sharpened master serves the points and the correlation; the filters and the report keep the
  // image as given (the NCC validator, when on, sees the original).
  const Raster<std::uint8_t> sharpened =
      co.master_sharpen.enabled() ? unsharp_mask(*master.pixels, co.master_sharpen) : Raster<std::uint8_t>{};
  const Raster<std::uint8_t>& master_pixels = co.master_sharpen.enabled() ? sharpened : *master.pixels;
  GridInterestOptions interest = co.interest;
  interest.cell_px = effective_cell_px(co, master.pixels->width(), master.pixels->height());
  // Points keep the window's margin from the border and, on a masked master, only where the whole
  // window is usable; a match's secondary window, the master window's size times the GSD ratio,
  // must be usable too (correlation_points, correlation_two_passes).
  const int half_window = co.match.window_px / 2;
  detail::check_mask_sizes(master, secondary);
  std::vector<Eigen::Vector2d> points = correlation_points(master_pixels, interest, co.match.window_px, master.mask);
  const int secondary_half =
      detail::secondary_half_px(master, master_dsm, secondary, secondary_dsm, epoch2_from_epoch1, half_window);
  const auto transfer = make_dsm_transfer(*master.frame, master_dsm, *secondary.frame, epoch2_from_epoch1);
  std::string relief_note;
  if (co.max_relief_gsd > 0.0) {
    const std::size_t before = points.size();
    points = detail::points_on_plane_ground(points, transfer, master, master_dsm, secondary, secondary_dsm,
                                            epoch2_from_epoch1, co);
    relief_note = ", " + std::to_string(before - points.size()) + " of them skipped on relief";
  }
  // The refit: the ground filter's Helmert on the first pass corrects the rough Helmert the
  // transfer went through (none when there are too few matches or no GSD to set its threshold).
  using Refit = CorrelationRefit<std::remove_const_t<decltype(transfer)>>;
  const auto refit = [&](const PointMatches& first) {
    if (first.size() < filters.ground.min_pairs) return Refit{};
    const double gsd =
        detail::image_gsd(*secondary.frame, secondary_dsm, secondary.pixels->width(), secondary.pixels->height());
    if (!std::isfinite(gsd)) return Refit{};
    const DsmLift<SecondaryFrame> secondary_lift(*secondary.frame, secondary_dsm);
    const auto master_lift = [&transfer](const Eigen::Vector2d& px) { return transfer.secondary_point(px); };
    const GroundFilterResult ground = ground_filter(first, master_lift, secondary_lift, gsd, filters.ground);
    if (!ground.success) return Refit{std::nullopt, "ground filter: " + ground.message};
    const Helmert3 refined = ground.model * epoch2_from_epoch1;
    return Refit{make_dsm_transfer(*master.frame, master_dsm, *secondary.frame, refined), std::string()};
  };
  CorrelationPasses passes = correlation_two_passes(master_pixels, *secondary.pixels, points, transfer, co.match,
                                                    co.second_pass_radius_px, refit, secondary.mask, secondary_half);
  report.masked = passes.masked();
  report.tentative = passes.second_ran ? std::move(passes.second) : std::move(passes.first);
  const std::string& second_pass = passes.message;
  report.seconds.tentative = detail::precise_seconds_since(start);
  filter_precise_pair(report, master, master_dsm, secondary, secondary_dsm, epoch2_from_epoch1, filters);
  report.message += "; " + std::to_string(points.size()) + " interest points (" + std::to_string(interest.cell_px) +
                    " px cells)" + relief_note + ", " + second_pass;
  if (report.masked > 0) report.message += "; " + std::to_string(report.masked) + " matches on masked pixels dropped";
  report.seconds.total = detail::precise_seconds_since(start);
  return report;
}

/// Two epochs as precise matching sees them: per image its frame (in the epoch's frame), a way to
/// read its pixels (called from worker threads, once per pair the image is in: wrap a cache in it
/// if reading is slow), and the epoch's DSM (same frame). The DSM must outlive the call.
/// `load_mask`, optional, reads an image's mask the same way (matching/image_mask.hpp: 0 = ignore
/// the pixel; an empty raster: no mask for that image; another size than the image's: an error).
template <class Frame>
struct PreciseEpoch {
  std::vector<Frame> frames;
  std::function<Raster<std::uint8_t>(std::size_t)> load_image;
  const Dsm* dsm = nullptr;
  std::function<Raster<std::uint8_t>(std::size_t)> load_mask{};

  void check(const char* which) const {
    DIACHRON_CHECK(dsm != nullptr && !dsm->empty(), "precise matching: epoch " << which << " has no DSM");
    DIACHRON_CHECK(static_cast<bool>(load_image), "precise matching: epoch " << which << " has no image loader");
  }
};

namespace detail {

template <class MasterFrame, class SecondaryFrame, class PairFn>
PreciseMatchingReport run_precise_pairs(const PreciseEpoch<MasterFrame>& epoch1,
                                        const PreciseEpoch<SecondaryFrame>& epoch2,
                                        const std::vector<ImagePairOverlap>& pairs,
                                        const PreciseMatchingOptions& options, PairFn&& run_pair) {
  PreciseMatchingReport out;
  out.pairs.resize(pairs.size());
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    DIACHRON_CHECK(pairs[k].master < epoch1.frames.size() && pairs[k].secondary < epoch2.frames.size(),
                   "precise matching: pair " << k << " refers to images " << pairs[k].master << " and "
                                             << pairs[k].secondary << ", the epochs have " << epoch1.frames.size()
                                             << " and " << epoch2.frames.size());
  }
  ProgressReporter progress(options.progress, "precise matching (pairs)", pairs.size());
  parallel_for(pairs.size(), options.threads, [&](std::size_t k) {
    const auto start = std::chrono::steady_clock::now();
    const Raster<std::uint8_t> a = epoch1.load_image(pairs[k].master);
    const Raster<std::uint8_t> b = epoch2.load_image(pairs[k].secondary);
    const ImageMask mask_a(epoch1.load_mask ? epoch1.load_mask(pairs[k].master) : Raster<std::uint8_t>{});
    const ImageMask mask_b(epoch2.load_mask ? epoch2.load_mask(pairs[k].secondary) : Raster<std::uint8_t>{});
    mask_a.check_size(a.width(), a.height(), "image " + std::to_string(pairs[k].master) + " of epoch 1");
    mask_b.check_size(b.width(), b.height(), "image " + std::to_string(pairs[k].secondary) + " of epoch 2");
    const double load = precise_seconds_since(start);
    PreciseImage<MasterFrame> master{&epoch1.frames[pairs[k].master], &a, &mask_a};
    PreciseImage<SecondaryFrame> secondary{&epoch2.frames[pairs[k].secondary], &b, &mask_b};
    PrecisePairReport r = run_pair(k, master, secondary);
    r.master = pairs[k].master;
    r.secondary = pairs[k].secondary;
    r.seconds.images = load;
    r.seconds.total += load;
    out.pairs[k] = std::move(r);
    progress.advance();
  });
  std::size_t with_matches = 0;
  for (const PrecisePairReport& r : out.pairs) {
    out.tentative += r.tentative.size();
    out.grounded += r.grounded.size();
    out.final_matches += r.matches.size();
    with_matches += r.success;
  }
  out.success = with_matches > 0;
  out.message = pairs.empty() ? std::string("no overlapping pair")
                              : std::to_string(with_matches) + " of " + std::to_string(pairs.size()) +
                                    " pairs with matches, " + std::to_string(out.final_matches) + " final matches";
  return out;
}

// Inner stages run single-threaded when the pairs already keep every core busy.
inline PreciseMatchingOptions per_pair_options(const PreciseMatchingOptions& options, std::size_t pairs) {
  PreciseMatchingOptions inner = options;
  const std::size_t inner_threads = pairs >= resolve_threads(options.threads) ? 1 : options.threads;
  inner.patch.threads = inner_threads;
  inner.guided.threads = inner_threads;
  inner.correlation.match.threads = inner_threads;
  inner.ground.threads = inner_threads;
  inner.ncc.threads = inner_threads;
  inner.progress = nullptr;
  return inner;
}

// The composition of the methods whose pairs are independent (patch, correlation): the checks,
// the inner options, `match_pair(master, secondary, inner options)` on every pair, the total time.
template <class MasterFrame, class SecondaryFrame, class MatchPair>
PreciseMatchingReport precise_matching_each_pair(const PreciseEpoch<MasterFrame>& epoch1,
                                                 const PreciseEpoch<SecondaryFrame>& epoch2,
                                                 const std::vector<ImagePairOverlap>& pairs,
                                                 const PreciseMatchingOptions& options, MatchPair&& match_pair) {
  options.check();
  epoch1.check("1");
  epoch2.check("2");
  const auto start = std::chrono::steady_clock::now();
  const PreciseMatchingOptions inner = per_pair_options(options, pairs.size());
  PreciseMatchingReport out = run_precise_pairs(
      epoch1, epoch2, pairs, options,
      [&](std::size_t, const PreciseImage<MasterFrame>& a, const PreciseImage<SecondaryFrame>& b) {
        return match_pair(a, b, inner);
      });
  out.seconds_total = precise_seconds_since(start);
  return out;
}

}  // namespace detail

/// Precise matching of every pair by patch matching with `matcher` (any PairMatcher; thread-safe,
/// as the tiling schemes require). `pairs` come from overlapping_pairs() (or the user).
template <class MasterFrame, class SecondaryFrame, class Matcher>
PreciseMatchingReport precise_matching_patch(const PreciseEpoch<MasterFrame>& epoch1,
                                             const PreciseEpoch<SecondaryFrame>& epoch2,
                                             const Helmert3& epoch2_from_epoch1,
                                             const std::vector<ImagePairOverlap>& pairs, const Matcher& matcher,
                                             const PreciseMatchingOptions& options = {}) {
  static_assert(check_pair_matcher<Matcher>());
  return detail::precise_matching_each_pair(
      epoch1, epoch2, pairs, options,
      [&](const PreciseImage<MasterFrame>& a, const PreciseImage<SecondaryFrame>& b, const PreciseMatchingOptions& inner) {
        return precise_match_pair_patch(a, *epoch1.dsm, b, *epoch2.dsm, epoch2_from_epoch1, matcher, inner);
      });
}

/// Precise matching of every pair by guided matching of the features `extractor` finds in the
/// whole images (a FeatureExtractor; RootSIFT in the paper). Each image involved is read and
/// extracted once, in parallel, before the pairs.
template <class MasterFrame, class SecondaryFrame, class Extractor>
PreciseMatchingReport precise_matching_guided(const PreciseEpoch<MasterFrame>& epoch1,
                                              const PreciseEpoch<SecondaryFrame>& epoch2,
                                              const Helmert3& epoch2_from_epoch1,
                                              const std::vector<ImagePairOverlap>& pairs, const Extractor& extractor,
                                              const PreciseMatchingOptions& options = {}) {
  static_assert(check_feature_extractor<Extractor>());
  options.check();
  epoch1.check("1");
  epoch2.check("2");
  const auto start = std::chrono::steady_clock::now();
  // Features of the images the pairs use, one slot per image of each epoch.
  std::vector<std::uint8_t> used1(epoch1.frames.size(), 0), used2(epoch2.frames.size(), 0);
  for (const ImagePairOverlap& p : pairs) {
    DIACHRON_CHECK(p.master < used1.size() && p.secondary < used2.size(),
                   "precise_matching_guided: a pair refers to images " << p.master << " and " << p.secondary
                                                                       << " outside the epochs");
    used1[p.master] = used2[p.secondary] = 1;
  }
  std::vector<std::pair<int, std::size_t>> jobs;
  for (std::size_t i = 0; i < used1.size(); ++i)
    if (used1[i]) jobs.emplace_back(1, i);
  for (std::size_t i = 0; i < used2.size(); ++i)
    if (used2[i]) jobs.emplace_back(2, i);
  std::vector<Features> features1(used1.size()), features2(used2.size());
  {
    ProgressReporter progress(options.progress, "precise matching (features)", jobs.size());
    parallel_for(jobs.size(), options.threads, [&](std::size_t k) {
      const auto [epoch, i] = jobs[k];
      const Raster<std::uint8_t> image = epoch == 1 ? epoch1.load_image(i) : epoch2.load_image(i);
      const auto& load_mask = epoch == 1 ? epoch1.load_mask : epoch2.load_mask;
      const ImageMask mask(load_mask ? load_mask(i) : Raster<std::uint8_t>{});
      mask.check_size(image.width(), image.height(),
                      "image " + std::to_string(i) + " of epoch " + std::to_string(epoch));
      (epoch == 1 ? features1 : features2)[i] = detail::usable_features(extractor.extract(image), mask);
      progress.advance();
    });
  }
  const double seconds_features = detail::precise_seconds_since(start);
  const PreciseMatchingOptions inner = detail::per_pair_options(options, pairs.size());
  PreciseMatchingReport out = detail::run_precise_pairs(
      epoch1, epoch2, pairs, options,
      [&](std::size_t k, const PreciseImage<MasterFrame>& a, const PreciseImage<SecondaryFrame>& b) {
        return precise_match_pair_guided(a, features1[pairs[k].master], *epoch1.dsm, b, features2[pairs[k].secondary],
                                         *epoch2.dsm, epoch2_from_epoch1, inner);
      });
  out.seconds_features = seconds_features;
  out.seconds_total = detail::precise_seconds_since(start);
  return out;
}

/// Precise matching of every pair by correlation (precise_match_pair_correlation): no feature
/// extraction, so each pair is independent. `pairs` come from overlapping_pairs() (or the user).
template <class MasterFrame, class SecondaryFrame>
PreciseMatchingReport precise_matching_correlation(const PreciseEpoch<MasterFrame>& epoch1,
                                                   const PreciseEpoch<SecondaryFrame>& epoch2,
                                                   const Helmert3& epoch2_from_epoch1,
                                                   const std::vector<ImagePairOverlap>& pairs,
                                                   const PreciseMatchingOptions& options = {}) {
  return detail::precise_matching_each_pair(
      epoch1, epoch2, pairs, options,
      [&](const PreciseImage<MasterFrame>& a, const PreciseImage<SecondaryFrame>& b, const PreciseMatchingOptions& inner) {
        return precise_match_pair_correlation(a, *epoch1.dsm, b, *epoch2.dsm, epoch2_from_epoch1, inner);
      });
}

}  // namespace diachron
