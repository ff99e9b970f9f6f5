#include <catch2/catch.hpp>

#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/terrain/fft2.hpp>
#include <diachron/terrain/masked_ncc.hpp>

namespace {

// A small deterministic generator (the standard distributions differ between libraries).
struct Lcg {
  std::uint64_t s;
  double next() {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(s >> 11) / 9007199254740992.0;
  }
};

diachron::Raster<float> random_raster(int w, int h, std::uint64_t seed, double hole_fraction) {
  Lcg rng{seed};
  diachron::Raster<float> r(w, h);
  for (float& v : r) v = rng.next() < hole_fraction ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(1000.0 + 50.0 * rng.next());
  return r;
}

}  // namespace

TEST_CASE("Fft2: inverse undoes forward, and a delta has a flat spectrum", "[terrain]") {
  diachron::Fft2 fft(8, 4);
  std::vector<std::complex<double>> x(32), y;
  Lcg rng{3};
  for (auto& v : x) v = {rng.next(), rng.next()};
  y = x;
  fft.forward(y);
  fft.inverse(y);
  for (std::size_t i = 0; i < x.size(); ++i) CHECK(std::abs(y[i] - x[i]) < 1e-12);
  std::vector<std::complex<double>> d(32);
  d[0] = 1.0;
  fft.forward(d);
  for (const auto& v : d) CHECK(std::abs(v - std::complex<double>(1.0, 0.0)) < 1e-12);
  // One cycle along x: the energy is in bin (1, 0).
  std::vector<std::complex<double>> c(32);
  for (int yy = 0; yy < 4; ++yy)
    for (int xx = 0; xx < 8; ++xx) c[static_cast<std::size_t>(yy * 8 + xx)] = std::polar(1.0, 2.0 * diachron::kPi * xx / 8.0);
  fft.forward(c);
  CHECK(std::abs(c[1] - std::complex<double>(32.0, 0.0)) < 1e-9);
  CHECK(std::abs(c[0]) < 1e-9);
  CHECK_THROWS_AS(diachron::Fft2(6, 4), diachron::Error);
  CHECK(diachron::next_power_of_two(33) == 64);
}

TEST_CASE("MaskedNcc: equals the direct sum over the overlap at every tested shift, holes included", "[terrain]") {
  const diachron::Raster<float> fixed = random_raster(23, 17, 1, 0.2);
  const diachron::Raster<float> moving = random_raster(9, 12, 2, 0.2);
  diachron::MaskedNcc ncc(fixed, 9, 12);
  const diachron::MaskedNccMap map = ncc.correlate(moving, 5, 1e-9);
  CHECK(map.min_dx == -8);
  CHECK(map.min_dy == -11);
  int compared = 0;
  for (const auto& d : std::vector<std::pair<int, int>>{{0, 0}, {3, 2}, {-4, -6}, {14, 5}, {20, 14}, {-8, -11}, {10, 0}}) {
    const double direct = diachron::masked_ncc_at(fixed, moving, d.first, d.second, 5, 1e-9);
    const double fast = map.score(d.first - map.min_dx, d.second - map.min_dy);
    if (std::isnan(direct)) {
      CHECK(std::isnan(fast));
    } else {
      CHECK(fast == Approx(direct).margin(1e-5));
      ++compared;
    }
  }
  CHECK(compared >= 5);
}

TEST_CASE("MaskedNcc: a moving window cut from the fixed raster scores 1 at its place, gain and offset aside", "[terrain]") {
  const diachron::Raster<float> fixed = random_raster(30, 20, 7, 0.1);
  diachron::Raster<float> moving(8, 6);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) moving(x, y) = 3.0f * fixed(x + 11, y + 9) - 500.0f;  // NaN stays NaN
  diachron::MaskedNcc ncc(fixed, 8, 6);
  const diachron::MaskedNccMap map = ncc.correlate(moving, 20, 1e-9);
  int dx = 0, dy = 0;
  double best = 0.0;
  REQUIRE(map.best(dx, dy, best));
  CHECK(dx == 11);
  CHECK(dy == 9);
  CHECK(best == Approx(1.0).margin(1e-6));
}

TEST_CASE("MaskedNcc: bad input throws diachron::Error", "[terrain]") {
  const diachron::Raster<float> fixed = random_raster(10, 10, 1, 0.0);
  CHECK_THROWS_AS(diachron::MaskedNcc(diachron::Raster<float>(), 3, 3), diachron::Error);
  CHECK_THROWS_AS(diachron::MaskedNcc(fixed, 0, 3), diachron::Error);
  diachron::MaskedNcc ncc(fixed, 4, 4);
  CHECK_THROWS_AS(ncc.correlate(random_raster(5, 4, 2, 0.0), 1, 0.0), diachron::Error);
  CHECK_THROWS_AS(ncc.correlate(random_raster(4, 4, 2, 0.0), 0, 0.0), diachron::Error);
}
