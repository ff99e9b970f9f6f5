#pragma once
/// @file
/// BundleReport: what bundle_adjust did (Ceres summaries, reprojection RMS per epoch and kind
/// before and after, tracks and observations used and rejected, intrinsics before/after with
/// standard deviations). Defaults mean failure.

#include <array>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace diachron {

/// The essentials of one Ceres solve.
struct SolveSummary {
  std::string stage;        ///< e.g. "all", "focal+pp", "round 1"
  bool usable = false;      ///< Ceres says the solution is usable
  std::string termination;  ///< CONVERGENCE, NO_CONVERGENCE, FAILURE, ... and Ceres' message
  int iterations = 0;
  double initial_cost = std::numeric_limits<double>::quiet_NaN();  ///< Ceres cost (half the sum of squares)
  double final_cost = std::numeric_limits<double>::quiet_NaN();
  double seconds = 0.0;
};

/// RMS of the reprojection error (unweighted, px) over a set of observations.
struct ResidualRms {
  double rms_px = std::numeric_limits<double>::quiet_NaN();  ///< NaN when there is none
  std::size_t observations = 0;
};

/// Reprojection RMS per epoch and per observation kind.
struct ReprojectionRms {
  std::vector<ResidualRms> by_epoch;  ///< by epoch index
  ResidualRms intra_epoch;
  ResidualRms inter_epoch;
  ResidualRms all;
};

/// One adjusted parameter.
struct ParameterChange {
  std::string name;  ///< "f", "cx", "cy", "K1", ..., "B1", "B2"
  double before = std::numeric_limits<double>::quiet_NaN();
  double after = std::numeric_limits<double>::quiet_NaN();
  /// A-posteriori standard deviation (ceres::Covariance scaled by sigma0^2); NaN when the
  /// parameter was fixed or the covariance is unavailable.
  double sigma = std::numeric_limits<double>::quiet_NaN();
};

/// The intrinsics of one camera.
struct CameraReport {
  int camera = 0;
  bool free = false;                      ///< estimated (else held fixed)
  std::vector<ParameterChange> values;    ///< f, cx, cy (px), K1, K2, K3, P1, P2
  /// Of a free camera, the intrinsics held at their initial values ("K3", "P1", ...) by
  /// EpochFreedom::fixed_intrinsics.
  std::vector<std::string> held;
  /// Of a free camera, the intrinsics tied to their initial values by a prior
  /// (EpochFreedom::intrinsic_priors), as "f", "K1", ..., with each prior's sigma beside it; a held
  /// intrinsic's prior is not listed (it has no effect).
  std::vector<std::string> priors;
  std::vector<double> prior_sigmas;
  /// A-posteriori covariance of the same 8 values, row-major 8 x 8 (ceres::Covariance scaled by
  /// sigma0^2; px^2 and the parameters' units); empty when the camera was fixed or the covariance
  /// is unavailable. eval/distortion_precision.hpp turns it into the distortion's 1-sigma over the
  /// image: the correlations (f against K1 on a near-nadir block) matter as much as the sigmas.
  std::vector<double> covariance;
};

/// The affine part of one image (with AffineScope::per_camera, its camera's shared values).
struct ImageAffineReport {
  int image = 0;
  bool free = false;
  std::vector<ParameterChange> values;  ///< B1, B2 (px)
};

/// What bundle_adjust did. Default: nothing ran (success == false).
struct BundleReport {
  bool success = false;
  std::string message;                ///< what happened, or why there is no answer
  std::vector<SolveSummary> solves;   ///< every Ceres solve, in order
  ReprojectionRms before;             ///< initial values, every observation of the usable tracks
  ReprojectionRms after;              ///< adjusted values, the observations kept
  std::size_t tracks_input = 0;
  std::size_t tracks_used = 0;
  std::size_t tracks_rejected = 0;       ///< no initial point, or too few observations left
  std::size_t tracks_not_triangulated = 0;  ///< of tracks_rejected: triangulation failed
  std::size_t inter_epoch_tracks = 0;    ///< used tracks with an inter-epoch observation
  std::size_t observations_used = 0;
  std::size_t observations_rejected = 0;  ///< residual above the threshold (and their partners)
  std::size_t control_points = 0;        ///< GCP priors used
  std::vector<CameraReport> cameras;
  std::vector<ImageAffineReport> affine;
  /// A-posteriori standard deviation of unit weight sqrt(2 cost / redundancy) (1 when the
  /// sigmas are right); scales the reported standard deviations.
  double sigma0 = std::numeric_limits<double>::quiet_NaN();
  bool covariance_available = false;
  std::string covariance_message;  ///< why not, when unavailable
  double seconds = 0.0;            ///< whole call
};

}  // namespace diachron
