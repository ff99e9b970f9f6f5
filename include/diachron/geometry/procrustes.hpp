#pragma once
/// @file
/// Weighted similarity Procrustes in 2D and 3D (Umeyama, PAMI 1991, with weights; Horn's symmetric
/// scale as an option): the closed-form least-squares fit behind Similarity2 and Helmert3 refits.

#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>

#include <Eigen/Core>
#include <Eigen/LU>  // determinant()
#include <Eigen/SVD>

#include <diachron/core/error.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/similarity2.hpp>

namespace diachron {

/// What the Procrustes fit estimates besides the rotation and translation.
struct ProcrustesOptions {
  /// false: rigid fit, scale fixed to 1.
  bool estimate_scale = true;
  /// Only with estimate_scale. false: Umeyama's scale, which minimises the weighted squared error
  /// in the target frame (so scale(a->b) != 1 / scale(b->a) under noise). true: Horn's symmetric
  /// scale s = sqrt(sum w |y_c|^2 / sum w |x_c|^2), independent of the rotation, so fitting b->a
  /// gives exactly the inverse scale; pick it when neither epoch is privileged.
  bool symmetric_scale = false;
};

/// The result of a Procrustes fit: `target = scale * rotation * source + translation`.
/// `rotation` is proper (det +1); `scale` > 0 (1 for a rigid fit); `translation` in target units.
template <int D>
struct SimilarityFit {
  double scale = 1.0;
  Eigen::Matrix<double, D, D> rotation = Eigen::Matrix<double, D, D>::Identity();
  Eigen::Matrix<double, D, 1> translation = Eigen::Matrix<double, D, 1>::Zero();
};

/// Relative tolerance of the rank test on the centred, weighted cross-covariance: in 3D the second
/// singular value below this fraction of the first (about a 1e-7 width-to-length ratio for exact
/// data) means collinear data, whose rotation about the line is undetermined.
inline constexpr double kProcrustesRankTolerance = 1e-14;

/// Weighted least-squares similarity between corresponding points, minimising
/// sum_i w_i |target_i - (s R source_i + t)|^2 over proper rotations R (and s when estimated).
///
/// Algorithm: one pass of weighted sums after subtracting a point near the centroid (so UTM or ECEF
/// coordinates of 5e6 m keep their precision), centred cross-covariance
/// Sigma = sum w y_c x_c^T / W from them, then in 3D
/// Sigma = U D V^T and R = U S V^T with S = diag(1, 1, sign(det U det V)) (Umeyama's reflection
/// fix); in 2D the optimal angle atan2(Sigma10 - Sigma01, Sigma00 + Sigma11) in closed form.
///
/// @tparam D     2 or 3.
/// @tparam Pairs anything with `size()` and `operator[](i)` giving an object with `.source` and
///               `.target` convertible to Eigen::Matrix<double, D, 1>: std::vector<PointPair3>,
///               Subset<PointPair2>, ...
/// @param weights null for unit weights, otherwise `pairs.size()` finite weights >= 0. Pairs with
///               zero weight are ignored entirely, even when their coordinates are not finite.
/// @return nullopt when the data do not determine a proper rotation: zero total weight, fewer than
///         2 distinct points, all coincident, collinear in 3D (rank of Sigma < D - 1), a weighted
///         point with non-finite coordinates, or a 2D set whose best rotation is undetermined.
/// Precondition (throws diachron::Error): every weight finite and >= 0.
template <int D, class Pairs>
std::optional<SimilarityFit<D>> fit_similarity(const Pairs& pairs, const double* weights = nullptr,
                                               const ProcrustesOptions& options = {});

/// fit_similarity<2> as a Similarity2 (angle in (-pi, pi]).
template <class Pairs>
std::optional<Similarity2> fit_similarity2(const Pairs& pairs, const double* weights = nullptr,
                                           const ProcrustesOptions& options = {});

/// fit_similarity<3> as a Helmert3 (`epoch2_from_epoch1` when sources are epoch 1).
template <class Pairs>
std::optional<Helmert3> fit_helmert3(const Pairs& pairs, const double* weights = nullptr,
                                     const ProcrustesOptions& options = {});

// Implementation ---------------------------------------------------------------------------------

template <int D, class Pairs>
std::optional<SimilarityFit<D>> fit_similarity(const Pairs& pairs, const double* weights,
                                               const ProcrustesOptions& options) {
  static_assert(D == 2 || D == 3, "fit_similarity supports D = 2 and D = 3");
  using VecD = Eigen::Matrix<double, D, 1>;
  using MatD = Eigen::Matrix<double, D, D>;
  const std::size_t n = pairs.size();
  auto weight = [weights](std::size_t i) { return weights ? weights[i] : 1.0; };

  if (weights) {
    for (std::size_t i = 0; i < n; ++i) {
      DIACHRON_CHECK(std::isfinite(weights[i]) && weights[i] >= 0.0,
                     "weight " << i << " is " << weights[i] << ", must be finite and >= 0");
    }
  }

  // One pass of shifted sums. Subtracting a point near the centroid (the mean of up to 256 pairs
  // spread over the set) keeps every sum in the range of the data's extent rather than of its
  // absolute coordinates (UTM, ECEF), and keeps the cancellation in "mean of products minus product
  // of means" to a digit or so; a second pass over the data for exact centring would cost as much
  // again, and in RANSAC's final refit over all inliers the data are the bottleneck.
  constexpr std::size_t kShiftSamples = 256;
  const std::size_t stride = n > kShiftSamples ? n / kShiftSamples : 1;
  VecD source_ref = VecD::Zero();
  VecD target_ref = VecD::Zero();
  std::size_t shift_count = 0;
  for (std::size_t i = 0; i < n; i += stride) {
    if (weight(i) > 0.0 && VecD(pairs[i].source).allFinite() && VecD(pairs[i].target).allFinite()) {
      source_ref += VecD(pairs[i].source);
      target_ref += VecD(pairs[i].target);
      ++shift_count;
    }
  }
  if (shift_count == 0) {  // every strided pair unweighted or not finite: take the first usable
    for (std::size_t i = 0; i < n && shift_count == 0; ++i) {
      if (weight(i) > 0.0 && VecD(pairs[i].source).allFinite() &&
          VecD(pairs[i].target).allFinite()) {
        source_ref = pairs[i].source;
        target_ref = pairs[i].target;
        shift_count = 1;
      }
    }
    if (shift_count == 0) return std::nullopt;
  }
  source_ref /= static_cast<double>(shift_count);
  target_ref /= static_cast<double>(shift_count);

  double total_weight = 0.0;
  VecD source_sum = VecD::Zero();
  VecD target_sum = VecD::Zero();
  MatD cross = MatD::Zero();
  double source_squares = 0.0;
  double target_squares = 0.0;
  const auto add = [&](std::size_t i, double w) {
    const VecD s = VecD(pairs[i].source) - source_ref;
    const VecD t = VecD(pairs[i].target) - target_ref;
    total_weight += w;
    source_sum += w * s;
    target_sum += w * t;
    for (int r = 0; r < D; ++r) {  // cross += w t s^T, without an outer-product expression
      const double wt = w * t(r);
      for (int c = 0; c < D; ++c) cross(r, c) += wt * s(c);
    }
    source_squares += w * s.squaredNorm();
    target_squares += w * t.squaredNorm();
  };
  if (weights) {
    for (std::size_t i = 0; i < n; ++i) {
      if (weights[i] != 0.0) add(i, weights[i]);  // zero weight: ignored, finite or not
    }
  } else {
    for (std::size_t i = 0; i < n; ++i) add(i, 1.0);
  }
  // A non-finite coordinate of a weighted pair makes the sums non-finite: no per-datum test.
  if (!(total_weight > 0.0) || !std::isfinite(total_weight) || !source_sum.allFinite() ||
      !target_sum.allFinite() || !cross.allFinite() || !std::isfinite(source_squares) ||
      !std::isfinite(target_squares)) {
    return std::nullopt;
  }
  const VecD source_mean = source_sum / total_weight;
  const VecD target_mean = target_sum / total_weight;
  MatD sigma;
  for (int r = 0; r < D; ++r) {
    for (int c = 0; c < D; ++c) sigma(r, c) = cross(r, c) / total_weight - target_mean(r) * source_mean(c);
  }
  const double source_var = source_squares / total_weight - source_mean.squaredNorm();
  const double target_var = target_squares / total_weight - target_mean.squaredNorm();
  // A variance within rounding of the raw second moment is zero: all points coincide.
  const double resolution = 16.0 * std::numeric_limits<double>::epsilon() / total_weight;
  if (!(source_var > resolution * source_squares) || !(target_var > resolution * target_squares) ||
      !sigma.allFinite()) {
    return std::nullopt;
  }

  SimilarityFit<D> fit;
  double correlation = 0.0;  // trace(D S): the maximised sum sum w y_c . R x_c / W
  if constexpr (D == 2) {
    const double c = sigma(0, 0) + sigma(1, 1);
    const double s = sigma(1, 0) - sigma(0, 1);
    correlation = std::hypot(c, s);
    // Zero when the target is a reflection (or a point) of the source: no best rotation.
    if (!(correlation > kProcrustesRankTolerance * std::sqrt(source_var * target_var))) {
      return std::nullopt;
    }
    fit.rotation = rotation2<double>(std::atan2(s, c));
  } else {
    const Eigen::JacobiSVD<MatD> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const VecD singular = svd.singularValues();
    if (!(singular(0) > 0.0) || !(singular(1) > kProcrustesRankTolerance * singular(0))) {
      return std::nullopt;
    }
    // R = U diag(1, 1, sign) V^T, sign = -1 when U V^T would be a reflection.
    MatD u = svd.matrixU();
    const double sign = u.determinant() * svd.matrixV().determinant() < 0.0 ? -1.0 : 1.0;
    u.col(D - 1) *= sign;
    fit.rotation.noalias() = u * svd.matrixV().transpose();
    correlation = singular(0) + singular(1) + sign * singular(2);
  }

  if (!options.estimate_scale) {
    fit.scale = 1.0;
  } else if (options.symmetric_scale) {
    fit.scale = std::sqrt(target_var / source_var);
  } else {
    fit.scale = correlation / source_var;
  }
  const VecD source_centroid = source_ref + source_mean;
  const VecD target_centroid = target_ref + target_mean;
  fit.translation = target_centroid - fit.scale * (fit.rotation * source_centroid);
  if (!(fit.scale > 0.0) || !std::isfinite(fit.scale) || !fit.rotation.allFinite() ||
      !fit.translation.allFinite()) {
    return std::nullopt;
  }
  return fit;
}

template <class Pairs>
std::optional<Similarity2> fit_similarity2(const Pairs& pairs, const double* weights,
                                           const ProcrustesOptions& options) {
  const std::optional<SimilarityFit<2>> fit = fit_similarity<2>(pairs, weights, options);
  if (!fit) return std::nullopt;
  // wrap_angle: atan2 gives -pi for a -0.0 sine, the convention is (-pi, pi].
  return Similarity2{fit->scale, wrap_angle(std::atan2(fit->rotation(1, 0), fit->rotation(0, 0))),
                     fit->translation};
}

template <class Pairs>
std::optional<Helmert3> fit_helmert3(const Pairs& pairs, const double* weights,
                                     const ProcrustesOptions& options) {
  const std::optional<SimilarityFit<3>> fit = fit_similarity<3>(pairs, weights, options);
  if (!fit) return std::nullopt;
  return Helmert3{fit->scale, fit->rotation, fit->translation};
}

}  // namespace diachron
