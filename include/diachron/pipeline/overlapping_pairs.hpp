#pragma once
/// @file
/// Which images of two epochs overlap on the ground: each image's footprint through its epoch's DSM
/// (corner and edge-sample rays intersected with the DSM surface), the master footprints moved into
/// the secondary frame by the epoch 1 -> epoch 2 point transform, and every master x secondary pair
/// ranked by the area of the footprints' intersection.
///
/// MicMac (TiePHistorical's image-pair selection) intersects the corner rays with a plane at the
/// DSM's mean height; over strong relief or with oblique views that footprint is off by the
/// relief times the view angle's tangent. Here every ray meets the DSM itself (intersect_ray_dsm),
/// so the footprint is the ground the image really sees, and rays that miss are counted.
///
/// Also the polygon tools it needs, usable alone: polygon_signed_area, polygon_is_simple,
/// triangulate_polygon (ear clipping) and polygon_intersection_area (exact for simple polygons,
/// convex or not: both are triangulated and every pair of triangles is clipped, a convex against a
/// convex polygon).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/geometry/ray.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/gsd.hpp>  // detail::ray_plane_z
#include <diachron/terrain/ray_dsm_intersection.hpp>
#include <diachron/terrain/transfer.hpp>

namespace diachron {

// Polygons -------------------------------------------------------------------------------------

/// A polygon as its vertices in order, XY (any unit); the last vertex connects to the first.
using Polygon2 = std::vector<Eigen::Vector2d>;

/// Shoelace area: positive when the vertices run counter-clockwise (X right, Y up), units^2.
inline double polygon_signed_area(const Polygon2& polygon) {
  const std::size_t n = polygon.size();
  if (n < 3) return 0.0;
  // Relative to the first vertex: keeps precision for UTM-sized coordinates.
  const Eigen::Vector2d o = polygon[0];
  double twice = 0.0;
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const Eigen::Vector2d a = polygon[i] - o, b = polygon[i + 1] - o;
    twice += a.x() * b.y() - a.y() * b.x();
  }
  return 0.5 * twice;
}

namespace detail {

inline double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// Sign of the turn a -> b -> c with a tolerance relative to the edge lengths, so that samples
// along a straight image edge (collinear up to rounding) count as collinear.
inline int turn(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  const Eigen::Vector2d u = b - a, v = c - b;
  const double c2 = cross2(u, v);
  const double tolerance = 1e-12 * u.norm() * v.norm();
  if (c2 > tolerance) return 1;
  if (c2 < -tolerance) return -1;
  return 0;
}

inline bool on_segment(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return std::min(a.x(), b.x()) <= p.x() && p.x() <= std::max(a.x(), b.x()) && std::min(a.y(), b.y()) <= p.y() &&
         p.y() <= std::max(a.y(), b.y());
}

// Closed segments [a, b] and [c, d] share a point.
inline bool segments_meet(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                          const Eigen::Vector2d& d) {
  const int o1 = turn(a, b, c), o2 = turn(a, b, d), o3 = turn(c, d, a), o4 = turn(c, d, b);
  if (o1 != o2 && o3 != o4 && o1 != 0 && o2 != 0 && o3 != 0 && o4 != 0) return true;
  if (o1 == 0 && on_segment(c, a, b)) return true;
  if (o2 == 0 && on_segment(d, a, b)) return true;
  if (o3 == 0 && on_segment(a, c, d)) return true;
  return o4 == 0 && on_segment(b, c, d);
}

// The polygon without repeated consecutive vertices and without vertices where it goes straight on
// (an image edge's samples over flat ground): these add nothing and would make zero-area ears.
inline Polygon2 drop_collinear(const Polygon2& polygon) {
  Polygon2 p;
  for (const Eigen::Vector2d& v : polygon)
    if (p.empty() || v != p.back()) p.push_back(v);
  while (p.size() > 1 && p.front() == p.back()) p.pop_back();
  bool changed = true;
  while (changed && p.size() >= 3) {
    changed = false;
    for (std::size_t i = 0; i < p.size() && p.size() >= 3; ++i) {
      const std::size_t n = p.size();
      const Eigen::Vector2d& a = p[(i + n - 1) % n];
      const Eigen::Vector2d& c = p[(i + 1) % n];
      // Straight on (the middle vertex between its neighbours), not a spike back.
      if (turn(a, p[i], c) == 0 && (p[i] - a).dot(c - p[i]) > 0.0) {
        p.erase(p.begin() + static_cast<std::ptrdiff_t>(i));
        changed = true;
        --i;
      }
    }
  }
  return p;
}

// Area of the intersection of two convex counter-clockwise polygons (Sutherland-Hodgman: the
// subject clipped by each edge of the clip polygon in turn).
inline double convex_intersection_area(const Polygon2& subject, const Polygon2& clip) {
  Polygon2 out = subject, in;
  const std::size_t m = clip.size();
  for (std::size_t e = 0; e < m && !out.empty(); ++e) {
    const Eigen::Vector2d a = clip[e], b = clip[(e + 1) % m];
    const Eigen::Vector2d ab = b - a;
    in.swap(out);
    out.clear();
    const std::size_t n = in.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d& p = in[i];
      const Eigen::Vector2d& q = in[(i + 1) % n];
      const double sp = cross2(ab, p - a), sq = cross2(ab, q - a);
      if (sp >= 0.0) out.push_back(p);
      if ((sp >= 0.0) != (sq >= 0.0)) {
        const double t = sp / (sp - sq);
        out.push_back(p + t * (q - p));
      }
    }
  }
  return out.size() >= 3 ? std::max(0.0, polygon_signed_area(out)) : 0.0;
}

}  // namespace detail

