#pragma once
/// @file
/// Rough co-registration of two epochs from their DSMs (paper section 3.2.1): DSM images ->
/// scale hypotheses (one DSM coarsened 2, 4, 8 times, for resolution gaps) x quarter-turn rotation
/// hypotheses x one-to-many tiling with any PairMatcher -> 2D similarity
/// RANSAC -> lift the inliers to 3D through both DSMs -> 3D Helmert (least squares, 3D RANSAC guard).
///
/// Generic in the PairMatcher; every stage is a component of its own (terrain/dsm_image.hpp,
/// tiling/one_to_many.hpp, matching/rotation_hypotheses.hpp, robust/), so users can recompose it.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/progress.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/helmert3_estimator.hpp>
#include <diachron/geometry/similarity2.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/matching/rotation_hypotheses.hpp>
#include <diachron/matching/scale_hypotheses.hpp>
#include <diachron/robust/chance_inliers.hpp>
#include <diachron/robust/robust_estimation.hpp>
#include <diachron/terrain/crs_kind.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/dsm_correlation_search.hpp>
#include <diachron/terrain/dsm_image.hpp>
#include <diachron/terrain/relief_image.hpp>
#include <diachron/terrain/surface_agreement.hpp>
#include <diachron/terrain/surface_alignment.hpp>
#include <diachron/tiling/feature_cache_matcher.hpp>
#include <diachron/tiling/grid_tiler.hpp>
#include <diachron/tiling/one_to_many.hpp>
#include <diachron/tiling/pair_matcher.hpp>

namespace diachron {

/// Which 8-bit image the DSMs are turned into before matching.
enum class DsmImageKind {
  kStretch,           ///< mean +- k sigma linear stretch only
  kStretchWallis,     ///< the stretch, then the Wallis local-contrast filter (the paper; MicMac)
  kHillshade,         ///< a hillshade lit from `hillshade.azimuth_deg` (turns with the frame)
  kMultiHillshade,    ///< the mean of 8 hillshades lit from all around (terrain/relief_image.hpp)
  kSlope,             ///< slope magnitude (terrain/relief_image.hpp)
  kLocalRelief,       ///< z-score of the height in a box, on float heights (terrain/relief_image.hpp)
};

/// A short name for tables and command lines: stretch, wallis, hillshade, multihillshade, slope, relief.
inline const char* to_string(DsmImageKind kind) {
  switch (kind) {
    case DsmImageKind::kStretch: return "stretch";
    case DsmImageKind::kStretchWallis: return "wallis";
    case DsmImageKind::kHillshade: return "hillshade";
    case DsmImageKind::kMultiHillshade: return "multihillshade";
    case DsmImageKind::kSlope: return "slope";
    case DsmImageKind::kLocalRelief: return "relief";
  }
  return "?";
}

/// Options of rough_coregistration(). Defaults: the paper's, except where a measurement in
/// docs/rough-coregistration.md chose otherwise (each field says which).
struct RoughCoregistrationOptions {
  /// DSM image variant. Slope by measurement (docs/rough-coregistration.md): on real DEMs moved into
  /// arbitrary frames it succeeded where the paper's stretch (k = 2) and MicMac's stretch + Wallis
  /// mostly failed; kStretchWallis reproduces the paper.
  DsmImageKind image_kind = DsmImageKind::kSlope;
  /// The stretch: k = 2 in the paper ("values beyond 2 sigma are ignored"), 5 in MicMac today.
  DsmImageOptions dsm_image{};
  WallisOptions wallis{};
  HillshadeOptions hillshade{};
  SlopeImageOptions slope{};
  LocalReliefOptions relief{};

  /// Matches whose point lies closer than this to a DSM hole (in DSM pixels) are dropped before
  /// RANSAC: the edge between data and fill is the strongest structure in a DSM image with holes,
  /// and it is not terrain. 0 keeps them all.
  double min_hole_distance_px = 6.0;
  /// Give a masked matcher (tiling/pair_matcher.hpp) each image's validity mask: pixels whose DSM
  /// cell is valid and at least `min_hole_distance_px` from a hole, inside the DSM, and nonzero in
  /// GeoImage::mask. A slope image writes holes as 0, like flat ground: without the mask a detector
  /// puts its strongest features on hole rims. Matchers without the masked overload are unaffected.
  bool pass_masks = true;

  /// One-to-many tiling (every master tile with every secondary tile). Off matches whole images.
  bool use_tiling = true;
  /// Tile size in DSM-image pixels, no buffer: 1920 x 1440 as MicMac today (the paper's era used
  /// 640 x 480). Measured with SIFT on DSM images up to ~1300 px, smaller tiles found the same
  /// answers at 2 to 6 times the cost; tiles keep large DSMs (and learned matchers with a fixed
  /// input size) tractable.
  GridTilerOptions master_tiles{1920, 1440, 0, 0};
  GridTilerOptions secondary_tiles{1920, 1440, 0, 0};

  /// Try the four quarter-turns of the secondary image (paper: matchers are not invariant to
  /// rotations beyond 45 degrees). Off tries 0 degrees only.
  bool rotation_hypotheses = true;
  /// Skip the hypotheses when the matcher says it is rotation invariant (`rotation_invariant()`
  /// returning true, as SIFT and oriented AKAZE do): measured, they found the same answer at four
  /// times the cost (docs/rough-coregistration.md). Matchers that do not say are treated as variant.
  bool skip_rotations_if_invariant = true;

  /// Scale hypotheses (rough_coregistration() only, not the image mode): when the DSMs as given
  /// give no significant result, the DSM with more valid cells, then the other, is coarsened 2, 4
  /// and 8 times (block means) and matched again; the first significant hypothesis wins. For
  /// resolution gaps (a 10 m historical DSM against a 2 m modern one): measured in
  /// docs/rough-coregistration.md, a 4 to 8 times gap failed without them. DSMs without a gap
  /// succeed at the first hypothesis and cost nothing more; failures cost every hypothesis (each
  /// level about a quarter of the one before, the unchanged DSM's features extracted once). DSM
  /// images under 160 px on their shorter side are enlarged before matching (upsample_below_px).
  ScaleHypothesesOptions scale_hypotheses{};

