#pragma once
/// @file
/// combined_epochs_adjustment(): the paper's combined processing (section 3.3, Algorithm 1) for
/// any number of epochs. Every epoch is moved into the reference epoch's frame by its rough
/// Helmert, each epoch's own tie points and the inter-epoch matches of every pair of epochs become
/// tracks (a track may span any number of epochs), and one bundle adjustment refines all
/// orientations: the reference held by default, every other epoch's poses, camera(s) and affine
/// parts free. pipeline/combined_adjustment.hpp is the two-epoch form of the same stage.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numeric>
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
  std::size_t master = 0;     ///< image index in the master epoch
  std::size_t secondary = 0;  ///< image index in the secondary epoch
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

/// The matches between two epochs of combined_epochs_adjustment (indices into its epochs): each
/// pair's master image is an image of `master_epoch`, its secondary one of `secondary_epoch`.
struct EpochLinkMatches {
  std::size_t master_epoch = 0;
  std::size_t secondary_epoch = 1;
  std::vector<EpochPairMatches> pairs;
};

/// A ground control point for combined_epochs_adjustment: a point whose position in the reference
/// frame is known, and its observations in the images of any epochs. It becomes a track of its
/// own, weighted as the tie points (BundleOptions::intra_epoch_sigma_px), whose point is held to
/// `position` by a prior of `sigma` per axis (BundleInput::control_points). A point seen in 2
/// images or more starts triangulated, one seen in a single image (e.g. matched to an orthophoto
/// reference) starts at `position`.
struct EpochsControlPoint {
  /// Position in the reference epoch's frame, its units.
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  /// Standard deviation of the position per axis, reference units, > 0.
  double sigma = 1.0;
  /// observations[e]: the observations in epoch e's images (index within epoch e, px); may be
  /// shorter than the number of epochs (the epochs beyond have none).
  std::vector<std::vector<ImagePixel>> observations = {};
};

/// What became of a control point in the combined adjustment. Default: not used.
struct ControlPointOutcome {
  /// Triangulated and kept to the end (not rejected).
  bool used = false;
  /// Its adjusted point and the point minus its given position, reference frame; NaN when not used.
  Eigen::Vector3d point = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d error = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Index of its track in the result's track_list.
  std::size_t track = 0;
};

/// Options of the combined adjustment (two epochs or more).
struct CombinedAdjustmentOptions {
  /// The bundle adjustment. When `bundle.epochs` is empty the stage fills it: every epoch all free
  /// but the reference, fixed when `fix_reference_epoch` (else free too, and the gauge is fixed
  /// internally). Inter-epoch matches count as 6 px observations, intra-epoch tie points as 1 px:
  /// matches across decades err more (correlation matches: median 1.14 reference px), and
  /// systematically, and a heavy weight lets their errors bend a free epoch's camera. On 10
  /// decades seeds, 6 px against 3 px gave a smaller worst distortion error on 8 (median 1.50 ->
  /// 1.24 px) and check points within 0.03 m (median 0.41 -> 0.42 m); with a reference that covers
  /// the film block, smaller on 7 of 10 and larger on 2 (median 0.99 -> 0.79 px;
  /// docs/adjustment.md). Set 1 px for matches as precise as the tie points.
  BundleOptions bundle = [] {
    BundleOptions o;
    o.inter_epoch_sigma_px = 6.0;
    return o;
  }();
  /// Hold the reference epoch's poses, camera and affine parts fixed (its orientation is the
  /// reference, as MicMac's FrozenPoses).
  bool fix_reference_epoch = true;
  /// Merging of tie points and matches into tracks.
  TrackOptions tracks;
};

