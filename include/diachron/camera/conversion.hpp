#pragma once
/// @file
/// What every camera-model conversion returns (the converted model and its measured pixel error)
/// and the least-squares fit used where two models do not coincide; shared by
/// colmap_conversion.hpp and micmac_conversion.hpp.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// Options of a camera-model conversion.
struct ConversionOptions {
  /// Pixels sampled per image side (corners included) to measure the conversion and, when the
  /// forms differ, to fit the target model. >= 2.
  int grid_points_per_side = 21;
  /// Most Levenberg-Marquardt iterations of the fit. >= 1.
  int max_iterations = 100;

  /// Precondition: as above, else throws diachron::Error.
  void check() const {
    DIACHRON_CHECK(grid_points_per_side >= 2,
                   "ConversionOptions::grid_points_per_side must be >= 2, got "
                       << grid_points_per_side);
    DIACHRON_CHECK(max_iterations >= 1,
                   "ConversionOptions::max_iterations must be >= 1, got " << max_iterations);
  }
};

/// A converted camera model with the measured quality of the conversion. Never silently lossy:
/// `max_error_px` is measured, not assumed, over a grid of the whole image (corners included):
/// for each grid pixel, the ray of the source model is projected by the converted model.
/// @tparam Model the target description (Camera<FraserAffine>, ColmapOpenCv, MicmacFraser, ...).
template <class Model>
struct ConversionResult {
  /// The converted model.
  Model model;
  /// True when the two forms coincide for these parameters and the conversion is closed-form
  /// (the errors are then rounding only); false when the target was fitted by least squares.
  bool exact = false;
  /// Largest pixel distance between source and converted model over the grid, px.
  double max_error_px = std::numeric_limits<double>::infinity();
  /// Root mean square of the same distances, px.
  double rms_error_px = std::numeric_limits<double>::infinity();
  /// Grid pixels used (those the source model could unproject).
  int num_samples = 0;
};

namespace detail {

/// A ray of the source model (ideal normalised coordinates) and the pixel it gives, px in
/// diachron's convention.
struct PixelSample {
  Vec2 normalized;
  Vec2 pixel;
};

/// Samples `forward` (ideal normalised -> diachron pixel) on an n x n grid of pixels covering
/// [-0.5, width - 0.5] x [-0.5, height - 0.5]. Each grid pixel is inverted by Newton with a
/// numeric Jacobian from the pinhole guess; the stored pixel is forward(xy) itself, so a sample is
/// exact even when the inversion is slightly off. Pixels that cannot be inverted are skipped.
template <class Forward>
std::vector<PixelSample> sample_image(const Forward& forward, int width, int height, double focal,
                                      const Vec2& principal_point, int n) {
  const auto jacobian = [&forward](const Vec2& xy) {
    constexpr double h = 1e-6;
    Mat2 j;
    j.col(0) = (forward(xy + Vec2(h, 0.0)) - forward(xy - Vec2(h, 0.0))) / (2.0 * h);
    j.col(1) = (forward(xy + Vec2(0.0, h)) - forward(xy - Vec2(0.0, h))) / (2.0 * h);
    return j;
  };
  UndistortOptions newton;
  newton.tolerance = 1e-6;  // px: only the grid position depends on it
  std::vector<PixelSample> samples;
  samples.reserve(static_cast<std::size_t>(n) * n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < n; ++k) {
      const Vec2 pixel(-0.5 + width * double(k) / (n - 1), -0.5 + height * double(i) / (n - 1));
      const Vec2 start = (pixel - principal_point) / focal;
      const UndistortResult r = newton_invert(forward, jacobian, pixel, start, newton);
      if (!r.converged) continue;
      const Vec2 exact_pixel = forward(r.xy);
      if (exact_pixel.allFinite()) samples.push_back({r.xy, exact_pixel});
    }
  }
  return samples;
}

/// Max and RMS pixel distance of `target` (ideal normalised -> pixel) from the samples.
template <class Target, class Model>
ConversionResult<Model> measure_conversion(const Model& model, bool exact, const Target& target,
                                           const std::vector<PixelSample>& samples) {
  ConversionResult<Model> out{model, exact};
  out.num_samples = static_cast<int>(samples.size());
  if (samples.empty()) return out;
  double max_error = 0.0;
  double sum_squared = 0.0;
  for (const PixelSample& s : samples) {
    const double e = (target(s.normalized) - s.pixel).norm();
    if (!std::isfinite(e)) return out;  // keeps the infinite errors: the conversion failed
    max_error = std::max(max_error, e);
    sum_squared += e * e;
  }
  out.max_error_px = max_error;
  out.rms_error_px = std::sqrt(sum_squared / static_cast<double>(samples.size()));
  return out;
}