  /// Fallback when no feature hypothesis succeeds (rough_coregistration() only): search the master
  /// DSM in the secondary by the correlation of their heights' gradients over rotations and scales
  /// (terrain/dsm_correlation_search.hpp), then 3D correspondences on a grid of master cells and the
  /// same 3D Helmert RANSAC guard. Not run when a feature result was refused by max_rms_3d_cells
  /// (the caller asked for agreement in 3D, which the fallback cannot show). On by default
  /// (docs/rough-coregistration.md, "The fallback on by default"): it answered 10 more of 100
  /// resolution-gap cases (80 instead of 70) and 12 more of 40 small synthetic epoch pairs (33
  /// instead of 21), none wrong, and none of 190 DSM pairs that do not overlap; it does not find the
  /// real 10 m / 2 m Mount St. Helens pair (the dome changed as much as the relief there). A failure
  /// then costs a median of 5 s more (1 to 28 s measured, one thread). Its successes are graded
  /// RoughCoregistrationTrust::kLow. Turn it off when failures must be fast.
  bool correlation_fallback = true;
  DsmCorrelationSearchOptions correlation_search{};
  /// The fallback's Helmert must explain at least this fraction of its grid correspondences within
  /// the 3D guard's threshold: a wrong placement leaves most heights disagreeing.
  double correlation_min_inlier_fraction = 0.5;

  /// When the fallback's search refuses its winner (score, margin, gain or tiles), the winner is
  /// still the answer when the two surfaces confirm it: its grid correspondences pass the 3D guard,
  /// the surface refinement (`surface_alignment`) accepts it, and after that the surfaces agree
  /// within `surface_confirmation_max_noise_ratio` times the DSMs' own cell-scale noise
  /// (terrain/surface_agreement.hpp). The search's tests judge a correlation of gradients on
  /// working rasters, which noise on a coarse DSM drags down at right placements; the surfaces
  /// judge the heights themselves. Measured (docs/rough-coregistration.md, "Confirmation by the
  /// surfaces"): 18 right placements 0.80 to 2.57 times the noise; the 49 wrong ones whose
  /// refinement was accepted, on 285 DSM pairs that do not overlap, 3.17 times and more. The one at
  /// 3.17 rested on 118 cells of the coarser DSM, every right one on 2695 or more, hence also
  /// `min_cells`: a misfit from a few hundred heights, after fitting 7 parameters, does not tell
  /// ground apart. It answered 12 more of 200 resolution-gap cases, 2 more of 100 no-gap cases at
  /// 10-30 % overlap and 4 more of 40 synthetic epoch pairs, none wrong. Answers confirmed so are
  /// graded RoughCoregistrationTrust::kLow, as every fallback answer.
  bool surface_confirmation = true;
  double surface_confirmation_max_noise_ratio = 3.0;
  double surface_confirmation_min_cells = 500.0;
  /// The confirmation's refinement starts from the search's winner, which may be several coarse
  /// cells off at the master's centre and more at its edges (the search's rotation and scale steps),
  /// so it may move the master by up to 30 coarse cells in up to 100 iterations: the agreement after
  /// it decides, not the move. With `surface_alignment`'s 10 cells and 50 iterations, 4 right
  /// winners of 100 gap cases (SRTM 8 times coarser) were refused on the way to the right answer.
  SurfaceAlignmentOptions surface_confirmation_alignment = [] {
    SurfaceAlignmentOptions o;
    o.max_move_cells = 30.0;
    o.max_iterations = 100;
    return o;
  }();
  SurfaceAgreementOptions surface_agreement{};

  /// After a success (rough_coregistration() only), refine the Helmert by robust least-squares
  /// matching of the two surfaces (terrain/surface_alignment.hpp): the 3D guard's 10-cell threshold
  /// lets ground that changed between the epochs pull the fit, and the biweight leaves it out. A
  /// refinement that is refused (flat ground, no convergence, a cost that does not fall, a move
  /// beyond `surface_alignment.max_move_cells`) leaves the result as it was; the report says why.
  bool refine_surface = true;
  SurfaceAlignmentOptions surface_alignment{};

  /// 2D similarity RANSAC on DSM-image pixels: 10 px and 1000 iterations as the paper and MicMac.
  /// The seed is also the pipeline's seed.
  RansacOptions ransac_2d = [] {
    RansacOptions o;
    o.threshold = 10.0;
    o.max_iterations = 1000;
    return o;
  }();

  /// 3D guard: Helmert RANSAC threshold in secondary DSM cells (the 2D threshold, lifted). The
  /// paper's 3D filter of precise matching uses 10 x GSD; here the DSM cell plays the GSD's part.
  double ransac_3d_threshold_cells = 10.0;

  /// Significance of the 2D result: the winner must have more inliers than random matches reach
  /// with probability `alpha` over all hypotheses scored (robust/chance_inliers.hpp), and at least
  /// `min_inliers_2d`. This is what makes "no overlap" a failure instead of a wrong Helmert.
  double alpha = 1e-3;
  std::size_t min_inliers_2d = 8;
  /// Fewest 3D inliers (lifted 2D inliers that agree with the Helmert) for success.
  std::size_t min_inliers_3d = 6;

  /// Trust of a success (RoughCoregistrationReport::trust): `kHigh` needs the RMS 3D residual of
  /// the 3D inliers at or below this many secondary DSM cells and at least `trusted_min_inliers_3d`
  /// 3D inliers; other successes are `kLow`. The significance test only says the 2D inliers are
  /// not chance; this says whether they agree in 3D as closely as correct matches do. Defaults by
  /// measurement (docs/rough-coregistration.md, "How far a success can be trusted"): every wrong
  /// success of the stretch and Wallis images was graded low, no default-configuration success was.
  double trusted_rms_3d_cells = 2.0;
  std::size_t trusted_min_inliers_3d = 12;
  /// A success whose RMS 3D residual exceeds this many secondary cells becomes a failure; the
  /// rejected Helmert stays in the report for inspection. Infinity (default) keeps them all, graded
  /// `kLow`; 2.5 would have rejected every wrong success measured and 9 of the 25 right successes of
  /// the stretch and Wallis images (those 1.2 to 1.9 cells off).
  double max_rms_3d_cells = std::numeric_limits<double>::infinity();

  /// Worker threads over tile pairs and the correlation fallback's hypotheses (0 = all cores; it
  /// replaces `correlation_search.threads`). Results do not depend on it.
  std::size_t threads = 0;
  /// Progress over tile pairs, per rotation hypothesis, and over the correlation fallback's stages
  /// (it replaces `correlation_search.progress`). May be empty.
  ProgressCallback progress;