/// Outcome of combined_epochs_adjustment. Default: failure.
struct CombinedEpochsResult {
  /// The adjustment's report (success, message, RMS per epoch and kind, intrinsics, ...).
  BundleReport report;
  /// What the track building merged and dropped.
  TrackReport tracks;
  /// One image list over all epochs in their order: epoch e's images are first_image[e] ..
  /// first_image[e] + size - 1 (track_list's and image_camera's numbering).
  std::vector<std::size_t> first_image;
  /// Camera of each image of that list as BundleReport::cameras numbers them
  /// (CameraReport::camera): epoch 0's cameras first, in order of their first image, then epoch 1's.
  std::vector<int> image_camera;
  /// epoch_links(a, b): tracks (tie points, matches and control points merged, before the
  /// adjustment) observed in both epoch a and epoch b: what ties the epochs to each other.
  Eigen::Matrix<std::size_t, Eigen::Dynamic, Eigen::Dynamic> epoch_links;
  /// Adjusted frames of every epoch, in the reference frame. When !report.success: every epoch
  /// moved by its rough Helmert (the reference as given).
  std::vector<std::vector<Frame<FraserAffine>>> epochs;
  /// The tracks adjusted, over the one image list; for residual pictures and exports with points.
  std::vector<Track> track_list;
  /// Adjusted point of each track, reference frame; NaN for tracks not used (or on failure).
  std::vector<Eigen::Vector3d> points;
  /// Whether each track took part to the end (after rejection).
  std::vector<bool> track_used;
  /// One per control point given, in their order (their tracks come last in track_list).
  std::vector<ControlPointOutcome> control_points;
};

