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
///
///   // Optional: the same with validity masks, one per image and of its size; nonzero = a feature
///   // may lie there (OpenCV's convention), 0 = no data (DSM holes, outside the footprint). Pixel
///   // values under 0 are arbitrary fill (a slope image writes 0 there, like flat ground), so a
///   // matcher should detect nothing in them. The tiling and the pipeline call this one when it
///   // exists and they have masks.
///   std::vector<diachron::PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b,
///                                           const Raster<std::uint8_t>& mask_a,
///                                           const Raster<std::uint8_t>& mask_b) const;
///
///   // Optional: true when the features do not change as the image turns (SIFT, oriented AKAZE);
///   // the pipeline then skips the rotation hypotheses. Missing means false. It must be const: a
///   // non-const one is a compile error (it would otherwise be silently ignored).
///   bool rotation_invariant() const;
/// };
/// @endcode
/// A matcher that is not thread-safe (e.g. one wrapping a stateful network session) is still a
/// PairMatcher if it serialises internally; otherwise run the tiling with `threads = 1`.
///
/// Requirements for FeatureExtractor:
/// @code
/// struct MyExtractor {
///   // Keypoints (pixels, scale in pixels, angle in radians) and one descriptor row per keypoint
///   // (matching/features.hpp). const and thread-safe for the same reason.
///   diachron::Features extract(const diachron::Raster<std::uint8_t>& image) const;
///   // Optional: no keypoint where mask == 0 (mask of the image's size, as above).
///   diachron::Features extract(const Raster<std::uint8_t>& image, const Raster<std::uint8_t>& mask) const;
///   // Optional, as for PairMatcher.
///   bool rotation_invariant() const;
///   // Optional (vision/cv_features.hpp): how descriptor rows compare. Missing means
///   // DescriptorMetric::L2, real-valued rows. Hamming requires one float per bit, 0 or 1
///   // (unpack_bits() makes that from packed bytes); other values are an error when matching.
///   diachron::DescriptorMetric descriptor_metric() const;
/// };
/// @endcode
///
/// Requirements for FeaturePairMatcher, a PairMatcher whose extraction and matching are separate
/// (FeatureCacheMatcher extracts each tile once for it, instead of once per tile pair):
/// @code
/// struct M {
///   const Extractor& extractor() const;   // a FeatureExtractor
///   std::vector<PointMatch> match(const Features& a, const Features& b) const;
/// };
/// @endcode
/// Models: ExtractorPairMatcher<...> and XFeatPairMatcher (vision/).

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
struct has_masked_match : std::false_type {};
template <class M>
struct has_masked_match<M, std::void_t<decltype(std::declval<const M&>().match(
                               std::declval<const Image8&>(), std::declval<const Image8&>(),
                               std::declval<const Image8&>(), std::declval<const Image8&>()))>>
    : std::is_convertible<decltype(std::declval<const M&>().match(
                              std::declval<const Image8&>(), std::declval<const Image8&>(),
                              std::declval<const Image8&>(), std::declval<const Image8&>())),
                          std::vector<PointMatch>> {};

template <class E, class = void>
struct has_masked_extract : std::false_type {};
template <class E>
struct has_masked_extract<E, std::void_t<decltype(std::declval<const E&>().extract(
                                 std::declval<const Image8&>(), std::declval<const Image8&>()))>>
    : std::is_convertible<decltype(std::declval<const E&>().extract(std::declval<const Image8&>(),
                                                                    std::declval<const Image8&>())),
                          Features> {};

template <class M, class = void>
struct has_rotation_invariant : std::false_type {};
template <class M>
struct has_rotation_invariant<M, std::void_t<decltype(bool(std::declval<const M&>().rotation_invariant()))>>
    : std::true_type {};

template <class M, class = void>
struct has_any_rotation_invariant : std::false_type {};
template <class M>
struct has_any_rotation_invariant<M, std::void_t<decltype(bool(std::declval<M&>().rotation_invariant()))>>
    : std::true_type {};

template <class M, class = void>
struct is_feature_pair_matcher : std::false_type {};
template <class M>
struct is_feature_pair_matcher<
    M, std::void_t<decltype(std::declval<const M&>().extractor().extract(std::declval<const Image8&>())),
                   decltype(std::declval<const M&>().match(std::declval<const Features&>(),
                                                           std::declval<const Features&>()))>> : std::true_type {};

