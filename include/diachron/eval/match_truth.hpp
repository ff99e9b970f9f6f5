#pragma once
/// @file
/// The true error of a match between two images of a synthetic scene, and accuracy curves over
/// many matches (MicMac's TiePtEvaluation: share of matches within t px). Needs Eigen and the
/// standard library only.
///
/// Truth of a match (pixel_a in image a, pixel_b in image b): the ray of pixel_a (true camera,
/// true world pose of image a) meets epoch a's true surface at the ground point X; X projected by
/// image b's true camera and pose is the true pixel; the error is |pixel_b - true pixel|. A match
/// cannot be scored when that ray misses the surface, X is not in image b, image b's epoch has
/// another surface at X (a building built or demolished in between), or X is hidden from image b.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/ray.hpp>
#include <diachron/synth/render.hpp>
#include <diachron/synth/scene.hpp>

namespace diachron {

/// An image of a scene: index of the epoch in Scene::epochs, index of the image in that epoch.
struct ImageRef {
  int epoch = 0;
  int image = 0;
};

/// Why a match has, or has no, true error.
enum class MatchTruthStatus {
  scored,           ///< true_pixel and (for score()) error_px are valid
  no_surface,       ///< the ray of pixel_a misses epoch a's true surface (or cannot be cast)
  off_image,        ///< the ground point is behind image b's camera or outside its image
  occluded,         ///< image b's ray towards the ground point meets its surface elsewhere first
  changed_surface,  ///< the two epochs' true surfaces differ at the ground point (new/removed building)
};

/// The truth of one match. Pixels in diachron's convention ((0, 0) = centre of the top-left pixel).
struct MatchTruth {
  /// Default: not scored.
  MatchTruthStatus status = MatchTruthStatus::no_surface;
  /// True position of pixel_a's ground point in image b, px: valid when scored; also set when
  /// off_image and the point is in front of camera b (it then lies outside the image), so that a
  /// bench can tell how far such a match is off; NaN otherwise.
  Eigen::Vector2d true_pixel = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// |pixel_b - true_pixel|, px (valid when scored by score(); NaN from transfer()).
  double error_px = std::numeric_limits<double>::quiet_NaN();

  bool scored() const { return status == MatchTruthStatus::scored; }
};

/// Tolerances of MatchTruthScorer, metres of the world frame.
struct MatchTruthOptions {
  /// Image b sees the ground point when its ray through the true pixel meets epoch b's true
  /// surface within this distance of the point. Must exceed the height differences that
  /// change_tolerance_m lets through (a ray meets a surface raised by dz about dz / cos(view
  /// angle) early). > 0.
  double occlusion_tolerance_m = 0.5;
  /// The two epochs' true surfaces count as the same at the point when their heights there differ
  /// by at most this. >= 0.
  double change_tolerance_m = 0.2;

  /// Precondition: as above, else throws diachron::Error.
  void check() const {
    DIACHRON_CHECK(occlusion_tolerance_m > 0.0 && std::isfinite(occlusion_tolerance_m),
                   "MatchTruthOptions::occlusion_tolerance_m must be > 0, got " << occlusion_tolerance_m);
    DIACHRON_CHECK(change_tolerance_m >= 0.0 && std::isfinite(change_tolerance_m),
                   "MatchTruthOptions::change_tolerance_m must be >= 0, got " << change_tolerance_m);
  }
};

/// Scores matches between images of a scene against its truth (true cameras, true world poses,
/// true surfaces). Keeps a reference to the scene, which must outlive it. score() and transfer()
/// are const and touch no shared mutable state: call them from any number of threads.
class MatchTruthScorer {
 public:
  /// Precondition: every epoch has a non-empty true surface, valid options; else diachron::Error.
  explicit MatchTruthScorer(const Scene& scene, MatchTruthOptions options = {}) : scene_(scene), options_(options) {
    options_.check();
    tracers_.reserve(scene.epochs.size());
    for (const SyntheticEpoch& epoch : scene.epochs) {
      DIACHRON_CHECK(!epoch.true_surface.empty(),
                     "MatchTruthScorer: epoch '" << epoch.name << "' has no true surface (a scene without its truth)");
      tracers_.emplace_back(epoch.true_surface);
    }
  }
  /// The scorer keeps a reference: a temporary scene would dangle.
  MatchTruthScorer(Scene&&, MatchTruthOptions = {}) = delete;

  const MatchTruthOptions& options() const { return options_; }

  /// The truth of the match (pixel_a in image a, pixel_b in image b): status, true pixel and error.
  /// Precondition: valid image references, finite pixels; else diachron::Error.
  MatchTruth score(ImageRef a, ImageRef b, const Eigen::Vector2d& pixel_a, const Eigen::Vector2d& pixel_b) const {
    DIACHRON_CHECK(pixel_b.allFinite(), "MatchTruthScorer::score: pixel_b is not finite");
    MatchTruth out = transfer(a, b, pixel_a);
    if (out.scored()) out.error_px = (pixel_b - out.true_pixel).norm();
    return out;
  }

