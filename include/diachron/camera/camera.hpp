#pragma once
/// @file
/// Camera<Distortion>: the interior orientation of a frame camera (focal length, principal point,
/// image size, distortion) with projection usable by Ceres autodiff and an iterative unprojection.
///
/// Conventions (docs/conventions.md): pixel (0, 0) is the centre of the top-left pixel, x right,
/// y down; the camera frame has x right, y down, z forward; a camera-frame point X projects through
/// normalised coordinates (x, y) = (X/Z, Y/Z), the distortion policy gives (x', y') and
///   (u - cx, v - cy) = (f I + A) (x', y'),
/// where A is the policy's affine matrix (zero, or [[B1, B2], [0, 0]] for FraserAffine).
/// The Distortion concept is documented in diachron/camera/distortion.hpp.

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <type_traits>

#include <Eigen/Core>
#include <Eigen/LU>

#include <diachron/camera/distortion.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// Options of Camera::unproject.
struct UnprojectOptions {
  /// Largest accepted reprojection error of the returned direction, in pixels. > 0.
  double tolerance_px = 1e-10;
  /// Most Newton iterations. >= 1.
  int max_iterations = 60;
};

/// Outcome of Camera::unproject_detailed.
struct UnprojectResult {
  /// Ideal normalised coordinates (X/Z, Y/Z) of the pixel's ray; valid only when `converged`.
  Vec2 normalized = Vec2::Zero();
  /// True when projecting `normalized` gives the pixel back within the tolerance, on the branch
  /// of the distortion that contains the principal point.
  bool converged = false;
  /// Newton iterations used.
  int iterations = 0;
  /// Pixel distance between the projection of `normalized` and the input pixel, px.
  double residual_px = std::numeric_limits<double>::infinity();
};

/// The interior orientation of a frame camera.
///
/// Intrinsics block layout, as Ceres cost functors see it (one contiguous array of
/// kNumIntrinsics doubles or Jets):
///   [ f (px), cx (px), cy (px), params[0] ... params[kNumParams - 1] ]
/// The static templated functions also come in a two-block form, [f, cx, cy] and [params], so an
/// adjustment can share or hold constant the two parts separately.
///
/// A Camera is an immutable-by-default value type (setters check their arguments); all const
/// members are thread-safe.
/// @tparam Distortion a model of the Distortion concept (NoDistortion, RadialK3, Fraser,
///         FraserAffine).
template <class Distortion>
class Camera {
  static_assert(check_distortion<Distortion>());

 public:
  using DistortionType = Distortion;
  /// Number of distortion parameters.
  static constexpr int kNumParams = Distortion::kNumParams;
  /// Size of the intrinsics block [f, cx, cy, params...].
  static constexpr int kNumIntrinsics = 3 + kNumParams;
  /// Distortion parameters in the policy's order (units as the policy says).
  using Params = std::array<double, static_cast<std::size_t>(kNumParams)>;
  /// The intrinsics block [f, cx, cy, params...].
  using Intrinsics = std::array<double, static_cast<std::size_t>(kNumIntrinsics)>;

  /// @param focal_px focal length f in pixels, finite and > 0.
  /// @param cx_px, cy_px principal point in pixels, finite.
  /// @param width_px, height_px image size in pixels, > 0.
  /// @param params distortion parameters, finite; the pixel mapping f I + A must keep orientation.
  /// Precondition: as above, else throws diachron::Error.
  Camera(double focal_px, double cx_px, double cy_px, int width_px, int height_px,
         const Params& params = Params{})
      : focal_(focal_px), cx_(cx_px), cy_(cy_px), width_(width_px), height_(height_px),
        params_(params) {
    check();
  }

  /// Builds a camera from an intrinsics block [f, cx, cy, params...].
  static Camera from_intrinsics(const Intrinsics& intrinsics, int width_px, int height_px) {
    Params params{};
    for (int i = 0; i < kNumParams; ++i) params[i] = intrinsics[3 + i];
    return Camera(intrinsics[0], intrinsics[1], intrinsics[2], width_px, height_px, params);
  }

  /// Focal length, px.
  double focal() const { return focal_; }
  /// Principal point x, px.
  double cx() const { return cx_; }
  /// Principal point y, px.
  double cy() const { return cy_; }
  /// Principal point (cx, cy), px.
  Vec2 principal_point() const { return Vec2(cx_, cy_); }
  /// Image width, px.
  int width() const { return width_; }
  /// Image height, px.
  int height() const { return height_; }
  /// Distortion parameters.
  const Params& params() const { return params_; }
  /// The intrinsics block [f, cx, cy, params...].
  Intrinsics intrinsics() const {
    Intrinsics out{};
    out[0] = focal_;
    out[1] = cx_;
    out[2] = cy_;
    for (int i = 0; i < kNumParams; ++i) out[3 + i] = params_[i];
    return out;
  }

