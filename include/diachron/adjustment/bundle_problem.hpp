#pragma once
/// @file
/// BundleInput (frames, camera and epoch of each image, tracks, initial points, GCPs) and
/// BundleProblem: the parameter blocks of a FraserAffine bundle adjustment and the builder of the
/// ceres::Problem over them (which blocks are free, weights, robust loss, stages, gauge).
/// bundle_adjust (bundle_adjustment.hpp) drives it; a user can drive it too.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <ceres/autodiff_cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>

#include <diachron/adjustment/bundle_options.hpp>
#include <diachron/adjustment/bundle_report.hpp>
#include <diachron/adjustment/reprojection_error.hpp>
#include <diachron/adjustment/tracks.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// A ground control point: the world position of a track's point with its standard deviation.
struct GroundControlPoint {
  std::size_t track = 0;                              ///< index in BundleInput::tracks
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< world units
  double sigma = 1.0;                                 ///< per axis, world units, > 0
};

/// The input of a bundle adjustment. All images in one world frame.
struct BundleInput {
  /// The images, indexed by the tracks' image indices.
  std::vector<Frame<FraserAffine>> frames;
  /// Camera index of each image (images of one camera share f, cx, cy, K1-K3, P1, P2; the
  /// initial values are those of the camera's first image). Empty: one camera per epoch.
  std::vector<int> image_camera;
  /// Epoch index of each image (>= 0), for freedom, weights and reports. Empty: all epoch 0.
  std::vector<int> image_epoch;
  std::vector<Track> tracks;
  /// Initial world point of each track; empty: triangulated from the frames.
  std::vector<Eigen::Vector3d> points;
  std::vector<GroundControlPoint> control_points;
};

/// Prior on a point block: (X - position) / sigma, 3 residuals. Block: point (3).
struct PointPriorError {
  PointPriorError(const Vec3& position, double sigma) : position_(position), inverse_sigma_(1.0 / sigma) {}
  template <class T>
  bool operator()(const T* const point, T* residuals) const {
    for (int a = 0; a < 3; ++a) residuals[a] = (point[a] - T(position_[a])) * T(inverse_sigma_);
    return true;
  }
  /// Precondition: finite position, sigma > 0 (throws diachron::Error).
  static ceres::CostFunction* create(const Vec3& position, double sigma) {
    DIACHRON_CHECK(position.allFinite() && std::isfinite(sigma) && sigma > 0.0,
                   "PointPriorError: position must be finite and sigma > 0, got " << sigma);
    return new ceres::AutoDiffCostFunction<PointPriorError, 3, 3>(new PointPriorError(position, sigma));
  }

 private:
  Vec3 position_;
  double inverse_sigma_;
};

/// Prior of one intrinsic (IntrinsicPrior): (block[index] - value) / sigma, one residual on a
/// camera block [f, cx, cy, K1, K2, K3, P1, P2].
struct IntrinsicPriorError {
  IntrinsicPriorError(int index, double value, double sigma)
      : index_(index), value_(value), inverse_sigma_(1.0 / sigma) {}
  template <class T>
  bool operator()(const T* const camera, T* residual) const {
    residual[0] = (camera[index_] - T(value_)) * T(inverse_sigma_);
    return true;
  }
  /// Precondition: index in [0, 8), finite value, sigma > 0 (throws diachron::Error).
  static ceres::CostFunction* create(int index, double value, double sigma) {
    DIACHRON_CHECK(index >= 0 && index < kFraserCameraBlockSize && std::isfinite(value) && std::isfinite(sigma) &&
                       sigma > 0.0,
                   "IntrinsicPriorError: index in [0, 8), a finite value and sigma > 0 needed, got index "
                       << index << ", sigma " << sigma);
    return new ceres::AutoDiffCostFunction<IntrinsicPriorError, 1, kFraserCameraBlockSize>(
        new IntrinsicPriorError(index, value, sigma));
  }

 private:
  int index_;
  double value_;
  double inverse_sigma_;
};

/// Which intrinsics a solve frees (staged self-calibration).
enum class IntrinsicsStage {
  focal_principal_point,  ///< f, cx, cy
  radial,                 ///< + K1, K2, K3
  all,                    ///< + P1, P2 and the affine B1, B2
};

