#pragma once
/// @file
/// Homography2Estimator: the Estimator (robust/estimator.hpp) for plane homographies from point
/// pairs (orthophotos of two epochs without a DSM), with an exact 4-point solver, a weighted
/// normalised DLT refit and sample tests for collinear, coincident and orientation-flipping
/// samples.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <diachron/core/error.hpp>
#include <diachron/core/static_vector.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/homography.hpp>

namespace diachron {

/// Options of Homography2Estimator.
struct Homography2EstimatorOptions {
  /// Two sample points count as coincident when their distance is at most this fraction of their
  /// largest absolute coordinate (dimensionless, in [0, 1)). Well above double rounding, also for
  /// UTM coordinates (5e6 m -> 5e-4 m).
  double coincidence_tolerance = 1e-10;
  /// Three sample points count as collinear when the height of their triangle over its longest
  /// side is at most this fraction of that side (2 * area / longest_side^2; dimensionless, in
  /// [0, 1)); invariant to translation and scale. Four points with three collinear do not
  /// determine a homography (or only a singular one).
  double collinearity_tolerance = 1e-6;
  /// false (default): refuse samples whose homography mirrors the image (reverses orientation).
  /// Two views of the ground from above, or two north-up orthophotos, never differ by a mirror,
  /// and a 2D similarity cannot mirror either. true: accept them (a scan mirrored by mistake).
  bool allow_reflection = false;

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

/// Estimator of `[x_t, y_t, 1]^T ~ H [x_s, y_s, 1]^T` (a Homography2, `target_from_source`) from
/// PointPair2 data, for diachron::Ransac: the map between orthophotos of two epochs when there is
/// no DSM to lift them to 3D.
///
/// - minimal: 4 pairs, exact: each point set, centred and scaled, is mapped from the projective
///   basis, H = B_t B_s^-1 (no SVD). One model or none: none when the homography is singular or
///   does not map the sample consistently (its homogeneous w changes sign across the sample: the
///   vanishing line cuts the sample), or mirrors it (unless allow_reflection).
/// - residual: the transfer error |target - H(source)| in target units (px), not squared; +inf
///   where the source maps to (near) the line at infinity. One-sided, like the other estimators,
///   so that RansacOptions::threshold is in target px. The symmetric transfer error would add a
///   source-side error in other units (source px), for no gain when the target is the reference.
/// - refine: weighted normalised DLT (Hartley) on any number of pairs: least squares of the
///   algebraic error after normalisation, which is the transfer error to first order near the
///   solution. No iterative minimisation of the transfer error.
/// - degenerate: non-finite, coincident or collinear (any three of four) source or target points,
///   and samples no homography maps consistently: the orientation (sign of the signed area) of the
///   four triangles, source against target, must agree, and with allow_reflection false be kept.
///   For an exact homography this is the same test as the sign of w in minimal (target area =
///   det(H) / (w_a w_b w_c) * source area), made before any solve. Ransac redraws refused
///   samples within the iteration: at 80 % outliers about 8 draws in 9 are refused, so an
///   iteration is more likely to be all-inlier than the Adaptive rule assumes, which errs on the
///   safe side (it stops no earlier).
/// Models have unit Frobenius norm and w > 0 at the (weighted) centroid of the source points they
/// were fit on. Stateless apart from its options; all members const, so one object can serve many
/// threads.
class Homography2Estimator {
 public:
  using Datum = PointPair2;
  using Model = Homography2;
  using Options = Homography2EstimatorOptions;
  static constexpr std::size_t kSampleSize = 4;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = StaticVector<Model, kMaxModels>;

  /// A model whose normalised matrix (unit Frobenius norm, normalised coordinates) has a
  /// determinant of at most this, in absolute value, counts as singular (the bound of
  /// estimate_homography()).
  static constexpr double kMinRelativeDeterminant = 1e-10;

  Homography2Estimator() = default;
  /// Precondition: `options.check()` passes (throws diachron::Error otherwise).
  explicit Homography2Estimator(const Options& options) : options_(options) { options_.check(); }

  const Options& options() const { return options_; }

