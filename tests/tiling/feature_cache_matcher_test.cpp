#include <catch2/catch.hpp>

#include <atomic>
#include <memory>
#include <type_traits>

#include <diachron/tiling/feature_cache_matcher.hpp>
#include <diachron/tiling/grid_tiler.hpp>
#include <diachron/tiling/one_to_many.hpp>

namespace {

// Features = one keypoint at the brightest pixel; counts extractions.
struct CountingExtractor {
  std::shared_ptr<std::atomic<int>> calls = std::make_shared<std::atomic<int>>(0);
  diachron::Features extract(const diachron::Raster<std::uint8_t>& image) const {
    calls->fetch_add(1);
    diachron::Features f;
    int bx = 0, by = 0;
    for (int y = 0; y < image.height(); ++y)
      for (int x = 0; x < image.width(); ++x)
        if (image(x, y) > image(bx, by)) bx = x, by = y;
    diachron::Keypoint k;
    k.position = {double(bx), double(by)};
    f.keypoints.push_back(k);
    f.descriptors = diachron::DescriptorMatrix::Constant(1, 1, float(image(bx, by)));
    return f;
  }
};

struct PeakMatcher {
  CountingExtractor ex;
  const CountingExtractor& extractor() const { return ex; }
  std::vector<diachron::PointMatch> match(const diachron::Features& a, const diachron::Features& b) const {
    if (a.descriptors(0, 0) == 0.0f || a.descriptors(0, 0) != b.descriptors(0, 0)) return {};
    return {diachron::PointMatch{a.keypoints[0].position, b.keypoints[0].position, 1.0}};
  }
  std::vector<diachron::PointMatch> match(const diachron::Raster<std::uint8_t>& a,
                                          const diachron::Raster<std::uint8_t>& b) const {
    return match(ex.extract(a), ex.extract(b));
  }
};

diachron::Raster<std::uint8_t> peaks_image(int w, int h, int seed) {
  diachron::Raster<std::uint8_t> r(w, h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) r(x, y) = static_cast<std::uint8_t>((x * 7 + y * 13 + seed) % 50);
  return r;
}

}  // namespace

TEST_CASE("FeatureCacheMatcher: extracts each distinct tile once and matches like the wrapped matcher",
          "[tiling]") {
  static_assert(diachron::is_feature_pair_matcher_v<PeakMatcher>);
  static_assert(diachron::is_pair_matcher_v<diachron::FeatureCacheMatcher<PeakMatcher>>);
  const auto master = peaks_image(300, 200, 1), secondary = peaks_image(250, 240, 2);
  diachron::GridTiler tiler(diachron::GridTilerOptions{100, 100, 0, 0});
  PeakMatcher plain;
  const auto expected = diachron::match_one_to_many(master, secondary, tiler, tiler, plain);
  const int plain_calls = plain.ex.calls->load();

  PeakMatcher wrapped;
  const diachron::FeatureCacheMatcher<PeakMatcher> cached(wrapped);
  for (std::size_t threads : {1u, 2u}) {
    diachron::OneToManyOptions options;
    options.threads = threads;
    const auto got = diachron::match_one_to_many(master, secondary, tiler, tiler, cached, options);
    REQUIRE(got.matches.size() == expected.matches.size());
    for (std::size_t i = 0; i < got.matches.size(); ++i) {
      REQUIRE(got.matches[i].a == expected.matches[i].a);
      REQUIRE(got.matches[i].b == expected.matches[i].b);
    }
  }
  const std::size_t tiles = expected.master_tiles.size() + expected.secondary_tiles.size();
  REQUIRE(plain_calls == static_cast<int>(2 * expected.pair_count));
  // Identical tiles share an entry, so at most one extraction per tile, over both runs.
  REQUIRE(wrapped.ex.calls->load() <= static_cast<int>(tiles) + 1);
  REQUIRE(cached.cached_images() <= tiles);
}