  /// Where pixel_a's ground point truly is in image b (status scored), or why it is nowhere;
  /// error_px stays NaN. Precondition: valid image references, finite pixel; else diachron::Error.
  MatchTruth transfer(ImageRef a, ImageRef b, const Eigen::Vector2d& pixel_a) const {
    check_ref(a, "a");
    check_ref(b, "b");
    DIACHRON_CHECK(pixel_a.allFinite(), "MatchTruthScorer: pixel_a is not finite");
    MatchTruth out;
    const SyntheticEpoch& ea = scene_.epochs[static_cast<std::size_t>(a.epoch)];
    const SyntheticEpoch& eb = scene_.epochs[static_cast<std::size_t>(b.epoch)];
    const Frame<FraserAffine> frame_a = ea.world_frame(static_cast<std::size_t>(a.image));
    const Frame<FraserAffine> frame_b = eb.world_frame(static_cast<std::size_t>(b.image));

    const std::optional<Ray3> ray_a = frame_a.ray(pixel_a);
    if (!ray_a) return out;  // no_surface
    const std::optional<Vec3> ground = tracers_[static_cast<std::size_t>(a.epoch)].intersect(*ray_a);
    if (!ground) return out;  // no_surface

    const std::optional<Vec2> projected = frame_b.project(*ground);
    if (!projected || !frame_b.in_image(*projected)) {
      out.status = MatchTruthStatus::off_image;
      if (projected) out.true_pixel = *projected;
      return out;
    }
    // The change test compares the surfaces, not the point with surface b, so that it does not
    // depend on where on a slope the ray landed.
    const double za = ea.true_surface.height_at(ground->head<2>());
    const double zb = eb.true_surface.height_at(ground->head<2>());
    if (!(std::abs(za - zb) <= options_.change_tolerance_m)) {
      out.status = MatchTruthStatus::changed_surface;
      return out;
    }
    const std::optional<Ray3> ray_b = frame_b.ray(*projected);
    const std::optional<Vec3> seen =
        ray_b ? tracers_[static_cast<std::size_t>(b.epoch)].intersect(*ray_b) : std::nullopt;
    if (!seen || (*seen - *ground).norm() > options_.occlusion_tolerance_m) {
      out.status = MatchTruthStatus::occluded;
      return out;
    }
    out.status = MatchTruthStatus::scored;
    out.true_pixel = *projected;
    return out;
  }

 private:
  void check_ref(ImageRef r, const char* which) const {
    DIACHRON_CHECK(r.epoch >= 0 && static_cast<std::size_t>(r.epoch) < scene_.epochs.size(),
                   "MatchTruthScorer: image " << which << " refers to epoch " << r.epoch << ", the scene has "
                                              << scene_.epochs.size());
    const std::size_t n = scene_.epochs[static_cast<std::size_t>(r.epoch)].images.size();
    DIACHRON_CHECK(r.image >= 0 && static_cast<std::size_t>(r.image) < n,
                   "MatchTruthScorer: image " << which << " refers to image " << r.image << " of epoch " << r.epoch
                                              << ", which has " << n);
  }

  const Scene& scene_;
  MatchTruthOptions options_;
  std::vector<detail::SurfaceTracer> tracers_;
};

/// Accuracy curve in MicMac's TiePtEvaluation form: for t = 0, 1, ..., max_px, the share of the
/// scored matches whose error is at most t px.
struct AccuracyCurve {
  /// 0, 1, ..., max_px, px.
  std::vector<double> thresholds_px;
  /// share[i]: fraction (0..1) of the scored matches with error_px <= thresholds_px[i]; NaN when
  /// nothing was scored.
  std::vector<double> share;
  /// Matches that were scored, and those that were not (any other status).
  std::size_t scored = 0, unscored = 0;
  /// Errors of the scored matches, ascending, px: share_within() reads any threshold from them.
  std::vector<double> errors_px;

  /// Fraction of the scored matches with error_px <= t_px (NaN when nothing was scored).
  double share_within(double t_px) const {
    if (scored == 0) return std::numeric_limits<double>::quiet_NaN();
    const auto end = std::upper_bound(errors_px.begin(), errors_px.end(), t_px);
    return static_cast<double>(end - errors_px.begin()) / static_cast<double>(scored);
  }
};

/// The accuracy curve of `truths` for t = 0..max_px px. A truth counts as scored when its status is
/// scored and its error finite (results of transfer(), which have no error, count as unscored).
/// Precondition: max_px in [0, 1e6], else throws diachron::Error.
inline AccuracyCurve accuracy_curve(const std::vector<MatchTruth>& truths, int max_px = 10) {
  DIACHRON_CHECK(max_px >= 0 && max_px <= 1000000, "accuracy_curve: max_px must be in [0, 1e6], got " << max_px);
  AccuracyCurve curve;
  for (const MatchTruth& t : truths) {
    if (t.scored() && std::isfinite(t.error_px)) {
      curve.errors_px.push_back(t.error_px);
    } else {
      ++curve.unscored;
    }
  }
  curve.scored = curve.errors_px.size();
  std::sort(curve.errors_px.begin(), curve.errors_px.end());
  for (int t = 0; t <= max_px; ++t) {
    curve.thresholds_px.push_back(static_cast<double>(t));
    curve.share.push_back(curve.share_within(static_cast<double>(t)));
  }
  return curve;
}

}  // namespace diachron