  /// The homography through the four pairs; empty when the sample does not determine a regular,
  /// consistently oriented one (see the class comment) or is not finite.
  Models minimal(const Sample& sample) const {
    Models models;
    std::array<Vec2, kSampleSize> source, target;
    for (std::size_t i = 0; i < kSampleSize; ++i) {
      source[i] = sample[i].source;
      target[i] = sample[i].target;
    }
    const std::optional<Eigen::Matrix3d> ns = normalisation(source);
    const std::optional<Eigen::Matrix3d> nt = normalisation(target);
    if (!ns || !nt) return models;
    // Basis matrices: columns are the first three points, scaled so that they sum to the fourth.
    // Then H_n = M_t diag(mu / lambda) M_s^-1 maps the normalised sources onto the normalised
    // targets, with w = mu_i / lambda_i at points 0, 1, 2 and w = 1 at point 3.
    Eigen::Matrix3d ms, mt;
    for (Eigen::Index i = 0; i < 3; ++i) {
      ms.col(i) = *ns * source[static_cast<std::size_t>(i)].homogeneous();
      mt.col(i) = *nt * target[static_cast<std::size_t>(i)].homogeneous();
    }
    const Eigen::Vector3d s3 = *ns * source[3].homogeneous();
    const Eigen::Vector3d t3 = *nt * target[3].homogeneous();
    bool invertible_s = false, invertible_t = false;
    Eigen::Matrix3d ms_inverse, mt_inverse;
    double det_s = 0.0, det_t = 0.0;
    ms.computeInverseAndDetWithCheck(ms_inverse, det_s, invertible_s, 0.0);
    mt.computeInverseAndDetWithCheck(mt_inverse, det_t, invertible_t, 0.0);
    if (!invertible_s || !invertible_t) return models;
    const Eigen::Vector3d lambda = ms_inverse * s3;
    const Eigen::Vector3d mu = mt_inverse * t3;
    Eigen::Vector3d w;
    for (Eigen::Index i = 0; i < 3; ++i) {
      w(i) = mu(i) / lambda(i);
      // Every w must be finite and positive: a zero is a collinear triple, a negative w a sample
      // cut by the vanishing line (w = 1 at point 3).
      if (!std::isfinite(w(i)) || !(w(i) > 0.0)) return models;
    }
    const Eigen::Matrix3d hn = mt * w.asDiagonal() * ms_inverse;
    if (!finish(hn, *ns, *nt, models)) models.clear();
    return models;
  }

  /// residual(model, .) with the matrix copied once: the RANSAC hot loop. operator() is the
  /// transfer error, squared() its square (operator() == std::sqrt(squared())), +inf where the
  /// source maps to (near) infinity (Homography2::operator() gives nullopt there).
  struct ResidualFunction {
    Eigen::Matrix3d h;
    double squared(const Datum& datum) const {
      const double x = datum.source.x();
      const double y = datum.source.y();
      const double w = h(2, 0) * x + h(2, 1) * y + h(2, 2);
      const double w_scale = std::abs(h(2, 0) * x) + std::abs(h(2, 1) * y) + std::abs(h(2, 2));
      if (!(std::abs(w) > Homography2::kMinRelativeW * w_scale)) {
        return std::numeric_limits<double>::infinity();
      }
      const double ex = (h(0, 0) * x + h(0, 1) * y + h(0, 2)) / w - datum.target.x();
      const double ey = (h(1, 0) * x + h(1, 1) * y + h(1, 2)) / w - datum.target.y();
      return ex * ex + ey * ey;
    }
    double operator()(const Datum& datum) const { return std::sqrt(squared(datum)); }
  };

  ResidualFunction residual_function(const Model& model) const {
    return ResidualFunction{model.matrix};
  }

  /// |target - model(source)| in target units; +inf where model(source) is nullopt.
  double residual(const Model& model, const Datum& datum) const {
    return residual_function(model)(datum);
  }

