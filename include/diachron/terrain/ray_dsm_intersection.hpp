#pragma once
/// @file
/// First crossing of a ray with a DSM's bilinear surface: a march in steps of a fraction of a cell,
/// split at cell edges so that no crossing between samples is skipped, refined by bisection.
///
/// This replaces MicMac's fixed-point projection (nearest-neighbour height, iterate Z -> X/Y, at most
/// 11 rounds, which can oscillate on steep relief) by a search for the *first* crossing along the ray.

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/geometry/ray.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of intersect_ray_dsm().
struct RayDsmOptions {
  /// Largest horizontal step of the march, in cells (measured in the DSM's pixel grid). The march
  /// also stops at every cell edge, and inside a cell the bilinear surface along the ray is a
  /// quadratic, which is tested exactly, so this only bounds the bisection bracket: crossings are
  /// found whatever its value. 0.5 by default.
  double step_cells = 0.5;
  /// Bisection stops when the bracket along the ray is shorter than this many cells (of the
  /// smaller cell size); a final linear interpolation of the bracket follows, exact on planar
  /// cells. 1e-8 by default: far below any image's pixel footprint, at ~27 evaluations per hit.
  double tolerance_cells = 1e-8;
  /// Only the part of the ray with 0 <= t <= max_distance is searched (world units along the ray).
  /// Infinite by default.
  double max_distance = std::numeric_limits<double>::infinity();

  void check() const {
    DIACHRON_CHECK(step_cells > 0.0 && std::isfinite(step_cells), "step_cells must be positive, got " << step_cells);
    DIACHRON_CHECK(tolerance_cells > 0.0 && std::isfinite(tolerance_cells),
                   "tolerance_cells must be positive, got " << tolerance_cells);
    DIACHRON_CHECK(max_distance > 0.0, "max_distance must be positive, got " << max_distance);
  }
};

/// Why a ray did or did not meet the DSM.
enum class RayDsmOutcome {
  hit,             ///< the first crossing was found
  outside,         ///< the searched part of the ray never passes over the grid within the height range
  above_surface,   ///< the ray stays above all the valid terrain it passes over until it leaves the
                   ///< DSM (sideways, or at max_distance)
  only_holes,      ///< the ray passes over the grid only where the DSM has holes
  below_surface,   ///< the ray is already below the surface where it first meets valid terrain
                   ///< (origin underground, or entering the DSM from the side below its surface)
  hidden_by_hole,  ///< the ray goes below the surface inside a hole (it is below the surface after
                   ///< the hole, or reaches the lowest DSM height over it): the crossing is in missing data
  no_ray,          ///< there was no ray to intersect: the pixel is not finite or the frame cannot
                   ///< unproject it (DsmLift, DsmTransfer); intersect_ray_dsm itself never says this
};

/// Short text for an outcome (for messages and reports).
inline const char* to_string(RayDsmOutcome outcome) {
  switch (outcome) {
    case RayDsmOutcome::hit: return "hit";
    case RayDsmOutcome::outside: return "ray does not pass over the DSM";
    case RayDsmOutcome::above_surface: return "ray stays above the surface";
    case RayDsmOutcome::only_holes: return "ray passes over holes only";
    case RayDsmOutcome::below_surface: return "ray starts below the surface";
    case RayDsmOutcome::hidden_by_hole: return "ray crosses the surface inside a hole";
    case RayDsmOutcome::no_ray: return "pixel cannot be unprojected (no ray)";
  }
  return "unknown";
}

/// Result of intersect_ray_dsm(): `point` and `distance` are meaningful only when `success`.
struct RayDsmResult {
  bool success = false;
  Eigen::Vector3d point = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());  ///< world
  double distance = std::numeric_limits<double>::quiet_NaN();  ///< along the ray from its origin, world units
  RayDsmOutcome outcome = RayDsmOutcome::outside;
};

namespace detail {

/// Interval of t where lo <= a + b t <= hi; empty (lo > hi) when none.
inline void clip_slab(double a, double b, double lo, double hi, double& t0, double& t1) {
  if (b == 0.0) {
    if (a < lo || a > hi) {
      t0 = std::numeric_limits<double>::infinity();
      t1 = -std::numeric_limits<double>::infinity();
    }
    return;
  }
  double ta = (lo - a) / b, tb = (hi - a) / b;
  if (ta > tb) std::swap(ta, tb);
  t0 = std::max(t0, ta);
  t1 = std::min(t1, tb);
}

}  // namespace detail

