#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/terrain/tile_agreement.hpp>

namespace {

// A rough texture on a w x h grid: a sum of random sinusoids, from a small deterministic generator.
diachron::Raster<float> texture(int w, int h, std::uint64_t seed) {
  std::uint64_t s = seed;
  auto next = [&] {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(s >> 11) / 9007199254740992.0;
  };
  std::vector<double> kx, ky, phase;
  for (int i = 0; i < 24; ++i) {
    kx.push_back((next() - 0.5) * 1.6);
    ky.push_back((next() - 0.5) * 1.6);
    phase.push_back(next() * 6.283);
  }
  diachron::Raster<float> r(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double v = 0.0;
      for (std::size_t i = 0; i < kx.size(); ++i) v += std::sin(kx[i] * x + ky[i] * y + phase[i]);
      r(x, y) = static_cast<float>(v);
    }
  return r;
}

// The w x h window of `big` whose origin is at (ox, oy): moving(x, y) = big(x + ox, y + oy).
diachron::Raster<float> crop(const diachron::Raster<float>& big, int ox, int oy, int w, int h) {
  diachron::Raster<float> r(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) r(x, y) = big(x + ox, y + oy);
  return r;
}

// P(X >= k) by enumerating every outcome of n trials: the oracle of binomial_tail.
double tail_by_enumeration(int k, int n, double p) {
  double sum = 0.0;
  for (std::uint32_t outcome = 0; outcome < (1u << n); ++outcome) {
    int successes = 0;
    double probability = 1.0;
    for (int i = 0; i < n; ++i) {
      const bool hit = (outcome >> i) & 1u;
      successes += hit;
      probability *= hit ? p : 1.0 - p;
    }
    if (successes >= k) sum += probability;
  }
  return sum;
}

}  // namespace

TEST_CASE("binomial_tail: every outcome enumerated", "[terrain]") {
  for (int n : {0, 1, 5, 12})
    for (int k = -1; k <= n + 1; ++k)
      for (double p : {0.0, 0.05, 0.25, 0.5, 0.9, 1.0}) {
        INFO("k " << k << " n " << n << " p " << p);
        CHECK(diachron::binomial_tail(k, n, p) == Approx(tail_by_enumeration(std::max(k, 0), n, p)).margin(1e-12));
      }
  // Large n and a tiny tail neither underflow to 0 too early nor exceed 1.
  CHECK(diachron::binomial_tail(200, 200, 0.5) == Approx(std::pow(0.5, 200)));
  CHECK(diachron::binomial_tail(1, 1000, 0.5) == Approx(1.0));
  CHECK_THROWS_AS(diachron::binomial_tail(1, 4, 1.5), diachron::Error);
  CHECK_THROWS_AS(diachron::binomial_tail(1, -1, 0.5), diachron::Error);
}

TEST_CASE("tile_agreement: a right placement agrees everywhere, one 4 px off nowhere", "[terrain]") {
  const diachron::Raster<float> fixed = texture(120, 100, 7);
  // moving(x, y) = fixed(x + 30, y + 20): the placement (30, 20) is right.
  const std::vector<diachron::Raster<float>> f{fixed}, m{crop(fixed, 30, 20, 60, 56)};
  const diachron::TileAgreement right = diachron::tile_agreement(f, m, 30, 20);
  CHECK(right.tiles == 16);
  CHECK(right.agree == 16);
  CHECK(right.share() == 1.0);
  // A right placement off by a pixel still agrees (the tile peaks within one pixel of it).
  CHECK(diachron::tile_agreement(f, m, 31, 19).agree == 16);
  // 4 px off: every tile finds the right shift, which is 4 px from the placement, inside the radius.
  const diachron::TileAgreement off = diachron::tile_agreement(f, m, 34, 20);
  CHECK(off.tiles == 16);
  CHECK(off.agree == 0);
}

TEST_CASE("tile_agreement: an unrelated raster agrees about as often as chance", "[terrain]") {
  const std::vector<diachron::Raster<float>> f{texture(120, 100, 7)}, m{texture(60, 56, 1234)};
  diachron::TileAgreementOptions o;
  o.tiles_per_side = 6;  // 36 tiles, each a chance of about 9 / 169 to peak within a pixel
  const diachron::TileAgreement t = diachron::tile_agreement(f, m, 30, 20, o);
  CHECK(t.tiles == 36);
  CHECK(t.agree <= 8);
  CHECK(diachron::binomial_tail(t.agree, t.tiles, 0.25) > 1e-3);
}

TEST_CASE("tile_agreement: holes and the overlap's edge leave tiles out; several channels", "[terrain]") {
  const diachron::Raster<float> fixed = texture(120, 100, 7);
  diachron::Raster<float> moving = crop(fixed, 30, 20, 60, 56);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // The top-left quarter of the moving raster is a hole: its 4 tiles (of 16, on the same bounding
  // box since the other corners are valid) have nothing to correlate.
  for (int y = 0; y < 28; ++y)
    for (int x = 0; x < 30; ++x) moving(x, y) = nan;
  const diachron::TileAgreement holes = diachron::tile_agreement({fixed}, {moving}, 30, 20);
  CHECK(holes.tiles == 12);
  CHECK(holes.agree == 12);
  // Two channels: the same answer as one when both carry the same texture.
  diachron::Raster<float> fixed2 = texture(120, 100, 8);
  diachron::Raster<float> moving2 = crop(fixed2, 30, 20, 60, 56);
  const diachron::TileAgreement two = diachron::tile_agreement({fixed, fixed2}, {moving, moving2}, 30, 20);
  CHECK(two.tiles == 12);
  CHECK(two.agree == 12);
  // No overlap at all: no tile.
  const diachron::TileAgreement none = diachron::tile_agreement({fixed}, {moving}, 500, 500);
  CHECK(none.tiles == 0);
  CHECK(std::isnan(none.share()));
  // Bad input.
  CHECK_THROWS_AS(diachron::tile_agreement({fixed}, {moving, moving2}, 0, 0), diachron::Error);
  CHECK_THROWS_AS(diachron::tile_agreement({fixed, fixed2}, {moving, crop(fixed2, 0, 0, 10, 10)}, 0, 0), diachron::Error);
  diachron::TileAgreementOptions o;
  o.radius_px = 1;
  CHECK_THROWS_AS(diachron::tile_agreement({fixed}, {moving}, 30, 20, o), diachron::Error);
}