  void check() const {
    dsm_image.check();
    ransac_2d.check();
    scale_hypotheses.check();
    correlation_search.check();
    surface_alignment.check();
    surface_agreement.check();
    surface_confirmation_alignment.check();
    DIACHRON_CHECK(surface_confirmation_max_noise_ratio > 0.0 && !std::isnan(surface_confirmation_max_noise_ratio),
                   "surface_confirmation_max_noise_ratio must be positive, got " << surface_confirmation_max_noise_ratio);
    DIACHRON_CHECK(surface_confirmation_min_cells >= 0.0 && std::isfinite(surface_confirmation_min_cells),
                   "surface_confirmation_min_cells must be >= 0, got " << surface_confirmation_min_cells);
    DIACHRON_CHECK(correlation_min_inlier_fraction > 0.0 && correlation_min_inlier_fraction <= 1.0,
                   "correlation_min_inlier_fraction must be in (0, 1], got " << correlation_min_inlier_fraction);
    DIACHRON_CHECK(ransac_3d_threshold_cells > 0.0 && std::isfinite(ransac_3d_threshold_cells),
                   "ransac_3d_threshold_cells must be positive, got " << ransac_3d_threshold_cells);
    DIACHRON_CHECK(alpha > 0.0 && alpha < 1.0, "alpha must be in (0, 1), got " << alpha);
    DIACHRON_CHECK(min_inliers_3d >= 3, "min_inliers_3d must be >= 3");
    DIACHRON_CHECK(trusted_rms_3d_cells > 0.0 && !std::isnan(trusted_rms_3d_cells),
                   "trusted_rms_3d_cells must be positive, got " << trusted_rms_3d_cells);
    DIACHRON_CHECK(max_rms_3d_cells > 0.0 && !std::isnan(max_rms_3d_cells),
                   "max_rms_3d_cells must be positive, got " << max_rms_3d_cells);
  }
};

/// An 8-bit image on a georeferenced grid and the DSM its pixels are lifted with. For the DSM mode
/// the image is the DSM image and `transform` the DSM's; for the orthophoto mode (paper 4.3) it is
/// an orthophoto with its own geotransform in the same frame as `dsm`.
struct GeoImage {
  Raster<std::uint8_t> image;
  GeoTransform transform;
  /// Optional, the image's size: nonzero where the image shows valid data (e.g. an orthophoto's
  /// footprint). Empty: every pixel; the pipeline also masks where the DSM has no valid height.
  Raster<std::uint8_t> mask{};
};

/// Wall-clock seconds per stage. With scale hypotheses, the stages are the chosen hypothesis',
/// `images` covers every DSM image made and `total` every hypothesis (see ScaleHypothesisResult).
struct RoughCoregistrationTimings {
  double images = 0.0;    ///< DSM images (stretch, Wallis or hillshade)
  double matching = 0.0;  ///< tiling + pair matcher, all hypotheses
  double ransac_2d = 0.0; ///< 2D similarity RANSAC, all hypotheses
  double lift = 0.0;      ///< 2D inliers to 3D through both DSMs
  double helmert = 0.0;   ///< least squares + 3D RANSAC guard
  double correlation = 0.0;  ///< the dense correlation fallback, when it ran (search + Helmert)
  double total = 0.0;
};

/// How far a rough co-registration result can be trusted.
enum class RoughCoregistrationTrust {
  kNone,  ///< no result (success == false)
  /// significant in 2D, but the 3D inliers are few or disagree by more than correct matches do; or
  /// an answer of the correlation fallback, whatever its residuals (see correlation_fallback)
  kLow,
  kHigh,  ///< feature path: enough 3D inliers agreeing within RoughCoregistrationOptions::trusted_rms_3d_cells
};

/// none, low, high.
inline const char* to_string(RoughCoregistrationTrust trust) {
  switch (trust) {
    case RoughCoregistrationTrust::kNone: return "none";
    case RoughCoregistrationTrust::kLow: return "low";
    case RoughCoregistrationTrust::kHigh: return "high";
  }
  return "?";
}

/// The outcome of one scale hypothesis of rough_coregistration().
struct ScaleHypothesisResult {
  ScaleHypothesis hypothesis;  ///< which DSM was coarsened, and how much
  int master_width = 0, master_height = 0;        ///< the master image matched, pixels
  int secondary_width = 0, secondary_height = 0;  ///< the secondary image matched, pixels
  /// How many times each image was enlarged after coarsening (ScaleHypothesesOptions::
  /// upsample_below_px): image pixels per coarsened DSM cell along each axis, 1 when not enlarged.
  int master_upsample = 1, secondary_upsample = 1;
  bool success = false;        ///< this hypothesis alone gave a co-registration
  std::size_t matches = 0;     ///< tentative matches of its best rotation
  std::size_t inliers = 0;     ///< 2D inliers of its best rotation
  std::size_t required_inliers = 0;  ///< its significance bound (0 when no rotation gave a model)
  double seconds = 0.0;        ///< wall-clock time of the hypothesis (images, matching, RANSAC, Helmert)
  std::string message;         ///< the pipeline's message for this hypothesis
};

/// What rough_coregistration() found. Defaults mean failure.
struct RoughCoregistrationReport {
  bool success = false;
  /// How far a success can be trusted (see RoughCoregistrationTrust and the options' trusted_*).
  RoughCoregistrationTrust trust = RoughCoregistrationTrust::kNone;
  std::string message = "not run";  ///< why it failed, or a one-line summary on success

  /// The result: X2 = scale R X1 + T maps epoch 1 (master) into epoch 2 (secondary, reference).
  Helmert3 epoch2_from_epoch1 = Helmert3::identity();
  /// secondary image px = image_similarity(master image px), from the winning hypothesis.
  Similarity2 image_similarity{};

  /// Per hypothesis (rotation of the secondary image, clockwise degrees): matches and 2D inliers.
  std::vector<RotationHypothesisResult> hypotheses;
  int best_rotation_deg = -1;  ///< winning quarter-turn, -1 when none won

  /// Per scale hypothesis tried, in order (rough_coregistration() only; empty in the image mode).
  /// The fields above and below describe the chosen hypothesis, whose images may be coarsened:
  /// image pixels (image_similarity, tentative_2d, inliers_2d) are pixels of those images.
  std::vector<ScaleHypothesisResult> scale_hypotheses;
  int best_scale_hypothesis = -1;  ///< index into scale_hypotheses of the chosen one, -1 when none
  /// The chosen master image's pixel / the master DSM's cell, along each axis: the coarsening
  /// factor over the enlargement (ScaleHypothesesOptions::upsample_below_px), e.g. 4 for a DSM
  /// coarsened 4 times, 0.5 for one enlarged twice. Image pixel p is DSM pixel
  /// factor (p + 0.5) - 0.5 (pixel centres, both grids on the same corner).
  double master_image_factor = 1.0;
  double secondary_image_factor = 1.0;  ///< the same for the secondary