/// True when the polygon (>= 3 vertices after dropping repeated and straight-on vertices) has no
/// two non-adjacent edges that touch or cross: a simple polygon, which triangulate_polygon and
/// polygon_intersection_area require.
inline bool polygon_is_simple(const Polygon2& polygon) {
  const Polygon2 p = detail::drop_collinear(polygon);
  const std::size_t n = p.size();
  if (n < 3) return false;
  for (const Eigen::Vector2d& v : p)
    if (!v.allFinite()) return false;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      if (j == i + 1 || (i == 0 && j == n - 1)) continue;  // adjacent edges share a vertex
      if (detail::segments_meet(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n])) return false;
    }
  return true;
}

/// Triangles (each counter-clockwise) that partition a simple polygon, by ear clipping (O(n^3),
/// meant for footprints of tens of vertices). Either orientation is accepted. nullopt when the
/// polygon is not simple or has no area.
inline std::optional<std::vector<std::array<Eigen::Vector2d, 3>>> triangulate_polygon(const Polygon2& polygon) {
  if (!polygon_is_simple(polygon)) return std::nullopt;
  Polygon2 p = detail::drop_collinear(polygon);
  if (polygon_signed_area(p) < 0.0) std::reverse(p.begin(), p.end());
  if (!(polygon_signed_area(p) > 0.0)) return std::nullopt;
  std::vector<std::array<Eigen::Vector2d, 3>> triangles;
  while (p.size() > 3) {
    const std::size_t n = p.size();
    bool clipped = false;
    for (std::size_t i = 0; i < n && !clipped; ++i) {
      const std::size_t ia = (i + n - 1) % n, ic = (i + 1) % n;
      const Eigen::Vector2d &a = p[ia], &b = p[i], &c = p[ic];
      const int t = detail::turn(a, b, c);
      if (t == 0) {
        // Straight on after earlier clips: drop the vertex, no triangle to emit.
        p.erase(p.begin() + static_cast<std::ptrdiff_t>(i));
        clipped = true;
        continue;
      }
      if (t < 0) continue;  // reflex
      bool empty = true;
      for (std::size_t k = 0; k < n && empty; ++k) {
        if (k == ia || k == i || k == ic) continue;
        const Eigen::Vector2d& q = p[k];
        if (q == a || q == b || q == c) continue;
        // Inside or on the ear's boundary: cutting it would cross or touch the rest.
        if (detail::cross2(b - a, q - a) >= 0.0 && detail::cross2(c - b, q - b) >= 0.0 &&
            detail::cross2(a - c, q - c) >= 0.0)
          empty = false;
      }
      if (!empty) continue;
      triangles.push_back({a, b, c});
      p.erase(p.begin() + static_cast<std::ptrdiff_t>(i));
      clipped = true;
    }
    if (!clipped) return std::nullopt;  // only possible through rounding on a near-degenerate polygon
  }
  if (p.size() == 3 && polygon_signed_area(p) > 0.0) triangles.push_back({p[0], p[1], p[2]});
  return triangles;
}

