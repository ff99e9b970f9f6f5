#pragma once
/// @file
/// Conversions between Camera<FraserAffine> and COLMAP's OPENCV and FULL_OPENCV camera models,
/// exact where the forms coincide and fitted by least squares, with the measured pixel error,
/// where they do not. Formulas and conventions: docs/camera-model.md.
///
/// Conventions that differ from diachron's:
/// - COLMAP puts the centre of the top-left pixel at (0.5, 0.5): cx_colmap = cx + 0.5.
/// - OpenCV's p1 multiplies 2 x y in x', diachron's P1 multiplies (r^2 + 2 x^2): P1 = p2, P2 = p1.
/// - fx != fy is diachron's B1: f = fy, B1 = fx - fy; OpenCV has no shear (B2).
/// - FULL_OPENCV's rational radial factor (k4, k5, k6) has no diachron counterpart.

#include <array>
#include <cmath>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/conversion.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// Where COLMAP puts the centre of the top-left pixel, minus where diachron puts it, px.
inline constexpr double kColmapPixelShift = 0.5;

/// COLMAP's OPENCV camera: params (fx, fy, cx, cy, k1, k2, p1, p2), COLMAP pixel convention.
/// fx, fy, cx, cy in px; k1, k2, p1, p2 dimensionless (normalised coordinates).
struct ColmapOpenCv {
  static constexpr const char* kModelName = "OPENCV";
  static constexpr int kNumParams = 8;

  int width = 0;   ///< px
  int height = 0;  ///< px
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0;

  /// The params line of cameras.txt, in COLMAP's order.
  std::vector<double> params() const { return {fx, fy, cx, cy, k1, k2, p1, p2}; }

  /// From COLMAP's params (fx, fy, cx, cy, k1, k2, p1, p2).
  /// Precondition: 8 params, else throws diachron::Error.
  static ColmapOpenCv from_params(int width_px, int height_px, const std::vector<double>& p) {
    DIACHRON_CHECK(p.size() == kNumParams,
                   "COLMAP OPENCV needs " << kNumParams << " params, got " << p.size());
    ColmapOpenCv c;
    c.width = width_px;
    c.height = height_px;
    c.fx = p[0];
    c.fy = p[1];
    c.cx = p[2];
    c.cy = p[3];
    c.k1 = p[4];
    c.k2 = p[5];
    c.p1 = p[6];
    c.p2 = p[7];
    return c;
  }
};

/// COLMAP's FULL_OPENCV camera: params (fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6), COLMAP
/// pixel convention; radial factor (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6).
struct ColmapFullOpenCv {
  static constexpr const char* kModelName = "FULL_OPENCV";
  static constexpr int kNumParams = 12;

  int width = 0;   ///< px
  int height = 0;  ///< px
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0;
  double k3 = 0.0, k4 = 0.0, k5 = 0.0, k6 = 0.0;

  /// The params line of cameras.txt, in COLMAP's order.
  std::vector<double> params() const { return {fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6}; }

  /// From COLMAP's params (fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6).
  /// Precondition: 12 params, else throws diachron::Error.
  static ColmapFullOpenCv from_params(int width_px, int height_px, const std::vector<double>& p) {
    DIACHRON_CHECK(p.size() == kNumParams,
                   "COLMAP FULL_OPENCV needs " << kNumParams << " params, got " << p.size());
    ColmapFullOpenCv c;
    c.width = width_px;
    c.height = height_px;
    c.fx = p[0];
    c.fy = p[1];
    c.cx = p[2];
    c.cy = p[3];
    c.k1 = p[4];
    c.k2 = p[5];
    c.p1 = p[6];
    c.p2 = p[7];
    c.k3 = p[8];
    c.k4 = p[9];
    c.k5 = p[10];
    c.k6 = p[11];
    return c;
  }
};

/// Camera<FraserAffine> from COLMAP OPENCV. Always exact: f = fy, B1 = fx - fy, B2 = 0,
/// (cx, cy) - 0.5, K1 = k1, K2 = k2, K3 = 0, P1 = p2, P2 = p1.
/// Precondition: finite parameters, fx, fy > 0, positive size, else throws diachron::Error.
inline ConversionResult<Camera<FraserAffine>> camera_from_colmap(
    const ColmapOpenCv& colmap, const ConversionOptions& options = {});

/// Camera<FraserAffine> from COLMAP FULL_OPENCV. Exact (K3 = k3) when k4 = k5 = k6 = 0;
/// otherwise all ten FraserAffine parameters and f, cx, cy are fitted to the rational model over
/// the image grid and the result says how far apart they are.
inline ConversionResult<Camera<FraserAffine>> camera_from_colmap(
    const ColmapFullOpenCv& colmap, const ConversionOptions& options = {});

