// Tests for matching/unsharp_mask.hpp: against a brute-force 2D convolution with mirrored edges
// (over several bands of rows too);
// off and flat images unchanged; an edge overshoots on both sides; bad options throw.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/unsharp_mask.hpp>

#include "support/rasters.hpp"

using diachron::Raster;
using diachron::UnsharpMaskOptions;

namespace {

// Mirror by walking: reflect at each edge until inside (the edge sample not repeated).
int walk_mirror(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * (n - 1) - i;
  return i;
}

// The unsharp mask with the 2D Gaussian summed directly over the (2r+1)^2 neighbourhood.
Raster<std::uint8_t> brute_unsharp(const Raster<std::uint8_t>& img, double amount, double sigma) {
  const int r = std::max(1, static_cast<int>(std::lround(4.0 * sigma)));
  double norm = 0.0;
  for (int j = -r; j <= r; ++j)
    for (int i = -r; i <= r; ++i) norm += std::exp(-0.5 * (i * i + j * j) / (sigma * sigma));
  Raster<std::uint8_t> out(img.width(), img.height());
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      double blurred = 0.0;
      for (int j = -r; j <= r; ++j)
        for (int i = -r; i <= r; ++i)
          blurred += std::exp(-0.5 * (i * i + j * j) / (sigma * sigma)) *
                     img(walk_mirror(x + i, img.width()), walk_mirror(y + j, img.height()));
      blurred /= norm;
      const double v = img(x, y) + amount * (img(x, y) - blurred);
      out(x, y) = static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 255.0)));
    }
  return out;
}

}  // namespace

TEST_CASE("unsharp_mask equals the brute-force 2D convolution", "[unsharp_mask]") {
  struct Case {
    int w, h;
    double amount, sigma;
  };
  // The last two are smaller than the kernel: the mirror is applied more than once. The first is
  // taller than a band of rows (256), so that bands meet inside the image.
  for (const Case c : {Case{9, 600, 1.2, 3.0}, Case{37, 23, 1.0, 1.0}, Case{20, 31, 2.5, 0.7}, Case{5, 4, 1.5, 2.0},
                       Case{1, 6, 3.0, 1.0}}) {
    const Raster<std::uint8_t> img = diachron::test::uniform_noise_image(c.w, c.h, 7);
    UnsharpMaskOptions o;
    o.amount = c.amount;
    o.sigma_px = c.sigma;
    const Raster<std::uint8_t> fast = diachron::unsharp_mask(img, o), slow = brute_unsharp(img, c.amount, c.sigma);
    REQUIRE(fast.width() == c.w);
    REQUIRE(fast.height() == c.h);
    int differ = 0;
    for (int y = 0; y < c.h; ++y)
      for (int x = 0; x < c.w; ++x) {
        // The sums differ by rounding only: at most one grey level, where a value sits on .5.
        CHECK(std::abs(fast(x, y) - slow(x, y)) <= 1);
        differ += fast(x, y) != slow(x, y);
      }
    CHECK(differ <= c.w * c.h / 100);
  }
}

TEST_CASE("unsharp_mask leaves the image alone when off or flat, and sharpens an edge", "[unsharp_mask]") {
  const Raster<std::uint8_t> img = diachron::test::uniform_noise_image(16, 12, 3);
  UnsharpMaskOptions off;
  const Raster<std::uint8_t> same = diachron::unsharp_mask(img, off);
  CHECK(diachron::test::same_values(same, img));

  UnsharpMaskOptions on;
  on.amount = 2.0;
  const Raster<std::uint8_t> flat(9, 9, 100);
  const Raster<std::uint8_t> flat_out = diachron::unsharp_mask(flat, on);
  CHECK(std::all_of(flat_out.begin(), flat_out.end(), [](std::uint8_t v) { return v == 100; }));

  // A vertical step from 80 to 160: the dark side gets darker and the bright side brighter next to
  // it, and far from it nothing changes.
  Raster<std::uint8_t> step(20, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 20; ++x) step(x, y) = x < 10 ? 80 : 160;
  const Raster<std::uint8_t> sharp = diachron::unsharp_mask(step, on);
  CHECK(sharp(9, 2) < 80);
  CHECK(sharp(10, 2) > 160);
  CHECK(sharp(0, 2) == 80);
  CHECK(sharp(19, 2) == 160);
}

TEST_CASE("unsharp_mask rejects bad options", "[unsharp_mask]") {
  const Raster<std::uint8_t> img = diachron::test::uniform_noise_image(8, 8, 1);
  UnsharpMaskOptions o;
  o.amount = -1.0;
  CHECK_THROWS_AS(diachron::unsharp_mask(img, o), diachron::Error);
  o.amount = std::nan("");
  CHECK_THROWS_AS(diachron::unsharp_mask(img, o), diachron::Error);
  o.amount = 1.0;
  o.sigma_px = 0.0;
  CHECK_THROWS_AS(diachron::unsharp_mask(img, o), diachron::Error);
  o.sigma_px = 25.0;
  CHECK_THROWS_AS(diachron::unsharp_mask(img, o), diachron::Error);
}
