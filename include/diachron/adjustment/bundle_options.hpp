#pragma once
/// @file
/// BundleOptions: what the bundle adjustment frees per epoch, observation weights, robust loss,
/// staged freeing of the intrinsics, outlier rejection, solver limits and covariance.

#include <cmath>
#include <cstddef>
#include <vector>

#include <diachron/adjustment/triangulation.hpp>
#include <diachron/core/error.hpp>

namespace diachron {

/// Robust loss on each observation's whitened residual (pixels / sigma).
enum class RobustLoss {
  none,    ///< plain least squares
  huber,   ///< quadratic within the scale, linear beyond
  cauchy,  ///< log(1 + s / scale^2): strongly downweights large residuals
};

/// Where the affine part B1, B2 of a FraserAffine camera lives in the adjustment.
enum class AffineScope {
  per_image,   ///< one [B1, B2] per image: each scan of a film deforms on its own
  per_camera,  ///< one [B1, B2] per camera, as MicMac's Fraser calibration keeps b1, b2: one
               ///< scanner and one film stock for a flight, 2 parameters instead of 2 per image
};

/// One intrinsic of a camera block [f, cx, cy, K1, K2, K3, P1, P2] (the order of
/// fraser_camera_block), for EpochFreedom::fixed_intrinsics.
enum class Intrinsic { f, cx, cy, k1, k2, k3, p1, p2 };

/// "f", "cx", "cy", "K1", "K2", "K3", "P1", "P2": the names reports and programs use.
inline const char* intrinsic_name(Intrinsic k) {
  static const char* const kNames[] = {"f", "cx", "cy", "K1", "K2", "K3", "P1", "P2"};
  const int i = static_cast<int>(k);
  return i >= 0 && i <= static_cast<int>(Intrinsic::p2) ? kNames[i] : "?";
}

/// What is known of one intrinsic before the adjustment, e.g. from a calibration certificate: the
/// adjustment adds the observation "the intrinsic equals its initial value" with standard deviation
/// `sigma`, in the intrinsic's own unit (px for f, cx, cy; the coefficient itself for K1-K3, P1, P2,
/// docs/camera-model.md). In between holding it (sigma -> 0, EpochFreedom::fixed_intrinsics) and
/// leaving it free (sigma -> infinity): a block too weak to determine it keeps it near the
/// certificate, a strong one moves it where the images say. A sigma many orders of magnitude below
/// what the images determine leaves the covariance too ill-conditioned for ceres::Covariance (the
/// report then has no sigmas): hold such an intrinsic instead (EpochFreedom::fixed_intrinsics).
struct IntrinsicPrior {
  Intrinsic intrinsic = Intrinsic::f;
  double sigma = 1.0;  ///< > 0, finite
};

/// Which parameter blocks of the images of one epoch the adjustment may change.
/// The reference epoch with a known orientation keeps poses and camera fixed, like MicMac's
/// FrozenPoses; an epoch to be co-registered and self-calibrated frees everything.
struct EpochFreedom {
  bool poses = true;   ///< the images' poses (angle-axis + centre)
  bool camera = true;  ///< the epoch's cameras [f, cx, cy, K1, K2, K3, P1, P2]
  bool affine = true;  ///< the images' affine parts [B1, B2] (per image or per camera: AffineScope)
  /// With `camera` free, intrinsics held at their initial values, as photogrammetric packages let
  /// one choose per parameter: e.g. {Intrinsic::k3} where the block cannot tell K3 from K1, K2 and
  /// the focal length (near-nadir images from one height), so that it does not wander at the
  /// image corners. A camera that serves several epochs holds what any of them holds.
  std::vector<Intrinsic> fixed_intrinsics = {};
  /// With `camera` free, intrinsics tied to their initial values with a standard deviation (see
  /// IntrinsicPrior). A camera that serves several epochs takes each epoch's priors; a held
  /// intrinsic needs none.
  std::vector<IntrinsicPrior> intrinsic_priors = {};

