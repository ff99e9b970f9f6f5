#pragma once
/// @file
/// One epoch of a synthetic scene: its options (flight block, camera, film look, the DSM an SfM
/// would deliver, the frame it is delivered in) and its data with ground truth (images, true and
/// "as estimated" cameras and poses, DSMs, the epoch-to-world Helmert, intra-epoch tie points).

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/camera/ortho_frame.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/synth/render.hpp>
#include <diachron/synth/texture.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// The arbitrary frame an epoch's SfM delivers its orientations and DSM in:
/// X_epoch = scale * R * (X_world - block centre) + shift, R = (small tilt) * Rz(yaw).
struct EpochFrameOptions {
  /// The epoch frame is the world frame itself (a georeferenced epoch, e.g. a recent one with
  /// ground truth); the other members are then ignored.
  bool is_world = false;
  /// Rotation about the vertical, degrees; NaN draws it uniformly in [0, 360).
  double yaw_deg = std::numeric_limits<double>::quiet_NaN();
  /// Largest tilt of the epoch's vertical, degrees (uniform angle about a random horizontal axis).
  double max_tilt_deg = 2.0;
  /// Scale range (epoch units per metre), drawn log-uniformly. 0 < min <= max.
  double min_scale = 0.5;
  double max_scale = 2.0;
  /// Each component of the shift is uniform in [-max_shift, max_shift], epoch units. >= 0.
  double max_shift = 1000.0;

  void check() const {
    DIACHRON_CHECK(std::isnan(yaw_deg) || std::isfinite(yaw_deg), "EpochFrameOptions::yaw_deg must be finite or NaN");
    DIACHRON_CHECK(max_tilt_deg >= 0.0 && max_tilt_deg <= 45.0, "EpochFrameOptions::max_tilt_deg must be in [0, 45]");
    DIACHRON_CHECK(min_scale > 0.0 && min_scale <= max_scale && std::isfinite(max_scale),
                   "EpochFrameOptions: need 0 < min_scale <= max_scale");
    DIACHRON_CHECK(max_shift >= 0.0 && std::isfinite(max_shift), "EpochFrameOptions::max_shift must be >= 0");
  }
};

/// How the epoch's DSM "as an SfM delivers it" degrades the true surface.
struct SfmDsmOptions {
  /// DSM cell size in ground sampling distances of the epoch's images (the paper computes DSMs on
  /// images downsampled by 4). > 0.
  double cell_gsd = 4.0;
  /// White height noise, metres (converted to epoch units). >= 0.
  double noise_sigma_m = 0.3;
  /// Amplitude of a smooth correlated height error (wavelength 200 m), metres. >= 0.
  double ripple_m = 0.3;
  /// Fraction of the covered area lost to random round holes (matching failures). In [0, 0.9].
  double hole_fraction = 0.03;
  /// Radius of those holes, metres. > 0.
  double hole_radius_m = 12.0;
  /// Cells seen by fewer true images than this are holes (no stereo there). >= 1.
  int min_views = 2;
  /// Dome bending from poorly known intrinsics: height added at the block centre, falling
  /// quadratically to 0 at the DSM's corners, metres (0 = none). Not part of the true Helmert.
  double dome_m = 0.0;

  void check() const {
    DIACHRON_CHECK(cell_gsd > 0.0 && std::isfinite(cell_gsd), "SfmDsmOptions::cell_gsd must be > 0");
    DIACHRON_CHECK(noise_sigma_m >= 0.0 && ripple_m >= 0.0, "SfmDsmOptions: noise must be >= 0");
    DIACHRON_CHECK(hole_fraction >= 0.0 && hole_fraction <= 0.9, "SfmDsmOptions::hole_fraction must be in [0, 0.9]");
    DIACHRON_CHECK(hole_radius_m > 0.0, "SfmDsmOptions::hole_radius_m must be > 0");
    DIACHRON_CHECK(min_views >= 1, "SfmDsmOptions::min_views must be >= 1");
    DIACHRON_CHECK(std::isfinite(dome_m), "SfmDsmOptions::dome_m must be finite");
  }
};