  /// Weighted normalised DLT on `data` (`initial` is not needed: the fit is closed form).
  /// `weights` null for unit weights, else one finite weight >= 0 per datum; data of weight 0 are
  /// ignored (also in the normalisation). Hartley's normalisation uses the weighted centroid and
  /// mean distance; the weighted 9 x 9 normal matrix of the DLT rows gives the solution as its
  /// eigenvector of the smallest eigenvalue. With unit weights this is estimate_homography()'s
  /// solution. nullopt when fewer than 4 data have a positive weight, a weighted coordinate or a
  /// weight is not finite, the data do not determine one homography (second eigenvalue at most
  /// 1e-12 of the largest: collinear sets) or it is singular.
  std::optional<Model> refine(const Model& initial, const Subset<Datum>& data,
                              const double* weights) const {
    static_cast<void>(initial);
    const std::size_t n = data.size();
    std::size_t used = 0;
    std::size_t first = n;
    for (std::size_t i = 0; i < n; ++i) {
      const double wi = weights ? weights[i] : 1.0;
      if (!std::isfinite(wi) || wi < 0.0) return std::nullopt;
      if (wi == 0.0) continue;
      if (!data[i].source.allFinite() || !data[i].target.allFinite()) return std::nullopt;
      if (first == n) first = i;
      ++used;
    }
    if (used < kSampleSize) return std::nullopt;
    const std::optional<Eigen::Matrix3d> ns =
        weighted_normalisation(data, weights, first, [](const Datum& d) -> const Vec2& {
          return d.source;
        });
    const std::optional<Eigen::Matrix3d> nt =
        weighted_normalisation(data, weights, first, [](const Datum& d) -> const Vec2& {
          return d.target;
        });
    if (!ns || !nt) return std::nullopt;

    // Rows for y ~ H x (h row-major): [0^T, -x^T, v x^T] and [x^T, 0^T, -u x^T], y = (u, v, 1).
    Eigen::Matrix<double, 9, 9> normal = Eigen::Matrix<double, 9, 9>::Zero();
    Eigen::Matrix<double, 9, 1> r1, r2;
    for (std::size_t i = 0; i < n; ++i) {
      const double wi = weights ? weights[i] : 1.0;
      if (wi == 0.0) continue;
      const Eigen::Vector3d x = *ns * data[i].source.homogeneous();
      const Eigen::Vector3d y = *nt * data[i].target.homogeneous();
      r1 << 0.0, 0.0, 0.0, -x, y.y() * x;
      r2 << x, 0.0, 0.0, 0.0, -y.x() * x;
      normal.selfadjointView<Eigen::Lower>().rankUpdate(r1, wi);
      normal.selfadjointView<Eigen::Lower>().rankUpdate(r2, wi);
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eigen(
        normal.selfadjointView<Eigen::Lower>());
    if (eigen.info() != Eigen::Success) return std::nullopt;
    // Increasing eigenvalues (squared singular values of the weighted DLT system): a second
    // (near-)null direction means the data do not pin down one homography. 1e-12 on the squares
    // is 1e-6 on the singular values, above what the normal matrix resolves.
    if (!(eigen.eigenvalues()(1) > 1e-12 * eigen.eigenvalues()(8))) return std::nullopt;
    const Eigen::Matrix<double, 9, 1> h = eigen.eigenvectors().col(0);
    Eigen::Matrix3d hn;
    hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
    Models models;
    if (!finish(hn, *ns, *nt, models)) return std::nullopt;
    return models[0];
  }

  /// True when the sample cannot give a meaningful homography: a non-finite coordinate, two
  /// coincident source or target points, three collinear source or target points, or triangle
  /// orientations that no homography maps consistently (or only with a mirror, unless
  /// allow_reflection). See the class comment.
  bool degenerate(const Sample& sample) const {
    std::array<double, 4> source_area{}, target_area{};
    if (!triangle_areas(sample, [](const Datum& d) -> const Vec2& { return d.source; },
                        source_area) ||
        !triangle_areas(sample, [](const Datum& d) -> const Vec2& { return d.target; },
                        target_area)) {
      return true;
    }
    // Ratio of orientations, source to target, for the four triangles: one sign for all, and
    // positive unless mirrors are allowed.
    const bool kept = (source_area[0] > 0.0) == (target_area[0] > 0.0);
    for (std::size_t k = 0; k < 4; ++k) {
      if (((source_area[k] > 0.0) == (target_area[k] > 0.0)) != kept) return true;
    }
    return !kept && !options_.allow_reflection;
  }

 private:
  // Hartley's normalisation of four points: centroid to the origin, mean distance sqrt(2); the
  // centroid is taken relative to the first point, which keeps UTM coordinates precise.
  static std::optional<Eigen::Matrix3d> normalisation(const std::array<Vec2, kSampleSize>& p) {
    Vec2 mean = Vec2::Zero();
    for (const Vec2& q : p) mean += q - p[0];
    mean /= static_cast<double>(kSampleSize);
    double distance = 0.0;
    for (const Vec2& q : p) distance += ((q - p[0]) - mean).norm();
    distance /= static_cast<double>(kSampleSize);
    return scaling(p[0] + mean, distance);
  }

  // The same with weights (null: unit), over the data of positive weight; `first` is one of them.
  template <class Get>
  static std::optional<Eigen::Matrix3d> weighted_normalisation(const Subset<Datum>& data,
                                                               const double* weights,
                                                               std::size_t first, Get get) {
    const Vec2 ref = get(data[first]);
    Vec2 mean = Vec2::Zero();
    double total = 0.0;
    for (std::size_t i = 0; i < data.size(); ++i) {
      const double wi = weights ? weights[i] : 1.0;
      if (wi == 0.0) continue;
      mean += wi * (get(data[i]) - ref);
      total += wi;
    }
    mean /= total;
    double distance = 0.0;
    for (std::size_t i = 0; i < data.size(); ++i) {
      const double wi = weights ? weights[i] : 1.0;
      if (wi == 0.0) continue;
      distance += wi * ((get(data[i]) - ref) - mean).norm();
    }
    distance /= total;
    return scaling(ref + mean, distance);
  }

  static std::optional<Eigen::Matrix3d> scaling(const Vec2& centre, double mean_distance) {
    if (!(mean_distance > 0.0) || !std::isfinite(mean_distance) || !centre.allFinite()) {
      return std::nullopt;
    }
    const double s = std::sqrt(2.0) / mean_distance;
    Eigen::Matrix3d t;
    t << s, 0.0, -s * centre.x(),  //
        0.0, s, -s * centre.y(),   //
        0.0, 0.0, 1.0;
    return t;
  }

  // Checks a homography between normalised point sets and appends it, denormalised, to `models`:
  // not finite, singular, or (unless allowed) a mirror gives false. The centroid of the normalised
  // sources is the origin, where w = hn(2, 2); the sign makes it positive. With w > 0, the map
  // keeps orientation exactly when det > 0 (the Jacobian's determinant is det(H) / w^3).
  bool finish(Eigen::Matrix3d hn, const Eigen::Matrix3d& ns, const Eigen::Matrix3d& nt,
              Models& models) const {
    const double norm = hn.norm();
    if (!(norm > 0.0) || !std::isfinite(norm)) return false;
    hn /= norm;
    if (hn(2, 2) < 0.0) hn = -hn;
    const double det = hn.determinant();
    if (!(std::abs(det) > kMinRelativeDeterminant)) return false;
    if (det < 0.0 && !options_.allow_reflection) return false;
    // nt^-1 in closed form: a scaling s and a translation c, so (x - c') / s.
    const double st = nt(0, 0);
    Eigen::Matrix3d nt_inverse;
    nt_inverse << 1.0 / st, 0.0, -nt(0, 2) / st,  //
        0.0, 1.0 / st, -nt(1, 2) / st,            //
        0.0, 0.0, 1.0;
    Eigen::Matrix3d h = nt_inverse * hn * ns;
    const double h_norm = h.norm();
    if (!(h_norm > 0.0) || !std::isfinite(h_norm)) return false;
    h /= h_norm;
    if (!h.allFinite()) return false;
    models.push_back(Homography2{h});
    return true;
  }

  // Twice the signed areas of the four triangles of the sample's points (triangle k leaves out
  // point k), computed on differences. False when a point is not finite, two coincide or three
  // are collinear (see the options).
  template <class Get>
  bool triangle_areas(const Sample& sample, Get get, std::array<double, 4>& area) const {
    std::array<Vec2, kSampleSize> p;
    double magnitude = 0.0;
    for (std::size_t i = 0; i < kSampleSize; ++i) {
      p[i] = get(sample[i]);
      if (!p[i].allFinite()) return false;
      magnitude = std::max(magnitude, p[i].cwiseAbs().maxCoeff());
    }
    const double min_distance = options_.coincidence_tolerance * magnitude;
    for (std::size_t i = 0; i < kSampleSize; ++i) {
      for (std::size_t j = i + 1; j < kSampleSize; ++j) {
        if (!((p[j] - p[i]).squaredNorm() > min_distance * min_distance)) return false;
      }
    }
    static constexpr std::size_t kTriangles[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    for (std::size_t k = 0; k < 4; ++k) {
      const Vec2& a = p[kTriangles[k][0]];
      const Vec2& b = p[kTriangles[k][1]];
      const Vec2& c = p[kTriangles[k][2]];
      const Vec2 ab = b - a, ac = c - a, bc = c - b;
      area[k] = ab.x() * ac.y() - ab.y() * ac.x();
      const double longest2 = std::max({ab.squaredNorm(), ac.squaredNorm(), bc.squaredNorm()});
      if (!std::isfinite(area[k]) || !std::isfinite(longest2)) return false;
      if (!(std::abs(area[k]) > options_.collinearity_tolerance * longest2)) return false;
    }
    return true;
  }

  Options options_{};
};

}  // namespace diachron
