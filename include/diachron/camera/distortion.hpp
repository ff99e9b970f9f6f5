#pragma once
/// @file
/// Lens distortion policies for Camera<Distortion>: NoDistortion, RadialK3, Fraser and FraserAffine
/// (docs/conventions.md), the Distortion concept they model, and the iterative undistortion.
///
/// Requirements for Distortion (a pseudo-class; every member static, so a policy carries no state
/// and the same code serves double, float and ceres::Jet):
/// @code
/// struct MyDistortion {
///   // Number of parameters (>= 0); Camera stores them in this order.
///   static constexpr int kNumParams;
///
///   // One short name per parameter ("K1", "B1", ...), for reports and docs.
///   static constexpr std::array<std::string_view, kNumParams> param_names();
///
///   // Ideal normalised coordinates xy = (X/Z, Y/Z) -> distorted normalised coordinates.
///   // `params` holds kNumParams values (it may be null when kNumParams == 0). T is double,
///   // float or ceres::Jet: literals as T(...), no value-dependent branches.
///   template <class T>
///   static void distort(const T* params, const T* xy, T* xy_distorted);
///
///   // d(xy_distorted)/d(xy) at xy, row-major 2x2 [dxd/dx, dxd/dy, dyd/dx, dyd/dy]. Used by the
///   // Newton inversion and by the fold test (the determinant must stay positive from the
///   // origin to the point, else the polynomial has folded over and is no longer one-to-one).
///   static void distort_jacobian(const double* params, const double* xy, double* jacobian);
///
///   // The 2x2 matrix A (pixels, row-major) of the affine part of the pixel mapping
///   //   (u - cx, v - cy) = (f I + A) (xd, yd).
///   // All zeros for policies without an affine part; [B1, B2, 0, 0] for FraserAffine.
///   template <class T>
///   static void affine(const T* params, T* a);
///
///   // OPTIONAL. Closed-form inverse of distort. Without it, undistort() runs Newton's method on
///   // distort/distort_jacobian.
///   static UndistortResult undistort_closed_form(const double* params, const Vec2& xy_distorted);
/// };
/// @endcode
/// Models: NoDistortion, RadialK3, Fraser, FraserAffine (all in this header).
/// Parameter units: K1, K2, K3 and P1, P2 are dimensionless (they act on normalised coordinates);
/// B1, B2 are in pixels.

#include <array>
#include <cmath>
#include <limits>
#include <string_view>
#include <type_traits>
#include <utility>

#include <Eigen/Core>
#include <Eigen/LU>

#include <diachron/core/types.hpp>