/// Options of one epoch. Defaults: a small 2 x 3 block of 400 x 300 px images of an old
/// wide-angle film camera (f / width ~ 0.66 as a 152 mm lens on 230 mm film), 60 % forward and
/// 30 % side overlap (the paper's table), a ground sampling distance of about 1.9 m.
struct EpochOptions {
  /// Name, used for file names ("e1" gives images "e1_r0_c0").
  std::string name = "epoch";

  // --- flight block ---
  /// Flight lines (rows) and images per line (columns). >= 1.
  int rows = 2;
  int columns = 3;
  /// Forward (along the line) and side (between lines) overlap, fractions in [0, 0.95).
  double forward_overlap = 0.6;
  double side_overlap = 0.3;
  /// Flying height above the scene's mean ground height, metres. > 0.
  double flying_height_m = 520.0;
  /// Azimuth of the flight lines (image +x), degrees counter-clockwise from world +X.
  double heading_deg = 0.0;
  /// Odd lines are flown in the opposite direction (images turned by 180 degrees).
  bool alternate_direction = true;
  /// Offset of the block centre from the scene centre, metres (world X, Y).
  Eigen::Vector2d block_offset_m = Eigen::Vector2d::Zero();
  /// Standard deviations of the random attitude of each image: pitch and roll, and yaw (crab),
  /// degrees; and of its position (each axis), metres. >= 0.
  double attitude_sigma_deg = 1.0;
  double yaw_sigma_deg = 2.0;
  double position_sigma_m = 3.0;

  // --- camera ---
  /// Image size, pixels. > 0.
  int image_width_px = 400;
  int image_height_px = 300;
  /// Focal length, pixels. > 0.
  double focal_px = 265.0;
  /// Principal point offset from the image centre ((w - 1) / 2, (h - 1) / 2), pixels.
  Eigen::Vector2d principal_point_offset_px = Eigen::Vector2d(1.5, -2.0);
  /// True Fraser + affine parameters [K1, K2, K3, P1, P2, B1 (px), B2 (px)]
  /// (docs/conventions.md; K and P dimensionless on normalised coordinates).
  std::array<double, 7> distortion = {-0.025, 0.004, 0.0, 2e-4, -1.5e-4, 0.4, -0.2};

  // --- the camera as the epoch's SfM estimated it ---
  /// Estimated focal length = true focal length * this factor. > 0.
  double estimated_focal_scale = 1.01;
  /// Estimated principal point = true + this offset, pixels.
  Eigen::Vector2d estimated_principal_point_error_px = Eigen::Vector2d(2.0, -1.0);
  /// Estimated K and P = true * this fraction; estimated B1 = B2 = 0. Finite.
  double estimated_distortion_fraction = 0.5;

  // --- products ---
  /// Radiometric look of the images.
  LookOptions look;
  /// Frame the SfM delivers in.
  EpochFrameOptions frame;
  /// The SfM DSM.
  SfmDsmOptions dsm;
  /// Intra-epoch tie points: number of attempts (each gives a track when seen by >= 2 images),
  /// and the standard deviation of their pixel noise, pixels. >= 0.
  int tie_points = 300;
  double tie_noise_px = 0.3;