/// Area of the intersection of two simple polygons (convex or not, either orientation), units^2:
/// both are triangulated and the triangles' pairwise intersections summed, which is exact because
/// each polygon's triangles have disjoint interiors. nullopt when either is not simple.
inline std::optional<double> polygon_intersection_area(const Polygon2& a, const Polygon2& b) {
  const auto ta = triangulate_polygon(a);
  const auto tb = triangulate_polygon(b);
  if (!ta || !tb) return std::nullopt;
  const auto box = [](const std::array<Eigen::Vector2d, 3>& t) {
    Eigen::Vector4d r(t[0].x(), t[0].y(), t[0].x(), t[0].y());
    for (const Eigen::Vector2d& v : t) {
      r(0) = std::min(r(0), v.x());
      r(1) = std::min(r(1), v.y());
      r(2) = std::max(r(2), v.x());
      r(3) = std::max(r(3), v.y());
    }
    return r;
  };
  std::vector<Eigen::Vector4d> boxes_b;
  for (const auto& t : *tb) boxes_b.push_back(box(t));
  double area = 0.0;
  for (const auto& s : *ta) {
    const Eigen::Vector4d bs = box(s);
    const Polygon2 subject(s.begin(), s.end());
    for (std::size_t k = 0; k < tb->size(); ++k) {
      const Eigen::Vector4d& bc = boxes_b[k];
      if (bs(2) < bc(0) || bc(2) < bs(0) || bs(3) < bc(1) || bc(3) < bs(1)) continue;
      area += detail::convex_intersection_area(subject, Polygon2((*tb)[k].begin(), (*tb)[k].end()));
    }
  }
  return area;
}

// Footprints ------------------------------------------------------------------------------------

/// An image for footprinting: its frame and its size. The frame needs
/// `std::optional<Ray3> ray(const Eigen::Vector2d& pixel) const` (diachron::Frame, any user type).
template <class Frame>
struct FootprintImage {
  Frame frame;
  int width_px = 0;   ///< image width, px (> 0)
  int height_px = 0;  ///< image height, px (> 0)
};

namespace detail {
template <class F, class = void>
struct has_camera_size : std::false_type {};
template <class F>
struct has_camera_size<F, std::void_t<decltype(int(std::declval<const F&>().camera().width())),
                                      decltype(int(std::declval<const F&>().camera().height()))>> : std::true_type {};
}  // namespace detail

/// A FootprintImage whose size is read from the frame's camera (diachron::Frame<D>: camera().width(),
/// camera().height()). Other frame types give the size themselves: FootprintImage<F>{frame, w, h}.
template <class Frame, std::enable_if_t<detail::has_camera_size<Frame>::value, int> = 0>
FootprintImage<Frame> make_footprint_image(const Frame& frame) {
  return FootprintImage<Frame>{frame, frame.camera().width(), frame.camera().height()};
}

/// make_footprint_image() of every frame, in order: the images of one epoch for overlapping_pairs().
template <class Frame, std::enable_if_t<detail::has_camera_size<Frame>::value, int> = 0>
std::vector<FootprintImage<Frame>> make_footprint_images(const std::vector<Frame>& frames) {
  std::vector<FootprintImage<Frame>> out;
  out.reserve(frames.size());
  for (const Frame& frame : frames) out.push_back(make_footprint_image(frame));
  return out;
}

/// Options of image_footprint() and overlapping_pairs().
struct FootprintOptions {
  /// Rays cast per image edge between its two corners (>= 0, <= 10000), besides the 4 corners: the
  /// footprint polygon has up to 4 * (samples_per_edge + 1) vertices. Over relief the edges' ground
  /// traces are curved, which more samples follow. 8 by default.
  int samples_per_edge = 8;
  /// The footprint is valid only when at least this fraction (0..1] of the rays hit the DSM (and at
  /// least 3 do). The rays that miss are left out of the polygon, which then cuts across the part
  /// of the image over missing DSM. 0.5 by default. Not used with `plane_fallback`.
  double min_hit_fraction = 0.5;
  /// A boundary ray that misses the DSM meets the horizontal plane at the mean height of the DSM
  /// points the image's rays did hit instead (MicMac's plane at AltiSol, but only where the DSM has
  /// no answer). An SfM DSM covers the multi-view part of a block only, so the rays of its outer
  /// images' edges often miss it: without the fallback those images have no footprint at all. The
  /// footprint is then valid when any ray of the boundary or of a 5 x 5 interior grid meets the DSM,
  /// and invalid (with the reason) when the DSM has no cell under the image. On by default.
  bool plane_fallback = true;
  /// Options of the ray-DSM intersections.
  RayDsmOptions ray;