namespace diachron {

/// Outcome of inverting a distortion (or a whole pixel mapping) by Newton's method.
struct UndistortResult {
  /// The ideal point found (normalised coordinates, or whatever the inverted map takes).
  Vec2 xy = Vec2::Zero();
  /// True when the residual reached the tolerance on the branch of the map that contains the
  /// origin (positive Jacobian determinant); false means `xy` must not be used.
  bool converged = false;
  /// Newton iterations performed.
  int iterations = 0;
  /// Distance between the map of `xy` and the target, in the target's units.
  double residual = std::numeric_limits<double>::infinity();
};

/// Options of the Newton inversion of a distortion.
struct UndistortOptions {
  /// Largest accepted residual, in the units of the inverted map (normalised coordinates for
  /// undistort(), pixels for Camera::unproject). > 0.
  double tolerance = 1e-14;
  /// Most Newton iterations (each with at most 40 step halvings). >= 1.
  int max_iterations = 60;
};

namespace detail {

// The Fraser radial + decentring form shared by RadialK3, Fraser and FraserAffine.
template <class T>
void fraser_distort(const T& k1, const T& k2, const T& k3, const T& p1, const T& p2, const T* xy,
                    T* out) {
  const T x = xy[0];
  const T y = xy[1];
  const T x2 = x * x;
  const T y2 = y * y;
  const T xy_product = x * y;
  const T r2 = x2 + y2;
  const T radial = T(1) + r2 * (k1 + r2 * (k2 + r2 * k3));
  out[0] = x * radial + p1 * (r2 + T(2) * x2) + T(2) * p2 * xy_product;
  out[1] = y * radial + p2 * (r2 + T(2) * y2) + T(2) * p1 * xy_product;
}

inline void fraser_jacobian(double k1, double k2, double k3, double p1, double p2, const double* xy,
                            double* jacobian) {
  const double x = xy[0];
  const double y = xy[1];
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  // d(radial)/d(r^2); d(r^2)/dx = 2x.
  const double slope = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
  const double cross = 2.0 * x * y * slope;
  jacobian[0] = radial + 2.0 * x * x * slope + 6.0 * p1 * x + 2.0 * p2 * y;
  jacobian[1] = cross + 2.0 * p1 * y + 2.0 * p2 * x;
  jacobian[2] = cross + 2.0 * p2 * x + 2.0 * p1 * y;
  jacobian[3] = radial + 2.0 * y * y * slope + 6.0 * p2 * y + 2.0 * p1 * x;
}

template <class T>
void zero_affine(T* a) {
  a[0] = T(0);
  a[1] = T(0);
  a[2] = T(0);
  a[3] = T(0);
}

inline bool all_finite(const Vec2& v) { return std::isfinite(v.x()) && std::isfinite(v.y()); }

/// True when the Jacobian determinant stays positive on the segment from the origin to `xy`
/// (sampled at 16 points): the point lies on the branch of the distortion that contains the
/// principal point. A strongly negative K1 makes the radial polynomial fold and then turn back, so
/// a positive determinant at `xy` alone would accept mirrored solutions beyond the fold.
template <class Jacobian>
bool on_principal_branch(const Jacobian& jacobian, const Vec2& xy) {
  constexpr int kSamples = 16;
  for (int k = 1; k <= kSamples; ++k) {
    const double det = jacobian(Vec2((double(k) / kSamples) * xy)).determinant();
    if (!(det > 0.0)) return false;
  }
  return true;
}

/// Solves map(xy) = target by damped Newton from `start`. `map(xy) -> Vec2`, `jacobian(xy) ->
/// Mat2`. Iterates past `tolerance` (to tolerance / 1000) while that still makes progress, because
/// the extra quadratic steps are nearly free; `converged` needs residual <= tolerance and a
/// positive Jacobian determinant from the origin to the solution (the branch that contains the
/// identity).
template <class Map, class Jacobian>
UndistortResult newton_invert(const Map& map, const Jacobian& jacobian, const Vec2& target,
                              const Vec2& start, const UndistortOptions& options) {
  UndistortResult result;
  if (!all_finite(target) || !all_finite(start)) return result;
  Vec2 xy = start;
  Vec2 r = map(xy) - target;
  double norm = r.norm();
  const double goal = options.tolerance * 1e-3;
  int it = 0;
  for (; it < options.max_iterations && norm > goal && std::isfinite(norm); ++it) {
    const Mat2 j = jacobian(xy);
    const double det = j.determinant();
    if (!(std::abs(det) > 0.0) || !std::isfinite(det)) break;
    const Vec2 step = j.inverse() * r;
    // A step at the rounding level of xy cannot improve it; halving it would only burn evaluations.
    if (step.norm() <= std::numeric_limits<double>::epsilon() * xy.norm()) break;
    // Backtracking keeps the iteration from jumping to another branch of a strongly folded
    // polynomial; it stops when no shorter step lowers the residual (stagnation at rounding level).
    double scale = 1.0;
    bool improved = false;
    for (int halving = 0; halving < 40; ++halving, scale *= 0.5) {
      const Vec2 candidate = xy - scale * step;
      const Vec2 rc = map(candidate) - target;
      const double nc = rc.norm();
      if (std::isfinite(nc) && nc < norm) {
        xy = candidate;
        r = rc;
        norm = nc;
        improved = true;
        break;
      }
    }
    if (!improved) break;
  }
  result.xy = xy;
  result.iterations = it;
  result.residual = norm;
  result.converged =
      std::isfinite(norm) && norm <= options.tolerance && on_principal_branch(jacobian, xy);
  return result;
}

}  // namespace detail

/// The pinhole: no distortion, no parameters.
struct NoDistortion {
  static constexpr int kNumParams = 0;
  static constexpr std::array<std::string_view, 0> param_names() { return {}; }

