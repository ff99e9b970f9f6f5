#pragma once
/// @file
/// FeatureCacheMatcher: a PairMatcher that extracts each distinct image once. One-to-many tiling
/// calls the matcher on M x N tile pairs, but there are only M + N distinct tiles; a matcher built
/// from an extractor would otherwise extract every tile N (or M) times.
///
/// The wrapped matcher is a FeaturePairMatcher (concept and trait `is_feature_pair_matcher_v` in
/// tiling/pair_matcher.hpp): `extractor()` plus `match(const Features&, const Features&) const`.
/// Other PairMatchers get no caching: wrap them or extract yourself. Models: ExtractorPairMatcher<...>
/// and XFeatPairMatcher (vision/).

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
#include <diachron/tiling/pair_matcher.hpp>

namespace diachron {

namespace detail {

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

/// Wraps a FeaturePairMatcher: `match(a, b)` extracts the features of `a` and `b` at most once per
/// distinct image content (width, height, pixel hash) over the wrapper's lifetime, then matches
/// them. Results equal the wrapped matcher's `match(a, b)`.
/// Thread-safe: concurrent calls share the cache under a mutex; extraction runs outside the lock
/// (two threads may extract the same new image at once; both results are identical, one is kept).
/// With a masked extractor (`extract(image, mask)`) the wrapper is a masked PairMatcher too, and a
/// mask is part of the cache key.
/// Holds a reference to `matcher`, which must outlive the wrapper (a temporary does not compile).
/// Memory grows with the number of distinct images seen: make one wrapper per tiling run.
template <class Matcher>
class FeatureCacheMatcher {
  static_assert(is_feature_pair_matcher_v<Matcher>,
                "FeatureCacheMatcher needs `extractor().extract(Raster<uint8_t>)` and "
                "`match(const Features&, const Features&) const` (see tiling/pair_matcher.hpp)");
  using Extractor = std::decay_t<decltype(std::declval<const Matcher&>().extractor())>;

 public:
  explicit FeatureCacheMatcher(const Matcher& matcher) : matcher_(matcher) {}
  /// The wrapper keeps a reference: a temporary matcher would dangle.
  explicit FeatureCacheMatcher(const Matcher&&) = delete;

  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b) const {
    const std::shared_ptr<const Features> fa = features(a);
    const std::shared_ptr<const Features> fb = features(b);
    return matcher_.match(*fa, *fb);
  }

  /// Masked matching (only with a masked extractor): no feature where a mask is 0.
  template <class E = Extractor, std::enable_if_t<is_masked_feature_extractor_v<E>, int> = 0>
  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b,
                                const Raster<std::uint8_t>& mask_a, const Raster<std::uint8_t>& mask_b) const {
    const std::shared_ptr<const Features> fa = features(a, mask_a);
    const std::shared_ptr<const Features> fb = features(b, mask_b);
    return matcher_.match(*fa, *fb);
  }

  bool rotation_invariant() const { return diachron::rotation_invariant(matcher_); }

  /// The features of `image`, from the cache or freshly extracted.
  std::shared_ptr<const Features> features(const Raster<std::uint8_t>& image) const {
    return cached(Key{image.width(), image.height(), detail::content_hash(image), 0, false},
                  [&] { return matcher_.extractor().extract(image); });
  }

  /// The features of `image` under `mask` (only with a masked extractor).
  template <class E = Extractor, std::enable_if_t<is_masked_feature_extractor_v<E>, int> = 0>
  std::shared_ptr<const Features> features(const Raster<std::uint8_t>& image, const Raster<std::uint8_t>& mask) const {
    return cached(Key{image.width(), image.height(), detail::content_hash(image), detail::content_hash(mask), true},
                  [&] { return matcher_.extractor().extract(image, mask); });
  }

  /// Distinct images extracted so far.
  std::size_t cached_images() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->cache.size();
  }

 private:
  // width, height, pixel hash, mask hash, has a mask
  using Key = std::tuple<int, int, std::uint64_t, std::uint64_t, bool>;

  template <class Extract>
  std::shared_ptr<const Features> cached(const Key& key, Extract&& extract) const {
    {
      std::lock_guard<std::mutex> lock(state_->mutex);
      auto it = state_->cache.find(key);
      if (it != state_->cache.end()) return it->second;
    }
    auto extracted = std::make_shared<const Features>(extract());
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->cache.emplace(key, std::move(extracted)).first->second;
  }

  struct State {
    std::mutex mutex;
    std::map<Key, std::shared_ptr<const Features>> cache;
  };
  const Matcher& matcher_;
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

}  // namespace diachron