  void check() const {
    DIACHRON_CHECK(samples_per_edge >= 0 && samples_per_edge <= 10000,
                   "FootprintOptions::samples_per_edge must be in [0, 10000], got " << samples_per_edge);
    DIACHRON_CHECK(min_hit_fraction > 0.0 && min_hit_fraction <= 1.0,
                   "FootprintOptions::min_hit_fraction must be in (0, 1], got " << min_hit_fraction);
    ray.check();
  }
};

/// The ground footprint of one image: a polygon in the XY plane of the target frame (the DSM's
/// frame moved by the point transform), counter-clockwise, frame units.
struct Footprint {
  bool valid = false;  ///< polygon and area are meaningful
  std::string reason;  ///< why not valid (empty when valid)
  /// Ground XY of the rays that hit, in image-boundary order (top edge left to right, right edge
  /// down, bottom edge right to left, left edge up), reoriented counter-clockwise.
  Polygon2 polygon;
  double area = 0.0;       ///< frame units^2 (XY)
  std::size_t rays = 0;    ///< rays cast: 4 * (samples_per_edge + 1)
  std::size_t hits = 0;    ///< rays that met the DSM
  std::size_t misses = 0;  ///< rays that did not (or pixels the frame could not unproject)
  std::size_t plane_hits = 0;  ///< of the misses, rays placed on the fallback plane (plane_fallback)
};

/// The footprint of `image` on `dsm`: pixels along the image boundary (the outer pixel edges,
/// [-0.5, w - 0.5] x [-0.5, h - 0.5]) cast as rays through the frame, their first crossings with the
/// DSM moved by `point_transform` (e.g. a Helmert3 epoch2_from_epoch1; the identity by default),
/// XY kept. Invalid, with the reason, when too few rays hit or the polygon is not simple (folded by
/// extreme relief) or has no area. Throws diachron::Error for invalid options or image size.
template <class Frame, class PointTransform = IdentityPointTransform>
Footprint image_footprint(const FootprintImage<Frame>& image, const Dsm& dsm, const FootprintOptions& options = {},
                          const PointTransform& point_transform = PointTransform{}) {
  static_assert(has_frame_ray_v<Frame>,
                "image_footprint: Frame must have `std::optional<Ray3> ray(const Eigen::Vector2d& pixel) const`");
  static_assert(is_point_transform_v<PointTransform>,
                "image_footprint: PointTransform must be callable as `Eigen::Vector3d(const Eigen::Vector3d&) const`");
  options.check();
  DIACHRON_CHECK(image.width_px > 0 && image.height_px > 0,
                 "image size must be positive, got " << image.width_px << " x " << image.height_px);
  const double x0 = -0.5, y0 = -0.5, x1 = image.width_px - 0.5, y1 = image.height_px - 0.5;
  const std::array<Eigen::Vector2d, 4> corners = {Eigen::Vector2d(x0, y0), Eigen::Vector2d(x1, y0),
                                                  Eigen::Vector2d(x1, y1), Eigen::Vector2d(x0, y1)};
  const int steps = options.samples_per_edge + 1;
  Footprint out;
  const auto usable = [](const std::optional<Ray3>& ray) {
    return ray && ray->origin.allFinite() && ray->direction.allFinite() && ray->direction.squaredNorm() > 0.0;
  };
  // Every boundary ray, in boundary order; the DSM point where it has one.
  std::vector<std::optional<Ray3>> rays;
  std::vector<std::optional<Eigen::Vector3d>> ground;
  double z_sum = 0.0;
  std::size_t z_count = 0;
  for (int e = 0; e < 4; ++e) {
    const Eigen::Vector2d& a = corners[static_cast<std::size_t>(e)];
    const Eigen::Vector2d& b = corners[static_cast<std::size_t>((e + 1) % 4)];
    for (int k = 0; k < steps; ++k) {
      const Eigen::Vector2d px = a + (b - a) * (static_cast<double>(k) / steps);
      ++out.rays;
      rays.push_back(image.frame.ray(px));
      ground.emplace_back();
      if (!usable(rays.back())) continue;
      const RayDsmResult hit = intersect_ray_dsm(dsm, *rays.back(), options.ray);
      if (!hit.success) continue;
      ground.back() = hit.point;
      z_sum += hit.point.z();
      ++z_count;
    }
  }
  if (options.plane_fallback) {
    // The interior tells whether the DSM is under the image at all, and gives the plane's height
    // when every boundary ray misses.
    constexpr int kInterior = 5;
    for (int j = 0; j < kInterior && z_count == 0; ++j)
      for (int i = 0; i < kInterior; ++i) {
        const Eigen::Vector2d px(x0 + (x1 - x0) * (i + 0.5) / kInterior, y0 + (y1 - y0) * (j + 0.5) / kInterior);
        const std::optional<Ray3> ray = image.frame.ray(px);
        if (!usable(ray)) continue;
        const RayDsmResult hit = intersect_ray_dsm(dsm, *ray, options.ray);
        if (!hit.success) continue;
        z_sum += hit.point.z();
        ++z_count;
      }
    if (z_count == 0) {
      out.misses = out.rays;
      out.reason = "the DSM has no valid cell under the image (none of " + std::to_string(out.rays) +
                   " boundary rays and " + std::to_string(kInterior * kInterior) + " interior rays meets it)";
      return out;
    }
  }
  const double plane_z = z_count > 0 ? z_sum / static_cast<double>(z_count) : 0.0;
  Polygon2 points;
  for (std::size_t r = 0; r < rays.size(); ++r) {
    std::optional<Eigen::Vector3d> p = ground[r];
    if (!p && options.plane_fallback && usable(rays[r])) {
      p = detail::ray_plane_z(*rays[r], plane_z);
      if (p) ++out.plane_hits;
    }
    if (!ground[r]) ++out.misses;
    if (!p) continue;
    const Eigen::Vector3d moved = point_transform(*p);
    if (!moved.allFinite()) continue;
    if (ground[r]) ++out.hits;
    points.push_back(moved.head<2>());
  }
  if (options.plane_fallback ? points.size() < 3
                             : (out.hits < 3 ||
                                static_cast<double>(out.hits) < options.min_hit_fraction * static_cast<double>(out.rays))) {
    std::ostringstream why;
    why << out.hits << " of " << out.rays << " boundary rays hit the DSM (at least "
        << std::max(3.0, std::ceil(options.min_hit_fraction * static_cast<double>(out.rays))) << " needed)";
    out.reason = why.str();
    return out;
  }
  if (polygon_signed_area(points) < 0.0) std::reverse(points.begin(), points.end());
  out.polygon = std::move(points);
  out.area = polygon_signed_area(out.polygon);
  if (!(out.area > 0.0)) {
    out.reason = "footprint polygon has no area";
    return out;
  }
  if (!polygon_is_simple(out.polygon)) {
    out.reason = "footprint polygon crosses itself (boundary rays folded by relief or missing DSM)";
    return out;
  }
  out.valid = true;
  return out;
}

