#pragma once
/// @file
/// combined_adjustment(): the paper's combined processing (section 3.3, Algorithm 1) for two
/// epochs. Epoch 1 is moved into the epoch-2 frame by the rough Helmert, intra-epoch tie points and
/// inter-epoch matches become tracks, the tracks are triangulated, and one bundle adjustment
/// (epoch 2 fixed by default; epoch 1's poses, camera and affine free) co-registers and
/// self-calibrates epoch 1. Plain inputs in, adjusted copies and a report out. The two-epoch form
/// of combined_epochs_adjustment (pipeline/combined_epochs.hpp), with the same results.

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include <diachron/adjustment/tracks.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/pipeline/combined_epochs.hpp>

namespace diachron {

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

/// Runs the combined adjustment of two epochs: combined_epochs_adjustment with epoch 2 as the
/// reference.
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
  std::vector<EpochsControlPoint> control;
  control.reserve(control_points.size());
  for (const CombinedControlPoint& g : control_points) control.push_back({g.position, g.sigma, {g.epoch1, g.epoch2}});
  CombinedEpochsResult all = combined_epochs_adjustment({epoch1, epoch2}, {epoch2_from_epoch1, Helmert3{}}, 1,
                                                        {{0, 1, matches}}, options, control);
  CombinedAdjustmentResult result;
  result.report = std::move(all.report);
  result.tracks = all.tracks;
  result.image_camera = std::move(all.image_camera);
  result.epoch1 = std::move(all.epochs[0]);
  result.epoch2 = std::move(all.epochs[1]);
  result.track_list = std::move(all.track_list);
  result.points = std::move(all.points);
  result.track_used = std::move(all.track_used);
  result.control_points = std::move(all.control_points);
  return result;
}

}  // namespace diachron