/// Levenberg-Marquardt on sum_i |model(theta, xy_i) - pixel_i|^2 with central-difference
/// Jacobians (`steps` per parameter, in its units) and columns scaled to unit norm, so pixel
/// parameters (focal, principal point) and dimensionless ones (K, P) are solved together.
/// Each damped step is solved by QR of [J; sqrt(lambda) I] rather than the normal equations,
/// whose squared condition number would cost digits on the r^2, r^4, r^6 columns.
/// `model(theta, xy) -> Vec2`. Returns the best theta found (never worse than the start).
template <class Model>
Eigen::VectorXd fit_pixel_model(const Model& model, Eigen::VectorXd theta,
                                const Eigen::VectorXd& steps,
                                const std::vector<PixelSample>& samples, int max_iterations) {
  const Eigen::Index p = theta.size();
  const Eigen::Index m = 2 * static_cast<Eigen::Index>(samples.size());
  if (m < p || p == 0) return theta;
  const auto residuals = [&](const Eigen::VectorXd& t) {
    Eigen::VectorXd r(m);
    for (std::size_t i = 0; i < samples.size(); ++i) {
      r.segment<2>(2 * static_cast<Eigen::Index>(i)) = model(t, samples[i].normalized) -
                                                       samples[i].pixel;
    }
    return r;
  };
  Eigen::VectorXd r = residuals(theta);
  double cost = r.squaredNorm();
  if (!std::isfinite(cost)) return theta;
  double lambda = 1e-6;
  Eigen::MatrixXd j(m, p);
  Eigen::MatrixXd augmented(m + p, p);
  Eigen::VectorXd rhs(m + p);
  bool recompute = true;
  for (int it = 0; it < max_iterations; ++it) {
    if (recompute) {
      for (Eigen::Index c = 0; c < p; ++c) {
        Eigen::VectorXd plus = theta;
        Eigen::VectorXd minus = theta;
        plus[c] += steps[c];
        minus[c] -= steps[c];
        j.col(c) = (residuals(plus) - residuals(minus)) / (2.0 * steps[c]);
      }
    }
    Eigen::VectorXd scale(p);
    for (Eigen::Index c = 0; c < p; ++c) {
      const double n = j.col(c).norm();
      scale[c] = n > 0.0 ? n : 1.0;
    }
    augmented.topRows(m) = j * scale.cwiseInverse().asDiagonal();
    augmented.bottomRows(p) = std::sqrt(lambda) * Eigen::MatrixXd::Identity(p, p);
    rhs.head(m) = -r;
    rhs.tail(p).setZero();
    const Eigen::VectorXd step_scaled = augmented.colPivHouseholderQr().solve(rhs);
    const Eigen::VectorXd candidate = theta + step_scaled.cwiseQuotient(scale);
    const Eigen::VectorXd rc = residuals(candidate);
    const double candidate_cost = rc.squaredNorm();
    if (std::isfinite(candidate_cost) && candidate_cost < cost) {
      const double decrease = (cost - candidate_cost) / cost;
      theta = candidate;
      r = rc;
      cost = candidate_cost;
      lambda = std::max(lambda * 0.1, 1e-15);
      recompute = true;
      if (decrease < 1e-14 || cost == 0.0) break;
    } else {
      lambda *= 10.0;
      recompute = false;
      if (lambda > 1e12) break;
    }
  }
  return theta;
}

inline Camera<FraserAffine> camera_from_theta(const Eigen::VectorXd& t, int width, int height) {
  return Camera<FraserAffine>(t[0], t[1], t[2], width, height,
                              {t[3], t[4], t[5], t[6], t[7], t[8], t[9]});
}

// A FraserAffine pixel from the fit vector [f, cx, cy, K1, K2, K3, P1, P2, B1, B2], without the
// constructor's checks (the fit may pass through odd values on its way).
inline Vec2 fraser_affine_pixel(const Eigen::VectorXd& t, const Vec2& xy) {
  const double focal_pp[3] = {t[0], t[1], t[2]};
  const double params[7] = {t[3], t[4], t[5], t[6], t[7], t[8], t[9]};
  Vec2 pixel;
  Camera<FraserAffine>::pixel_from_normalized(focal_pp, params, xy.data(), pixel.data());
  return pixel;
}

inline Eigen::VectorXd theta_of(const Camera<FraserAffine>& c) {
  Eigen::VectorXd t(10);
  const auto& p = c.params();
  t << c.focal(), c.cx(), c.cy(), p[0], p[1], p[2], p[3], p[4], p[5], p[6];
  return t;
}

// Steps of the fit's central differences: px for f, cx, cy, B1, B2; dimensionless for K, P.
inline Eigen::VectorXd fraser_affine_steps() {
  Eigen::VectorXd s(10);
  s << 1e-3, 1e-3, 1e-3, 1e-7, 1e-7, 1e-7, 1e-7, 1e-7, 1e-3, 1e-3;
  return s;
}

inline std::vector<PixelSample> camera_samples(const Camera<FraserAffine>& camera, int n) {
  std::vector<PixelSample> samples;
  samples.reserve(static_cast<std::size_t>(n) * n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < n; ++k) {
      const Vec2 pixel(-0.5 + camera.width() * double(k) / (n - 1),
                       -0.5 + camera.height() * double(i) / (n - 1));
      const UnprojectResult r = camera.unproject_detailed(pixel);
      if (r.converged) samples.push_back({r.normalized, camera.pixel_from_normalized(r.normalized)});
    }
  }
  return samples;
}

}  // namespace detail
}  // namespace diachron
