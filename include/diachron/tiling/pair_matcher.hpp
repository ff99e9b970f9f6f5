#pragma once
/// @file
/// The PairMatcher and FeatureExtractor concepts (docs/architecture.md), their detection traits and
/// static_assert helpers, and an adapter that makes a PairMatcher from a callable. (The adapter from
/// a FeatureExtractor plus descriptor matching is vision/extractor_pair_matcher.hpp.)
///
/// Requirements for PairMatcher (a pseudo-class):
/// @code
/// struct MyMatcher {
///   // Correspondences between 8-bit image `a` (master) and `b` (secondary), each point in its own
///   // image's pixels (pixel-centre convention). const: the tiling schemes call one matcher object
///   // from many threads at once, so match() must not modify shared state without synchronising it.
///   std::vector<diachron::PointMatch> match(const diachron::Raster<std::uint8_t>& a,
///                                           const diachron::Raster<std::uint8_t>& b) const;
/// };
/// @endcode
/// A matcher that is not thread-safe (e.g. one wrapping a stateful network session) is still a
/// PairMatcher if it serialises internally; otherwise run the tiling with `threads = 1`.
///
/// Requirements for FeatureExtractor:
/// @code
/// struct MyExtractor {
///   // Keypoints (pixels, scale in pixels, angle in radians) and one descriptor row per keypoint.
///   // const and thread-safe for the same reason.
///   diachron::Features extract(const diachron::Raster<std::uint8_t>& image) const;
/// };
/// @endcode

#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

#include <diachron/core/raster.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/matching/point_match.hpp>

namespace diachron {

namespace detail {

using Image8 = Raster<std::uint8_t>;

template <class M, class = void>
struct has_const_match : std::false_type {};
template <class M>
struct has_const_match<M, std::void_t<decltype(std::declval<const M&>().match(
                              std::declval<const Image8&>(), std::declval<const Image8&>()))>>
    : std::is_convertible<decltype(std::declval<const M&>().match(std::declval<const Image8&>(),
                                                                  std::declval<const Image8&>())),
                          std::vector<PointMatch>> {};

template <class M, class = void>
struct has_any_match : std::false_type {};
template <class M>
struct has_any_match<M, std::void_t<decltype(std::declval<M&>().match(std::declval<const Image8&>(),
                                                                       std::declval<const Image8&>()))>>
    : std::true_type {};

template <class E, class = void>
struct has_const_extract : std::false_type {};
template <class E>
struct has_const_extract<E, std::void_t<decltype(std::declval<const E&>().extract(
                                std::declval<const Image8&>()))>>
    : std::is_convertible<decltype(std::declval<const E&>().extract(std::declval<const Image8&>())),
                          Features> {};

template <class E, class = void>
struct has_any_extract : std::false_type {};
template <class E>
struct has_any_extract<E, std::void_t<decltype(std::declval<E&>().extract(std::declval<const Image8&>()))>>
    : std::true_type {};

template <class M, class = void>
struct has_rotation_invariant : std::false_type {};
template <class M>
struct has_rotation_invariant<M, std::void_t<decltype(bool(std::declval<const M&>().rotation_invariant()))>>
    : std::true_type {};

}  // namespace detail

/// True when M meets the PairMatcher requirements.
template <class M>
inline constexpr bool is_pair_matcher_v = detail::has_const_match<std::decay_t<M>>::value;

/// True when E meets the FeatureExtractor requirements.
template <class E>
inline constexpr bool is_feature_extractor_v = detail::has_const_extract<std::decay_t<E>>::value;

/// Compile-time check with a message naming what is missing; use as
/// `static_assert(diachron::check_pair_matcher<M>());`.
template <class M>
constexpr bool check_pair_matcher() {
  using T = std::decay_t<M>;
  static_assert(!(detail::has_any_match<T>::value && !detail::has_const_match<T>::value),
                "diachron: PairMatcher::match exists but is not const or does not return something "
                "convertible to std::vector<PointMatch>; one matcher serves many threads, so declare "
                "`std::vector<PointMatch> match(const Raster<std::uint8_t>&, const "
                "Raster<std::uint8_t>&) const`");
  static_assert(detail::has_any_match<T>::value,
                "diachron: PairMatcher needs `std::vector<PointMatch> match(const "
                "Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b) const`");
  return is_pair_matcher_v<T>;
}

/// Compile-time check for FeatureExtractor; use as `static_assert(check_feature_extractor<E>());`.
template <class E>
constexpr bool check_feature_extractor() {
  using T = std::decay_t<E>;
  static_assert(!(detail::has_any_extract<T>::value && !detail::has_const_extract<T>::value),
                "diachron: FeatureExtractor::extract exists but is not const or does not return "
                "Features; declare `Features extract(const Raster<std::uint8_t>&) const`");
  static_assert(detail::has_any_extract<T>::value,
                "diachron: FeatureExtractor needs `Features extract(const Raster<std::uint8_t>& "
                "image) const`");
  return is_feature_extractor_v<T>;
}

/// A PairMatcher from any callable
/// `std::vector<PointMatch>(const Raster<std::uint8_t>&, const Raster<std::uint8_t>&) const`, a
/// lambda typically. The callable is called concurrently when the tiling runs threaded.
template <class Fn>
class FunctionPairMatcher {
 public:
  explicit FunctionPairMatcher(Fn fn) : fn_(std::move(fn)) {}
  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b) const {
    return fn_(a, b);
  }

 private:
  Fn fn_;
};

/// Wraps a callable as a PairMatcher (see FunctionPairMatcher).
template <class Fn>
FunctionPairMatcher<std::decay_t<Fn>> make_pair_matcher(Fn&& fn) {
  return FunctionPairMatcher<std::decay_t<Fn>>(std::forward<Fn>(fn));
}

/// What a matcher or extractor says of itself through an optional `bool rotation_invariant() const`
/// (its features do not change when the image turns); false when it says nothing. Pipelines use it
/// to skip rotation hypotheses.
template <class M>
bool rotation_invariant(const M& matcher) {
  if constexpr (detail::has_rotation_invariant<M>::value) {
    return matcher.rotation_invariant();
  } else {
    return false;
  }
}

}  // namespace diachron