  void check() const {
    DIACHRON_CHECK(!name.empty(), "EpochOptions::name must not be empty");
    DIACHRON_CHECK(rows >= 1 && columns >= 1 && rows * columns <= 10000,
                   "EpochOptions: rows and columns must be >= 1, got " << rows << " x " << columns);
    DIACHRON_CHECK(forward_overlap >= 0.0 && forward_overlap < 0.95 && side_overlap >= 0.0 && side_overlap < 0.95,
                   "EpochOptions: overlaps must be in [0, 0.95)");
    DIACHRON_CHECK(flying_height_m > 0.0 && std::isfinite(flying_height_m),
                   "EpochOptions::flying_height_m must be > 0, got " << flying_height_m);
    DIACHRON_CHECK(std::isfinite(heading_deg) && block_offset_m.allFinite(), "EpochOptions: heading and offset must be finite");
    DIACHRON_CHECK(attitude_sigma_deg >= 0.0 && yaw_sigma_deg >= 0.0 && position_sigma_m >= 0.0,
                   "EpochOptions: attitude and position sigmas must be >= 0");
    DIACHRON_CHECK(image_width_px > 0 && image_height_px > 0 && image_width_px <= 100000 && image_height_px <= 100000,
                   "EpochOptions: image size must be positive, got " << image_width_px << " x " << image_height_px);
    DIACHRON_CHECK(focal_px > 0.0 && std::isfinite(focal_px), "EpochOptions::focal_px must be > 0, got " << focal_px);
    DIACHRON_CHECK(principal_point_offset_px.allFinite() && estimated_principal_point_error_px.allFinite(),
                   "EpochOptions: principal point offsets must be finite");
    for (double p : distortion) DIACHRON_CHECK(std::isfinite(p), "EpochOptions::distortion must be finite");
    DIACHRON_CHECK(estimated_focal_scale > 0.0 && std::isfinite(estimated_focal_scale),
                   "EpochOptions::estimated_focal_scale must be > 0");
    DIACHRON_CHECK(std::isfinite(estimated_distortion_fraction), "EpochOptions::estimated_distortion_fraction must be finite");
    DIACHRON_CHECK(tie_points >= 0 && tie_points <= 10000000, "EpochOptions::tie_points must be >= 0");
    DIACHRON_CHECK(tie_noise_px >= 0.0 && std::isfinite(tie_noise_px), "EpochOptions::tie_noise_px must be >= 0");
    look.check();
    frame.check();
    dsm.check();
  }

  /// Ground sampling distance at the mean ground height, metres per pixel.
  double gsd_m() const { return flying_height_m / focal_px; }

  /// Flies the epoch `height_m` above the mean ground at the same GSD: the focal length follows the
  /// height (a longer lens higher up), so images and footprints keep their size while the relief's
  /// displacement shrinks. Rugged real terrain needs it for the cameras to stay above the summits.
  /// Throws diachron::Error for a height that is not finite and > 0.
  void set_flying_height_keeping_gsd(double height_m) {
    DIACHRON_CHECK(height_m > 0.0 && std::isfinite(height_m),
                   "EpochOptions: the flying height must be finite and > 0 m, got " << height_m);
    focal_px *= height_m / flying_height_m;
    flying_height_m = height_m;
  }

  /// An older epoch: wide-angle film, worn scan (gamma, low contrast, grain, scratches, dust).
  static EpochOptions historical(std::string epoch_name = "e1") {
    EpochOptions o;
    o.name = std::move(epoch_name);
    o.look.sun_azimuth_deg = 120.0;
    o.look.sun_elevation_deg = 40.0;
    o.look.gain = 0.85;
    o.look.offset = 0.08;
    o.look.contrast = 0.85;
    o.look.gamma = 1.25;
    o.look.vignetting = 0.2;
    o.look.blur_sigma_px = 0.8;
    o.look.grain_sigma = 0.03;
    o.look.scratches = 3;
    o.look.dust_per_megapixel = 250.0;
    return o;
  }

  /// A recent epoch: narrower lens flown higher, clean radiometry, its own camera errors.
  static EpochOptions recent(std::string epoch_name = "e2") {
    EpochOptions o;
    o.name = std::move(epoch_name);
    o.focal_px = 420.0;
    o.flying_height_m = 800.0;
    o.heading_deg = 12.0;
    o.block_offset_m = Eigen::Vector2d(40.0, -30.0);
    o.principal_point_offset_px = Eigen::Vector2d(-1.0, 1.0);
    o.distortion = {-0.01, 0.002, 0.0, -1e-4, 1e-4, -0.3, 0.15};
    o.estimated_focal_scale = 0.995;
    o.estimated_principal_point_error_px = Eigen::Vector2d(-1.0, 1.5);
    o.look.sun_azimuth_deg = 200.0;
    o.look.sun_elevation_deg = 55.0;
    o.look.blur_sigma_px = 0.5;
    o.look.grain_sigma = 0.012;
    o.look.dust_per_megapixel = 20.0;
    return o;
  }
};

/// One observation of a 3D point in an image of an epoch: `image` is the index in
/// SyntheticEpoch::images (the shape the adjustment's tie points take, core/types.hpp).
using ImageObservation = ImagePixel;

