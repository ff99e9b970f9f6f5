#pragma once
/// @file
/// Similarity2Estimator: the Estimator (robust/estimator.hpp) for 2D similarities from point pairs,
/// with a 2-point closed-form minimal solver and a weighted Procrustes refit.

#include <array>
#include <cmath>
#include <cstddef>
#include <optional>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/static_vector.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/procrustes.hpp>
#include <diachron/geometry/similarity2.hpp>

namespace diachron {

/// Options of Similarity2Estimator.
struct Similarity2EstimatorOptions {
  /// false: rigid (scale fixed to 1; minimal() then returns the 2-point least-squares fit).
  bool estimate_scale = true;
  /// Horn's symmetric scale in refine() (see ProcrustesOptions::symmetric_scale). The minimal
  /// solver is exact, so there both scales agree.
  bool symmetric_scale = false;
  /// Two sample points count as coincident when their distance is at most this fraction of their
  /// largest absolute coordinate (dimensionless, in [0, 1)). The default sits well above double
  /// rounding, also for UTM coordinates (5e6 m -> 5e-4 m).
  double coincidence_tolerance = 1e-10;

  /// Throws diachron::Error when a field is out of range.
  void check() const {
    DIACHRON_CHECK(std::isfinite(coincidence_tolerance) && coincidence_tolerance >= 0.0 &&
                       coincidence_tolerance < 1.0,
                   "coincidence_tolerance " << coincidence_tolerance << " must be in [0, 1)");
  }
};

/// Estimator of `target = scale * R(angle) * source + translation` (a Similarity2) from
/// PointPair2 data, for diachron::Ransac. The paper's rough co-registration runs it on DSM-image
/// matches (1000 iterations, 10 px threshold).
///
/// - minimal: 2 pairs, exact closed form (complex ratio of the centred pair), one model or none.
/// - residual: Euclidean distance |target - model(source)| in target units (not squared).
/// - refine: weighted least squares (fit_similarity2).
/// - degenerate: coincident source or target points (relative tolerance, see options).
/// Stateless apart from its options; all members const, so one object can serve many threads.
class Similarity2Estimator {
 public:
  using Datum = PointPair2;
  using Model = Similarity2;
  using Options = Similarity2EstimatorOptions;
  static constexpr std::size_t kSampleSize = 2;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = StaticVector<Model, kMaxModels>;

  Similarity2Estimator() = default;
  /// Precondition: `options.check()` passes (throws diachron::Error otherwise).
  explicit Similarity2Estimator(const Options& options) : options_(options) { options_.check(); }

  const Options& options() const { return options_; }

  /// The similarity through both pairs; empty when the sample is degenerate or non-finite.
  Models minimal(const Sample& sample) const {
    Models models;
    // z = (t1 - t0) / (s1 - s0) as complex numbers: |z| is the scale, arg z the angle.
    const Eigen::Vector2d ds = sample[1].source - sample[0].source;
    const Eigen::Vector2d dt = sample[1].target - sample[0].target;
    const double norm2 = ds.squaredNorm();
    if (!(norm2 > 0.0) || !std::isfinite(norm2)) return models;
    const double re = (dt.x() * ds.x() + dt.y() * ds.y()) / norm2;
    const double im = (dt.y() * ds.x() - dt.x() * ds.y()) / norm2;
    Model model;
    model.scale = options_.estimate_scale ? std::hypot(re, im) : 1.0;
    if (!(model.scale > 0.0) || !std::isfinite(model.scale)) return models;
    model.angle = std::atan2(im, re);
    if (model.angle <= -kPi) model.angle = kPi;  // atan2(-0.0, x < 0) is -pi; keep (-pi, pi]
    // Translation from the midpoints: their difference is small even for UTM coordinates.
    const Eigen::Vector2d source_mid = sample[0].source + 0.5 * ds;
    const Eigen::Vector2d target_mid = sample[0].target + 0.5 * dt;
    model.translation = target_mid - model.scale * (rotation2(model.angle) * source_mid);
    if (!model.translation.allFinite() || !std::isfinite(model.angle)) return models;
    models.push_back(model);
    return models;
  }

  /// residual(model, .) with s cos(angle) and s sin(angle) computed once: the RANSAC hot loop.
  /// operator() is the distance, squared() its square (operator() == std::sqrt(squared())).
  struct ResidualFunction {
    double a, b, tx, ty;
    double squared(const Datum& datum) const {
      const double ex = a * datum.source.x() - b * datum.source.y() + tx - datum.target.x();
      const double ey = b * datum.source.x() + a * datum.source.y() + ty - datum.target.y();
      return ex * ex + ey * ey;
    }
    double operator()(const Datum& datum) const { return std::sqrt(squared(datum)); }
  };

  ResidualFunction residual_function(const Model& model) const {
    return ResidualFunction{model.scale * std::cos(model.angle),
                            model.scale * std::sin(model.angle), model.translation.x(),
                            model.translation.y()};
  }

  /// |target - model(source)| in target units.
  double residual(const Model& model, const Datum& datum) const { return residual_function(model)(datum); }

  /// Weighted least-squares similarity on `data` (`initial` is not needed: the fit is closed form).
  /// `weights` null for unit weights, else one finite weight >= 0 per datum. nullopt when the data
  /// do not determine a model (see fit_similarity()).
  std::optional<Model> refine(const Model& initial, const Subset<Datum>& data,
                              const double* weights) const {
    static_cast<void>(initial);
    ProcrustesOptions procrustes;
    procrustes.estimate_scale = options_.estimate_scale;
    procrustes.symmetric_scale = options_.symmetric_scale;
    return fit_similarity2(data, weights, procrustes);
  }

  /// True when the two source points or the two target points coincide (or are not finite).
  bool degenerate(const Sample& sample) const {
    return coincident(sample[0].source, sample[1].source) ||
           coincident(sample[0].target, sample[1].target);
  }

 private:
  bool coincident(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const {
    const double magnitude = std::fmax(a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff());
    const double distance = (b - a).norm();
    if (!std::isfinite(magnitude) || !std::isfinite(distance)) return true;
    return !(distance > options_.coincidence_tolerance * magnitude);
  }

  Options options_{};
};

}  // namespace diachron
