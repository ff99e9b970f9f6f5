#pragma once
/// @file
/// Small estimators for the robust/ tests. MeanEstimator is the archetype: the least an Estimator
/// may be (no refine, no degenerate); the others exercise optional members and corner cases.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <diachron/core/random.hpp>
#include <diachron/core/static_vector.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/core/types.hpp>
#include <diachron/robust/estimator.hpp>

namespace diachron_test {

/// 1D location from one value: the archetype of the Estimator concept (required members only).
struct MeanEstimator {
  using Datum = double;
  using Model = double;
  static constexpr std::size_t kSampleSize = 1;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = diachron::StaticVector<Model, kMaxModels>;

  Models minimal(const Sample& sample) const {
    Models models;
    if (std::isfinite(sample[0])) models.push_back(sample[0]);
    return models;
  }
  double residual(const Model& model, const Datum& datum) const { return std::abs(datum - model); }
};

/// A 2D line n . p = d with |n| = 1.
struct Line {
  Eigen::Vector2d normal = Eigen::Vector2d::UnitY();
  double offset = 0.0;
};

/// 2D line through two points; weighted total least squares refine; coincident points degenerate.
struct LineEstimator {
  using Datum = Eigen::Vector2d;
  using Model = Line;
  static constexpr std::size_t kSampleSize = 2;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = diachron::StaticVector<Model, kMaxModels>;

  Models minimal(const Sample& sample) const {
    Models models;
    const Eigen::Vector2d d = sample[1] - sample[0];
    const double length = d.norm();
    if (!(length > 0.0) || !std::isfinite(length)) return models;
    Line line;
    line.normal = Eigen::Vector2d(-d.y(), d.x()) / length;
    line.offset = line.normal.dot(sample[0]);
    models.push_back(line);
    return models;
  }

  double residual(const Model& model, const Datum& datum) const {
    return std::abs(model.normal.dot(datum) - model.offset);
  }

  std::optional<Model> refine(const Model& /*initial*/, const diachron::Subset<Datum>& data,
                              const double* weights) const {
    if (data.size() < kSampleSize) throw std::logic_error("LineEstimator::refine: too few data");
    double total = 0.0;
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    for (std::size_t i = 0; i < data.size(); ++i) {
      const double w = weights ? weights[i] : 1.0;
      total += w;
      centroid += w * data[i];
    }
    if (!(total > 0.0)) return std::nullopt;
    centroid /= total;
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    for (std::size_t i = 0; i < data.size(); ++i) {
      const double w = weights ? weights[i] : 1.0;
      const Eigen::Vector2d p = data[i] - centroid;
      scatter += w * p * p.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(scatter);
    if (!(eigen.eigenvalues()(1) > 0.0)) return std::nullopt;
    Line line;
    line.normal = eigen.eigenvectors().col(0).normalized();
    line.offset = line.normal.dot(centroid);
    if (!line.normal.allFinite() || !std::isfinite(line.offset)) return std::nullopt;
    return line;
  }

  bool degenerate(const Sample& sample) const { return !((sample[1] - sample[0]).norm() > 1e-12); }
};

/// 2D translation from one pair: for all-outlier tests, where chance agreement is negligible.
struct TranslationEstimator {
  using Datum = diachron::PointPair2;
  using Model = Eigen::Vector2d;
  static constexpr std::size_t kSampleSize = 1;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = diachron::StaticVector<Model, kMaxModels>;

  Models minimal(const Sample& sample) const {
    Models models;
    models.push_back(sample[0].target - sample[0].source);
    return models;
  }
  double residual(const Model& model, const Datum& datum) const {
    return (datum.target - datum.source - model).norm();
  }
  std::optional<Model> refine(const Model& /*initial*/, const diachron::Subset<Datum>& data,
                              const double* weights) const {
    double total = 0.0;
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (std::size_t i = 0; i < data.size(); ++i) {
      const double w = weights ? weights[i] : 1.0;
      total += w;
      sum += w * (data[i].target - data[i].source);
    }
    if (!(total > 0.0)) return std::nullopt;
    return Eigen::Vector2d(sum / total);
  }
};

/// Two models per sample (x and -x): exercises the several-models path of Ransac.
struct SignEstimator {
  using Datum = double;
  using Model = double;
  static constexpr std::size_t kSampleSize = 1;
  static constexpr std::size_t kMaxModels = 2;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = diachron::StaticVector<Model, kMaxModels>;