/// The first point where `ray` crosses the DSM's bilinear surface (Dsm::height_at), going from above
/// to on-or-below it. The ray's direction need not be unit length (it is normalised here); `distance`
/// is measured along the normalised direction. "No intersection" is a result, not an error; a ray
/// with a non-finite or zero direction, or non-finite origin, throws diachron::Error.
///
/// How: the ray is clipped to the grid of pixel centres and to the DSM's height range (so a
/// near-vertical ray is searched only over [min, max] height, never over an unbounded interval),
/// then marched in pixel space, stopping at every cell edge and at least every `step_cells`. Inside
/// one cell the height along the ray is quadratic in t, so with the two ends and the middle of each
/// step the whole step is tested: a cliff or a spike between samples is not skipped.
inline RayDsmResult intersect_ray_dsm(const Dsm& dsm, const Ray3& ray, const RayDsmOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(ray.origin.allFinite() && ray.direction.allFinite(), "ray has non-finite origin or direction");
  const double norm = ray.direction.norm();
  DIACHRON_CHECK(norm > 0.0, "ray has a zero direction");
  const Eigen::Vector3d o = ray.origin;
  const Eigen::Vector3d d = ray.direction / norm;

  RayDsmResult result;
  if (dsm.empty()) return result;
  const int w = dsm.width(), h = dsm.height();

  // The ray in pixel space is affine in t: p(t) = a + b t.
  const Eigen::Vector2d a = dsm.world_to_pixel(o.head<2>());
  const Eigen::Vector2d b = dsm.world_to_pixel(o.head<2>() + d.head<2>()) - a;

  double t0 = 0.0, t1 = options.max_distance;
  bool ends_below = false;
  detail::clip_slab(a.x(), b.x(), 0.0, w - 1.0, t0, t1);
  detail::clip_slab(a.y(), b.y(), 0.0, h - 1.0, t0, t1);
  if (!(t0 <= t1)) return result;  // outside
  const DsmStatistics& stats = dsm.statistics();
  if (stats.count == 0) {
    result.outcome = RayDsmOutcome::only_holes;
    return result;
  }
  {
    // A small margin keeps rays that touch the highest or lowest sample exactly.
    const double margin = 1e-9 * (1.0 + std::abs(stats.min) + std::abs(stats.max));
    double z0 = t0, z1 = t1;
    detail::clip_slab(o.z(), d.z(), stats.min - margin, stats.max + margin, z0, z1);
    if (!(z0 <= z1)) {
      // Over the grid but entirely above or below the height range.
      result.outcome = o.z() + d.z() * t0 > stats.max ? RayDsmOutcome::above_surface
                                                      : RayDsmOutcome::below_surface;
      return result;
    }
    // The ray reaches the bottom of the height range inside the grid: below there, it is under
    // any valid terrain, so a march that ends in a hole there has crossed the surface in the hole.
    ends_below = z1 < t1;
    t0 = z0;
    t1 = z1;
  }

  const auto pixel = [&](double t) {
    // Clamping absorbs rounding at the clipped ends; inside, p(t) is already in the grid.
    const Eigen::Vector2d p = a + b * t;
    return Eigen::Vector2d(std::clamp(p.x(), 0.0, w - 1.0), std::clamp(p.y(), 0.0, h - 1.0));
  };
  const auto f = [&](double t) { return o.z() + d.z() * t - dsm.height_at_pixel(pixel(t)); };

  const double tolerance = options.tolerance_cells * dsm.min_cell_size();
  const auto bisect = [&](double lo, double flo, double hi, double fhi) {
    for (int i = 0; i < 200 && hi - lo > tolerance; ++i) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      const double fmid = f(mid);
      if (std::isnan(fmid)) break;
      if (fmid > 0.0) {
        lo = mid;
        flo = fmid;
      } else {
        hi = mid;
        fhi = fmid;
      }
    }
    const double t = (flo - fhi) > 0.0 ? lo + (hi - lo) * flo / (flo - fhi) : hi;
    RayDsmResult hit;
    hit.success = true;
    hit.distance = std::clamp(t, lo, hi);
    hit.point = o + hit.distance * d;
    hit.outcome = RayDsmOutcome::hit;
    return hit;
  };

  // Cell-edge march (a DDA over the bilinear cells [i, i+1] x [j, j+1] of the pixel grid).
  const double inf = std::numeric_limits<double>::infinity();
  const double speed = b.norm();  // cells per unit t
  const double max_step = speed > 0.0 ? options.step_cells / speed : inf;
  const int sx = b.x() > 0.0 ? 1 : (b.x() < 0.0 ? -1 : 0);
  const int sy = b.y() > 0.0 ? 1 : (b.y() < 0.0 ? -1 : 0);
  const Eigen::Vector2d p0 = pixel(t0);
  int ix = std::clamp(static_cast<int>(std::floor(p0.x())), 0, std::max(w - 2, 0));
  int iy = std::clamp(static_cast<int>(std::floor(p0.y())), 0, std::max(h - 2, 0));
  if (sx < 0 && ix > 0 && p0.x() == ix) --ix;
  if (sy < 0 && iy > 0 && p0.y() == iy) --iy;
  const auto next_x = [&](int i) { return sx > 0 ? (i + 1 - a.x()) / b.x() : (sx < 0 ? (i - a.x()) / b.x() : inf); };
  const auto next_y = [&](int j) { return sy > 0 ? (j + 1 - a.y()) / b.y() : (sy < 0 ? (j - a.y()) / b.y() : inf); };
  double tx = next_x(ix), ty = next_y(iy);

  bool seen_valid = false;  // a fully valid step has been seen
  bool gap = false;         // holes since the last valid step
  double t = t0;
  double ft = f(t);
  while (t < t1) {
    const double tn = std::min({t1, t + max_step, tx, ty});
    if (tn > t) {
      const double tm = 0.5 * (t + tn);
      const double fm = f(tm), fn = f(tn);
      if (std::isnan(ft) || std::isnan(fm) || std::isnan(fn)) {
        gap = true;
      } else {
        if (ft <= 0.0) {
          // Only the first valid sample can be on or below the surface: any later one would have
          // been bracketed by the previous step, unless a hole lay in between.
          if (ft == 0.0) return bisect(t, ft, t, ft);
          result.outcome = gap ? RayDsmOutcome::hidden_by_hole : RayDsmOutcome::below_surface;
          return result;
        }
        seen_valid = true;
        gap = false;
        // f(s) = ft + B s + A s^2 on s in [0, 1], exact inside one bilinear cell.
        const double A = 2.0 * ft - 4.0 * fm + 2.0 * fn;
        const double B = -3.0 * ft + 4.0 * fm - fn;
        if (A > 0.0) {
          const double s = -B / (2.0 * A);
          if (s > 0.0 && s < 1.0 && ft - B * B / (4.0 * A) <= 0.0) {
            const double ts = t + s * (tn - t);
            const double fs = f(ts);
            if (!std::isnan(fs) && fs <= 0.0) return bisect(t, ft, ts, fs);
          }
        }
        if (fm <= 0.0) return bisect(t, ft, tm, fm);
        if (fn <= 0.0) return bisect(tm, fm, tn, fn);
      }
      t = tn;
      ft = fn;
    }
    if (tn == tx) {
      ix += sx;
      tx = next_x(ix);
    }
    if (tn == ty) {
      iy += sy;
      ty = next_y(iy);
    }
  }
  if (!seen_valid) {
    result.outcome = RayDsmOutcome::only_holes;
  } else {
    result.outcome = gap && ends_below ? RayDsmOutcome::hidden_by_hole : RayDsmOutcome::above_surface;
  }
  return result;
}

/// The first crossing of `ray` with the DSM, or nullopt when there is none (see intersect_ray_dsm()).
inline std::optional<Eigen::Vector3d> ray_dsm_point(const Dsm& dsm, const Ray3& ray,
                                                    const RayDsmOptions& options = {}) {
  const RayDsmResult r = intersect_ray_dsm(dsm, ray, options);
  if (!r.success) return std::nullopt;
  return r.point;
}

}  // namespace diachron