/// The parameter blocks of a FraserAffine bundle adjustment and the observations on them.
/// Copies the input; owns its blocks (the ceres::Problem built on them must not outlive it).
/// Not thread-safe.
class BundleProblem {
 public:
  /// One observation of a track in an image.
  struct Observation {
    std::size_t track = 0;
    int image = 0;
    Vec2 pixel = Vec2::Zero();
    ObservationKind kind = ObservationKind::intra_epoch;
    bool active = true;  ///< false once rejected
    Eigen::Matrix2d weight = Eigen::Matrix2d::Identity();  ///< TrackObservation::weight
  };

  /// Precondition: consistent sizes and indices (image_camera, image_epoch, track image indices,
  /// points, GCP track indices), else throws diachron::Error. Points may be non-finite (a track
  /// without an initial point is left out of the problem).
  BundleProblem(const BundleInput& input, const BundleOptions& options) : options_(options) {
    options_.check();
    const std::size_t n = input.frames.size();
    DIACHRON_CHECK(input.image_camera.empty() || input.image_camera.size() == n,
                   "BundleInput: image_camera has " << input.image_camera.size() << " entries for " << n << " images");
    DIACHRON_CHECK(input.image_epoch.empty() || input.image_epoch.size() == n,
                   "BundleInput: image_epoch has " << input.image_epoch.size() << " entries for " << n << " images");
    DIACHRON_CHECK(input.points.size() == input.tracks.size(),
                   "BundleInput: " << input.points.size() << " points for " << input.tracks.size() << " tracks");
    epoch_.assign(n, 0);
    for (std::size_t i = 0; i < n && !input.image_epoch.empty(); ++i) {
      DIACHRON_CHECK(input.image_epoch[i] >= 0, "BundleInput: negative epoch index for image " << i);
      epoch_[i] = input.image_epoch[i];
    }
    camera_ = input.image_camera.empty() ? epoch_ : input.image_camera;
    int cameras = 0;
    for (std::size_t i = 0; i < n; ++i) {
      DIACHRON_CHECK(camera_[i] >= 0, "BundleInput: negative camera index for image " << i);
      cameras = std::max(cameras, camera_[i] + 1);
      epochs_ = std::max(epochs_, epoch_[i] + 1);
    }
    cameras_.assign(static_cast<std::size_t>(cameras), {});
    const bool shared_affine = options_.affine_scope == AffineScope::per_camera;
    if (shared_affine) affine_.assign(static_cast<std::size_t>(cameras), {});
    std::vector<bool> seen(static_cast<std::size_t>(cameras), false);
    for (std::size_t i = 0; i < n; ++i) {
      const auto c = static_cast<std::size_t>(camera_[i]);
      if (!seen[c]) {
        cameras_[c] = fraser_camera_block(input.frames[i].camera());
        if (shared_affine) affine_[c] = affine_block(input.frames[i].camera());
      }
      seen[c] = true;
      if (!shared_affine) affine_.push_back(affine_block(input.frames[i].camera()));
      affine_slot_.push_back(shared_affine ? c : i);
      poses_.push_back(pose_block(input.frames[i].pose()));
      sizes_.emplace_back(input.frames[i].camera().width(), input.frames[i].camera().height());
    }
    initial_cameras_ = cameras_;
    // A shared block is free only when every epoch whose images use it frees the affine part.
    affine_free_.assign(affine_.size(), true);
    for (std::size_t i = 0; i < n; ++i)
      if (!freedom(epoch_[i]).affine) affine_free_[affine_slot_[i]] = false;
    for (const Vec3& p : input.points) points_.push_back({p.x(), p.y(), p.z()});
    for (std::size_t t = 0; t < input.tracks.size(); ++t)
      for (const TrackObservation& o : input.tracks[t].observations) {
        DIACHRON_CHECK(o.image >= 0 && static_cast<std::size_t>(o.image) < n,
                       "BundleInput: track " << t << " names image " << o.image << " of " << n);
        DIACHRON_CHECK(o.pixel.allFinite(), "BundleInput: track " << t << " has a non-finite pixel");
        observations_.push_back({t, o.image, o.pixel, o.kind, input.points[t].allFinite(), o.weight});
      }
    for (const GroundControlPoint& g : input.control_points) {
      DIACHRON_CHECK(g.track < input.tracks.size(), "BundleInput: GCP of track " << g.track << " of " << input.tracks.size());
      DIACHRON_CHECK(g.position.allFinite() && std::isfinite(g.sigma) && g.sigma > 0.0,
                     "BundleInput: a GCP needs a finite position and sigma > 0");
    }
    control_ = input.control_points;
  }