  Models minimal(const Sample& sample) const {
    Models models;
    models.push_back(-sample[0]);
    models.push_back(sample[0]);
    return models;
  }
  double residual(const Model& model, const Datum& datum) const { return std::abs(datum - model); }
};

/// Needs two data but its model is the first one alone, so on well-separated data every
/// hypothesis has ONE inlier, fewer than kSampleSize: the local optimisation must then never call
/// refine (COLMAP #4678). refine throws when given too few data, and `drift` makes it return a
/// model shifted away from the data (an inlier set that shrinks), which must be rejected.
struct ShrinkingEstimator {
  using Datum = double;
  using Model = double;
  static constexpr std::size_t kSampleSize = 2;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = diachron::StaticVector<Model, kMaxModels>;

  double drift = 0.0;

  Models minimal(const Sample& sample) const {
    Models models;
    models.push_back(sample[0]);
    return models;
  }
  double residual(const Model& model, const Datum& datum) const { return std::abs(datum - model); }
  std::optional<Model> refine(const Model& initial, const diachron::Subset<Datum>& data,
                              const double* /*weights*/) const {
    if (data.size() < kSampleSize) {
      throw std::logic_error("ShrinkingEstimator::refine called with fewer than 2 data");
    }
    return initial + drift;
  }
};

/// Points on the line y = slope x + intercept, x in [0, extent], with Gaussian noise `sigma`
/// perpendicular-ish (on y), and `outliers` uniform in [0, extent]^2 shifted to cover the line.
/// The first `inliers` entries are the inliers.
inline std::vector<Eigen::Vector2d> make_line_data(std::size_t inliers, std::size_t outliers,
                                                   double sigma, std::uint64_t seed,
                                                   double slope = 0.5, double intercept = 20.0,
                                                   double extent = 100.0) {
  diachron::RandomStream rng(seed, 0);
  std::vector<Eigen::Vector2d> points;
  for (std::size_t i = 0; i < inliers; ++i) {
    const double x = rng.uniform(0.0, extent);
    points.emplace_back(x, slope * x + intercept + rng.normal(0.0, sigma));
  }
  // One draw per statement, y before x: the order of a call's arguments is unspecified
  // (core/random.hpp, "Order of draws").
  for (std::size_t i = 0; i < outliers; ++i) {
    const double y = rng.uniform(0.0, extent);
    points.emplace_back(rng.uniform(0.0, extent), y);
  }
  return points;
}

/// Largest vertical distance between the fitted line and y = slope x + intercept over
/// x in [0, extent]; +inf for a (near) vertical fit.
inline double line_error(const Line& line, double slope = 0.5, double intercept = 20.0,
                         double extent = 100.0) {
  if (!(std::abs(line.normal.y()) > 1e-9)) return std::numeric_limits<double>::infinity();
  auto y = [&](double x) { return (line.offset - line.normal.x() * x) / line.normal.y(); };
  return std::max(std::abs(y(0.0) - intercept), std::abs(y(extent) - (slope * extent + intercept)));
}

/// One pair of similarity_pairs(): an inlier of the similarity (scale 1.2, angle 0.3 rad, shift (50, -20))
/// with Gaussian noise of 1 per coordinate, or an outlier with a target uniform in [-500, 1500]^2; the
/// source uniform in [0, 1000]^2.
inline diachron::PointPair2 similarity_pair(diachron::RandomStream& rng, bool inlier) {
  const double c = 1.2 * std::cos(0.3), s = 1.2 * std::sin(0.3);
  diachron::PointPair2 p;
  // One draw per statement, y before x, as in make_line_data.
  const double sy = rng.uniform(0, 1000);
  p.source = Eigen::Vector2d(rng.uniform(0, 1000), sy);
  if (inlier) {
    const double ny = rng.normal(0, 1);
    p.target = Eigen::Vector2d(c * p.source.x() - s * p.source.y() + 50 + rng.normal(0, 1),
                               s * p.source.x() + c * p.source.y() - 20 + ny);
  } else {
    const double ty = rng.uniform(-500, 1500);
    p.target = Eigen::Vector2d(rng.uniform(-500, 1500), ty);
  }
  return p;
}

/// Point pairs under target = 1.2 R(0.3) source + (50, -20): `inliers` with Gaussian noise of 1 px
/// per coordinate, sources in [0, 1000]^2, and `outliers` with targets uniform in [-500, 1500]^2.
/// Inliers come first, or last with `outliers_first` (as a tile without overlap at the head of a
/// real match list would put them).
inline std::vector<diachron::PointPair2> similarity_pairs(std::size_t inliers,
                                                          std::size_t outliers,
                                                          std::uint64_t seed,
                                                          bool outliers_first = false) {
  diachron::RandomStream rng(seed, 7);
  std::vector<diachron::PointPair2> data;
  for (std::size_t k = 0; k < inliers + outliers; ++k)
    data.push_back(similarity_pair(rng, outliers_first ? k >= outliers : k < inliers));
  return data;
}

}  // namespace diachron_test