template <class M>
constexpr void check_rotation_invariant_is_const() {
  static_assert(!(has_any_rotation_invariant<M>::value && !has_rotation_invariant<M>::value),
                "diachron: rotation_invariant() exists but is not const (or does not return bool); it "
                "would be ignored and every rotation hypothesis would run: declare `bool "
                "rotation_invariant() const`");
}

}  // namespace detail

/// True when M meets the PairMatcher requirements.
template <class M>
inline constexpr bool is_pair_matcher_v = detail::has_const_match<std::decay_t<M>>::value;

/// True when M also has the optional masked `match(a, b, mask_a, mask_b) const`.
template <class M>
inline constexpr bool is_masked_pair_matcher_v = detail::has_masked_match<std::decay_t<M>>::value;

/// True when E meets the FeatureExtractor requirements.
template <class E>
inline constexpr bool is_feature_extractor_v = detail::has_const_extract<std::decay_t<E>>::value;

/// True when E also has the optional masked `extract(image, mask) const`.
template <class E>
inline constexpr bool is_masked_feature_extractor_v = detail::has_masked_extract<std::decay_t<E>>::value;

/// True when M is a FeaturePairMatcher (see the file comment): `extractor()` and
/// `match(const Features&, const Features&) const`. Only these get per-tile feature caching.
template <class M>
inline constexpr bool is_feature_pair_matcher_v = detail::is_feature_pair_matcher<std::decay_t<M>>::value;

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
  detail::check_rotation_invariant_is_const<T>();
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
  detail::check_rotation_invariant_is_const<T>();
  return is_feature_extractor_v<T>;
}

/// A PairMatcher from any callable: `std::vector<PointMatch>(const Raster<std::uint8_t>& a,
/// const Raster<std::uint8_t>& b) const`, or the masked form `(a, b, mask_a, mask_b)`, a lambda
/// typically. With the masked form the matcher receives masks (an all-valid mask when called
/// without). The callable is called concurrently when the tiling runs threaded.
template <class Fn>
class FunctionPairMatcher {
  static constexpr bool kTakesMasks =
      std::is_invocable_v<const Fn&, const detail::Image8&, const detail::Image8&, const detail::Image8&,
                          const detail::Image8&>;
  static_assert(kTakesMasks || std::is_invocable_v<const Fn&, const detail::Image8&, const detail::Image8&>,
                "make_pair_matcher: the callable must take (const Raster<std::uint8_t>& a, const "
                "Raster<std::uint8_t>& b) or (a, b, mask_a, mask_b), and be callable when const");

 public:
  /// `rotation_invariant`: what rotation_invariant() answers (see the PairMatcher concept).
  explicit FunctionPairMatcher(Fn fn, bool rotation_invariant = false)
      : fn_(std::move(fn)), rotation_invariant_(rotation_invariant) {}

  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b) const {
    if constexpr (kTakesMasks) {
      return fn_(a, b, Raster<std::uint8_t>(a.width(), a.height(), 255),
                 Raster<std::uint8_t>(b.width(), b.height(), 255));
    } else {
      return fn_(a, b);
    }
  }

  /// Only for callables that take masks.
  template <class F = Fn, std::enable_if_t<std::is_invocable_v<const F&, const detail::Image8&, const detail::Image8&,
                                                                const detail::Image8&, const detail::Image8&>,
                                            int> = 0>
  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b,
                                const Raster<std::uint8_t>& mask_a, const Raster<std::uint8_t>& mask_b) const {
    return fn_(a, b, mask_a, mask_b);
  }

  bool rotation_invariant() const { return rotation_invariant_; }

 private:
  Fn fn_;
  bool rotation_invariant_ = false;
};

/// Wraps a callable as a PairMatcher (see FunctionPairMatcher). Pass `rotation_invariant = true`
/// when the callable's features do not change as the image turns, so the pipeline runs one
/// rotation hypothesis instead of four.
template <class Fn>
FunctionPairMatcher<std::decay_t<Fn>> make_pair_matcher(Fn&& fn, bool rotation_invariant = false) {
  return FunctionPairMatcher<std::decay_t<Fn>>(std::forward<Fn>(fn), rotation_invariant);
}

/// What a matcher or extractor says of itself through an optional `bool rotation_invariant() const`
/// (its features do not change when the image turns); false when it says nothing. Pipelines use it
/// to skip rotation hypotheses. A non-const rotation_invariant() does not compile.
template <class M>
bool rotation_invariant(const M& matcher) {
  detail::check_rotation_invariant_is_const<M>();
  if constexpr (detail::has_rotation_invariant<M>::value) {
    return matcher.rotation_invariant();
  } else {
    return false;
  }
}

}  // namespace diachron