TEST_CASE("FeatureCacheMatcher: different content at the same size is not confused", "[tiling]") {
  PeakMatcher m;
  const diachron::FeatureCacheMatcher<PeakMatcher> cached(m);
  auto a = peaks_image(40, 40, 3);
  const auto fa = cached.features(a);
  a(0, 0) = 255;  // same buffer, same size, new content
  const auto fb = cached.features(a);
  REQUIRE(fa->keypoints[0].position != fb->keypoints[0].position);
  REQUIRE(m.ex.calls->load() == 2);
}

namespace {

// Masked: the brightest pixel where the mask is nonzero.
struct MaskedPeakExtractor {
  std::shared_ptr<std::atomic<int>> calls = std::make_shared<std::atomic<int>>(0);
  diachron::Features extract(const diachron::Raster<std::uint8_t>& image) const {
    return extract(image, diachron::Raster<std::uint8_t>(image.width(), image.height(), 1));
  }
  diachron::Features extract(const diachron::Raster<std::uint8_t>& image,
                             const diachron::Raster<std::uint8_t>& mask) const {
    calls->fetch_add(1);
    diachron::Features f;
    int bx = -1, by = -1;
    for (int y = 0; y < image.height(); ++y)
      for (int x = 0; x < image.width(); ++x)
        if (mask(x, y) && (bx < 0 || image(x, y) > image(bx, by))) bx = x, by = y;
    if (bx < 0) return f;
    diachron::Keypoint k;
    k.position = {double(bx), double(by)};
    f.keypoints.push_back(k);
    f.descriptors = diachron::DescriptorMatrix::Constant(1, 1, float(image(bx, by)));
    return f;
  }
};

struct MaskedPeakMatcher {
  MaskedPeakExtractor ex;
  const MaskedPeakExtractor& extractor() const { return ex; }
  std::vector<diachron::PointMatch> match(const diachron::Features& a, const diachron::Features& b) const {
    if (a.empty() || b.empty()) return {};
    return {diachron::PointMatch{a.keypoints[0].position, b.keypoints[0].position, 1.0}};
  }
  std::vector<diachron::PointMatch> match(const diachron::Raster<std::uint8_t>& a,
                                          const diachron::Raster<std::uint8_t>& b) const {
    return match(ex.extract(a), ex.extract(b));
  }
};

}  // namespace

TEST_CASE("FeatureCacheMatcher: passes masks to a masked extractor and keys the cache on them", "[tiling]") {
  using Cache = diachron::FeatureCacheMatcher<MaskedPeakMatcher>;
  STATIC_REQUIRE(diachron::is_masked_pair_matcher_v<Cache>);
  STATIC_REQUIRE_FALSE(diachron::is_masked_pair_matcher_v<diachron::FeatureCacheMatcher<PeakMatcher>>);
  // The wrapper keeps a reference: a temporary matcher does not compile.
  STATIC_REQUIRE(std::is_constructible_v<Cache, const MaskedPeakMatcher&>);
  STATIC_REQUIRE_FALSE(std::is_constructible_v<Cache, MaskedPeakMatcher>);
  STATIC_REQUIRE_FALSE(std::is_constructible_v<Cache, MaskedPeakMatcher&&>);

  diachron::Raster<std::uint8_t> image(10, 10, 0);
  image(2, 3) = 200;  // the peak
  image(7, 7) = 100;  // the peak once (2, 3) is masked
  diachron::Raster<std::uint8_t> all(10, 10, 255), masked(10, 10, 255);
  masked(2, 3) = 0;
  const MaskedPeakMatcher plain;
  const Cache cache(plain);
  const auto free = cache.match(image, image, all, all);
  REQUIRE(free.size() == 1);
  REQUIRE(free[0].a == Eigen::Vector2d(2, 3));
  const auto under_mask = cache.match(image, image, masked, masked);
  REQUIRE(under_mask.size() == 1);
  REQUIRE(under_mask[0].a == Eigen::Vector2d(7, 7));
  REQUIRE(cache.cached_images() == 2);  // same pixels, two masks
  cache.match(image, image, masked, all);
  REQUIRE(cache.cached_images() == 2);
  REQUIRE(plain.ex.calls->load() == 2);
}
