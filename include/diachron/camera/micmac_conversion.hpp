#pragma once
/// @file
/// Conversions between Camera<FraserAffine> and MicMac's pixel-space Fraser model (Tapas
/// Fraser / FraserBasic, ModPhgrStd), exact where the forms coincide and fitted by least squares,
/// with the measured pixel error, where they do not. Formulas: docs/camera-model.md.
///
/// MicMac's model (cDistModStdPhpgr::Direct), with ideal pixel p = PP + F (x, y), u = p - CDist,
/// r^2 = |u|^2, all in pixels:
///   p' = CDist + u (1 + R3 r^2 + R5 r^4 + R7 r^6)
///        + (P1 (2 ux^2 + r^2) + 2 P2 ux uy + b1 ux + b2 uy,  P2 (2 uy^2 + r^2) + 2 P1 ux uy).
/// Differences from diachron: coefficients are in pixel units (R3 px^-2, R5 px^-4, R7 px^-6, P
/// px^-1), the distortion centre CDist may differ from PP, and the affinity b1, b2 acts on the
/// ideal offsets u where diachron's B1, B2 act on the distorted coordinates.
/// MicMac's linear extrapolation of the radial term beyond RMax (the image corner farthest from
/// CDist) is not modelled: conversions are made and measured inside the image only.

#include <cmath>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/conversion.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

// kMicmacPixelShift, MicMac's pixel convention against diachron's, is in core/types.hpp: the
// camera conversions here and the Homol tie points (io/homol.hpp) share it.

/// MicMac's CalibrationInternConique with a ModPhgrStd (Fraser) distortion, DistM2C direction
/// (ideal -> observed). All lengths in pixels.
struct MicmacFraser {
  Vec2 principal_point = Vec2::Zero();     ///< PP, px
  double focal = 0.0;                      ///< F, px
  Vec2 distortion_centre = Vec2::Zero();   ///< CDist, px (equal to PP for FraserBasic)
  double r3 = 0.0;                         ///< px^-2
  double r5 = 0.0;                         ///< px^-4
  double r7 = 0.0;                         ///< px^-6
  double p1 = 0.0;                         ///< px^-1
  double p2 = 0.0;                         ///< px^-1
  double b1 = 0.0;                         ///< dimensionless (x scale difference)
  double b2 = 0.0;                         ///< dimensionless (shear)
  int width = 0;                           ///< SzIm x, px
  int height = 0;                          ///< SzIm y, px

  /// MicMac's observed pixel (MicMac's pixel convention) of ideal normalised coordinates.
  Vec2 pixel_from_normalized(const Vec2& xy) const {
    const Vec2 u = principal_point + focal * xy - distortion_centre;
    const double r2 = u.squaredNorm();
    const double radial = 1.0 + r2 * (r3 + r2 * (r5 + r2 * r7));
    Vec2 p = distortion_centre + radial * u;
    p.x() += p1 * (2.0 * u.x() * u.x() + r2) + 2.0 * p2 * u.x() * u.y() + b1 * u.x() + b2 * u.y();
    p.y() += p2 * (2.0 * u.y() * u.y() + r2) + 2.0 * p1 * u.x() * u.y();
    return p;
  }
};

/// Camera<FraserAffine> from MicMac. Exact when CDist = PP and b1 = b2 = 0: f = F,
/// (cx, cy) = PP - shift, K1 = R3 F^2, K2 = R5 F^4, K3 = R7 F^6, P1 = P1 F, P2 = P2 F, B = 0.
/// Otherwise all of f, cx, cy, K1..K3, P1, P2, B1, B2 are fitted over the image grid.
/// @param pixel_shift_px MicMac pixel minus diachron pixel.
/// Precondition: finite values, F > 0, positive size, else throws diachron::Error.
inline ConversionResult<Camera<FraserAffine>> camera_from_micmac(
    const MicmacFraser& micmac, const ConversionOptions& options = {},
    double pixel_shift_px = kMicmacPixelShift);

/// MicMac (CDist = PP, as FraserBasic) from a camera. Exact when B1 = B2 = 0 (the inverse of the
/// formulas above); otherwise PP, F, R3, R5, R7, P1, P2, b1, b2 are fitted over the image grid.
template <class Distortion>
ConversionResult<MicmacFraser> micmac_from_camera(const Camera<Distortion>& camera,
                                                  const ConversionOptions& options = {},
                                                  double pixel_shift_px = kMicmacPixelShift);

// Implementation ----------------------------------------------------------------------------------

