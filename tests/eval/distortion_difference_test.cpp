// Tests of eval/distortion_difference.hpp: zero for equal distortions whatever the focal length and
// principal point, the radial displacement at the corner from an independent solve of the radial
// equation, symmetry, at given pixels, bad input.
#include <cmath>

#include <catch2/catch.hpp>

#include <diachron/camera/camera.hpp>
#include <diachron/core/error.hpp>
#include <diachron/eval/distortion_difference.hpp>

using namespace diachron;

namespace {

// FraserAffine parameters: K1, K2, K3, P1, P2, B1, B2.
Camera<FraserAffine> camera(double f, double cx, double cy, double k1, double b1 = 0.0) {
  return Camera<FraserAffine>(f, cx, cy, 1000, 800, {k1, 0.0, 0.0, 0.0, 0.0, b1, 0.0});
}

}  // namespace

TEST_CASE("distortion_difference: equal distortions give zero, whatever f and the principal point", "[eval]") {
  const DistortionDifference same = distortion_difference(camera(1000, 499.5, 399.5, 0.02), camera(1000, 499.5, 399.5, 0.02));
  CHECK(same.valid);
  CHECK(same.samples == 17 * 17);
  CHECK(same.max_px == 0.0);
  // No distortion on either side: a different focal length and principal point are not distortion.
  const DistortionDifference ideal = distortion_difference(camera(1000, 499.5, 399.5, 0.0), camera(1100, 480.0, 410.0, 0.0));
  CHECK(ideal.max_px < 1e-9);
}

TEST_CASE("distortion_difference: radial K1 against none, the corner displacement from the radial equation", "[eval]") {
  const double f = 1000.0, k1 = 0.01;
  const Camera<FraserAffine> none = camera(f, 499.5, 399.5, 0.0), radial = camera(f, 499.5, 399.5, k1);
  const DistortionDifference d = distortion_difference(none, radial);
  // The corner pixel is the farthest from the centre: distorted radius rd = |corner - c| / f; the
  // ideal radius r solves r (1 + k1 r^2) = rd (Newton here, independent of Camera's unprojection);
  // the displacement is f (rd - r).
  const double rd = std::hypot(499.5, 399.5) / f;
  double r = rd;
  for (int i = 0; i < 50; ++i) r -= (r * (1.0 + k1 * r * r) - rd) / (1.0 + 3.0 * k1 * r * r);
  CHECK(d.valid);
  CHECK(d.max_px == Approx(f * (rd - r)).epsilon(1e-6));
  CHECK(d.max_px > 2.0);  // about 2.6 px: a real distortion, not rounding
  CHECK(d.rms_px < d.max_px);
  // Symmetric.
  CHECK(distortion_difference(radial, none).max_px == Approx(d.max_px).epsilon(1e-9));

  // At given pixels: near the principal point K1 does almost nothing, at the corner what the grid found.
  const DistortionDifference centre = distortion_difference_at(none, radial, {Vec2(499.5, 399.5), Vec2(520.0, 380.0)});
  CHECK(centre.valid);
  CHECK(centre.samples == 2);
  CHECK(centre.max_px == Approx(0.01 * std::pow(std::hypot(20.5, 19.5) / 1000.0, 3) * 1000.0).epsilon(1e-3));  // k1 r^3 f
  const DistortionDifference corner = distortion_difference_at(none, radial, {Vec2(499.5, 399.5), Vec2(0.0, 0.0)});
  CHECK(corner.max_px == Approx(d.max_px).epsilon(1e-12));
  CHECK(corner.rms_px == Approx(d.max_px / std::sqrt(2.0)).epsilon(1e-6));
  CHECK_FALSE(distortion_difference_at(none, radial, {}).valid);
}

TEST_CASE("distortion_difference: the affine part counts as distortion", "[eval]") {
  // B1 adds B1 x' to u: at the right edge x' = 499.5 / (f + B1), so about B1 * 0.5 px.
  const DistortionDifference d = distortion_difference(camera(1000, 499.5, 399.5, 0.0), camera(1000, 499.5, 399.5, 0.0, 2.0));
  CHECK(d.max_px == Approx(2.0 * 499.5 / 1002.0).epsilon(1e-6));
}

TEST_CASE("distortion_difference: bad input", "[eval]") {
  const Camera<FraserAffine> a = camera(1000, 499.5, 399.5, 0.0);
  const Camera<FraserAffine> other_size(1000, 499.5, 399.5, 1200, 800);
  CHECK_THROWS_AS(distortion_difference(a, other_size), Error);
  DistortionDifferenceOptions o;
  o.samples = 1;
  CHECK_THROWS_AS(distortion_difference(a, a, o), Error);
  CHECK_THROWS_AS(distortion_difference_at(a, other_size, {Vec2(1.0, 1.0)}), Error);
  CHECK_THROWS_AS(distortion_difference_at(a, a, {Vec2(std::nan(""), 1.0)}), Error);
}