namespace detail {

// Dense camera numbers (0, 1, ... in order of first image) of one epoch's images, from its labels
// or, without labels, by equal size and f, cx, cy, K1-K3, P1, P2.
inline std::vector<int> combined_epoch_cameras(const CombinedEpoch& epoch, const std::string& which) {
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

// "epoch 1" for two epochs (the names the two-epoch stage always used), "epoch k" (0-based) beyond.
inline std::string combined_epoch_name(std::size_t e, std::size_t count) {
  return "epoch " + std::to_string(count == 2 ? e + 1 : e);
}

// The first epoch that is free and not tied to any fixed epoch through a chain of epoch pairs
// each sharing at least `least` tracks, or `epochs` when every free epoch is tied (or no epoch
// is fixed: control points are then the datum, and the bundle's own checks apply).
inline std::size_t untied_epoch(const Eigen::Matrix<std::size_t, Eigen::Dynamic, Eigen::Dynamic>& links,
                                const std::vector<bool>& fixed, std::size_t least) {
  const std::size_t n = fixed.size();
  std::vector<bool> tied = fixed;
  if (std::none_of(fixed.begin(), fixed.end(), [](bool f) { return f; })) return n;
  for (bool grew = true; grew;) {
    grew = false;
    for (std::size_t a = 0; a < n; ++a)
      for (std::size_t b = 0; b < n && !tied[a]; ++b)
        if (a != b && tied[b] && links(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) >= least)
          tied[a] = grew = true;
  }
  for (std::size_t a = 0; a < n; ++a)
    if (!tied[a]) return a;
  return n;
}

}  // namespace detail

/// Runs the combined adjustment of any number of epochs (two or more; one is allowed and then
/// only refines that epoch).
/// @param epochs the epochs in their own frames.
/// @param reference_from_epoch per epoch, its rough co-registration into the reference's frame
///        (X_ref = scale R X + t); the reference's own entry must be the identity.
/// @param reference index of the reference epoch (the frame the adjustment works in).
/// @param links inter-epoch matches per pair of epochs, any pairs (free-free pairs tie the free
///        epochs to each other); a link's two epochs must differ.
/// @param control_points ground control points, if any.
/// Data failures (a free epoch tied to no fixed epoch by at least
/// BundleOptions::min_inter_epoch_tracks tracks, directly or through other epochs; the bundle's
/// own failures) give report.success == false with the reason; malformed input (an index out of
/// range, non-finite pixels or positions, a control point's sigma <= 0, bad options, a
/// non-identity Helmert for the reference) throws diachron::Error.
inline CombinedEpochsResult combined_epochs_adjustment(const std::vector<CombinedEpoch>& epochs,
                                                       const std::vector<Helmert3>& reference_from_epoch,
                                                       std::size_t reference,
                                                       const std::vector<EpochLinkMatches>& links,
                                                       const CombinedAdjustmentOptions& options = {},
                                                       const std::vector<EpochsControlPoint>& control_points = {}) {
  const std::size_t n_epochs = epochs.size();
  DIACHRON_CHECK(n_epochs >= 1, "combined_adjustment: no epoch given");
  DIACHRON_CHECK(reference < n_epochs,
                 "combined_adjustment: reference epoch " << reference << " outside [0, " << n_epochs << ")");
  DIACHRON_CHECK(reference_from_epoch.size() == n_epochs, "combined_adjustment: " << reference_from_epoch.size()
                                                                                  << " rough Helmerts for " << n_epochs
                                                                                  << " epochs");
  {
    const Helmert3& r = reference_from_epoch[reference];
    DIACHRON_CHECK(std::abs(r.scale - 1.0) < 1e-12 && r.rotation.isApprox(Eigen::Matrix3d::Identity(), 1e-12) &&
                       r.translation.norm() < 1e-9,
                   "combined_adjustment: the reference epoch's rough Helmert must be the identity");
  }
  DIACHRON_CHECK(options.bundle.epochs.empty() || options.bundle.epochs.size() == n_epochs,
                 "combined_adjustment: bundle.epochs has " << options.bundle.epochs.size() << " entries for "
                                                           << n_epochs << " epochs");
  CombinedEpochsResult result;

  // One image list, the epochs in their order; every epoch but the reference moved into its frame
  // (the reference's frames are copied as they are, bit for bit).
  BundleInput input;
  std::size_t total = 0;
  for (std::size_t e = 0; e < n_epochs; ++e) {
    result.first_image.push_back(total);
    total += epochs[e].frames.size();
    const std::vector<Frame<FraserAffine>> moved =
        e == reference ? epochs[e].frames : transformed_frames(epochs[e].frames, reference_from_epoch[e]);
    result.epochs.push_back(moved);
    input.frames.insert(input.frames.end(), moved.begin(), moved.end());
    input.image_epoch.insert(input.image_epoch.end(), epochs[e].frames.size(), static_cast<int>(e));
    // Cameras never span the epochs: each epoch's are numbered after the previous epochs'.
    const int offset = input.image_camera.empty()
                           ? 0
                           : *std::max_element(input.image_camera.begin(), input.image_camera.end()) + 1;
    for (int c : detail::combined_epoch_cameras(epochs[e], detail::combined_epoch_name(e, n_epochs)))
      input.image_camera.push_back(offset + c);
  }
  result.image_camera = input.image_camera;
  const auto image_of = [&](std::size_t e, int image) { return static_cast<int>(result.first_image[e]) + image; };

  std::vector<std::vector<ImagePixel>> ties;
  for (std::size_t e = 0; e < n_epochs; ++e) {
    const int count = static_cast<int>(epochs[e].frames.size());
    for (const auto& tie : epochs[e].tie_points) {
      ties.emplace_back();
      for (const ImagePixel& o : tie) {
        DIACHRON_CHECK(o.image >= 0 && o.image < count,
                       "combined_adjustment: tie-point image " << o.image << " outside [0, " << count << ")");
        ties.back().push_back({image_of(e, o.image), o.pixel});
      }
    }
  }
  std::vector<ImageMatch> matches;
  for (const EpochLinkMatches& link : links) {
    DIACHRON_CHECK(link.master_epoch < n_epochs && link.secondary_epoch < n_epochs &&
                       link.master_epoch != link.secondary_epoch,
                   "combined_adjustment: matches between epochs " << link.master_epoch << " and "
                                                                   << link.secondary_epoch << " of " << n_epochs);
    const std::size_t n1 = epochs[link.master_epoch].frames.size(), n2 = epochs[link.secondary_epoch].frames.size();
    for (const EpochPairMatches& pair : link.pairs) {
      DIACHRON_CHECK(pair.master < n1 && pair.secondary < n2, "combined_adjustment: pair ("
                                                                  << pair.master << ", " << pair.secondary
                                                                  << ") outside " << n1 << " x " << n2 << " images");
      DIACHRON_CHECK(pair.weights.empty() || pair.weights.size() == pair.matches.size(),
                     "combined_adjustment: pair (" << pair.master << ", " << pair.secondary << ") has "
                                                   << pair.weights.size() << " weights for " << pair.matches.size()
                                                   << " matches");
      for (std::size_t k = 0; k < pair.matches.size(); ++k) {
        const PointMatch& m = pair.matches[k];
        matches.push_back({{image_of(link.master_epoch, static_cast<int>(pair.master)), m.a},
                           {image_of(link.secondary_epoch, static_cast<int>(pair.secondary)), m.b},
                           pair.weights.empty() ? Eigen::Matrix2d::Identity() : pair.weights[k]});
      }
    }
  }
  TrackSet tracks = build_tracks(ties, matches, static_cast<int>(total), options.tracks);
  result.tracks = tracks.report;
  input.tracks = std::move(tracks.tracks);
  // Each control point is a track of its own, outside the union-find: its observations are
  // measured by hand, not matched, and must not merge with a tie point through a shared pixel.
  for (std::size_t k = 0; k < control_points.size(); ++k) {
    const EpochsControlPoint& g = control_points[k];
    DIACHRON_CHECK(g.position.allFinite() && std::isfinite(g.sigma) && g.sigma > 0.0,
                   "combined_adjustment: control point " << k << " needs a finite position and sigma > 0, got sigma "
                                                         << g.sigma);
    DIACHRON_CHECK(g.observations.size() <= n_epochs, "combined_adjustment: control point "
                                                          << k << " has observations for " << g.observations.size()
                                                          << " epochs of " << n_epochs);
    Track track;
    for (std::size_t e = 0; e < g.observations.size(); ++e) {
      const int count = static_cast<int>(epochs[e].frames.size());
      for (const ImagePixel& o : g.observations[e]) {
        DIACHRON_CHECK(o.image >= 0 && o.image < count, "combined_adjustment: control point "
                                                            << k << " names image " << o.image << " outside [0, "
                                                            << count << ")");
        DIACHRON_CHECK(o.pixel.allFinite(), "combined_adjustment: control point " << k << " has a non-finite pixel");
        track.observations.push_back({image_of(e, o.image), o.pixel, ObservationKind::intra_epoch});
      }
    }
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

  // What ties the epochs together: tracks seen in both epochs of each pair.
  const auto n = static_cast<Eigen::Index>(n_epochs);
  result.epoch_links = Eigen::Matrix<std::size_t, Eigen::Dynamic, Eigen::Dynamic>::Zero(n, n);
  for (const Track& t : input.tracks) {
    std::vector<bool> in(n_epochs, false);
    for (const TrackObservation& o : t.observations) in[static_cast<std::size_t>(input.image_epoch[static_cast<std::size_t>(o.image)])] = true;
    for (Eigen::Index a = 0; a < n; ++a)
      for (Eigen::Index b = 0; b < n; ++b)
        if (a != b && in[static_cast<std::size_t>(a)] && in[static_cast<std::size_t>(b)]) ++result.epoch_links(a, b);
  }

  BundleOptions bundle = options.bundle;
  if (bundle.epochs.empty())
    for (std::size_t e = 0; e < n_epochs; ++e)
      bundle.epochs.push_back(e == reference && options.fix_reference_epoch ? EpochFreedom::all_fixed()
                                                                              : EpochFreedom::all_free());
  bundle.check();
  // A free epoch tied to nothing fixed would float: its datum undetermined, the solve's answer
  // arbitrary. Two epochs keep the bundle's own check and message.
  if (n_epochs > 2) {
    std::vector<bool> fixed;
    for (const EpochFreedom& f : bundle.epochs) fixed.push_back(!f.poses && !f.camera && !f.affine);
    const std::size_t untied = detail::untied_epoch(result.epoch_links, fixed, bundle.min_inter_epoch_tracks);
    if (untied < n_epochs) {
      std::size_t most = 0;
      for (Eigen::Index b = 0; b < n; ++b) most = std::max(most, result.epoch_links(static_cast<Eigen::Index>(untied), b));
      result.report.message = "epoch " + std::to_string(untied) + " is tied to no fixed epoch by " +
                              std::to_string(bundle.min_inter_epoch_tracks) +
                              " tracks or more, directly or through other epochs (at most " + std::to_string(most) +
                              " tracks with any one epoch)";
      return result;
    }
  }
  BundleResult adjusted = bundle_adjust(input, bundle);
  result.report = std::move(adjusted.report);
  if (!result.report.success) return result;
  for (std::size_t e = 0; e < n_epochs; ++e) {
    const auto first = adjusted.frames.begin() + static_cast<std::ptrdiff_t>(result.first_image[e]);
    result.epochs[e].assign(first, first + static_cast<std::ptrdiff_t>(epochs[e].frames.size()));
  }
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