/// Options of overlapping_pairs().
struct OverlappingPairsOptions {
  FootprintOptions footprint;
  /// Keep a pair only when its overlap is at least this fraction [0, 1] of the smaller of its two
  /// footprints (ImagePairOverlap::fraction_of_smaller). 0 by default: every pair with a positive
  /// overlap area.
  double min_overlap_fraction = 0.0;
  /// Keep a pair only when its overlap area is at least this, secondary frame units^2 (>= 0).
  double min_overlap_area = 0.0;
  /// Threads over images and pairs; 0 = all cores. The result does not depend on it.
  std::size_t threads = 0;

  void check() const {
    footprint.check();
    DIACHRON_CHECK(min_overlap_fraction >= 0.0 && min_overlap_fraction <= 1.0,
                   "OverlappingPairsOptions::min_overlap_fraction must be in [0, 1], got " << min_overlap_fraction);
    DIACHRON_CHECK(min_overlap_area >= 0.0 && std::isfinite(min_overlap_area),
                   "OverlappingPairsOptions::min_overlap_area must be finite and >= 0, got " << min_overlap_area);
  }
};

/// One inter-epoch image pair and the ground overlap of its footprints.
struct ImagePairOverlap {
  std::size_t master = 0;     ///< index into the master images
  std::size_t secondary = 0;  ///< index into the secondary images
  double area = 0.0;          ///< overlap area in the secondary frame's XY, frame units^2
  /// area / min(master footprint area, secondary footprint area): 1 when the smaller footprint is
  /// entirely inside the other. This is what min_overlap_fraction filters on, because the epochs'
  /// image scales differ (a small recent image inside a large historical one overlaps fully).
  double fraction_of_smaller = 0.0;
  double fraction_of_master = 0.0;  ///< area / master footprint area (in the secondary frame)
};