  std::size_t tile_pairs = 0;          ///< tile pairs matched per hypothesis
  std::size_t matches_2d = 0;          ///< tentative matches of the winner
  std::size_t required_inliers_2d = 0; ///< significance bound the winner had to reach
  PointMatches tentative_2d;           ///< the winner's tentative matches (master px, unrotated secondary px)
  std::vector<std::size_t> inlier_indices_2d;  ///< indices into `tentative_2d` of the 2D inliers
  PointMatches inliers_2d;             ///< the winner's 2D inliers (master image px, secondary image px)
  std::vector<PointPair3> lifted;      ///< inliers lifted to 3D (both DSM heights valid)
  std::vector<std::size_t> inliers_3d; ///< indices into `lifted` that agree with the Helmert
  double rms_3d = 0.0;                 ///< RMS 3D residual of those, secondary units
  double rms_3d_cells = 0.0;           ///< rms_3d in secondary DSM cells (min_cell_size)

  /// The dense correlation fallback (RoughCoregistrationOptions::correlation_fallback): whether it
  /// ran (every feature hypothesis failed), whether its answer is the result, and what it found.
  bool correlation_ran = false;
  bool correlation_used = false;
  DsmCorrelationResult correlation;  ///< its search result (score, runner-up, similarity, times)

  /// The fallback's winner was refused by its search and confirmed by the surfaces
  /// (RoughCoregistrationOptions::surface_confirmation); then `correlation_used` too.
  bool confirmed_by_surface = false;

