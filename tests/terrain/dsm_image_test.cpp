// Tests of dsm_to_image (mean +- k sigma stretch with holes), wallis_filter (against a brute-force
// oracle, contrast equalisation, masks) and hillshade (exact on planes, holes).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/terrain/dsm_image.hpp>

using diachron::Dsm;
using diachron::GeoTransform;
using diachron::Raster;
using U8 = Raster<std::uint8_t>;

namespace {
const float kNaN = std::numeric_limits<float>::quiet_NaN();

// Local standard deviation of `img` over a (2r+1)^2 box at (x, y).
double local_std(const U8& img, int x, int y, int r) {
  double s = 0, s2 = 0, n = 0;
  for (int yy = std::max(0, y - r); yy <= std::min(img.height() - 1, y + r); ++yy)
    for (int xx = std::max(0, x - r); xx <= std::min(img.width() - 1, x + r); ++xx) {
      s += img(xx, yy);
      s2 += double(img(xx, yy)) * img(xx, yy);
      ++n;
    }
  return std::sqrt(std::max(0.0, s2 / n - (s / n) * (s / n)));
}
}  // namespace

TEST_CASE("DsmImage: mean +- k sigma stretch with holes", "[terrain]") {
  Raster<float> z(4, 3);
  const float values[12] = {0, 1, 2, 3, kNaN, 5, 6, 7, 8, 9, kNaN, -std::numeric_limits<float>::infinity()};
  std::copy(values, values + 12, z.data());
  double mean = 0, sq = 0;
  for (float v : {0, 1, 2, 3, 5, 6, 7, 8, 9}) mean += v / 9.0;
  for (float v : {0, 1, 2, 3, 5, 6, 7, 8, 9}) sq += (v - mean) * (v - mean);
  const double sigma = std::sqrt(sq / 9.0);
  for (double k : {1.0, 2.0, 5.0}) {
    diachron::DsmImageOptions options;
    options.k_sigma = k;
    options.fill = 7;
    const auto out = diachron::dsm_to_image(z, options);
    CHECK(out.valid_count == 9);
    CHECK(out.low == Approx(mean - k * sigma));
    CHECK(out.high == Approx(mean + k * sigma));
    for (int i = 0; i < 12; ++i) {
      INFO("k " << k << " pixel " << i);
      if (!std::isfinite(values[i])) {
        CHECK(out.image.data()[i] == 7);
        CHECK(out.mask.data()[i] == 0);
        continue;
      }
      const double g = std::clamp(255.0 * (values[i] - out.low) / (out.high - out.low), 0.0, 255.0);
      CHECK(out.image.data()[i] == std::lround(g));
      CHECK(out.mask.data()[i] == 255);
    }
    // The Dsm overload uses the Dsm's statistics and agrees.
    const auto from_dsm = diachron::dsm_to_image(Dsm(z, GeoTransform::north_up(0, 0, 1)), options);
    CHECK(std::equal(from_dsm.image.begin(), from_dsm.image.end(), out.image.begin()));
  }
  // k = 1 clips: 0 and 9 are beyond one sigma.
  diachron::DsmImageOptions one;
  one.k_sigma = 1.0;
  one.make_mask = false;
  const auto clipped = diachron::dsm_to_image(z, one);
  CHECK(clipped.image(0, 0) == 0);
  CHECK(clipped.image(1, 2) == 255);
  CHECK(clipped.mask.empty());
  // Constant heights: mid gray; no valid pixel: all fill.
  CHECK(diachron::dsm_to_image(Raster<float>(3, 3, 42.0f)).image(1, 1) == 128);
  const auto none = diachron::dsm_to_image(Raster<float>(3, 3, kNaN));
  CHECK(none.valid_count == 0);
  CHECK(none.image(2, 2) == 0);
  diachron::DsmImageOptions bad;
  bad.k_sigma = 0.0;
  CHECK_THROWS_AS(diachron::dsm_to_image(z, bad), diachron::Error);
}

TEST_CASE("Wallis: matches a brute-force evaluation of the recipe", "[terrain]") {
  U8 img(37, 29);
  diachron::RandomStream rng(7);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      img(x, y) = static_cast<std::uint8_t>(std::clamp(60.0 + 2.0 * x + 30.0 * rng.normal(), 0.0, 255.0));
  diachron::WallisOptions options;
  options.half_window = 4;
  const U8 out = diachron::wallis_filter(img, options);

  // Oracle: the tone from mid-rank equalisations written out directly, local stats by loops.
  std::array<double, 256> hist{};
  int max_level = 0;
  for (auto v : img) {
    hist[v] += 1;
    max_level = std::max<int>(max_level, v);
  }
  const auto cdf_mid = [&](int v, bool sq) {
    double below = 0, total = 0;
    for (int i = 0; i < 256; ++i) total += sq ? std::sqrt(hist[i]) : hist[i];
    for (int i = 0; i < v; ++i) below += sq ? std::sqrt(hist[i]) : hist[i];
    return 255.0 * (below + 0.5 * (sq ? std::sqrt(hist[v]) : hist[v])) / total;
  };
  int worst = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      const int v = img(x, y);
      const double g = (cdf_mid(v, false) + 2.0 * 255.0 * v / max_level + 3.0 * cdf_mid(v, true)) / 6.0;
      double s = 0, n = 0;
      for (int yy = std::max(0, y - 4); yy <= std::min(img.height() - 1, y + 4); ++yy)
        for (int xx = std::max(0, x - 4); xx <= std::min(img.width() - 1, x + 4); ++xx) {
          s += img(xx, yy);
          ++n;
        }
      const double sd = local_std(img, x, y, 4);
      const double zz = sd > 0 ? (v - s / n) / sd : 0.0;
      const double expected = g + std::min({64.0, g, 255.0 - g}) * std::atan(zz) / (diachron::kPi / 2);
      worst = std::max(worst, std::abs(int(out(x, y)) - int(std::lround(expected))));
    }
  CHECK(worst <= 1);  // rounding of values exactly half way only
  // A constant image: z = 0, tone (127.5 + 2 * 255 + 3 * 127.5) / 6 = 170.
  const U8 flat = diachron::wallis_filter(U8(20, 20, 90));
  CHECK(flat(3, 17) == 170);
}