  /// Precondition: focal_px finite and > 0, else throws diachron::Error.
  void set_focal(double focal_px) {
    const double old = focal_;
    focal_ = focal_px;
    try {
      check();
    } catch (...) {
      focal_ = old;
      throw;
    }
  }
  /// Precondition: finite, else throws diachron::Error.
  void set_principal_point(double cx_px, double cy_px) {
    DIACHRON_CHECK(std::isfinite(cx_px) && std::isfinite(cy_px),
                   "principal point must be finite, got (" << cx_px << ", " << cy_px << ")");
    cx_ = cx_px;
    cy_ = cy_px;
  }
  /// Precondition: finite parameters that keep the pixel mapping orientation-preserving.
  void set_params(const Params& params) {
    const Params old = params_;
    params_ = params;
    try {
      check();
    } catch (...) {
      params_ = old;
      throw;
    }
  }

  // --- scalar-templated projection (Ceres autodiff) ----------------------------------------------

  /// Pixel of ideal normalised coordinates, two-block form.
  /// @param focal_pp [f, cx, cy] in px. @param params kNumParams distortion parameters (may be
  /// null when kNumParams == 0). @param xy normalised (X/Z, Y/Z). @param pixel out (u, v), px.
  template <class T>
  static void pixel_from_normalized(const T* focal_pp, const T* params, const T* xy, T* pixel) {
    T xd[2];
    Distortion::distort(params, xy, xd);
    T a[4];
    Distortion::affine(params, a);
    pixel[0] = focal_pp[1] + (focal_pp[0] + a[0]) * xd[0] + a[1] * xd[1];
    pixel[1] = focal_pp[2] + a[2] * xd[0] + (focal_pp[0] + a[3]) * xd[1];
  }

  /// Pixel of a camera-frame point, two-block form. No check of Z: the caller keeps Z > 0
  /// (a Ceres functor returns false otherwise), so no branch interrupts the derivatives.
  template <class T>
  static void project(const T* focal_pp, const T* params, const T* point_cam, T* pixel) {
    const T xy[2] = {point_cam[0] / point_cam[2], point_cam[1] / point_cam[2]};
    pixel_from_normalized(focal_pp, params, xy, pixel);
  }

  /// Pixel of a camera-frame point, one-block form: `intrinsics` is [f, cx, cy, params...].
  template <class T>
  static void project(const T* intrinsics, const T* point_cam, T* pixel) {
    project(intrinsics, intrinsics + 3, point_cam, pixel);
  }

  // --- double API ---------------------------------------------------------------------------------

  /// Pixel (px) of ideal normalised coordinates (X/Z, Y/Z).
  Vec2 pixel_from_normalized(const Vec2& xy) const {
    const double focal_pp[3] = {focal_, cx_, cy_};
    Vec2 pixel;
    pixel_from_normalized(focal_pp, params_.data(), xy.data(), pixel.data());
    return pixel;
  }

  /// True when `xy` (normalised) lies on the branch of the distortion that contains the
  /// principal point: the Jacobian determinant stays positive from the origin to `xy`. Beyond
  /// the first fold of the polynomial, points far outside the field of view would otherwise
  /// land inside the image.
  bool distortion_valid_at(const Vec2& xy) const {
    const auto jacobian = [this](const Vec2& p) {
      Eigen::Matrix<double, 2, 2, Eigen::RowMajor> j;
      Distortion::distort_jacobian(params_.data(), p.data(), j.data());
      return Mat2(j);
    };
    return detail::on_principal_branch(jacobian, xy);
  }

  /// Pixel (px) of a camera-frame point; nullopt when the point is not in front of the camera
  /// (Z <= 0), is not finite, or lies beyond the fold of the distortion polynomial.
  /// The pixel may be outside the image; see in_image().
  std::optional<Vec2> project(const Vec3& point_cam) const {
    if (!(point_cam.z() > 0.0) || !point_cam.allFinite()) return std::nullopt;
    const Vec2 xy(point_cam.x() / point_cam.z(), point_cam.y() / point_cam.z());
    if (!xy.allFinite() || !distortion_valid_at(xy)) return std::nullopt;
    const Vec2 pixel = pixel_from_normalized(xy);
    if (!pixel.allFinite()) return std::nullopt;
    return pixel;
  }

