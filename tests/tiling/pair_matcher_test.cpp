#include <catch2/catch.hpp>

#include <cstdint>
#include <vector>

#include <diachron/matching/descriptor_matching.hpp>
#include <diachron/tiling/pair_matcher.hpp>
// The OpenCV adapters must model the concepts, and their names must not clash with matching/'s.
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>

using diachron::Features;
using diachron::PointMatch;
using diachron::Raster;

namespace {

struct GoodMatcher {
  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b) const {
    return {PointMatch{{a.width(), a.height()}, {b.width(), b.height()}, 1.0}};
  }
};
struct NonConstMatcher {
  std::vector<PointMatch> match(const Raster<std::uint8_t>&, const Raster<std::uint8_t>&) { return {}; }
};
struct WrongReturnMatcher {
  int match(const Raster<std::uint8_t>&, const Raster<std::uint8_t>&) const { return 0; }
};
struct FloatImageMatcher {
  std::vector<PointMatch> match(const Raster<float>&, const Raster<float>&) const { return {}; }
};
struct NoMatcher {};

struct GoodExtractor {
  Features extract(const Raster<std::uint8_t>&) const { return {}; }
};
struct NonConstExtractor {
  Features extract(const Raster<std::uint8_t>&) { return {}; }
};

}  // namespace

TEST_CASE("PairMatcher: detection trait accepts const match and rejects the rest", "[tiling]") {
  STATIC_REQUIRE(diachron::is_pair_matcher_v<GoodMatcher>);
  STATIC_REQUIRE(diachron::is_pair_matcher_v<const GoodMatcher&>);
  STATIC_REQUIRE_FALSE(diachron::is_pair_matcher_v<NonConstMatcher>);
  STATIC_REQUIRE_FALSE(diachron::is_pair_matcher_v<WrongReturnMatcher>);
  STATIC_REQUIRE_FALSE(diachron::is_pair_matcher_v<FloatImageMatcher>);
  STATIC_REQUIRE_FALSE(diachron::is_pair_matcher_v<NoMatcher>);
  STATIC_REQUIRE(diachron::check_pair_matcher<GoodMatcher>());
}

TEST_CASE("FeatureExtractor: detection trait", "[tiling]") {
  STATIC_REQUIRE(diachron::is_feature_extractor_v<GoodExtractor>);
  STATIC_REQUIRE_FALSE(diachron::is_feature_extractor_v<NonConstExtractor>);
  STATIC_REQUIRE_FALSE(diachron::is_feature_extractor_v<GoodMatcher>);
  STATIC_REQUIRE(diachron::check_feature_extractor<GoodExtractor>());
}

TEST_CASE("PairMatcher: vision adapters model the concepts", "[tiling]") {
  STATIC_REQUIRE(diachron::is_feature_extractor_v<diachron::SiftExtractor>);
  STATIC_REQUIRE(diachron::is_pair_matcher_v<diachron::ExtractorPairMatcher<diachron::SiftExtractor>>);
}

TEST_CASE("make_pair_matcher: a lambda becomes a PairMatcher", "[tiling]") {
  int calls = 0;
  auto matcher = diachron::make_pair_matcher(
      [&calls](const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b) {
        ++calls;
        return std::vector<PointMatch>{PointMatch{{a.width(), 0}, {b.width(), 0}, 0.5}};
      });
  STATIC_REQUIRE(diachron::is_pair_matcher_v<decltype(matcher)>);
  const Raster<std::uint8_t> a(3, 2), b(7, 5);
  const auto m = matcher.match(a, b);
  REQUIRE(calls == 1);
  REQUIRE(m.size() == 1);
  REQUIRE(m[0].a.x() == 3);
  REQUIRE(m[0].b.x() == 7);
  REQUIRE(m[0].score == 0.5);
}