/// What overlapping_pairs() found.
struct OverlappingPairsResult {
  bool success = false;  ///< at least one pair was kept
  std::string message;   ///< why not, or a summary
  /// Footprints of the master images, in the secondary frame (moved by the point transform).
  std::vector<Footprint> master_footprints;
  std::vector<Footprint> secondary_footprints;  ///< in the secondary frame
  /// Kept pairs, largest overlap area first; equal areas by master index, then secondary index.
  std::vector<ImagePairOverlap> pairs;
  std::size_t invalid_master_footprints = 0, invalid_secondary_footprints = 0;
  std::size_t candidate_pairs = 0;  ///< pairs of two valid footprints
  std::size_t overlapping_pairs = 0;  ///< of those, with a positive overlap area
  std::size_t filtered_pairs = 0;   ///< overlapping pairs dropped by min_overlap_fraction / min_overlap_area
};

/// Every master image x every secondary image with the ground overlap of their footprints. Master
/// footprints are made on `master_dsm` (master epoch frame) and moved by `epoch2_from_epoch1`
/// (X2 = s R X1 + T, e.g. a Helmert3; the identity when the epochs share a frame); secondary
/// footprints on `secondary_dsm` in the secondary frame. Pairs with an invalid footprint are not
/// candidates (the footprints say why). Throws diachron::Error for invalid options or image sizes.
template <class MasterFrame, class SecondaryFrame, class PointTransform = IdentityPointTransform>
OverlappingPairsResult overlapping_pairs(const std::vector<FootprintImage<MasterFrame>>& master, const Dsm& master_dsm,
                                         const std::vector<FootprintImage<SecondaryFrame>>& secondary,
                                         const Dsm& secondary_dsm,
                                         const PointTransform& epoch2_from_epoch1 = PointTransform{},
                                         const OverlappingPairsOptions& options = {}) {
  options.check();
  OverlappingPairsResult result;
  const std::size_t nm = master.size(), ns = secondary.size();
  result.master_footprints.resize(nm);
  result.secondary_footprints.resize(ns);
  parallel_for(nm + ns, options.threads, [&](std::size_t i) {
    if (i < nm)
      result.master_footprints[i] = image_footprint(master[i], master_dsm, options.footprint, epoch2_from_epoch1);
    else
      result.secondary_footprints[i - nm] = image_footprint(secondary[i - nm], secondary_dsm, options.footprint);
  });
  for (const Footprint& f : result.master_footprints) result.invalid_master_footprints += f.valid ? 0 : 1;
  for (const Footprint& f : result.secondary_footprints) result.invalid_secondary_footprints += f.valid ? 0 : 1;

  // Slot per pair, then a stable sort: the ranking cannot depend on the thread count.
  std::vector<std::optional<ImagePairOverlap>> slots(nm * ns);
  parallel_for(nm * ns, options.threads, [&](std::size_t k) {
    const Footprint& fm = result.master_footprints[k / ns];
    const Footprint& fs = result.secondary_footprints[k % ns];
    if (!fm.valid || !fs.valid) return;
    const std::optional<double> area = polygon_intersection_area(fm.polygon, fs.polygon);
    ImagePairOverlap o;
    o.master = k / ns;
    o.secondary = k % ns;
    o.area = area ? *area : 0.0;  // both are simple here, so area always exists
    o.fraction_of_smaller = o.area / std::min(fm.area, fs.area);
    o.fraction_of_master = o.area / fm.area;
    slots[k] = o;
  });
  for (const std::optional<ImagePairOverlap>& o : slots) {
    if (!o) continue;
    ++result.candidate_pairs;
    if (!(o->area > 0.0)) continue;
    ++result.overlapping_pairs;
    if (o->fraction_of_smaller < options.min_overlap_fraction || o->area < options.min_overlap_area) {
      ++result.filtered_pairs;
      continue;
    }
    result.pairs.push_back(*o);
  }
  std::stable_sort(result.pairs.begin(), result.pairs.end(),
                   [](const ImagePairOverlap& a, const ImagePairOverlap& b) { return a.area > b.area; });
  std::ostringstream summary;
  summary << result.pairs.size() << " pair(s) kept of " << result.overlapping_pairs << " overlapping, "
          << result.candidate_pairs << " candidate(s) (" << nm << " x " << ns << " images; "
          << result.invalid_master_footprints << " master and " << result.invalid_secondary_footprints
          << " secondary footprint(s) invalid)";
  result.message = summary.str();
  result.success = !result.pairs.empty();
  return result;
}

}  // namespace diachron