  std::size_t image_count() const { return poses_.size(); }
  std::size_t camera_count() const { return cameras_.size(); }
  int epoch_count() const { return epochs_; }
  int epoch_of(std::size_t image) const { return epoch_[image]; }
  int camera_of(std::size_t image) const { return camera_[image]; }
  const std::vector<Observation>& observations() const { return observations_; }
  std::vector<Observation>& observations() { return observations_; }
  const std::vector<GroundControlPoint>& control_points() const { return control_; }

  /// Camera block [f, cx, cy, K1, K2, K3, P1, P2] of camera c.
  std::array<double, kFraserCameraBlockSize>& camera_block(std::size_t c) { return cameras_[c]; }
  /// Affine block [B1, B2] of image i (its camera's with AffineScope::per_camera).
  std::array<double, kAffineBlockSize>& affine_block_of(std::size_t i) { return affine_[affine_slot_[i]]; }
  const std::array<double, kAffineBlockSize>& affine_block_of(std::size_t i) const { return affine_[affine_slot_[i]]; }
  /// Number of distinct affine blocks: one per image, or one per camera.
  std::size_t affine_entry_count() const { return affine_.size(); }
  /// Distinct affine block k (k < affine_entry_count()), each once whatever the scope.
  std::array<double, kAffineBlockSize>& affine_entry(std::size_t k) { return affine_[k]; }
  /// Pose block [angle-axis, C] of image i.
  std::array<double, kPoseBlockSize>& pose_block_of(std::size_t i) { return poses_[i]; }
  /// Point block of track t.
  std::array<double, 3>& point_block(std::size_t t) { return points_[t]; }

  /// Freedom of the images of an epoch (options.epochs, all free without an entry).
  EpochFreedom freedom(int epoch) const {
    return static_cast<std::size_t>(epoch) < options_.epochs.size() ? options_.epochs[static_cast<std::size_t>(epoch)]
                                                                      : EpochFreedom{};
  }
  /// A camera is free when every epoch it serves frees its camera.
  bool camera_free(std::size_t c) const {
    bool any = false;
    for (std::size_t i = 0; i < image_count(); ++i)
      if (static_cast<std::size_t>(camera_[i]) == c) {
        any = true;
        if (!freedom(epoch_[i]).camera) return false;
      }
    return any;
  }

