#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <utility>
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

TEST_CASE("Fft2: equals the direct 2D DFT, forward and inverse, on every shape", "[terrain]") {
  // The columns are transformed together, each butterfly along two whole rows: checked against
  // the O(N^2) sum on wide, tall, square and degenerate shapes.
  for (const auto& [w, h] : {std::pair{16, 8}, std::pair{4, 32}, std::pair{8, 8}, std::pair{1, 16}, std::pair{16, 1},
                             std::pair{1, 1}}) {
    diachron::Fft2 fft(w, h);
    std::vector<std::complex<double>> x(static_cast<std::size_t>(w * h));
    Lcg rng{static_cast<std::uint64_t>(w * 100 + h)};
    for (auto& v : x) v = {rng.next() - 0.5, rng.next() - 0.5};
    for (const bool inverse : {false, true}) {
      std::vector<std::complex<double>> y = x;
      if (inverse) fft.inverse(y); else fft.forward(y);
      const double sign = inverse ? 1.0 : -1.0, scale = inverse ? 1.0 / (w * h) : 1.0;
      double worst = 0.0;
      for (int ky = 0; ky < h; ++ky)
        for (int kx = 0; kx < w; ++kx) {
          std::complex<double> sum(0.0, 0.0);
          for (int yy = 0; yy < h; ++yy)
            for (int xx = 0; xx < w; ++xx)
              sum += x[static_cast<std::size_t>(yy * w + xx)] *
                     std::polar(1.0, sign * 2.0 * diachron::kPi * (static_cast<double>(kx * xx) / w + static_cast<double>(ky * yy) / h));
          worst = std::max(worst, std::abs(scale * sum - y[static_cast<std::size_t>(ky * w + kx)]));
        }
      INFO(w << " x " << h << (inverse ? " inverse" : " forward"));
      CHECK(worst < 1e-12);
    }
  }
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

namespace {

// The two-channel ZNCC written out: the pixel pairs of the overlap, each channel centred on its own
// mean there, laid end to end.
double two_channel_oracle(const std::vector<diachron::Raster<float>>& f, const std::vector<diachron::Raster<float>>& g,
                          int dx, int dy) {
  double cov = 0.0, vf = 0.0, vg = 0.0;
  for (std::size_t c = 0; c < f.size(); ++c) {
    std::vector<double> a, b;
    for (int y = 0; y < g[c].height(); ++y)
      for (int x = 0; x < g[c].width(); ++x) {
        if (!f[c].contains(x + dx, y + dy)) continue;
        const float fv = f[c](x + dx, y + dy), gv = g[c](x, y);
        if (std::isnan(fv) || std::isnan(gv)) continue;
        a.push_back(fv);
        b.push_back(gv);
      }
    double ma = 0.0, mb = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      ma += a[i] / static_cast<double>(a.size());
      mb += b[i] / static_cast<double>(b.size());
    }
    for (std::size_t i = 0; i < a.size(); ++i) {
      cov += (a[i] - ma) * (b[i] - mb);
      vf += (a[i] - ma) * (a[i] - ma);
      vg += (b[i] - mb) * (b[i] - mb);
    }
  }
  return cov / std::sqrt(vf * vg);
}

// A second channel with the holes of the first.
diachron::Raster<float> with_holes_of(const diachron::Raster<float>& holes, std::uint64_t seed) {
  diachron::Raster<float> r = random_raster(holes.width(), holes.height(), seed, 0.0);
  for (int y = 0; y < r.height(); ++y)
    for (int x = 0; x < r.width(); ++x)
      if (std::isnan(holes(x, y))) r(x, y) = std::numeric_limits<float>::quiet_NaN();
  return r;
}

}  // namespace

TEST_CASE("MaskedNcc: two channels equal the written-out sum, each channel centred on its own mean", "[terrain]") {
  const diachron::Raster<float> f0 = random_raster(21, 15, 11, 0.2), g0 = random_raster(8, 10, 12, 0.2);
  // The second channels sit on another level: a shared mean would mix the two.
  diachron::Raster<float> f1 = with_holes_of(f0, 13), g1 = with_holes_of(g0, 14);
  for (float& v : f1) v -= 5000.0f;
  for (float& v : g1) v *= 0.01f;
  const std::vector<diachron::Raster<float>> fixed{f0, f1}, moving{g0, g1};
  diachron::MaskedNcc ncc(fixed, 8, 10);
  CHECK(ncc.channels() == 2);
  const diachron::MaskedNccMap map = ncc.correlate(moving, 5, 1e-9);
  int compared = 0;
  for (const auto& d : std::vector<std::pair<int, int>>{{0, 0}, {3, 2}, {-4, -6}, {12, 4}, {18, 12}, {-7, -9}, {9, 0}}) {
    const double oracle = two_channel_oracle(fixed, moving, d.first, d.second);
    const double direct = diachron::masked_ncc_at(fixed, moving, d.first, d.second, 5, 1e-9);
    const double fast = map.score(d.first - map.min_dx, d.second - map.min_dy);
    if (std::isnan(direct)) {
      CHECK(std::isnan(fast));
      continue;
    }
    CHECK(direct == Approx(oracle).margin(1e-9));
    CHECK(fast == Approx(oracle).margin(1e-5));
    ++compared;
  }
  CHECK(compared >= 5);
  // One channel through the vector interface is the single-raster correlation.
  diachron::MaskedNcc one({f0}, 8, 10), plain(f0, 8, 10);
  const diachron::MaskedNccMap a = one.correlate(std::vector<diachron::Raster<float>>{g0}, 5, 1e-9);
  const diachron::MaskedNccMap b = plain.correlate(g0, 5, 1e-9);
  for (int y = 0; y < a.score.height(); ++y)
    for (int x = 0; x < a.score.width(); ++x)
      CHECK((a.score(x, y) == b.score(x, y) || (std::isnan(a.score(x, y)) && std::isnan(b.score(x, y)))));
}

TEST_CASE("MaskedNcc: channels of another size or with other holes throw diachron::Error", "[terrain]") {
  const diachron::Raster<float> f0 = random_raster(10, 10, 1, 0.2);
  CHECK_THROWS_AS(diachron::MaskedNcc(std::vector<diachron::Raster<float>>{f0, random_raster(9, 10, 2, 0.0)}, 4, 4),
                  diachron::Error);
  CHECK_THROWS_AS(diachron::MaskedNcc(std::vector<diachron::Raster<float>>{f0, random_raster(10, 10, 2, 0.0)}, 4, 4),
                  diachron::Error);
  CHECK_THROWS_AS(diachron::MaskedNcc(std::vector<diachron::Raster<float>>{}, 4, 4), diachron::Error);
  diachron::MaskedNcc ncc(std::vector<diachron::Raster<float>>{f0, with_holes_of(f0, 3)}, 4, 4);
  const diachron::Raster<float> g = random_raster(4, 4, 5, 0.0);
  CHECK_THROWS_AS(ncc.correlate(g, 1, 0.0), diachron::Error);  // one channel against two
  CHECK_THROWS_AS(diachron::masked_ncc_at(std::vector<diachron::Raster<float>>{f0}, std::vector<diachron::Raster<float>>{g, g}, 0, 0, 1, 0.0),
                  diachron::Error);
}