  /// The surface refinement (RoughCoregistrationOptions::refine_surface): run after a success;
  /// when `surface.accepted`, `epoch2_from_epoch1` is its Helmert. Also what the confirmation
  /// refined, when it ran, whether it confirmed or not.
  SurfaceAlignmentResult surface;
  /// How closely the surfaces agree under the result, against the DSMs' own noise
  /// (terrain/surface_agreement.hpp): measured after every success, and by the confirmation once
  /// its refinement was accepted (then also on refusal).
  SurfaceAgreement agreement;
  RoughCoregistrationTimings seconds;
};

/// The 8-bit image of a DSM as `options.image_kind` says.
inline Raster<std::uint8_t> make_dsm_image(const Dsm& dsm, const RoughCoregistrationOptions& options) {
  switch (options.image_kind) {
    case DsmImageKind::kHillshade: return hillshade(dsm, options.hillshade);
    case DsmImageKind::kMultiHillshade: return multidirectional_hillshade(dsm, 8, options.hillshade);
    case DsmImageKind::kSlope: return slope_image(dsm, options.slope);
    case DsmImageKind::kLocalRelief: return local_relief_image(dsm, options.relief);
    default: break;
  }
  DsmImage stretched = dsm_to_image(dsm, options.dsm_image);
  if (options.image_kind == DsmImageKind::kStretch) return std::move(stretched.image);
  return wallis_filter(stretched.image, options.wallis, options.dsm_image.make_mask ? &stretched.mask : nullptr);
}

/// Rough co-registration from two georeferenced 8-bit images and the DSMs that lift their pixels to
/// 3D (the orthophoto mode, and the core of the DSM mode). Master = epoch 1 (moved), secondary =
/// epoch 2 (reference). Throws diachron::Error for empty inputs or invalid options; "no
/// co-registration found" is `success == false` with the reason.
template <class Matcher>
RoughCoregistrationReport rough_coregistration_images(const GeoImage& master, const Dsm& master_dsm,
                                                      const GeoImage& secondary, const Dsm& secondary_dsm,
                                                      const Matcher& matcher,
                                                      const RoughCoregistrationOptions& options = {});

/// Rough co-registration of two DSMs (paper 3.2.1): the DSM images are made with
/// make_dsm_image(), then rough_coregistration_images() runs on them; with scale hypotheses
/// (options.scale_hypotheses) again on coarsened DSMs until one is significant. Matches are lifted
/// through the DSMs as given, whatever the hypothesis.
template <class Matcher>
RoughCoregistrationReport rough_coregistration(const Dsm& master, const Dsm& secondary, const Matcher& matcher,
                                               const RoughCoregistrationOptions& options = {});

// Implementation --------------------------------------------------------------------------------

namespace detail {

inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Two decimals: messages quote residuals in cells, where more digits are noise.
inline std::string format_cells(double cells) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", cells);
  return text;
}

/// The 3D point of image pixel `px`: its ground X/Y through the image's geotransform and the DSM
/// height there; NaN height when the DSM has none.
inline Eigen::Vector3d lift_pixel(const GeoImage& image, const Dsm& dsm, const Eigen::Vector2d& px) {
  const Eigen::Vector2d xy = image.transform.pixel_to_world(px);
  return {xy.x(), xy.y(), dsm.height_at(xy)};
}

/// Distance in pixels from each DSM pixel to the nearest hole (chamfer 3-4 approximation of the
/// Euclidean distance, two passes); +inf everywhere when the DSM has no hole. Borders are not holes.
inline Raster<float> distance_to_holes(const Dsm& dsm) {
  const int w = dsm.width(), h = dsm.height();
  const float inf = std::numeric_limits<float>::infinity();
  Raster<float> d(w, h, inf);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (!dsm.valid(x, y)) d(x, y) = 0.0f;
  auto relax = [&](int x, int y, int dx, int dy, float cost) {
    const int u = x + dx, v = y + dy;
    if (u >= 0 && v >= 0 && u < w && v < h) d(x, y) = std::min(d(x, y), d(u, v) + cost);
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      relax(x, y, -1, 0, 1.0f);
      relax(x, y, 0, -1, 1.0f);
      relax(x, y, -1, -1, 4.0f / 3.0f);
      relax(x, y, 1, -1, 4.0f / 3.0f);
    }
  for (int y = h - 1; y >= 0; --y)
    for (int x = w - 1; x >= 0; --x) {
      relax(x, y, 1, 0, 1.0f);
      relax(x, y, 0, 1, 1.0f);
      relax(x, y, 1, 1, 4.0f / 3.0f);
      relax(x, y, -1, 1, 4.0f / 3.0f);
    }
  return d;
}

/// The mask a masked matcher gets for `image`: 255 where the pixel's DSM cell exists, is valid and
/// lies at least `min_distance` DSM pixels from a hole (the hole-border margin), and the image's own
/// mask (if any) is nonzero; 0 elsewhere.
inline Raster<std::uint8_t> matching_mask(const GeoImage& image, const Dsm& dsm, const Raster<float>& distance,
                                          double min_distance) {
  const int w = image.image.width(), h = image.image.height();
  const bool own = !image.mask.empty();
  DIACHRON_CHECK(!own || (image.mask.width() == w && image.mask.height() == h),
                 "GeoImage::mask is " << image.mask.width() << " x " << image.mask.height() << ", its image " << w
                                      << " x " << h);
  const double needed = std::max(min_distance, 1.0);  // distance 0 is the hole itself
  Raster<std::uint8_t> mask(w, h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (own && image.mask(x, y) == 0) continue;
      const Eigen::Vector2d p = dsm.world_to_pixel(image.transform.pixel_to_world(Eigen::Vector2d(x, y)));
      const long u = std::lround(p.x()), v = std::lround(p.y());
      if (u < 0 || v < 0 || u >= distance.width() || v >= distance.height()) continue;
      if (distance(static_cast<int>(u), static_cast<int>(v)) >= needed) mask(x, y) = 255;
    }
  return mask;
}

// How the pipeline calls matcher M: through the feature cache (`cache`) or directly, and whether
// with masks (`masks`). The cache is used for FeaturePairMatchers, except when only the matcher,
// not its extractor, takes masks: the cache would drop them. A specialisation, so
// FeatureCacheMatcher<M> is only named for the matchers it accepts.
template <class M, bool = is_feature_pair_matcher_v<M>>
struct pipeline_matcher {
  static constexpr bool cache = false;
  static constexpr bool masks = is_masked_pair_matcher_v<M>;
};
template <class M>
struct pipeline_matcher<M, true> {
  static constexpr bool cache_masked = is_masked_pair_matcher_v<FeatureCacheMatcher<M>>;
  static constexpr bool cache = cache_masked || !is_masked_pair_matcher_v<M>;
  static constexpr bool masks = cache_masked || is_masked_pair_matcher_v<M>;
};

/// True when image pixel `px` lies at least `min_distance` DSM pixels away from any hole of `dsm`.
inline bool away_from_holes(const GeoImage& image, const Dsm& dsm, const Raster<float>& distance,
                            const Eigen::Vector2d& px, double min_distance) {
  const Eigen::Vector2d p = dsm.world_to_pixel(image.transform.pixel_to_world(px));
  const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
  if (!distance.contains(x, y)) return false;
  return distance(x, y) >= min_distance;
}

// A geographic DSM has degrees horizontally and metres vertically: no 3D similarity relates two of
// them, yet the fit would return numbers. Refused before any work, naming the remedy.
inline void require_metric_frame(const Dsm& dsm, const char* which) {
  DIACHRON_CHECK(crs_kind(dsm.crs()) != CrsKind::geographic,
                 "rough co-registration: the " << which
                     << " DSM is in a geographic CRS (degrees horizontally, heights in metres), and a 3D "
                        "similarity needs one unit on all three axes; reproject it to a projected CRS first "
                        "(reproject_dsm() of diachron/io/dsm_reproject.hpp, or gdalwarp -t_srs EPSG:326zz)");
}

/// rough_coregistration_images() with two more inputs, for the scale hypotheses: the DSMs whose
/// holes mask the images (`*_hole_dsm`: the coarsened DSM an image was made from, so the hole rims
/// are those the image shows) may differ from the DSMs that lift the matches (`*_dsm`: as given, the
/// most precise heights); and the significance test counts `searches` independent searches (the
/// planned scale hypotheses), so that trying more hypotheses does not make chance look significant.
template <class Matcher>
RoughCoregistrationReport rough_coregistration_images_impl(const GeoImage& master, const Dsm& master_dsm,
                                                           const Dsm& master_hole_dsm, const GeoImage& secondary,
                                                           const Dsm& secondary_dsm, const Dsm& secondary_hole_dsm,
                                                           const Matcher& matcher,
                                                           const RoughCoregistrationOptions& options,
                                                           double searches) {
  static_assert(check_pair_matcher<Matcher>());
  options.check();
  DIACHRON_CHECK(!master.image.empty() && !secondary.image.empty(), "rough co-registration needs two non-empty images");
  DIACHRON_CHECK(!master_dsm.empty() && !secondary_dsm.empty(), "rough co-registration needs two non-empty DSMs");
  DIACHRON_CHECK(searches >= 1.0, "searches must be >= 1, got " << searches);
  const auto start = std::chrono::steady_clock::now();
  RoughCoregistrationReport report;

  // Stage 1: tentative matches under each rotation hypothesis, and a 2D similarity RANSAC on each
  // (timed by match_with_rotation_hypotheses itself).
  const GridTilerOptions whole_m{master.image.width(), master.image.height(), 0, 0};
  const GridTilerOptions whole_s{std::max(secondary.image.width(), secondary.image.height()),
                                 std::max(secondary.image.width(), secondary.image.height()), 0, 0};
  const GridTiler master_tiler(options.use_tiling ? options.master_tiles : whole_m);
  const GridTiler secondary_tiler(options.use_tiling ? options.secondary_tiles : whole_s);
  // One extraction per distinct tile instead of one per tile pair (M + N instead of 2 M N), and the
  // master's tiles, which no hypothesis rotates, only once for all hypotheses.
  [[maybe_unused]] const auto cached_matcher = [&] {
    if constexpr (detail::pipeline_matcher<Matcher>::cache)
      return FeatureCacheMatcher<Matcher>(matcher);
    else
      return 0;
  }();
  const Raster<float> master_holes = detail::distance_to_holes(master_hole_dsm);
  const Raster<float> secondary_holes = detail::distance_to_holes(secondary_hole_dsm);
  // Masks only for matchers that take them (see detail::pipeline_matcher).
  const bool use_masks = detail::pipeline_matcher<Matcher>::masks && options.pass_masks;
  const Raster<std::uint8_t> master_mask =
      use_masks ? detail::matching_mask(master, master_hole_dsm, master_holes, options.min_hole_distance_px)
                : Raster<std::uint8_t>();
  const Raster<std::uint8_t> secondary_mask =
      use_masks ? detail::matching_mask(secondary, secondary_hole_dsm, secondary_holes, options.min_hole_distance_px)
                : Raster<std::uint8_t>();
  auto match_fn = [&](const Raster<std::uint8_t>& m, const Raster<std::uint8_t>& s, int rotation_deg) {
    OneToManyOptions one_to_many;
    one_to_many.threads = options.threads;
    one_to_many.progress = options.progress;
    one_to_many.progress_stage = "tile pairs (rotation " + std::to_string(rotation_deg) + ")";
    // The hypothesis turned the secondary image; its mask turns with it.
    const Raster<std::uint8_t> s_mask =
        use_masks ? rotate_quarter_turns(secondary_mask, rotation_deg / 90) : Raster<std::uint8_t>();
    OneToManyResult r;
    if constexpr (detail::pipeline_matcher<Matcher>::cache) {
      r = match_one_to_many(m, master_mask, s, s_mask, master_tiler, secondary_tiler, cached_matcher, one_to_many);
    } else {
      r = match_one_to_many(m, master_mask, s, s_mask, master_tiler, secondary_tiler, matcher, one_to_many);
    }
    report.tile_pairs = r.pair_count;
    if (options.min_hole_distance_px <= 0.0) return std::move(r.matches);
    // Points are checked in the unrotated secondary: undo this hypothesis' quarter-turn first.
    const int quarter_turns = rotation_deg / 90;
    PointMatches kept;
    kept.reserve(r.matches.size());
    for (const PointMatch& match : r.matches) {
      const Eigen::Vector2d b = unrotate_point_quarter_turns(match.b, quarter_turns, secondary.image.width(),
                                                             secondary.image.height());
      if (detail::away_from_holes(master, master_hole_dsm, master_holes, match.a, options.min_hole_distance_px) &&
          detail::away_from_holes(secondary, secondary_hole_dsm, secondary_holes, b, options.min_hole_distance_px))
        kept.push_back(match);
    }
    return kept;
  };
  RotationHypothesesOptions hypotheses_options;
  hypotheses_options.ransac = options.ransac_2d;
  if (!options.rotation_hypotheses || (options.skip_rotations_if_invariant && rotation_invariant(matcher)))
    hypotheses_options.rotations_deg = {0};
  RotationHypothesesReport hyp =
      match_with_rotation_hypotheses(master.image, secondary.image, match_fn, hypotheses_options);
  report.seconds.matching = hyp.seconds_matching;
  report.seconds.ransac_2d = hyp.seconds_ransac;
  report.hypotheses = hyp.hypotheses;

  if (!hyp.success) {
    report.message = "no 2D similarity found between the DSM images (the DSMs probably do not overlap, or "
                     "the matcher found too little): " + hyp.message;
    report.seconds.total = detail::seconds_since(start);
    return report;
  }
  report.best_rotation_deg = hyp.best_rotation_deg;
  report.image_similarity = hyp.similarity;
  report.matches_2d = hyp.best_matches;
  report.tentative_2d = hyp.matches;
  report.inlier_indices_2d = hyp.inliers;

  // Stage 2: is the winner more than what random matches reach? Each random match lands within
  // the threshold of a wrong prediction with probability pi t^2 / (secondary area).
  const double t = options.ransac_2d.threshold;
  const double area = static_cast<double>(secondary.image.width()) * secondary.image.height();
  const double p_chance = std::min(1.0, kPi * t * t / std::max(area, 1.0));
  std::size_t scored = 0;
  for (const auto& h : report.hypotheses) scored += std::max<std::size_t>(h.iterations, 1);
  report.required_inliers_2d =
      std::max(options.min_inliers_2d,
               min_significant_inliers(report.matches_2d, p_chance,
                                       searches * static_cast<double>(std::max<std::size_t>(scored, 1)), options.alpha, 2));
  report.inliers_2d = hyp.inlier_matches;
  if (report.inliers_2d.size() < report.required_inliers_2d) {
    report.message = "the best rotation hypothesis has " + std::to_string(report.inliers_2d.size()) +
                     " inliers among " + std::to_string(report.matches_2d) + " matches, fewer than the " +
                     std::to_string(report.required_inliers_2d) +
                     " random matches would give (the DSMs probably do not overlap)";
    report.seconds.total = detail::seconds_since(start);
    return report;
  }

  // Stage 3: lift the 2D inliers to 3D through both DSMs.
  auto t0 = std::chrono::steady_clock::now();
  for (const PointMatch& m : report.inliers_2d) {
    const Eigen::Vector3d x1 = detail::lift_pixel(master, master_dsm, m.a);
    const Eigen::Vector3d x2 = detail::lift_pixel(secondary, secondary_dsm, m.b);
    if (std::isfinite(x1.z()) && std::isfinite(x2.z())) report.lifted.push_back(PointPair3{x1, x2});
  }
  report.seconds.lift = detail::seconds_since(t0);
  if (report.lifted.size() < options.min_inliers_3d) {
    report.message = "only " + std::to_string(report.lifted.size()) + " of " +
                     std::to_string(report.inliers_2d.size()) + " 2D inliers have heights in both DSMs";
    report.seconds.total = detail::seconds_since(start);
    return report;
  }

  // Stage 4: the Helmert. Least squares on every lifted inlier first (what GCPBascule does), then a
  // 3D RANSAC guard against points whose heights disagree (real change, DSM blunders), and a final
  // least-squares fit on the guard's inliers.
  t0 = std::chrono::steady_clock::now();
  const Helmert3Estimator estimator;
  const std::optional<Helmert3> all_fit =
      estimator.refine(Helmert3::identity(), Subset<PointPair3>(report.lifted.data(), report.lifted.size()), nullptr);
  RansacOptions ransac_3d = options.ransac_2d;
  ransac_3d.threshold = options.ransac_3d_threshold_cells * secondary_dsm.min_cell_size();
  ransac_3d.min_inliers = options.min_inliers_3d;
  const RansacReport<Helmert3> guard = ransac_helmert3(report.lifted, ransac_3d);
  report.seconds.helmert = detail::seconds_since(t0);
  if (!guard.success) {
    report.message = "the lifted 2D inliers do not agree on a 3D Helmert: " + guard.message;
    report.seconds.total = detail::seconds_since(start);
    return report;
  }
  // Keep the all-point fit when it explains at least as many points: then the guard found nothing.
  Helmert3 best = guard.model;
  std::vector<std::size_t> inliers = guard.inliers;
  if (all_fit) {
    std::vector<std::size_t> all_inliers;
    for (std::size_t i = 0; i < report.lifted.size(); ++i)
      if (estimator.residual(*all_fit, report.lifted[i]) <= ransac_3d.threshold) all_inliers.push_back(i);
    if (all_inliers.size() > inliers.size()) {
      best = *all_fit;
      inliers = std::move(all_inliers);
    }
  }
  double sum2 = 0.0;
  for (std::size_t i : inliers) {
    const double r = estimator.residual(best, report.lifted[i]);
    sum2 += r * r;
  }
  report.epoch2_from_epoch1 = best;
  report.inliers_3d = std::move(inliers);
  report.rms_3d = std::sqrt(sum2 / static_cast<double>(report.inliers_3d.size()));
  report.rms_3d_cells = report.rms_3d / secondary_dsm.min_cell_size();
  const std::string summary = "rotation " + std::to_string(report.best_rotation_deg) + " deg: " +
                              std::to_string(report.inliers_2d.size()) + " of " +
                              std::to_string(report.matches_2d) + " matches are 2D inliers, " +
                              std::to_string(report.inliers_3d.size()) + " of " +
                              std::to_string(report.lifted.size()) + " agree in 3D, RMS " +
                              detail::format_cells(report.rms_3d_cells) + " cells";
  if (report.rms_3d_cells > options.max_rms_3d_cells) {
    report.message = summary + ": more than max_rms_3d_cells (" + detail::format_cells(options.max_rms_3d_cells) +
                     "), so the matches do not agree in 3D as correct matches do";
    report.seconds.total = detail::seconds_since(start);
    return report;
  }
  report.success = true;
  const bool high = report.rms_3d_cells <= options.trusted_rms_3d_cells &&
                    report.inliers_3d.size() >= options.trusted_min_inliers_3d;
  report.trust = high ? RoughCoregistrationTrust::kHigh : RoughCoregistrationTrust::kLow;
  report.message = summary + ", trust " + to_string(report.trust);
  report.seconds.total = detail::seconds_since(start);
  return report;
}

// The dense correlation fallback: runs the search; on an answer, grid correspondences, the 3D
// Helmert RANSAC guard (as the feature path), and the inlier-fraction check. On a winner the search
// refused, the confirmation by the surfaces instead of the fraction (see
// RoughCoregistrationOptions::surface_confirmation). Writes `report` only when the fallback
// succeeds (the feature path's failure message is kept otherwise, with the fallback's reason
// appended).
inline void correlation_fallback(const Dsm& master, const Dsm& secondary, const RoughCoregistrationOptions& options,
                                 RoughCoregistrationReport& report) {
  const auto t0 = std::chrono::steady_clock::now();
  report.correlation_ran = true;
  DsmCorrelationSearchOptions search = options.correlation_search;
  search.threads = options.threads;
  search.progress = options.progress;
  report.correlation = dsm_correlation_search(master, secondary, search);
  const auto fail = [&](const std::string& why) {
    report.message += "; correlation fallback: " + why;
    report.seconds.correlation = seconds_since(t0);
  };
  const DsmCorrelationResult& found = report.correlation;
  // A refused search still names a winner when some hypothesis had an overlap to score.
  const bool winner = std::isfinite(found.score) && std::isfinite(found.scale) && found.scale > 0.0 &&
                      found.translation.allFinite();
  const bool confirm = !found.success && options.surface_confirmation && winner;
  if (!found.success && !confirm) return fail(found.message);
  // On the confirmation's path every reason is the search's refusal and why the surfaces did not lift it.
  const std::string why = confirm ? found.message + "; the winner is not confirmed by the surfaces: " : std::string();
  std::vector<PointPair3> lifted = dsm_correlation_correspondences(master, secondary, found);
  if (lifted.size() < options.min_inliers_3d) return fail(why + "too few correspondences with heights on both sides");
  RansacOptions ransac_3d = options.ransac_2d;
  ransac_3d.threshold = options.ransac_3d_threshold_cells * secondary.min_cell_size();
  ransac_3d.min_inliers = options.min_inliers_3d;
  const RansacReport<Helmert3> guard = ransac_helmert3(lifted, ransac_3d);
  if (!guard.success) return fail(why + "the correspondences do not agree on a 3D Helmert: " + guard.message);
  std::string confirmation;
  if (confirm) {
    // Both kept in the report whatever the outcome: they say why a winner was refused.
    report.surface = refine_surface_alignment(master, secondary, guard.model, options.surface_confirmation_alignment);
    const SurfaceAlignmentResult& refined = report.surface;
    if (!refined.accepted) return fail(why + refined.message);
    report.agreement = surface_agreement(master, secondary, refined.epoch2_from_epoch1, options.surface_agreement);
    const SurfaceAgreement& agreement = report.agreement;
    if (!agreement.valid) return fail(why + "too few cells to compare the surfaces");
    std::ostringstream note;
    note.precision(3);
    note << "misfit " << agreement.misfit << " = " << agreement.noise_ratio << " x the DSMs' noise ("
         << agreement.master_noise << ", " << agreement.secondary_noise << ") over "
         << std::lround(agreement.overlap_cells) << " cells of the coarser DSM";
    if (!(agreement.noise_ratio <= options.surface_confirmation_max_noise_ratio))
      return fail(why + note.str() + ", a ratio above " + std::to_string(options.surface_confirmation_max_noise_ratio));
    if (agreement.overlap_cells < options.surface_confirmation_min_cells)
      return fail(why + note.str() + ", fewer cells than " +
                  std::to_string(std::lround(options.surface_confirmation_min_cells)));
    report.confirmed_by_surface = true;
    confirmation = "; confirmed by the surfaces: refined (" + refined.message + "), " + note.str();
  } else {
    const double fraction = static_cast<double>(guard.inliers.size()) / static_cast<double>(lifted.size());
    if (fraction < options.correlation_min_inlier_fraction)
      return fail("only " + std::to_string(guard.inliers.size()) + " of " + std::to_string(lifted.size()) +
                  " correspondences agree in 3D");
  }
  const Helmert3Estimator estimator;
  double sum2 = 0.0;
  for (std::size_t i : guard.inliers) {
    const double r = estimator.residual(guard.model, lifted[i]);
    sum2 += r * r;
  }
  report.success = true;
  report.correlation_used = true;
  report.epoch2_from_epoch1 = confirm ? report.surface.epoch2_from_epoch1 : guard.model;
  report.lifted = std::move(lifted);
  report.inliers_3d = guard.inliers;
  report.rms_3d = std::sqrt(sum2 / static_cast<double>(guard.inliers.size()));
  report.rms_3d_cells = report.rms_3d / secondary.min_cell_size();
  // Never high: the grid correspondences are placed by the search itself, so their 3D residuals say
  // how smooth the terrain is, not whether the placement is right. On DSM pairs that do not overlap,
  // the margin test with CorrelationStrength::share let 4 wrong placements through in 380 runs, every
  // one with all its grid points within 0.6 cells (docs/rough-coregistration.md, "Cases without an
  // answer").
  report.trust = RoughCoregistrationTrust::kLow;
  report.message = "correlation fallback: " + found.message + confirmation + "; " +
                   std::to_string(report.inliers_3d.size()) + " of " + std::to_string(report.lifted.size()) +
                   " grid correspondences agree in 3D, RMS " + format_cells(report.rms_3d_cells) + " cells, trust " +
                   to_string(report.trust);
  report.seconds.correlation = seconds_since(t0);
}

}  // namespace detail

