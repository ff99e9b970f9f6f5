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

namespace {

struct ConstInvariant {
  std::vector<PointMatch> match(const Raster<std::uint8_t>&, const Raster<std::uint8_t>&) const { return {}; }
  bool rotation_invariant() const { return true; }
};
// Forgot the const: used to be ignored silently (all four hypotheses ran); now check_pair_matcher
// and rotation_invariant() stop the build with a static_assert. Only the traits can be tested here.
struct NonConstInvariant {
  std::vector<PointMatch> match(const Raster<std::uint8_t>&, const Raster<std::uint8_t>&) const { return {}; }
  bool rotation_invariant() { return true; }
};
struct MaskedMatcher {
  std::vector<PointMatch> match(const Raster<std::uint8_t>&, const Raster<std::uint8_t>&) const { return {}; }
  std::vector<PointMatch> match(const Raster<std::uint8_t>&, const Raster<std::uint8_t>&, const Raster<std::uint8_t>&,
                                const Raster<std::uint8_t>&) const {
    return {};
  }
};
struct MaskedExtractor {
  Features extract(const Raster<std::uint8_t>&) const { return {}; }
  Features extract(const Raster<std::uint8_t>&, const Raster<std::uint8_t>&) const { return {}; }
};
struct FeatureMatcher {
  MaskedExtractor e;
  const MaskedExtractor& extractor() const { return e; }
  std::vector<PointMatch> match(const Features&, const Features&) const { return {}; }
};

}  // namespace

TEST_CASE("PairMatcher: a non-const rotation_invariant is detected, a const one is used", "[tiling]") {
  STATIC_REQUIRE(diachron::detail::has_rotation_invariant<ConstInvariant>::value);
  STATIC_REQUIRE(diachron::detail::has_any_rotation_invariant<NonConstInvariant>::value);
  STATIC_REQUIRE_FALSE(diachron::detail::has_rotation_invariant<NonConstInvariant>::value);
  STATIC_REQUIRE(diachron::check_pair_matcher<ConstInvariant>());
  REQUIRE(diachron::rotation_invariant(ConstInvariant{}));
  REQUIRE_FALSE(diachron::rotation_invariant(GoodMatcher{}));
}

TEST_CASE("make_pair_matcher: takes a rotation-invariance flag", "[tiling]") {
  auto fn = [](const Raster<std::uint8_t>&, const Raster<std::uint8_t>&) { return std::vector<PointMatch>{}; };
  REQUIRE_FALSE(diachron::rotation_invariant(diachron::make_pair_matcher(fn)));
  REQUIRE(diachron::rotation_invariant(diachron::make_pair_matcher(fn, true)));
  STATIC_REQUIRE_FALSE(diachron::is_masked_pair_matcher_v<decltype(diachron::make_pair_matcher(fn))>);
}

TEST_CASE("make_pair_matcher: a lambda taking masks is a masked PairMatcher", "[tiling]") {
  auto matcher = diachron::make_pair_matcher(
      [](const Raster<std::uint8_t>& a, const Raster<std::uint8_t>&, const Raster<std::uint8_t>& mask_a,
         const Raster<std::uint8_t>& mask_b) {
        // Report the mask sum of each image as a point, so the test sees what arrived.
        double sa = 0.0, sb = 0.0;
        for (int y = 0; y < mask_a.height(); ++y)
          for (int x = 0; x < mask_a.width(); ++x) sa += mask_a(x, y) != 0;
        for (int y = 0; y < mask_b.height(); ++y)
          for (int x = 0; x < mask_b.width(); ++x) sb += mask_b(x, y) != 0;
        return std::vector<PointMatch>{PointMatch{{sa, double(a.width())}, {sb, 0.0}, 1.0}};
      });
  STATIC_REQUIRE(diachron::is_pair_matcher_v<decltype(matcher)>);
  STATIC_REQUIRE(diachron::is_masked_pair_matcher_v<decltype(matcher)>);
  const Raster<std::uint8_t> a(4, 3, 7), b(5, 2, 9);
  Raster<std::uint8_t> ma(4, 3, 255), mb(5, 2, 0);
  ma(0, 0) = 0;
  mb(1, 1) = 1;
  const auto masked = matcher.match(a, b, ma, mb);
  REQUIRE(masked[0].a.x() == 11.0);
  REQUIRE(masked[0].b.x() == 1.0);
  // Without masks it sees all-valid ones.
  const auto unmasked = matcher.match(a, b);
  REQUIRE(unmasked[0].a.x() == 12.0);
  REQUIRE(unmasked[0].b.x() == 10.0);
}

TEST_CASE("Concept traits: masks and FeaturePairMatcher are detected", "[tiling]") {
  STATIC_REQUIRE(diachron::is_masked_pair_matcher_v<MaskedMatcher>);
  STATIC_REQUIRE_FALSE(diachron::is_masked_pair_matcher_v<GoodMatcher>);
  STATIC_REQUIRE(diachron::is_masked_feature_extractor_v<MaskedExtractor>);
  STATIC_REQUIRE(diachron::is_feature_pair_matcher_v<FeatureMatcher>);
  STATIC_REQUIRE_FALSE(diachron::is_feature_pair_matcher_v<GoodMatcher>);
  // The vision adapters take masks.
  STATIC_REQUIRE(diachron::is_masked_feature_extractor_v<diachron::SiftExtractor>);
  STATIC_REQUIRE(diachron::is_masked_pair_matcher_v<diachron::ExtractorPairMatcher<diachron::SiftExtractor>>);
}