/// COLMAP OPENCV from a camera. Exact when K3 = 0 and B2 = 0 (fx = f + B1, fy = f, P swapped,
/// principal point + 0.5); otherwise the eight OPENCV parameters are fitted.
template <class Distortion>
ConversionResult<ColmapOpenCv> colmap_opencv_from_camera(const Camera<Distortion>& camera,
                                                         const ConversionOptions& options = {});

/// COLMAP FULL_OPENCV from a camera. Exact when B2 = 0 (k4 = k5 = k6 = 0); otherwise fx, fy, cx,
/// cy, k1, k2, k3, p1, p2 are fitted with k4 = k5 = k6 = 0.
template <class Distortion>
ConversionResult<ColmapFullOpenCv> colmap_full_opencv_from_camera(
    const Camera<Distortion>& camera, const ConversionOptions& options = {});

// Implementation ----------------------------------------------------------------------------------

namespace detail {

// OpenCV's projection of ideal normalised coordinates, returned in diachron's pixel convention.
inline Vec2 opencv_pixel(const ColmapFullOpenCv& c, const Vec2& xy) {
  const double x = xy.x();
  const double y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = (1.0 + r2 * (c.k1 + r2 * (c.k2 + r2 * c.k3))) /
                        (1.0 + r2 * (c.k4 + r2 * (c.k5 + r2 * c.k6)));
  const double xd = x * radial + 2.0 * c.p1 * x * y + c.p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + c.p1 * (r2 + 2.0 * y * y) + 2.0 * c.p2 * x * y;
  return Vec2(c.fx * xd + c.cx - kColmapPixelShift, c.fy * yd + c.cy - kColmapPixelShift);
}

inline ColmapFullOpenCv full_from_opencv(const ColmapOpenCv& c) {
  ColmapFullOpenCv f;
  f.width = c.width;
  f.height = c.height;
  f.fx = c.fx;
  f.fy = c.fy;
  f.cx = c.cx;
  f.cy = c.cy;
  f.k1 = c.k1;
  f.k2 = c.k2;
  f.p1 = c.p1;
  f.p2 = c.p2;
  return f;
}

inline void check_colmap(const ColmapFullOpenCv& c, const char* model) {
  const std::vector<double> p = c.params();
  for (std::size_t i = 0; i < p.size(); ++i) {
    DIACHRON_CHECK(std::isfinite(p[i]), "COLMAP " << model << " param " << i << " is not finite");
  }
  DIACHRON_CHECK(c.fx > 0.0 && c.fy > 0.0,
                 "COLMAP " << model << " focal lengths must be > 0, got " << c.fx << ", " << c.fy);
  DIACHRON_CHECK(c.width > 0 && c.height > 0,
                 "COLMAP " << model << " image size must be positive, got " << c.width << " x "
                           << c.height);
}

// The closed-form part shared by both COLMAP models (exact when k3..k6 vanish).
inline Camera<FraserAffine> camera_from_opencv_form(const ColmapFullOpenCv& c, double k1,
                                                    double k2, double k3) {
  return Camera<FraserAffine>(c.fy, c.cx - kColmapPixelShift, c.cy - kColmapPixelShift, c.width,
                              c.height, {k1, k2, k3, c.p2, c.p1, c.fx - c.fy, 0.0});
}

// Fits [fx, fy, cx, cy, k1, k2, p1, p2] (plus k3 when `with_k3`) with k4..k6 held at 0.
inline ColmapFullOpenCv fit_opencv(const ColmapFullOpenCv& start,
                                   bool with_k3, const std::vector<PixelSample>& samples,
                                   int max_iterations) {
  const int p = with_k3 ? 9 : 8;
  Eigen::VectorXd theta(p);
  Eigen::VectorXd steps(p);
  theta.head(8) << start.fx, start.fy, start.cx, start.cy, start.k1, start.k2, start.p1, start.p2;
  steps.head(8) << 1e-3, 1e-3, 1e-3, 1e-3, 1e-7, 1e-7, 1e-7, 1e-7;
  if (with_k3) {
    theta[8] = start.k3;
    steps[8] = 1e-7;
  }
  const auto unpack = [&start, with_k3](const Eigen::VectorXd& t) {
    ColmapFullOpenCv c = start;
    c.fx = t[0];
    c.fy = t[1];
    c.cx = t[2];
    c.cy = t[3];
    c.k1 = t[4];
    c.k2 = t[5];
    c.p1 = t[6];
    c.p2 = t[7];
    c.k3 = with_k3 ? t[8] : 0.0;
    c.k4 = c.k5 = c.k6 = 0.0;
    return c;
  };
  const auto model = [&unpack](const Eigen::VectorXd& t, const Vec2& xy) {
    return opencv_pixel(unpack(t), xy);
  };
  return unpack(fit_pixel_model(model, theta, steps, samples, max_iterations));
}

inline ColmapFullOpenCv opencv_form_of(const Camera<FraserAffine>& c) {
  const auto& p = c.params();
  ColmapFullOpenCv o;
  o.width = c.width();
  o.height = c.height();
  o.fx = c.focal() + p[5];
  o.fy = c.focal();
  o.cx = c.cx() + kColmapPixelShift;
  o.cy = c.cy() + kColmapPixelShift;
  o.k1 = p[0];
  o.k2 = p[1];
  o.k3 = p[2];
  o.p1 = p[4];
  o.p2 = p[3];
  return o;
}

}  // namespace detail