  /// The epochs whose images use camera c, ascending, each once.
  std::vector<int> camera_epochs(std::size_t c) const {
    std::vector<int> out;
    for (std::size_t i = 0; i < image_count(); ++i)
      if (static_cast<std::size_t>(camera_[i]) == c) out.push_back(epoch_[i]);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  /// Positions in camera c's block [f, cx, cy, K1-K3, P1, P2] that any epoch it serves holds at
  /// their initial values (EpochFreedom::fixed_intrinsics), ascending, each once.
  std::vector<int> held_intrinsics(std::size_t c) const {
    std::vector<int> out;
    for (int e : camera_epochs(c))
      for (Intrinsic k : freedom(e).fixed_intrinsics) out.push_back(static_cast<int>(k));
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  /// The priors on camera c's intrinsics that take effect: EpochFreedom::intrinsic_priors of every
  /// epoch it serves (each epoch once), but none on a held intrinsic (held_intrinsics), as
  /// (position in the block, sigma).
  std::vector<std::pair<int, double>> intrinsic_priors(std::size_t c) const {
    const std::vector<int> held = held_intrinsics(c);
    std::vector<std::pair<int, double>> out;
    for (int e : camera_epochs(c))
      for (const IntrinsicPrior& prior : freedom(e).intrinsic_priors) {
        const int k = static_cast<int>(prior.intrinsic);
        if (!std::binary_search(held.begin(), held.end(), k)) out.emplace_back(k, prior.sigma);
      }
    return out;
  }

  /// Whether image i's affine block is free: its epoch frees the affine part and, per camera,
  /// so does every epoch the camera serves.
  bool affine_free(std::size_t i) const { return affine_free_[affine_slot_[i]]; }

  /// The adjusted frame of image i. Precondition: valid camera values (throws diachron::Error).
  Frame<FraserAffine> frame(std::size_t i) const {
    const auto c = static_cast<std::size_t>(camera_[i]);
    return Frame<FraserAffine>(camera_from_blocks(cameras_[c].data(), affine_block_of(i).data(), sizes_[i].first, sizes_[i].second),
                               pose_from_block(poses_[i].data()));
  }

  /// Reprojection error (px) of an observation with the current values; +inf when the point is
  /// behind the camera.
  double residual_px(const Observation& o) const {
    SplitAffineReprojectionError error(o.pixel, 1.0);
    const auto i = static_cast<std::size_t>(o.image);
    double r[2];
    if (!error(cameras_[static_cast<std::size_t>(camera_[i])].data(), affine_block_of(i).data(), poses_[i].data(),
               points_[o.track].data(), r))
      return std::numeric_limits<double>::infinity();
    return std::hypot(r[0], r[1]);
  }

  /// RMS per epoch and kind over the active observations with the current values.
  ReprojectionRms rms() const {
    std::vector<double> sum_epoch(static_cast<std::size_t>(epochs_), 0.0);
    ReprojectionRms out;
    out.by_epoch.assign(static_cast<std::size_t>(epochs_), {});
    double sum_intra = 0.0, sum_inter = 0.0;
    for (const Observation& o : observations_) {
      if (!o.active) continue;
      const double r2 = std::pow(residual_px(o), 2);
      const auto e = static_cast<std::size_t>(epoch_[static_cast<std::size_t>(o.image)]);
      sum_epoch[e] += r2;
      ++out.by_epoch[e].observations;
      (o.kind == ObservationKind::inter_epoch ? sum_inter : sum_intra) += r2;
      ++(o.kind == ObservationKind::inter_epoch ? out.inter_epoch : out.intra_epoch).observations;
    }
    const auto finish = [](ResidualRms& r, double sum) {
      if (r.observations > 0) r.rms_px = std::sqrt(sum / static_cast<double>(r.observations));
    };
    double total = 0.0;
    for (std::size_t e = 0; e < sum_epoch.size(); ++e) {
      finish(out.by_epoch[e], sum_epoch[e]);
      total += sum_epoch[e];
    }
    finish(out.intra_epoch, sum_intra);
    finish(out.inter_epoch, sum_inter);
    out.all.observations = out.intra_epoch.observations + out.inter_epoch.observations;
    finish(out.all, total);
    return out;
  }

  /// Adds the active observations, the GCP priors and the freedom of every block to `problem`.
  /// Blocks on which no active observation rests are not added. Gauge: when no pose is held
  /// fixed and fewer than 3 GCPs have their point in the problem (fewer cannot fix a 3D
  /// similarity), the first observed image's pose is held fixed and, against scale, the centre
  /// coordinate of the farthest observed image along the axis of largest separation.
  void add_to(ceres::Problem& problem, IntrinsicsStage stage) {
    std::vector<bool> image_used(image_count(), false);
    for (const Observation& o : observations_) {
      if (!o.active) continue;
      const auto i = static_cast<std::size_t>(o.image);
      image_used[i] = true;
      const double sigma =
          o.kind == ObservationKind::inter_epoch ? options_.inter_epoch_sigma_px : options_.intra_epoch_sigma_px;
      problem.AddResidualBlock(SplitAffineReprojectionError::create(o.pixel, sigma, o.weight), make_loss(sigma),
                               cameras_[static_cast<std::size_t>(camera_[i])].data(), affine_block_of(i).data(), poses_[i].data(),
                               points_[o.track].data());
    }
    std::size_t priors = 0;
    for (const GroundControlPoint& g : control_) {
      if (!problem.HasParameterBlock(points_[g.track].data())) continue;
      problem.AddResidualBlock(PointPriorError::create(g.position, g.sigma), nullptr, points_[g.track].data());
      ++priors;
    }
    bool any_pose_fixed = false;
    for (std::size_t i = 0; i < image_count(); ++i) {
      if (!image_used[i]) continue;
      const EpochFreedom f = freedom(epoch_[i]);
      if (!f.poses) {
        problem.SetParameterBlockConstant(poses_[i].data());
        any_pose_fixed = true;
      }
      if (!affine_free(i) || stage != IntrinsicsStage::all) problem.SetParameterBlockConstant(affine_block_of(i).data());
    }
    for (std::size_t c = 0; c < camera_count(); ++c) {
      double* block = cameras_[c].data();
      if (!problem.HasParameterBlock(block)) continue;
      std::vector<int> held = held_intrinsics(c);
      if (stage == IntrinsicsStage::focal_principal_point) held.insert(held.end(), {3, 4, 5, 6, 7});
      if (stage == IntrinsicsStage::radial) held.insert(held.end(), {6, 7});
      std::sort(held.begin(), held.end());
      held.erase(std::unique(held.begin(), held.end()), held.end());
      if (!camera_free(c) || held.size() == static_cast<std::size_t>(kFraserCameraBlockSize)) {
        problem.SetParameterBlockConstant(block);
        continue;
      }
      if (!held.empty()) problem.SetManifold(block, new ceres::SubsetManifold(kFraserCameraBlockSize, held));
      // Priors tie the free intrinsics to the input's values (not to an earlier solve's); not those
      // a stage holds.
      for (const auto& [index, sigma] : intrinsic_priors(c)) {
        if (std::binary_search(held.begin(), held.end(), index)) continue;
        const double centre = initial_cameras_[c][static_cast<std::size_t>(index)];
        problem.AddResidualBlock(IntrinsicPriorError::create(index, centre, sigma), nullptr, block);
      }
    }
    if (!any_pose_fixed && priors < 3) fix_gauge(problem, image_used);
  }

  /// Number of residuals (2 per active observation, 3 per GCP, 1 per intrinsic prior) and of free
  /// parameters in `problem` (its tangent size): their difference is the redundancy.
  static double redundancy(const ceres::Problem& problem) {
    return static_cast<double>(problem.NumResiduals()) - static_cast<double>(free_parameters(problem));
  }

 private:
  static int free_parameters(const ceres::Problem& problem) {
    std::vector<double*> blocks;
    problem.GetParameterBlocks(&blocks);
    int free = 0;
    for (double* b : blocks)
      if (!problem.IsParameterBlockConstant(b)) free += problem.ParameterBlockTangentSize(b);
    return free;
  }

  ceres::LossFunction* make_loss(double sigma) const {
    const double scale = options_.loss_scale_px / sigma;  // the whitened residual's scale
    switch (options_.loss) {
      case RobustLoss::huber: return new ceres::HuberLoss(scale);
      case RobustLoss::cauchy: return new ceres::CauchyLoss(scale);
      case RobustLoss::none: break;
    }
    return nullptr;
  }

  void fix_gauge(ceres::Problem& problem, const std::vector<bool>& image_used) {
    std::size_t first = image_count();
    for (std::size_t i = 0; i < image_count() && first == image_count(); ++i)
      if (image_used[i]) first = i;
    if (first == image_count()) return;
    problem.SetParameterBlockConstant(poses_[first].data());
    std::size_t far = first;
    double best = 0.0;
    int axis = 0;
    for (std::size_t i = 0; i < image_count(); ++i) {
      if (!image_used[i] || i == first) continue;
      for (int a = 0; a < 3; ++a) {
        const double d = std::abs(poses_[i][static_cast<std::size_t>(3 + a)] - poses_[first][static_cast<std::size_t>(3 + a)]);
        if (d > best) {
          best = d;
          far = i;
          axis = a;
        }
      }
    }
    if (far != first && !problem.IsParameterBlockConstant(poses_[far].data()))
      problem.SetManifold(poses_[far].data(), new ceres::SubsetManifold(kPoseBlockSize, {3 + axis}));
  }

  BundleOptions options_;
  std::vector<int> epoch_;
  std::vector<int> camera_;
  int epochs_ = 0;
  std::vector<std::array<double, kFraserCameraBlockSize>> cameras_;
  std::vector<std::array<double, kFraserCameraBlockSize>> initial_cameras_;  // the priors' centres
  std::vector<std::array<double, kAffineBlockSize>> affine_;  ///< per image or per camera
  std::vector<std::size_t> affine_slot_;                       ///< image -> its entry of affine_
  std::vector<bool> affine_free_;                              ///< per entry of affine_
  std::vector<std::array<double, kPoseBlockSize>> poses_;
  std::vector<std::pair<int, int>> sizes_;
  std::vector<std::array<double, 3>> points_;
  std::vector<Observation> observations_;
  std::vector<GroundControlPoint> control_;
};

}  // namespace diachron