  template <class T>
  static void distort(const T* /*params*/, const T* xy, T* xy_distorted) {
    xy_distorted[0] = xy[0];
    xy_distorted[1] = xy[1];
  }
  static void distort_jacobian(const double* /*params*/, const double* /*xy*/, double* jacobian) {
    jacobian[0] = 1.0;
    jacobian[1] = 0.0;
    jacobian[2] = 0.0;
    jacobian[3] = 1.0;
  }
  template <class T>
  static void affine(const T* /*params*/, T* a) {
    detail::zero_affine(a);
  }
  static UndistortResult undistort_closed_form(const double* /*params*/, const Vec2& xy_distorted) {
    UndistortResult result;
    result.xy = xy_distorted;
    result.converged = detail::all_finite(xy_distorted);
    result.residual = result.converged ? 0.0 : std::numeric_limits<double>::infinity();
    return result;
  }
};

/// Radial distortion with three coefficients (dimensionless, normalised coordinates):
/// x' = x (1 + K1 r^2 + K2 r^4 + K3 r^6), y' likewise. Parameters [K1, K2, K3].
struct RadialK3 {
  static constexpr int kNumParams = 3;
  static constexpr std::array<std::string_view, 3> param_names() { return {"K1", "K2", "K3"}; }

  template <class T>
  static void distort(const T* params, const T* xy, T* xy_distorted) {
    detail::fraser_distort(params[0], params[1], params[2], T(0), T(0), xy, xy_distorted);
  }
  static void distort_jacobian(const double* params, const double* xy, double* jacobian) {
    detail::fraser_jacobian(params[0], params[1], params[2], 0.0, 0.0, xy, jacobian);
  }
  template <class T>
  static void affine(const T* /*params*/, T* a) {
    detail::zero_affine(a);
  }
};

/// Fraser (1997) radial + decentring distortion in the Australis / Metashape form
/// (docs/conventions.md), all coefficients dimensionless. Parameters [K1, K2, K3, P1, P2]:
///   x' = x (1 + K1 r^2 + K2 r^4 + K3 r^6) + P1 (r^2 + 2 x^2) + 2 P2 x y
///   y' = y (1 + K1 r^2 + K2 r^4 + K3 r^6) + P2 (r^2 + 2 y^2) + 2 P1 x y
struct Fraser {
  static constexpr int kNumParams = 5;
  static constexpr std::array<std::string_view, 5> param_names() {
    return {"K1", "K2", "K3", "P1", "P2"};
  }

  template <class T>
  static void distort(const T* params, const T* xy, T* xy_distorted) {
    detail::fraser_distort(params[0], params[1], params[2], params[3], params[4], xy,
                           xy_distorted);
  }
  static void distort_jacobian(const double* params, const double* xy, double* jacobian) {
    detail::fraser_jacobian(params[0], params[1], params[2], params[3], params[4], xy, jacobian);
  }
  template <class T>
  static void affine(const T* /*params*/, T* a) {
    detail::zero_affine(a);
  }
};

/// Fraser plus the affinity of the pixel mapping: parameters [K1, K2, K3, P1, P2, B1, B2] with
/// B1, B2 in pixels, u = cx + f x' + B1 x' + B2 y', v = cy + f y'. B1 is the difference of the
/// x and y scales, B2 the shear (both act on the distorted coordinates).
struct FraserAffine {
  static constexpr int kNumParams = 7;
  static constexpr std::array<std::string_view, 7> param_names() {
    return {"K1", "K2", "K3", "P1", "P2", "B1", "B2"};
  }