/// An intra-epoch tie point as an SfM gives it: a true 3D point and its noisy image observations.
struct TiePoint {
  Eigen::Vector3d world = Eigen::Vector3d::Zero();  ///< true position, world frame, metres
  Eigen::Vector3d epoch = Eigen::Vector3d::Zero();  ///< true position in the epoch frame
  std::vector<ImageObservation> observations;       ///< pixels with N(0, tie_noise_px) noise
};

/// One image of an epoch with its true and estimated orientation.
struct SyntheticImage {
  std::string name;                  ///< "<epoch>_r<row>_c<column>"
  int row = 0;                       ///< flight line
  int column = 0;                    ///< position along the line
  Raster<std::uint8_t> pixels;       ///< 8-bit grey image
  Pose pose_world;                   ///< true pose in the world frame
  Pose pose_epoch;                   ///< true pose in the epoch frame
  Pose estimated_pose;               ///< pose in the epoch frame fitted to the estimated camera
};

/// A true orthophoto that stands for an epoch (synth/ortho_reference.hpp): the epoch's landscape
/// rendered straight down, delivered as a national orthophoto is, with its DSM.
struct SyntheticOrthophoto {
  Raster<std::uint8_t> pixels;  ///< 8-bit grey image
  OrthoFrame frame;             ///< its north-up grid in the epoch frame (X, Y axes of that frame)
};

/// One epoch of a synthetic scene, with its ground truth.
struct SyntheticEpoch {
  std::string name;
  /// The true camera (shared by all images of the epoch).
  Camera<FraserAffine> camera{1.0, 0.0, 0.0, 1, 1};
  /// The camera as the SfM estimated it (perturbed focal, principal point and distortion).
  Camera<FraserAffine> estimated_camera{1.0, 0.0, 0.0, 1, 1};
  std::vector<SyntheticImage> images;
  /// The true surface of this epoch (ground plus this epoch's buildings), world frame.
  Dsm true_surface;
  /// The ground albedo of this epoch, world frame.
  AlbedoMap albedo;
  /// The DSM as the SfM delivers it: epoch frame, noise, holes, optional dome.
  Dsm dsm;
  /// The true transform from the epoch frame into the world frame.
  Helmert3 world_from_epoch = Helmert3::identity();
  /// Intra-epoch tie points.
  std::vector<TiePoint> tie_points;
  /// Ground sampling distance at the mean ground height, metres (of the orthophoto, when there is one).
  double gsd_m = 0.0;
  /// Set when the epoch is delivered as a true orthophoto and its DSM instead of images and an SfM
  /// model (make_ortho_reference): then `images` and `tie_points` are empty, the cameras unused,
  /// and `dsm` is the true surface in the epoch frame.
  std::optional<SyntheticOrthophoto> orthophoto;

  /// The true transform from the world into the epoch frame.
  Helmert3 epoch_from_world() const { return world_from_epoch.inverse(); }
  /// Image i with its true camera and true pose in the world frame.
  Frame<FraserAffine> world_frame(std::size_t i) const { return {camera, images.at(i).pose_world}; }
  /// Image i with its true camera and true pose in the epoch frame.
  Frame<FraserAffine> epoch_frame(std::size_t i) const { return {camera, images.at(i).pose_epoch}; }
  /// Image i as the SfM estimated it (estimated camera, estimated pose, epoch frame).
  Frame<FraserAffine> estimated_frame(std::size_t i) const { return {estimated_camera, images.at(i).estimated_pose}; }
  /// The tie points' observations, one list per tie point (what an SfM hands over as tracks; the
  /// tie points of CombinedEpoch in pipeline/combined_adjustment.hpp).
  std::vector<std::vector<ImagePixel>> tie_point_observations() const {
    std::vector<std::vector<ImagePixel>> out;
    out.reserve(tie_points.size());
    for (const TiePoint& t : tie_points) out.push_back(t.observations);
    return out;
  }
  /// Every image as the SfM estimated it, in image order (what a user of the epoch has).
  std::vector<Frame<FraserAffine>> estimated_frames() const {
    std::vector<Frame<FraserAffine>> out;
    out.reserve(images.size());
    for (std::size_t i = 0; i < images.size(); ++i) out.push_back(estimated_frame(i));
    return out;
  }
};

}  // namespace diachron
