#pragma once
/// @file
/// The Transfer concept (master pixel -> secondary pixel) and its two families: DsmTransfer (master
/// ray -> master epoch's DSM -> epoch 1 to epoch 2 point transform -> secondary projection) and
/// MapTransfer (any 2D map: a similarity, a homography). Also DsmLift, the master pixel -> DSM point
/// half of DsmTransfer, for lifting matches to 3D.

#include <optional>
#include <type_traits>
#include <utility>

#include <Eigen/Core>

#include <diachron/geometry/ray.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>

namespace diachron {

/// @name Requirements for Transfer
/// A Transfer is a copyable object `t` with
///   `std::optional<Eigen::Vector2d> t(const Eigen::Vector2d& master_px) const`
/// that maps a pixel of the master image (diachron pixel convention) to the corresponding pixel of
/// the secondary image, or nullopt when there is none (the ray misses the DSM, the point is behind
/// the secondary camera, a homography sends it to infinity). It must be safe to call concurrently.
/// Tiling, guided matching, NCC warping and scale/rotation prediction (local_affine) take any
/// Transfer. Check a type with `is_transfer_v<T>` or `check_transfer<T>()`.
/// @{

namespace detail {
template <class T, class = void>
struct transfer_result {
  using type = void;
};
template <class T>
struct transfer_result<T, std::void_t<decltype(std::declval<const T&>()(std::declval<const Eigen::Vector2d&>()))>> {
  using type = decltype(std::declval<const T&>()(std::declval<const Eigen::Vector2d&>()));
};

template <class F, class = void>
struct has_frame_ray : std::false_type {};
template <class F>
struct has_frame_ray<F, std::void_t<decltype(std::declval<const F&>().ray(std::declval<const Eigen::Vector2d&>()))>>
    : std::is_convertible<decltype(std::declval<const F&>().ray(std::declval<const Eigen::Vector2d&>())),
                          std::optional<Ray3>> {};

template <class F, class = void>
struct has_frame_project : std::false_type {};
template <class F>
struct has_frame_project<
    F, std::void_t<decltype(std::declval<const F&>().project(std::declval<const Eigen::Vector3d&>()))>>
    : std::is_convertible<decltype(std::declval<const F&>().project(std::declval<const Eigen::Vector3d&>())),
                          std::optional<Eigen::Vector2d>> {};

template <class P, class = void>
struct is_point_transform : std::false_type {};
template <class P>
struct is_point_transform<P, std::void_t<decltype(std::declval<const P&>()(std::declval<const Eigen::Vector3d&>()))>>
    : std::is_convertible<decltype(std::declval<const P&>()(std::declval<const Eigen::Vector3d&>())),
                          Eigen::Vector3d> {};
}  // namespace detail

/// True when T satisfies the Transfer requirements (the call returns exactly optional<Vector2d>).
template <class T>
inline constexpr bool is_transfer_v =
    std::is_same_v<std::decay_t<typename detail::transfer_result<T>::type>, std::optional<Eigen::Vector2d>>;

/// Compile-time check whose message names the missing member; use at the top of any template that
/// consumes a Transfer: `static_assert(check_transfer<T>());`.
template <class T>
constexpr bool check_transfer() {
  static_assert(is_transfer_v<T>,
                "Transfer must have `std::optional<Eigen::Vector2d> operator()(const Eigen::Vector2d& master_px) "
                "const` (see diachron/terrain/transfer.hpp)");
  return true;
}
/// @}

/// True when F has `std::optional<Ray3> ray(const Eigen::Vector2d& pixel) const` (an image frame
/// that can be lifted through a DSM).
template <class F>
inline constexpr bool has_frame_ray_v = detail::has_frame_ray<F>::value;
/// True when F has `std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& world) const`.
template <class F>
inline constexpr bool has_frame_project_v = detail::has_frame_project<F>::value;
/// True when P is callable as `Eigen::Vector3d(const Eigen::Vector3d&) const` (a Helmert3, a lambda).
template <class P>
inline constexpr bool is_point_transform_v = detail::is_point_transform<P>::value;

/// The identity point transform: the two epochs already share a frame.
struct IdentityPointTransform {
  Eigen::Vector3d operator()(const Eigen::Vector3d& p) const { return p; }
};

/// Master pixel -> the first point where its ray meets the DSM (in the DSM's, i.e. the frame's,
/// world frame), or nullopt. This is the 3D lift of image points used by the ground filter and by
/// the Helmert estimation. The frame is stored by value, the DSM by reference: it must outlive the
/// lift.
/// @tparam Frame has `std::optional<Ray3> ray(const Eigen::Vector2d&) const`, e.g. diachron::Frame<D>.
template <class Frame>
class DsmLift {
  static_assert(has_frame_ray_v<Frame>,
                "DsmLift: Frame must have `std::optional<Ray3> ray(const Eigen::Vector2d& pixel) const`");