TEST_CASE("Wallis: equalises local contrast; holes are ignored", "[terrain]") {
  // Left half: texture of amplitude ~3 gray levels; right half: ~40.
  const int w = 200, h = 100;
  U8 img(w, h);
  diachron::RandomStream rng(3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double amp = x < w / 2 ? 3.0 : 40.0;
      img(x, y) = static_cast<std::uint8_t>(std::clamp(128.0 + amp * rng.normal(), 0.0, 255.0));
    }
  diachron::WallisOptions options;
  options.half_window = 10;
  const U8 out = diachron::wallis_filter(img, options);
  const double in_ratio = local_std(img, 150, 50, 10) / local_std(img, 50, 50, 10);
  const double out_ratio = local_std(out, 150, 50, 10) / local_std(out, 50, 50, 10);
  WARN("local std ratio right/left: input " << in_ratio << ", Wallis output " << out_ratio);
  // The local term is amplitude-bounded and scale-free, so it alone would equalise fully; the
  // global tone (1/3 linear) keeps part of the original contrast: 14.6 -> 2.0 here.
  CHECK(in_ratio > 8.0);
  CHECK(out_ratio < in_ratio / 5.0);
  CHECK(out_ratio > 1.0);
  CHECK(*std::min_element(out.begin(), out.end()) >= 0);
  CHECK(*std::max_element(out.begin(), out.end()) <= 255);

  // Holes: whatever gray sits under the mask, the valid output is the same, and holes get fill.
  U8 mask(w, h, 255);
  for (int y = 30; y < 60; ++y)
    for (int x = 80; x < 130; ++x) mask(x, y) = 0;
  U8 a = img, b = img;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (!mask(x, y)) {
        a(x, y) = 0;
        b(x, y) = 255;
      }
  options.fill = 3;
  const U8 fa = diachron::wallis_filter(a, options, &mask);
  const U8 fb = diachron::wallis_filter(b, options, &mask);
  CHECK(std::equal(fa.begin(), fa.end(), fb.begin()));
  CHECK(fa(100, 40) == 3);
  const U8 wrong_size(3, 3, 255);
  CHECK_THROWS_AS(diachron::wallis_filter(img, options, &wrong_size), diachron::Error);
  options.half_window = 0;
  CHECK_THROWS_AS(diachron::wallis_filter(img, options), diachron::Error);
}

TEST_CASE("Hillshade: exact on planes, holes filled", "[terrain]") {
  for (const double a : {0.0, 0.5, -1.0}) {
    for (const bool rotated : {false, true}) {
      // Z = a X on a north-up grid or a grid turned by 0.4 rad.
      const double c = std::cos(0.4), s = std::sin(0.4);
      const GeoTransform gt = rotated ? GeoTransform{{10, 2 * c, -2 * s, 20, 2 * s, 2 * c}}
                                      : GeoTransform::north_up(10, 20, 2.0);
      Raster<float> z(12, 12);
      for (int y = 0; y < 12; ++y)
        for (int x = 0; x < 12; ++x) z(x, y) = static_cast<float>(a * gt.pixel_to_world({x, y}).x());
      z(9, 9) = kNaN;
      const Dsm dsm(z, gt);
      const U8 shade = diachron::hillshade(dsm);
      // Light from the north-west at 45 degrees: l = (-0.5, 0.5, sqrt(0.5)).
      const double expected = 255.0 * std::max(0.0, (0.5 * a + std::sqrt(0.5)) / std::sqrt(1 + a * a));
      INFO("a " << a << " rotated " << rotated);
      CHECK(int(shade(5, 5)) == std::lround(expected));
      CHECK(int(shade(0, 0)) == std::lround(expected));  // border: extrapolation keeps the plane
      CHECK(int(shade(8, 9)) == std::lround(expected));  // next to the hole
      CHECK(shade(9, 9) == 0);
    }
  }
  diachron::HillshadeOptions options;
  options.altitude_deg = 90.0;
  options.fill = 9;
  Raster<float> z(5, 5, 1.0f);
  z(2, 2) = kNaN;
  const U8 top = diachron::hillshade(Dsm(z, GeoTransform::north_up(0, 0, 1)), options);
  CHECK(top(0, 0) == 255);
  CHECK(top(2, 2) == 9);
  options.altitude_deg = 0.0;
  CHECK_THROWS_AS(diachron::hillshade(Dsm(z, GeoTransform::north_up(0, 0, 1)), options), diachron::Error);
}
