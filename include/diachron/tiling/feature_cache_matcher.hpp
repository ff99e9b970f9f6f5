#pragma once
/// @file
/// FeatureCacheMatcher: a PairMatcher that extracts each distinct image once. One-to-many tiling
/// calls the matcher on M x N tile pairs, but there are only M + N distinct tiles; a matcher built
/// from an extractor would otherwise extract every tile N (or M) times.
///
/// Requirements for the wrapped matcher (a "FeaturePairMatcher"):
/// @code
/// struct M {
///   const Extractor& extractor() const;   // Extractor: Features extract(const Raster<uint8_t>&) const
///   std::vector<PointMatch> match(const Features& a, const Features& b) const;
/// };
/// @endcode
/// Models: ExtractorPairMatcher<...> and XFeatPairMatcher (vision/).

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include <diachron/core/raster.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/matching/point_match.hpp>

namespace diachron {

namespace detail {

template <class M, class = void>
struct is_feature_pair_matcher : std::false_type {};
template <class M>
struct is_feature_pair_matcher<
    M, std::void_t<decltype(std::declval<const M&>().extractor().extract(std::declval<const Raster<std::uint8_t>&>())),
                   decltype(std::declval<const M&>().match(std::declval<const Features&>(),
                                                           std::declval<const Features&>()))>> : std::true_type {};

/// 64-bit FNV-1a over the pixels: identifies an image's content, so a cache entry can never be
/// served for another image that happens to reuse the same memory.
inline std::uint64_t content_hash(const Raster<std::uint8_t>& image) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  const std::uint8_t* p = image.data();
  for (std::size_t i = 0; i < image.size(); ++i) {
    h ^= p[i];
    h *= 0x100000001b3ULL;
  }
  return h;
}

}  // namespace detail

/// True when M can extract features and match them separately (see the file comment).
template <class M>
inline constexpr bool is_feature_pair_matcher_v = detail::is_feature_pair_matcher<M>::value;

/// Wraps a FeaturePairMatcher: `match(a, b)` extracts the features of `a` and `b` at most once per
/// distinct image content (width, height, pixel hash) over the wrapper's lifetime, then matches
/// them. Results equal the wrapped matcher's `match(a, b)`.
/// Thread-safe: concurrent calls share the cache under a mutex; extraction runs outside the lock
/// (two threads may extract the same new image at once; both results are identical, one is kept).
/// Holds a reference to `matcher`, which must outlive the wrapper. Memory grows with the number of
/// distinct images seen: make one wrapper per tiling run.
template <class Matcher>
class FeatureCacheMatcher {
  static_assert(is_feature_pair_matcher_v<Matcher>,
                "FeatureCacheMatcher needs `extractor().extract(Raster<uint8_t>)` and "
                "`match(const Features&, const Features&) const` (see tiling/feature_cache_matcher.hpp)");

 public:
  explicit FeatureCacheMatcher(const Matcher& matcher) : matcher_(matcher) {}

  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b) const {
    const std::shared_ptr<const Features> fa = features(a);
    const std::shared_ptr<const Features> fb = features(b);
    return matcher_.match(*fa, *fb);
  }

  /// The features of `image`, from the cache or freshly extracted.
  std::shared_ptr<const Features> features(const Raster<std::uint8_t>& image) const {
    const Key key{image.width(), image.height(), detail::content_hash(image)};
    {
      std::lock_guard<std::mutex> lock(state_->mutex);
      auto it = state_->cache.find(key);
      if (it != state_->cache.end()) return it->second;
    }
    auto extracted = std::make_shared<const Features>(matcher_.extractor().extract(image));
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->cache.emplace(key, std::move(extracted)).first->second;
  }

  /// Distinct images extracted so far.
  std::size_t cached_images() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->cache.size();
  }

 private:
  using Key = std::tuple<int, int, std::uint64_t>;
  struct State {
    std::mutex mutex;
    std::map<Key, std::shared_ptr<const Features>> cache;
  };
  const Matcher& matcher_;
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

}  // namespace diachron