 public:
  DsmLift(Frame frame, const Dsm& dsm, const RayDsmOptions& options = {})
      : frame_(std::move(frame)), dsm_(&dsm), options_(options) {
    options_.check();
  }
  /// The lift keeps a pointer to the DSM: a temporary one (e.g. straight from read_geotiff_dsm)
  /// would dangle, so it does not compile.
  DsmLift(Frame frame, const Dsm&& dsm, const RayDsmOptions& options = {}) = delete;

  /// The DSM point seen at `px`, or nullopt (no ray, or no first crossing: see RayDsmOutcome).
  std::optional<Eigen::Vector3d> operator()(const Eigen::Vector2d& px) const {
    const RayDsmResult r = intersect(px);
    if (!r.success) return std::nullopt;
    return r.point;
  }

  /// The full intersection result, with the reason when there is no point (`no_ray` when the pixel
  /// is not finite or the frame gives no usable ray for it).
  RayDsmResult intersect(const Eigen::Vector2d& px) const {
    RayDsmResult none;
    none.outcome = RayDsmOutcome::no_ray;
    if (!px.allFinite()) return none;
    const std::optional<Ray3> ray = frame_.ray(px);
    if (!ray || !ray->origin.allFinite() || !ray->direction.allFinite() || ray->direction.squaredNorm() == 0.0)
      return none;
    return intersect_ray_dsm(*dsm_, *ray, options_);
  }

  const Frame& frame() const { return frame_; }
  const Dsm& dsm() const { return *dsm_; }
  const RayDsmOptions& options() const { return options_; }

 private:
  Frame frame_;
  const Dsm* dsm_;
  RayDsmOptions options_;
};

/// The geometric Transfer of the paper: master pixel -> ray of the master frame (epoch 1) -> first
/// crossing with the master epoch's DSM -> `point_transform` (the Helmert epoch 1 -> epoch 2, or the
/// identity) -> projection into the secondary frame (epoch 2). Frames and the transform are stored
/// by value, the DSM by reference (it must outlive the transfer).
/// @tparam MasterFrame has `std::optional<Ray3> ray(const Eigen::Vector2d&) const`.
/// @tparam SecondaryFrame has `std::optional<Eigen::Vector2d> project(const Eigen::Vector3d&) const`.
/// @tparam PointTransform callable `Eigen::Vector3d(const Eigen::Vector3d&) const`, e.g. Helmert3.
template <class MasterFrame, class SecondaryFrame, class PointTransform = IdentityPointTransform>
class DsmTransfer {
  static_assert(has_frame_project_v<SecondaryFrame>,
                "DsmTransfer: SecondaryFrame must have `std::optional<Eigen::Vector2d> project(const "
                "Eigen::Vector3d& world) const`");
  static_assert(is_point_transform_v<PointTransform>,
                "DsmTransfer: PointTransform must be callable as `Eigen::Vector3d(const Eigen::Vector3d&) const`");

 public:
  DsmTransfer(MasterFrame master, const Dsm& master_dsm, SecondaryFrame secondary,
              PointTransform point_transform = PointTransform{}, const RayDsmOptions& options = {})
      : lift_(std::move(master), master_dsm, options),
        secondary_(std::move(secondary)),
        point_transform_(std::move(point_transform)) {}
  /// A temporary DSM would dangle (the transfer keeps a pointer to it): does not compile.
  DsmTransfer(MasterFrame master, const Dsm&& master_dsm, SecondaryFrame secondary,
              PointTransform point_transform = PointTransform{}, const RayDsmOptions& options = {}) = delete;