namespace detail {

inline void check_micmac(const MicmacFraser& m) {
  const double values[] = {m.principal_point.x(), m.principal_point.y(), m.focal,
                           m.distortion_centre.x(), m.distortion_centre.y(), m.r3, m.r5, m.r7,
                           m.p1, m.p2, m.b1, m.b2};
  for (const double v : values) {
    DIACHRON_CHECK(std::isfinite(v), "MicMac calibration has a non-finite value");
  }
  DIACHRON_CHECK(m.focal > 0.0, "MicMac focal F must be > 0 px, got " << m.focal);
  DIACHRON_CHECK(m.width > 0 && m.height > 0,
                 "MicMac image size must be positive, got " << m.width << " x " << m.height);
}

// The MicMac fit vector [F, PPx, PPy, k1, k2, k3, q1, q2, b1, b2] in well-scaled units:
// R3 = k1 / F0^2, R5 = k2 / F0^4, R7 = k3 / F0^6, P = q / F0, with F0 a fixed focal, so that all
// parameters are O(1) or pixels and one set of difference steps fits them all.
inline MicmacFraser micmac_from_theta(const Eigen::VectorXd& t, double f0, int width, int height) {
  MicmacFraser m;
  m.focal = t[0];
  m.principal_point = Vec2(t[1], t[2]);
  m.distortion_centre = m.principal_point;
  const double f2 = f0 * f0;
  m.r3 = t[3] / f2;
  m.r5 = t[4] / (f2 * f2);
  m.r7 = t[5] / (f2 * f2 * f2);
  m.p1 = t[6] / f0;
  m.p2 = t[7] / f0;
  m.b1 = t[8];
  m.b2 = t[9];
  m.width = width;
  m.height = height;
  return m;
}

}  // namespace detail

inline ConversionResult<Camera<FraserAffine>> camera_from_micmac(const MicmacFraser& micmac,
                                                                 const ConversionOptions& options,
                                                                 double pixel_shift_px) {
  options.check();
  detail::check_micmac(micmac);
  DIACHRON_CHECK(std::isfinite(pixel_shift_px), "pixel shift must be finite");
  const double f = micmac.focal;
  const auto source = [&micmac, pixel_shift_px](const Vec2& xy) {
    return Vec2(micmac.pixel_from_normalized(xy) - Vec2::Constant(pixel_shift_px));
  };
  const Vec2 pp = micmac.principal_point - Vec2::Constant(pixel_shift_px);
  const auto samples = detail::sample_image(source, micmac.width, micmac.height, f, pp,
                                            options.grid_points_per_side);
  const bool exact = micmac.distortion_centre == micmac.principal_point && micmac.b1 == 0.0 &&
                     micmac.b2 == 0.0;
  // To first order MicMac's b1 ux = b1 F x matches B1 x'; the fit removes the rest.
  Camera<FraserAffine> camera(f, pp.x(), pp.y(), micmac.width, micmac.height,
                              {micmac.r3 * f * f, micmac.r5 * std::pow(f, 4),
                               micmac.r7 * std::pow(f, 6), micmac.p1 * f, micmac.p2 * f,
                               micmac.b1 * f, micmac.b2 * f});
  if (!exact) {
    const Eigen::VectorXd theta = detail::fit_pixel_model(
        [](const Eigen::VectorXd& t, const Vec2& xy) { return detail::fraser_affine_pixel(t, xy); },
        detail::theta_of(camera), detail::fraser_affine_steps(), samples, options.max_iterations);
    camera = detail::camera_from_theta(theta, micmac.width, micmac.height);
  }
  return detail::measure_conversion(
      camera, exact, [&camera](const Vec2& xy) { return camera.pixel_from_normalized(xy); },
      samples);
}

template <class Distortion>
ConversionResult<MicmacFraser> micmac_from_camera(const Camera<Distortion>& source,
                                                  const ConversionOptions& options,
                                                  double pixel_shift_px) {
  options.check();
  DIACHRON_CHECK(std::isfinite(pixel_shift_px), "pixel shift must be finite");
  const Camera<FraserAffine> camera = as_fraser_affine(source);
  const auto& p = camera.params();
  const double f = camera.focal();
  const bool exact = p[5] == 0.0 && p[6] == 0.0;
  const auto samples = detail::camera_samples(camera, options.grid_points_per_side);
  Eigen::VectorXd theta(10);
  theta << f, camera.cx() + pixel_shift_px, camera.cy() + pixel_shift_px, p[0], p[1], p[2], p[3],
      p[4], p[5] / f, p[6] / f;
  if (!exact) {
    Eigen::VectorXd steps(10);
    steps << 1e-3, 1e-3, 1e-3, 1e-7, 1e-7, 1e-7, 1e-7, 1e-7, 1e-7, 1e-7;
    const auto model = [f, &camera, pixel_shift_px](const Eigen::VectorXd& t, const Vec2& xy) {
      return Vec2(detail::micmac_from_theta(t, f, camera.width(), camera.height())
                      .pixel_from_normalized(xy) -
                  Vec2::Constant(pixel_shift_px));
    };
    theta = detail::fit_pixel_model(model, theta, steps, samples, options.max_iterations);
  }
  const MicmacFraser micmac = detail::micmac_from_theta(theta, f, camera.width(), camera.height());
  return detail::measure_conversion(
      micmac, exact,
      [&micmac, pixel_shift_px](const Vec2& xy) {
        return Vec2(micmac.pixel_from_normalized(xy) - Vec2::Constant(pixel_shift_px));
      },
      samples);
}

}  // namespace diachron