template <class Matcher>
RoughCoregistrationReport rough_coregistration_images(const GeoImage& master, const Dsm& master_dsm,
                                                      const GeoImage& secondary, const Dsm& secondary_dsm,
                                                      const Matcher& matcher,
                                                      const RoughCoregistrationOptions& options) {
  // Checked here and in rough_coregistration(), not in the impl that runs once per scale hypothesis.
  detail::require_metric_frame(master_dsm, "master");
  detail::require_metric_frame(secondary_dsm, "secondary");
  return detail::rough_coregistration_images_impl(master, master_dsm, master_dsm, secondary, secondary_dsm,
                                                  secondary_dsm, matcher, options, 1.0);
}

template <class Matcher>
RoughCoregistrationReport rough_coregistration(const Dsm& master, const Dsm& secondary, const Matcher& matcher,
                                               const RoughCoregistrationOptions& options) {
  options.check();
  DIACHRON_CHECK(!master.empty() && !secondary.empty(), "rough co-registration needs two non-empty DSMs");
  detail::require_metric_frame(master, "master");
  detail::require_metric_frame(secondary, "secondary");
  const auto start = std::chrono::steady_clock::now();
  if (master.statistics().count == 0 || secondary.statistics().count == 0) {
    RoughCoregistrationReport report;
    report.message = std::string(master.statistics().count == 0 ? "the master" : "the secondary") +
                     " DSM has no valid height";
    return report;
  }
  const std::vector<ScaleHypothesis> plan = plan_scale_hypotheses(
      master.width(), master.height(), master.statistics().count, secondary.width(), secondary.height(),
      secondary.statistics().count, options.scale_hypotheses);
  // One feature cache for every hypothesis: the DSM a hypothesis leaves unchanged gives the same
  // images, whose features are then extracted once (the cache is keyed on image content).
  auto run = [&](const auto& effective_matcher) {
    RoughCoregistrationReport best;
    best.message = "no scale hypothesis was tried";
    std::vector<ScaleHypothesisResult> results;
    double images_seconds = 0.0;
    std::size_t best_index = plan.size();
    // The coarsened DSMs and their images, per side and level, made once.
    std::vector<std::optional<std::pair<Dsm, GeoImage>>> master_levels(8), secondary_levels(8);
    auto level = [&](const Dsm& dsm, int k, std::vector<std::optional<std::pair<Dsm, GeoImage>>>& cache)
        -> const std::pair<Dsm, GeoImage>& {
      auto& slot = cache[static_cast<std::size_t>(k)];
      if (!slot) {
        Dsm coarse = coarsen_dsm(dsm, 1 << k);
        GeoImage image{make_dsm_image(coarse, options), coarse.transform()};
        const int up = upsample_factor(std::min(image.image.width(), image.image.height()),
                                       options.scale_hypotheses.upsample_below_px,
                                       options.scale_hypotheses.max_upsample);
        if (up > 1) {
          image.image = upsample_bilinear(image.image, up);
          image.transform = upsample_transform(image.transform, up);
        }
        slot.emplace(std::move(coarse), std::move(image));
      }
      return *slot;
    };
    for (std::size_t i = 0; i < plan.size(); ++i) {
      const ScaleHypothesis& h = plan[i];
      const auto t0 = std::chrono::steady_clock::now();
      const auto& m = level(master, h.master_level, master_levels);
      const auto& s = level(secondary, h.secondary_level, secondary_levels);
      const double image_seconds = detail::seconds_since(t0);
      images_seconds += image_seconds;
      RoughCoregistrationReport r = detail::rough_coregistration_images_impl(
          m.second, master, m.first, s.second, secondary, s.first, effective_matcher, options,
          static_cast<double>(plan.size()));
      ScaleHypothesisResult result;
      result.hypothesis = h;
      result.master_width = m.second.image.width();
      result.master_height = m.second.image.height();
      result.secondary_width = s.second.image.width();
      result.secondary_height = s.second.image.height();
      result.master_upsample = m.second.image.width() / m.first.width();
      result.secondary_upsample = s.second.image.width() / s.first.width();
      result.success = r.success;
      result.matches = r.matches_2d;
      result.inliers = r.inliers_2d.size();
      result.required_inliers = r.required_inliers_2d;
      result.seconds = detail::seconds_since(t0);
      result.message = r.message;
      results.push_back(result);
      r.master_image_factor = static_cast<double>(h.master_factor()) / result.master_upsample;
      r.secondary_image_factor = static_cast<double>(h.secondary_factor()) / result.secondary_upsample;
      // The winner: a success before any failure; among successes (or failures), the largest
      // margin over the significance bound, in inliers; ties go to the earlier hypothesis.
      const auto margin = [](const RoughCoregistrationReport& x) {
        return static_cast<double>(x.inliers_2d.size()) - static_cast<double>(x.required_inliers_2d);
      };
      const bool better = best_index == plan.size() || (r.success && !best.success) ||
                          (r.success == best.success && margin(r) > margin(best));
      if (better) {
        best = std::move(r);
        best_index = i;
      }
      if (best.success && options.scale_hypotheses.stop_at_first_success) break;
    }
    best.scale_hypotheses = std::move(results);
    best.best_scale_hypothesis = best.success ? static_cast<int>(best_index) : -1;
    if (!best.success) {
      best.master_image_factor = best.secondary_image_factor = 1.0;
      if (best.scale_hypotheses.size() > 1)
        best.message = "no scale hypothesis succeeded (" + std::to_string(best.scale_hypotheses.size()) +
                       " tried); the closest: " + best.message;
    }
    // Stage times are the chosen hypothesis'; `images` counts every DSM image made, and `total`
    // (set by the caller) every hypothesis tried.
    best.seconds.images = images_seconds;
    return best;
  };
  RoughCoregistrationReport report;
  if constexpr (detail::pipeline_matcher<Matcher>::cache) {
    const FeatureCacheMatcher<Matcher> cached(matcher);
    report = run(cached);
  } else {
    report = run(matcher);
  }
  const bool refused_in_3d = report.rms_3d_cells > options.max_rms_3d_cells;
  if (!report.success && options.correlation_fallback && !refused_in_3d)
    detail::correlation_fallback(master, secondary, options, report);
  // A confirmed fallback answer is refined already (the confirmation is that refinement).
  if (report.success && options.refine_surface && !report.confirmed_by_surface) {
    report.surface = refine_surface_alignment(master, secondary, report.epoch2_from_epoch1, options.surface_alignment);
    if (report.surface.accepted) {
      report.epoch2_from_epoch1 = report.surface.epoch2_from_epoch1;
      std::ostringstream note;
      note.precision(3);
      note << "; surfaces matched: moved " << report.surface.moved / secondary.min_cell_size() << " cells, robust sigma "
           << report.surface.sigma_before << " -> " << report.surface.sigma_after;
      report.message += note.str();
    }
  }
  if (report.success && !report.confirmed_by_surface)
    report.agreement = surface_agreement(master, secondary, report.epoch2_from_epoch1, options.surface_agreement);
  report.seconds.total = detail::seconds_since(start);
  return report;
}

}  // namespace diachron