  /// Secondary pixel of master pixel `master_px`, or nullopt.
  std::optional<Eigen::Vector2d> operator()(const Eigen::Vector2d& master_px) const {
    const std::optional<Eigen::Vector3d> p = secondary_point(master_px);
    if (!p) return std::nullopt;
    std::optional<Eigen::Vector2d> px = secondary_.project(*p);
    if (px && !px->allFinite()) return std::nullopt;
    return px;
  }

  /// The master epoch's DSM point seen at `master_px` (epoch 1 frame), or nullopt.
  std::optional<Eigen::Vector3d> master_point(const Eigen::Vector2d& master_px) const { return lift_(master_px); }

  /// The same point moved into the secondary epoch's frame (epoch 2), or nullopt.
  std::optional<Eigen::Vector3d> secondary_point(const Eigen::Vector2d& master_px) const {
    const std::optional<Eigen::Vector3d> p = lift_(master_px);
    if (!p) return std::nullopt;
    const Eigen::Vector3d q = point_transform_(*p);
    if (!q.allFinite()) return std::nullopt;
    return q;
  }

  const DsmLift<MasterFrame>& lift() const { return lift_; }
  const SecondaryFrame& secondary() const { return secondary_; }
  const PointTransform& point_transform() const { return point_transform_; }

 private:
  DsmLift<MasterFrame> lift_;
  SecondaryFrame secondary_;
  PointTransform point_transform_;
};

/// Builds a DsmTransfer, deducing the types.
template <class MasterFrame, class SecondaryFrame, class PointTransform = IdentityPointTransform>
DsmTransfer<MasterFrame, SecondaryFrame, PointTransform> make_dsm_transfer(
    MasterFrame master, const Dsm& master_dsm, SecondaryFrame secondary,
    PointTransform point_transform = PointTransform{}, const RayDsmOptions& options = {}) {
  return DsmTransfer<MasterFrame, SecondaryFrame, PointTransform>(
      std::move(master), master_dsm, std::move(secondary), std::move(point_transform), options);
}

/// A Transfer made of any 2D map `f`: `Eigen::Vector2d f(const Eigen::Vector2d&) const` (a
/// Similarity2, a Homography) or one returning `std::optional<Eigen::Vector2d>`. Non-finite results
/// (a homography's line at infinity) become nullopt.
template <class F>
class MapTransfer {
  using Result = decltype(std::declval<const F&>()(std::declval<const Eigen::Vector2d&>()));
  static_assert(std::is_convertible_v<Result, Eigen::Vector2d> ||
                    std::is_convertible_v<Result, std::optional<Eigen::Vector2d>>,
                "MapTransfer: F must be callable as `Eigen::Vector2d(const Eigen::Vector2d&) const` or return "
                "std::optional<Eigen::Vector2d>");

 public:
  explicit MapTransfer(F map) : map_(std::move(map)) {}

  std::optional<Eigen::Vector2d> operator()(const Eigen::Vector2d& master_px) const {
    if (!master_px.allFinite()) return std::nullopt;
    if constexpr (std::is_convertible_v<Result, std::optional<Eigen::Vector2d>> &&
                  !std::is_convertible_v<Result, Eigen::Vector2d>) {
      std::optional<Eigen::Vector2d> p = map_(master_px);
      if (p && !p->allFinite()) return std::nullopt;
      return p;
    } else {
      const Eigen::Vector2d p = map_(master_px);
      if (!p.allFinite()) return std::nullopt;
      return p;
    }
  }

  const F& map() const { return map_; }

 private:
  F map_;
};

/// A temporary DSM would dangle in the returned transfer: does not compile.
template <class MasterFrame, class SecondaryFrame, class PointTransform = IdentityPointTransform>
DsmTransfer<MasterFrame, SecondaryFrame, PointTransform> make_dsm_transfer(
    MasterFrame master, const Dsm&& master_dsm, SecondaryFrame secondary,
    PointTransform point_transform = PointTransform{}, const RayDsmOptions& options = {}) = delete;

/// Builds a MapTransfer, deducing the map type.
template <class F>
MapTransfer<F> make_map_transfer(F map) {
  return MapTransfer<F>(std::move(map));
}

}  // namespace diachron