  /// Inverts the pixel mapping: the linear part in closed form, the distortion by damped Newton
  /// on its 2x2 Jacobian, stopping at a reprojection error far below options.tolerance_px.
  /// Never throws on data: a pixel with no preimage (absurd distortion, non-finite input) gives
  /// converged == false.
  UnprojectResult unproject_detailed(const Vec2& pixel, const UnprojectOptions& options = {}) const {
    DIACHRON_CHECK(options.tolerance_px > 0.0 && options.max_iterations >= 1,
                   "UnprojectOptions: tolerance_px must be > 0 and max_iterations >= 1, got "
                       << options.tolerance_px << " and " << options.max_iterations);
    UnprojectResult out;
    if (!pixel.allFinite()) return out;
    const Mat2 m = linear_part();
    const Vec2 xd = m.inverse() * (pixel - principal_point());
    UndistortResult solved;
    if constexpr (distortion_has_closed_form_v<Distortion>) {
      solved = Distortion::undistort_closed_form(params_.data(), xd);
      if (solved.converged) {
        solved.residual = (pixel_from_normalized(solved.xy) - pixel).norm();
        solved.converged = solved.residual <= options.tolerance_px;
      }
    } else {
      const auto map = [this](const Vec2& xy) { return pixel_from_normalized(xy); };
      const auto jacobian = [this, &m](const Vec2& xy) {
        Eigen::Matrix<double, 2, 2, Eigen::RowMajor> j;
        Distortion::distort_jacobian(params_.data(), xy.data(), j.data());
        return Mat2(m * j);
      };
      UndistortOptions newton;
      newton.tolerance = options.tolerance_px;
      newton.max_iterations = options.max_iterations;
      solved = detail::newton_invert(map, jacobian, pixel, xd, newton);
    }
    out.normalized = solved.xy;
    out.converged = solved.converged;
    out.iterations = solved.iterations;
    out.residual_px = solved.residual;
    return out;
  }

  /// Ideal normalised coordinates (X/Z, Y/Z) of a pixel; nullopt when unprojection fails.
  std::optional<Vec2> normalized_from_pixel(const Vec2& pixel,
                                            const UnprojectOptions& options = {}) const {
    const UnprojectResult r = unproject_detailed(pixel, options);
    if (!r.converged) return std::nullopt;
    return r.normalized;
  }

  /// Unit direction (camera frame, Z > 0) of the ray through a pixel; nullopt when unprojection
  /// fails (see unproject_detailed()).
  std::optional<Vec3> unproject(const Vec2& pixel, const UnprojectOptions& options = {}) const {
    const std::optional<Vec2> xy = normalized_from_pixel(pixel, options);
    if (!xy) return std::nullopt;
    return Vec3(xy->x(), xy->y(), 1.0).normalized();
  }

  /// True when `pixel` lies on the image, edges included: [-0.5, width - 0.5] x
  /// [-0.5, height - 0.5] (pixel centres at integers).
  bool in_image(const Vec2& pixel) const {
    return pixel.x() >= -0.5 && pixel.y() >= -0.5 && pixel.x() <= width_ - 0.5 &&
           pixel.y() <= height_ - 0.5;
  }

 private:
  // f I + A: the pixel mapping of distorted normalised coordinates, without the principal point.
  Mat2 linear_part() const {
    double a[4];
    Distortion::affine(params_.data(), a);
    Mat2 m;
    m << focal_ + a[0], a[1], a[2], focal_ + a[3];
    return m;
  }

  void check() const {
    DIACHRON_CHECK(std::isfinite(focal_) && focal_ > 0.0,
                   "focal length must be finite and > 0 px, got " << focal_);
    DIACHRON_CHECK(std::isfinite(cx_) && std::isfinite(cy_),
                   "principal point must be finite, got (" << cx_ << ", " << cy_ << ")");
    DIACHRON_CHECK(width_ > 0 && height_ > 0,
                   "image size must be positive, got " << width_ << " x " << height_);
    for (int i = 0; i < kNumParams; ++i) {
      DIACHRON_CHECK(std::isfinite(params_[i]), "distortion parameter "
                                                    << Distortion::param_names()[i]
                                                    << " must be finite, got " << params_[i]);
    }
    DIACHRON_CHECK(linear_part().determinant() > 0.0,
                   "the affine part of the pixel mapping must keep orientation (det(f I + A) > 0)");
  }

  double focal_;
  double cx_;
  double cy_;
  int width_;
  int height_;
  Params params_;
};

/// The same camera expressed with FraserAffine parameters (exact: every built-in policy is a
/// special case of it).
template <class Distortion>
Camera<FraserAffine> as_fraser_affine(const Camera<Distortion>& camera) {
  Camera<FraserAffine>::Params p{};
  const auto& q = camera.params();
  if constexpr (std::is_same_v<Distortion, NoDistortion>) {
    (void)q;
  } else if constexpr (std::is_same_v<Distortion, RadialK3>) {
    p = {q[0], q[1], q[2], 0.0, 0.0, 0.0, 0.0};
  } else if constexpr (std::is_same_v<Distortion, Fraser>) {
    p = {q[0], q[1], q[2], q[3], q[4], 0.0, 0.0};
  } else {
    static_assert(std::is_same_v<Distortion, FraserAffine>,
                  "as_fraser_affine knows the built-in policies only");
    p = q;
  }
  return Camera<FraserAffine>(camera.focal(), camera.cx(), camera.cy(), camera.width(),
                              camera.height(), p);
}

}  // namespace diachron