  /// Everything free: co-registration with self-calibration.
  static EpochFreedom all_free() { return {true, true, true}; }
  /// Everything fixed: the reference epoch.
  static EpochFreedom all_fixed() { return {false, false, false}; }
};

/// Options of bundle_adjust. Defaults: everything free, 1 px sigmas, Huber at 1 px, one solve,
/// rejection of observations above 3 px then a second solve, covariance of the intrinsics.
struct BundleOptions {
  /// Freedom per epoch index (BundleInput::image_epoch); epochs without an entry are all free.
  std::vector<EpochFreedom> epochs;
  /// Standard deviation of an intra-epoch tie-point observation, px. > 0.
  double intra_epoch_sigma_px = 1.0;
  /// Standard deviation of an inter-epoch match observation, px. > 0. Raise it to trust the
  /// epochs' own tie points more than the cross-epoch matches.
  double inter_epoch_sigma_px = 1.0;
  /// Per image (default) or per camera. Per camera, a camera's [B1, B2] starts from its first
  /// image's values and is free when every epoch it serves frees the affine part.
  AffineScope affine_scope = AffineScope::per_image;
  /// Robust loss and its scale, px (the point where it departs from least squares). scale > 0.
  RobustLoss loss = RobustLoss::huber;
  double loss_scale_px = 1.0;
  /// Free the intrinsics in three solves, as MicMac's Tapas/Campari do: focal and principal
  /// point, then + K1..K3, then everything (P1, P2, B1, B2). Off: one solve with all free.
  bool staged_intrinsics = false;
  /// After a solve, observations whose residual exceeds this are rejected and the problem solved
  /// again; a track left with fewer than 2 observations is rejected whole. px; 0 disables.
  double reject_residual_px = 3.0;
  /// Most reject-and-solve rounds. >= 0.
  int rejection_rounds = 1;
  /// Fewest tracks linking two epochs when the images span more than one epoch; fewer gives
  /// success == false ("too few inter-epoch tracks"). >= 0.
  std::size_t min_inter_epoch_tracks = 10;
  /// Ceres iterations per solve. >= 1.
  int max_iterations = 50;
  /// Ceres relative cost change that ends a solve. > 0.
  double function_tolerance = 1e-8;
  /// Ceres threads; results are deterministic for a given count (1 keeps them identical on
  /// every machine). >= 1.
  int num_threads = 1;
  /// Compute the standard deviations of the intrinsics (ceres::Covariance) after the solve.
  bool compute_covariance = true;
  /// Triangulation of tracks given without initial points.
  TriangulationOptions triangulation;

  void check() const {
    DIACHRON_CHECK(intra_epoch_sigma_px > 0.0 && std::isfinite(intra_epoch_sigma_px) && inter_epoch_sigma_px > 0.0 &&
                       std::isfinite(inter_epoch_sigma_px),
                   "BundleOptions: observation sigmas must be finite and > 0 px");
    DIACHRON_CHECK(loss_scale_px > 0.0 && std::isfinite(loss_scale_px),
                   "BundleOptions::loss_scale_px must be > 0, got " << loss_scale_px);
    DIACHRON_CHECK(reject_residual_px >= 0.0 && std::isfinite(reject_residual_px),
                   "BundleOptions::reject_residual_px must be >= 0, got " << reject_residual_px);
    DIACHRON_CHECK(rejection_rounds >= 0, "BundleOptions::rejection_rounds must be >= 0");
    DIACHRON_CHECK(max_iterations >= 1, "BundleOptions::max_iterations must be >= 1");
    DIACHRON_CHECK(function_tolerance > 0.0, "BundleOptions::function_tolerance must be > 0");
    DIACHRON_CHECK(num_threads >= 1, "BundleOptions::num_threads must be >= 1");
    for (std::size_t e = 0; e < epochs.size(); ++e) {
      for (Intrinsic k : epochs[e].fixed_intrinsics)
        DIACHRON_CHECK(static_cast<int>(k) >= 0 && static_cast<int>(k) <= static_cast<int>(Intrinsic::p2),
                       "BundleOptions::epochs[" << e << "].fixed_intrinsics holds " << static_cast<int>(k)
                                                << ", not an intrinsic (0 f .. 7 P2)");
      for (const IntrinsicPrior& prior : epochs[e].intrinsic_priors) {
        const int k = static_cast<int>(prior.intrinsic);
        DIACHRON_CHECK(k >= 0 && k <= static_cast<int>(Intrinsic::p2),
                       "BundleOptions::epochs[" << e << "].intrinsic_priors holds " << k
                                                << ", not an intrinsic (0 f .. 7 P2)");
        DIACHRON_CHECK(prior.sigma > 0.0 && std::isfinite(prior.sigma),
                       "BundleOptions::epochs[" << e << "]: the prior of " << intrinsic_name(prior.intrinsic)
                                                << " needs a finite sigma > 0, got " << prior.sigma);
      }
    }
    triangulation.check();
  }
};

}  // namespace diachron