inline ConversionResult<Camera<FraserAffine>> camera_from_colmap(const ColmapOpenCv& colmap,
                                                                 const ConversionOptions& options) {
  options.check();
  const ColmapFullOpenCv full = detail::full_from_opencv(colmap);
  detail::check_colmap(full, ColmapOpenCv::kModelName);
  const Camera<FraserAffine> camera =
      detail::camera_from_opencv_form(full, colmap.k1, colmap.k2, 0.0);
  const auto samples = detail::sample_image(
      [&full](const Vec2& xy) { return detail::opencv_pixel(full, xy); }, full.width, full.height,
      full.fy, Vec2(full.cx, full.cy), options.grid_points_per_side);
  return detail::measure_conversion(
      camera, true, [&camera](const Vec2& xy) { return camera.pixel_from_normalized(xy); },
      samples);
}

inline ConversionResult<Camera<FraserAffine>> camera_from_colmap(const ColmapFullOpenCv& colmap,
                                                                 const ConversionOptions& options) {
  options.check();
  detail::check_colmap(colmap, ColmapFullOpenCv::kModelName);
  const auto samples = detail::sample_image(
      [&colmap](const Vec2& xy) { return detail::opencv_pixel(colmap, xy); }, colmap.width,
      colmap.height, colmap.fy, Vec2(colmap.cx, colmap.cy), options.grid_points_per_side);
  const bool exact = colmap.k4 == 0.0 && colmap.k5 == 0.0 && colmap.k6 == 0.0;
  // Start from the series of the rational factor in r^2 (exact up to r^6 when k4..k6 vanish):
  // (1 + a1 s + a2 s^2 + a3 s^3) / (1 + b1 s + b2 s^2 + b3 s^3) = 1 + c1 s + c2 s^2 + c3 s^3 + ...
  const double c1 = colmap.k1 - colmap.k4;
  const double c2 = colmap.k2 - colmap.k5 - colmap.k4 * c1;
  const double c3 = colmap.k3 - colmap.k6 - colmap.k4 * c2 - colmap.k5 * c1;
  Camera<FraserAffine> camera = detail::camera_from_opencv_form(colmap, c1, c2, c3);
  if (!exact) {
    const Eigen::VectorXd theta = detail::fit_pixel_model(
        [](const Eigen::VectorXd& t, const Vec2& xy) { return detail::fraser_affine_pixel(t, xy); },
        detail::theta_of(camera), detail::fraser_affine_steps(), samples, options.max_iterations);
    camera = detail::camera_from_theta(theta, colmap.width, colmap.height);
  }
  return detail::measure_conversion(
      camera, exact, [&camera](const Vec2& xy) { return camera.pixel_from_normalized(xy); },
      samples);
}

template <class Distortion>
ConversionResult<ColmapOpenCv> colmap_opencv_from_camera(const Camera<Distortion>& source,
                                                         const ConversionOptions& options) {
  options.check();
  const Camera<FraserAffine> camera = as_fraser_affine(source);
  const auto& p = camera.params();
  const bool exact = p[2] == 0.0 && p[6] == 0.0;
  const auto samples = detail::camera_samples(camera, options.grid_points_per_side);
  ColmapFullOpenCv full = detail::opencv_form_of(camera);
  full.k3 = 0.0;
  if (!exact) {
    full = detail::fit_opencv(full, false, samples, options.max_iterations);
  }
  ColmapOpenCv out;
  out.width = full.width;
  out.height = full.height;
  out.fx = full.fx;
  out.fy = full.fy;
  out.cx = full.cx;
  out.cy = full.cy;
  out.k1 = full.k1;
  out.k2 = full.k2;
  out.p1 = full.p1;
  out.p2 = full.p2;
  return detail::measure_conversion(
      out, exact, [&full](const Vec2& xy) { return detail::opencv_pixel(full, xy); }, samples);
}

template <class Distortion>
ConversionResult<ColmapFullOpenCv> colmap_full_opencv_from_camera(
    const Camera<Distortion>& source, const ConversionOptions& options) {
  options.check();
  const Camera<FraserAffine> camera = as_fraser_affine(source);
  const bool exact = camera.params()[6] == 0.0;
  const auto samples = detail::camera_samples(camera, options.grid_points_per_side);
  ColmapFullOpenCv full = detail::opencv_form_of(camera);
  if (!exact) {
    full = detail::fit_opencv(full, true, samples, options.max_iterations);
  }
  return detail::measure_conversion(
      full, exact, [&full](const Vec2& xy) { return detail::opencv_pixel(full, xy); }, samples);
}

}  // namespace diachron