  template <class T>
  static void distort(const T* params, const T* xy, T* xy_distorted) {
    Fraser::distort(params, xy, xy_distorted);
  }
  static void distort_jacobian(const double* params, const double* xy, double* jacobian) {
    Fraser::distort_jacobian(params, xy, jacobian);
  }
  template <class T>
  static void affine(const T* params, T* a) {
    a[0] = params[5];
    a[1] = params[6];
    a[2] = T(0);
    a[3] = T(0);
  }
};

// --- concept detection ---------------------------------------------------------------------------

namespace detail {

template <class D, class = void>
struct has_num_params : std::false_type {};
template <class D>
struct has_num_params<D, std::enable_if_t<std::is_convertible_v<decltype(D::kNumParams), int>>>
    : std::true_type {};

template <class D, class = void>
struct has_param_names : std::false_type {};
template <class D>
struct has_param_names<D, std::void_t<decltype(D::param_names())>> : std::true_type {};

template <class D, class = void>
struct has_distort : std::false_type {};
template <class D>
struct has_distort<D, std::void_t<decltype(D::template distort<double>(
                          std::declval<const double*>(), std::declval<const double*>(),
                          std::declval<double*>()))>> : std::true_type {};

template <class D, class = void>
struct has_distort_jacobian : std::false_type {};
template <class D>
struct has_distort_jacobian<D, std::void_t<decltype(D::distort_jacobian(
                                   std::declval<const double*>(), std::declval<const double*>(),
                                   std::declval<double*>()))>> : std::true_type {};

template <class D, class = void>
struct has_affine : std::false_type {};
template <class D>
struct has_affine<D, std::void_t<decltype(D::template affine<double>(
                         std::declval<const double*>(), std::declval<double*>()))>>
    : std::true_type {};

template <class D, class = void>
struct has_undistort_closed_form : std::false_type {};
template <class D>
struct has_undistort_closed_form<
    D, std::enable_if_t<std::is_same_v<decltype(D::undistort_closed_form(
                                           std::declval<const double*>(),
                                           std::declval<const Vec2&>())),
                                       UndistortResult>>> : std::true_type {};

}  // namespace detail

/// True when D satisfies the required part of the Distortion concept.
template <class D>
inline constexpr bool is_distortion_v =
    detail::has_num_params<D>::value && detail::has_param_names<D>::value &&
    detail::has_distort<D>::value && detail::has_distort_jacobian<D>::value &&
    detail::has_affine<D>::value;

/// True when D provides the optional closed-form `undistort_closed_form`.
template <class D>
inline constexpr bool distortion_has_closed_form_v = detail::has_undistort_closed_form<D>::value;

/// Compile-time check with messages that name the missing member; used at the top of every
/// template that consumes a Distortion.
template <class D>
constexpr bool check_distortion() {
  static_assert(detail::has_num_params<D>::value,
                "Distortion must define `static constexpr int kNumParams` "
                "(see diachron/camera/distortion.hpp)");
  static_assert(detail::has_param_names<D>::value,
                "Distortion must define `static constexpr std::array<std::string_view, "
                "kNumParams> param_names()`");
  static_assert(detail::has_distort<D>::value,
                "Distortion must define `template <class T> static void distort(const T* params, "
                "const T* xy, T* xy_distorted)`");
  static_assert(detail::has_distort_jacobian<D>::value,
                "Distortion must define `static void distort_jacobian(const double* params, const "
                "double* xy, double* jacobian)`");
  static_assert(detail::has_affine<D>::value,
                "Distortion must define `template <class T> static void affine(const T* params, "
                "T* a)`");
  if constexpr (detail::has_num_params<D>::value) {
    static_assert(D::kNumParams >= 0, "Distortion::kNumParams must not be negative");
  }
  return true;
}

static_assert(is_distortion_v<NoDistortion> && is_distortion_v<RadialK3> &&
                  is_distortion_v<Fraser> && is_distortion_v<FraserAffine>,
              "the built-in distortion policies must model the Distortion concept");

/// Inverts `Distortion::distort`: the ideal normalised point whose distortion is `xy_distorted`.
/// Uses the policy's closed form when it has one, otherwise damped Newton from xy = xy_distorted.
/// Data failures (no preimage, a folded polynomial, non-finite input) give converged == false.
/// @param params Distortion::kNumParams values.
/// @param xy_distorted Distorted normalised coordinates.
template <class Distortion>
UndistortResult undistort(const double* params, const Vec2& xy_distorted,
                          const UndistortOptions& options = {}) {
  static_assert(check_distortion<Distortion>());
  if constexpr (distortion_has_closed_form_v<Distortion>) {
    (void)options;
    return Distortion::undistort_closed_form(params, xy_distorted);
  } else {
    const auto map = [params](const Vec2& xy) {
      Vec2 out;
      Distortion::distort(params, xy.data(), out.data());
      return out;
    };
    const auto jacobian = [params](const Vec2& xy) {
      Eigen::Matrix<double, 2, 2, Eigen::RowMajor> j;
      Distortion::distort_jacobian(params, xy.data(), j.data());
      return Mat2(j);
    };
    return detail::newton_invert(map, jacobian, xy_distorted, xy_distorted, options);
  }
}

}  // namespace diachron
