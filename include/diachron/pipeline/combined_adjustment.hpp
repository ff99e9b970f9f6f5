#pragma once
/// @file
/// combined_adjustment(): the paper's combined processing (section 3.3, Algorithm 1) as one
/// stage. Epoch 1 is moved into the epoch-2 frame by the rough Helmert, intra-epoch tie points and
/// inter-epoch matches become tracks, the tracks are triangulated, and one bundle adjustment
/// (epoch 2 fixed by default; epoch 1's poses, camera and affine free) co-registers and
/// self-calibrates epoch 1. Plain inputs in, adjusted copies and a report out.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/adjustment/bundle_adjustment.hpp>
#include <diachron/adjustment/bundle_options.hpp>
#include <diachron/adjustment/bundle_report.hpp>
#include <diachron/adjustment/reprojection_error.hpp>
#include <diachron/adjustment/tracks.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/matching/point_match.hpp>

namespace diachron {

/// One epoch as the combined adjustment takes it, in the epoch's own frame.
struct CombinedEpoch {
  /// The images, each with its own camera as the epoch's SfM estimated it.
  std::vector<Frame<FraserAffine>> frames;
  /// Intra-epoch tie points: per point, its observations (image index within this epoch, px).
  std::vector<std::vector<ImagePixel>> tie_points;
  /// Camera of each image, any non-negative label (images with one label share f, cx, cy, K1-K3,
  /// P1, P2, starting from the first such image's values, and must have one size). Empty: images
  /// whose size and those eight values are equal share a camera, so every image keeps the camera
  /// it was given (B1, B2 are per image unless AffineScope::per_camera). All one label: one camera
  /// for the epoch whatever the frames hold, e.g. a film block whose SfM gave each scan its own.
  std::vector<int> cameras = {};
};

/// The inter-epoch matches of one image pair: the shape of PrecisePairReport (master, secondary,
/// matches), so `{pair.master, pair.secondary, pair.matches}` carries precise matching over.
struct EpochPairMatches {
  std::size_t master = 0;     ///< image index in epoch 1
  std::size_t secondary = 0;  ///< image index in epoch 2
  PointMatches matches;       ///< a: master pixel, b: secondary pixel, px
  /// Empty, or one per match: the square root of the secondary pixel's information relative to
  /// the inter-epoch sigma (ImageMatch::weight_b), e.g. from a least-squares matcher's covariance.
  std::vector<Eigen::Matrix2d> weights = {};
};

/// The inter-epoch matches of any list of pair reports with members `master`, `secondary` and
/// `matches` (PointMatches), such as PreciseMatchingReport::pairs; pairs without matches are
/// skipped. Generic, so this header needs nothing of the matching stages.
template <class PairReports>
std::vector<EpochPairMatches> epoch_pair_matches(const PairReports& pairs) {
  std::vector<EpochPairMatches> out;
  for (const auto& pair : pairs)
    if (!pair.matches.empty()) out.push_back({pair.master, pair.secondary, pair.matches, {}});
  return out;
}

/// A ground control point for combined_adjustment: a point whose position in the reference frame
/// is known (surveyed, or read off a map or the reference epoch's orthophoto and DSM), and its
/// observations in the images of either epoch. It becomes a track of its own, weighted as the
/// tie points (BundleOptions::intra_epoch_sigma_px), whose point is held to `position` by a prior
/// of `sigma` per axis (BundleInput::control_points). With both epochs free
/// (`fix_reference_epoch` false) the control points are the datum; with the reference fixed they
/// add constraints on epoch 1. A point seen in 2 images or more starts triangulated, one seen in a
/// single image (e.g. matched to an orthophoto reference) starts at `position`; either is used.
struct CombinedControlPoint {
  /// Position in the epoch-2 frame (the reference's, which the adjustment works in), its units.
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  /// Standard deviation of the position per axis, epoch-2 units, > 0.
  double sigma = 1.0;
  /// Observations in epoch 1's images (index within epoch 1, px) and in epoch 2's.
  std::vector<ImagePixel> epoch1 = {};
  std::vector<ImagePixel> epoch2 = {};
};

/// What became of a control point in combined_adjustment. Default: not used.
struct ControlPointOutcome {
  /// Triangulated and kept to the end (not rejected).
  bool used = false;
  /// Its adjusted point and the point minus its given position, epoch-2 frame; NaN when not used.
  Eigen::Vector3d point = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d error = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Index of its track in CombinedAdjustmentResult::track_list.
  std::size_t track = 0;
};

/// Options of combined_adjustment.
struct CombinedAdjustmentOptions {
  /// The bundle adjustment. When `bundle.epochs` is empty the stage fills it: epoch 1 all free,
  /// epoch 2 fixed when `fix_reference_epoch` (else free too, and the gauge is fixed internally).
  /// Inter-epoch matches count as 6 px observations, intra-epoch tie points as 1 px: matches across
  /// decades err more (correlation matches: median 1.14 epoch-2 px), and systematically, and a
  /// heavy weight lets their errors bend epoch 1's camera. On 10 decades seeds, 6 px against 3 px
  /// gave a smaller worst distortion error on 8 (median 1.50 -> 1.24 px) and check points within
  /// 0.03 m (median 0.41 -> 0.42 m); with a reference that covers the film block, smaller on 7 of 10
  /// and larger on 2 (median 0.99 -> 0.79 px; docs/adjustment.md). Set 1 px for matches as precise
  /// as the tie points.
  BundleOptions bundle = [] {
    BundleOptions o;
    o.inter_epoch_sigma_px = 6.0;
    return o;
  }();
  /// Hold epoch 2's poses, camera and affine parts fixed (its orientation is the reference, as
  /// MicMac's FrozenPoses).
  bool fix_reference_epoch = true;
  /// Merging of tie points and matches into tracks.
  TrackOptions tracks;
};

/// Outcome of combined_adjustment. Default: failure.
struct CombinedAdjustmentResult {
  /// The adjustment's report (success, message, RMS per epoch and kind, intrinsics, ...).
  BundleReport report;
  /// What the track building merged and dropped.
  TrackReport tracks;
  /// Camera of each image as BundleReport::cameras numbers them (CameraReport::camera): epoch 1's
  /// images first, then epoch 2's; epoch 1's cameras come first, in order of their first image.
  std::vector<int> image_camera;
  /// Adjusted frames of epoch 1 and epoch 2 in the epoch-2 frame. When !report.success: epoch 1
  /// moved by the rough Helmert and epoch 2 as given.
  std::vector<Frame<FraserAffine>> epoch1;
  std::vector<Frame<FraserAffine>> epoch2;
  /// The tracks adjusted, over one image list: epoch 1's images first (0 .. n1 - 1), then epoch
  /// 2's (n1 + index in epoch 2); for residual pictures and for exports with points.
  std::vector<Track> track_list;
  /// Adjusted point of each track, epoch-2 frame; NaN for tracks not used (or on failure).
  std::vector<Eigen::Vector3d> points;
  /// Whether each track took part to the end (after rejection).
  std::vector<bool> track_used;
  /// One per control point given, in their order (their tracks come last in track_list).
  std::vector<ControlPointOutcome> control_points;
};

namespace detail {

// Dense camera numbers (0, 1, ... in order of first image) of one epoch's images, from its labels
// or, without labels, by equal size and f, cx, cy, K1-K3, P1, P2.
inline std::vector<int> combined_epoch_cameras(const CombinedEpoch& epoch, const char* which) {
  const std::size_t n = epoch.frames.size();
  DIACHRON_CHECK(epoch.cameras.empty() || epoch.cameras.size() == n,
                 "combined_adjustment: " << which << " has " << epoch.cameras.size() << " camera labels for " << n
                                         << " images");
  std::vector<int> out(n, 0);
  std::vector<std::size_t> first;  // first image of each camera
  for (std::size_t i = 0; i < n; ++i) {
    const Camera<FraserAffine>& camera = epoch.frames[i].camera();
    std::size_t k = 0;
    if (epoch.cameras.empty()) {
      while (k < first.size()) {
        const Camera<FraserAffine>& other = epoch.frames[first[k]].camera();
        if (camera.width() == other.width() && camera.height() == other.height() &&
            fraser_camera_block(camera) == fraser_camera_block(other))
          break;
        ++k;
      }
    } else {
      DIACHRON_CHECK(epoch.cameras[i] >= 0,
                     "combined_adjustment: " << which << " image " << i << " has camera label " << epoch.cameras[i]);
      while (k < first.size() && epoch.cameras[first[k]] != epoch.cameras[i]) ++k;
      if (k < first.size()) {
        const Camera<FraserAffine>& other = epoch.frames[first[k]].camera();
        DIACHRON_CHECK(camera.width() == other.width() && camera.height() == other.height(),
                       "combined_adjustment: " << which << " images " << first[k] << " and " << i
                                               << " share camera label " << epoch.cameras[i] << " but are "
                                               << other.width() << " x " << other.height() << " and "
                                               << camera.width() << " x " << camera.height() << " px");
      }
    }
    if (k == first.size()) first.push_back(i);
    out[i] = static_cast<int>(k);
  }
  return out;
}

}  // namespace detail

/// Runs the combined adjustment.
/// @param epoch1, epoch2 the epochs in their own frames.
/// @param matches inter-epoch matches per image pair (epoch-1 master, epoch-2 secondary).
/// @param epoch2_from_epoch1 the rough co-registration.
/// @param control_points ground control points, if any (CombinedControlPoint).
/// Data failures (e.g. no inter-epoch match: "too few inter-epoch tracks") give
/// report.success == false; malformed input (an image index out of range, non-finite pixels or
/// positions, a control point's sigma <= 0, bad options) throws diachron::Error.
inline CombinedAdjustmentResult combined_adjustment(const CombinedEpoch& epoch1, const CombinedEpoch& epoch2,
                                                    const std::vector<EpochPairMatches>& matches,
                                                    const Helmert3& epoch2_from_epoch1,
                                                    const CombinedAdjustmentOptions& options = {},
                                                    const std::vector<CombinedControlPoint>& control_points = {}) {
  const int n1 = static_cast<int>(epoch1.frames.size());
  const int n2 = static_cast<int>(epoch2.frames.size());
  CombinedAdjustmentResult result;

  // One image list: epoch 1 (moved into the epoch-2 frame) first, then epoch 2.
  BundleInput input;
  input.frames = transformed_frames(epoch1.frames, epoch2_from_epoch1);
  for (const auto& f : epoch2.frames) input.frames.push_back(f);
  input.image_epoch.assign(static_cast<std::size_t>(n1), 0);
  input.image_epoch.resize(static_cast<std::size_t>(n1 + n2), 1);
  // Cameras never span the epochs: epoch 1's are numbered first.
  input.image_camera = detail::combined_epoch_cameras(epoch1, "epoch 1");
  const int cameras1 =
      input.image_camera.empty() ? 0 : *std::max_element(input.image_camera.begin(), input.image_camera.end()) + 1;
  for (int c : detail::combined_epoch_cameras(epoch2, "epoch 2")) input.image_camera.push_back(cameras1 + c);
  result.image_camera = input.image_camera;
  result.epoch1.assign(input.frames.begin(), input.frames.begin() + n1);
  result.epoch2 = epoch2.frames;

  std::vector<std::vector<ImagePixel>> ties;
  const auto add_ties = [&](const CombinedEpoch& epoch, int offset, int count) {
    for (const auto& tie : epoch.tie_points) {
      ties.emplace_back();
      for (const ImagePixel& o : tie) {
        DIACHRON_CHECK(o.image >= 0 && o.image < count,
                       "combined_adjustment: tie-point image " << o.image << " outside [0, " << count << ")");
        ties.back().push_back({o.image + offset, o.pixel});
      }
    }
  };
  add_ties(epoch1, 0, n1);
  add_ties(epoch2, n1, n2);
  std::vector<ImageMatch> links;
  for (const EpochPairMatches& pair : matches) {
    DIACHRON_CHECK(pair.master < epoch1.frames.size() && pair.secondary < epoch2.frames.size(),
                   "combined_adjustment: pair (" << pair.master << ", " << pair.secondary << ") outside "
                                                 << n1 << " x " << n2 << " images");
    DIACHRON_CHECK(pair.weights.empty() || pair.weights.size() == pair.matches.size(),
                   "combined_adjustment: pair (" << pair.master << ", " << pair.secondary << ") has "
                                                 << pair.weights.size() << " weights for " << pair.matches.size()
                                                 << " matches");
    for (std::size_t k = 0; k < pair.matches.size(); ++k) {
      const PointMatch& m = pair.matches[k];
      links.push_back({{static_cast<int>(pair.master), m.a},
                       {n1 + static_cast<int>(pair.secondary), m.b},
                       pair.weights.empty() ? Eigen::Matrix2d::Identity() : pair.weights[k]});
    }
  }
  TrackSet tracks = build_tracks(ties, links, n1 + n2, options.tracks);
  result.tracks = tracks.report;
  input.tracks = std::move(tracks.tracks);
  // Each control point is a track of its own, outside the union-find: its observations are
  // measured by hand, not matched, and must not merge with a tie point through a shared pixel.
  for (std::size_t k = 0; k < control_points.size(); ++k) {
    const CombinedControlPoint& g = control_points[k];
    DIACHRON_CHECK(g.position.allFinite() && std::isfinite(g.sigma) && g.sigma > 0.0,
                   "combined_adjustment: control point " << k << " needs a finite position and sigma > 0, got sigma "
                                                         << g.sigma);
    Track track;
    const auto add = [&](const std::vector<ImagePixel>& observations, int offset, int count) {
      for (const ImagePixel& o : observations) {
        DIACHRON_CHECK(o.image >= 0 && o.image < count, "combined_adjustment: control point "
                                                            << k << " names image " << o.image << " outside [0, "
                                                            << count << ")");
        DIACHRON_CHECK(o.pixel.allFinite(), "combined_adjustment: control point " << k << " has a non-finite pixel");
        track.observations.push_back({o.image + offset, o.pixel, ObservationKind::intra_epoch});
      }
    };
    add(g.epoch1, 0, n1);
    add(g.epoch2, n1, n2);
    std::stable_sort(track.observations.begin(), track.observations.end(),
                     [](const TrackObservation& a, const TrackObservation& b) { return a.image < b.image; });
    for (std::size_t j = 1; j < track.observations.size(); ++j)
      DIACHRON_CHECK(track.observations[j].image != track.observations[j - 1].image,
                     "combined_adjustment: control point " << k << " is observed twice in one image");
    ControlPointOutcome outcome;
    outcome.track = input.tracks.size();
    result.control_points.push_back(outcome);
    input.control_points.push_back({input.tracks.size(), g.position, g.sigma});
    input.tracks.push_back(std::move(track));
  }
  result.track_list = input.tracks;

  BundleOptions bundle = options.bundle;
  if (bundle.epochs.empty())
    bundle.epochs = {EpochFreedom::all_free(),
                     options.fix_reference_epoch ? EpochFreedom::all_fixed() : EpochFreedom::all_free()};
  BundleResult adjusted = bundle_adjust(input, bundle);
  result.report = std::move(adjusted.report);
  if (!result.report.success) return result;
  result.epoch1.assign(adjusted.frames.begin(), adjusted.frames.begin() + n1);
  result.epoch2.assign(adjusted.frames.begin() + n1, adjusted.frames.end());
  result.points = std::move(adjusted.points);
  result.track_used = std::move(adjusted.track_used);
  for (std::size_t k = 0; k < control_points.size(); ++k) {
    ControlPointOutcome& outcome = result.control_points[k];
    outcome.used = result.track_used[outcome.track];
    if (!outcome.used) continue;
    outcome.point = result.points[outcome.track];
    outcome.error = outcome.point - control_points[k].position;
  }
  return result;
}

}  // namespace diachron
