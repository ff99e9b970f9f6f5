#pragma once
/// @file
/// Helmert3Estimator: the Estimator (robust/estimator.hpp) for 3D Helmert transforms from 3D point
/// pairs, with a 3-point minimal solver and a weighted Procrustes refit.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/core/error.hpp>
#include <diachron/core/static_vector.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/procrustes.hpp>

namespace diachron {

/// Options of Helmert3Estimator.
struct Helmert3EstimatorOptions {
  /// false: rigid (scale fixed to 1).
  bool estimate_scale = true;
  /// Horn's symmetric scale in minimal() and refine() (see ProcrustesOptions::symmetric_scale).
  /// Both scales are exact on noise-free data.
  bool symmetric_scale = false;
  /// Two points count as coincident when their distance is at most this fraction of their largest
  /// absolute coordinate (dimensionless, in [0, 1)); well above rounding also for ECEF coordinates.
  double coincidence_tolerance = 1e-10;
  /// A sample triangle counts as collinear when its height over its longest side is at most this
  /// (dimensionless, in [0, 1)): 2 * area / longest_side^2, invariant to translation and scale.
  double collinearity_tolerance = 1e-6;

  /// Throws diachron::Error when a field is out of range.
  void check() const {
    DIACHRON_CHECK(std::isfinite(coincidence_tolerance) && coincidence_tolerance >= 0.0 &&
                       coincidence_tolerance < 1.0,
                   "coincidence_tolerance " << coincidence_tolerance << " must be in [0, 1)");
    DIACHRON_CHECK(std::isfinite(collinearity_tolerance) && collinearity_tolerance >= 0.0 &&
                       collinearity_tolerance < 1.0,
                   "collinearity_tolerance " << collinearity_tolerance << " must be in [0, 1)");
  }
};

/// Estimator of `X2 = scale * R * X1 + T` (a Helmert3, `epoch2_from_epoch1`) from PointPair3
/// data (source in epoch 1, target in epoch 2), for diachron::Ransac. The paper runs it on
/// DSM-lifted matches, with a threshold of 10 x the secondary image's GSD.
///
/// - minimal: 3 pairs (7 parameters from 9 equations), least squares on the sample, which is exact
///   on noise-free data; one model or none.
/// - residual: |X2 - model(X1)| in target (epoch 2) units, not squared.
/// - refine: weighted least squares (fit_helmert3).
/// - degenerate: coincident or collinear source or target triangle. The test works on differences
///   (centred data): a triangle on a plane through the origin is fine (unlike an uncentred rank).
/// Stateless apart from its options; all members const, so one object can serve many threads.
class Helmert3Estimator {
 public:
  using Datum = PointPair3;
  using Model = Helmert3;
  using Options = Helmert3EstimatorOptions;
  static constexpr std::size_t kSampleSize = 3;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = StaticVector<Model, kMaxModels>;

  Helmert3Estimator() = default;
  /// Precondition: `options.check()` passes (throws diachron::Error otherwise).
  explicit Helmert3Estimator(const Options& options) : options_(options) { options_.check(); }

  const Options& options() const { return options_; }

  /// The Helmert through the three pairs; empty when the sample does not determine one.
  Models minimal(const Sample& sample) const {
    Models models;
    const std::optional<Model> model = fit_helmert3(sample, nullptr, procrustes_options());
    if (model) models.push_back(*model);
    return models;
  }

  /// residual(model, .) with scale * R formed once: the RANSAC hot loop.
  /// operator() is the distance, squared() its square (operator() == std::sqrt(squared())).
  struct ResidualFunction {
    Eigen::Matrix3d sr;
    Eigen::Vector3d t;
    double squared(const Datum& datum) const {
      return (sr * datum.source + t - datum.target).squaredNorm();
    }
    double operator()(const Datum& datum) const { return std::sqrt(squared(datum)); }
  };

  ResidualFunction residual_function(const Model& model) const {
    return ResidualFunction{model.scale * model.rotation, model.translation};
  }

  /// |X2 - model(X1)| in target units.
  double residual(const Model& model, const Datum& datum) const { return residual_function(model)(datum); }

  /// Weighted least-squares Helmert on `data` (`initial` is not needed: the fit is closed form).
  /// `weights` null for unit weights, else one finite weight >= 0 per datum. nullopt when the data
  /// do not determine a model (see fit_similarity()).
  std::optional<Model> refine(const Model& initial, const Subset<Datum>& data,
                              const double* weights) const {
    static_cast<void>(initial);
    return fit_helmert3(data, weights, procrustes_options());
  }

  /// True when the source or the target triangle has coincident or collinear corners (or is not
  /// finite).
  bool degenerate(const Sample& sample) const {
    return degenerate_triangle(sample[0].source, sample[1].source, sample[2].source) ||
           degenerate_triangle(sample[0].target, sample[1].target, sample[2].target);
  }

 private:
  ProcrustesOptions procrustes_options() const {
    ProcrustesOptions procrustes;
    procrustes.estimate_scale = options_.estimate_scale;
    procrustes.symmetric_scale = options_.symmetric_scale;
    return procrustes;
  }

  bool degenerate_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                           const Eigen::Vector3d& c) const {
    const Eigen::Vector3d ab = b - a;
    const Eigen::Vector3d ac = c - a;
    const Eigen::Vector3d bc = c - b;
    const double magnitude =
        std::max({a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff(), c.cwiseAbs().maxCoeff()});
    const double shortest2 = std::min({ab.squaredNorm(), ac.squaredNorm(), bc.squaredNorm()});
    const double longest2 = std::max({ab.squaredNorm(), ac.squaredNorm(), bc.squaredNorm()});
    const double twice_area = ab.cross(ac).norm();
    if (!std::isfinite(magnitude) || !std::isfinite(longest2) || !std::isfinite(twice_area)) {
      return true;
    }
    const double min_distance = options_.coincidence_tolerance * magnitude;
    if (!(shortest2 > min_distance * min_distance)) return true;
    return !(twice_area > options_.collinearity_tolerance * longest2);
  }

  Options options_{};
};

}  // namespace diachron
