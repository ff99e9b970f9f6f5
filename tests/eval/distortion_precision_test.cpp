// Tests of eval/distortion_precision.hpp: no covariance gives no spread; a sigma of K1 alone gives
// f sigma r^3 at the corner; the first-order propagation against a Monte-Carlo oracle (intrinsics
// drawn from the covariance, the spread of d at the worst pixel measured); bad input.
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/camera/camera.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/eval/distortion_precision.hpp>

using namespace diachron;

namespace {

// FraserAffine parameters: K1, K2, K3, P1, P2, B1, B2.
Camera<FraserAffine> camera() {
  return Camera<FraserAffine>(1000.0, 499.5, 399.5, 1000, 800, {-0.02, 0.003, 0.0, 1e-4, -5e-5, 0.3, -0.1});
}

// d(p) = p - c - f x(p), as the file comment defines it.
Vec2 distortion(const Camera<FraserAffine>& c, const Vec2& pixel) {
  return pixel - c.principal_point() - c.focal() * *c.normalized_from_pixel(pixel);
}

}  // namespace

TEST_CASE("distortion_precision: a zero covariance gives zero, a K1 sigma f sigma r^3 at the corner", "[eval]") {
  const Camera<FraserAffine> c = camera();
  const DistortionPrecision none = distortion_precision(c, std::vector<double>(64, 0.0));
  CHECK(none.valid);
  CHECK(none.samples == 17 * 17);
  CHECK(none.max_sigma_px < 1e-12);

  // Only K1 uncertain (index 3 of [f, cx, cy, K1, ...]): d moves by about f r^3 per unit of K1 along
  // the radius (r the ideal radius; the small other terms change that by a few percent).
  std::vector<double> cov(16, 0.0);
  const double sigma_k1 = 1e-3;
  cov[3 * 4 + 3] = sigma_k1 * sigma_k1;
  const DistortionPrecision k1 = distortion_precision(c, cov);
  const double r = c.normalized_from_pixel(Vec2(0.0, 0.0))->norm();
  CHECK(k1.max_sigma_px == Approx(1000.0 * sigma_k1 * r * r * r).epsilon(0.05));
  // The worst pixel is a corner, the farthest from the principal point.
  CHECK((k1.worst_pixel.x() == 0.0 || k1.worst_pixel.x() == 999.0));
  CHECK((k1.worst_pixel.y() == 0.0 || k1.worst_pixel.y() == 799.0));
  CHECK(k1.rms_sigma_px < k1.max_sigma_px);
}

TEST_CASE("distortion_precision: the first-order propagation against a Monte-Carlo oracle", "[eval]") {
  const Camera<FraserAffine> c = camera();
  // A correlated covariance over [f, cx, cy, K1, K2, K3, P1, P2], as a weak block gives: f and K1
  // strongly (the focal length's trade with the radial polynomial), K1 and K2 against each other.
  const double s[8] = {4.0, 1.5, 1.5, 2e-3, 1e-3, 3e-4, 2e-5, 2e-5};
  Eigen::Matrix<double, 8, 8> corr = Eigen::Matrix<double, 8, 8>::Identity();
  corr(0, 3) = corr(3, 0) = -0.9;
  corr(3, 4) = corr(4, 3) = -0.3;
  corr(1, 6) = corr(6, 1) = 0.6;
  Eigen::Matrix<double, 8, 8> cov;
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) cov(i, j) = corr(i, j) * s[i] * s[j];
  std::vector<double> flat(64);
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) flat[static_cast<std::size_t>(i * 8 + j)] = cov(i, j);
  const DistortionPrecision predicted = distortion_precision(c, flat);
  REQUIRE(predicted.valid);

  // Draw intrinsics from N(c, cov) and measure the spread of d at the predicted worst pixel, along
  // its worst direction: the largest eigenvalue of the sample covariance.
  const Eigen::LLT<Eigen::Matrix<double, 8, 8>> llt(cov);
  REQUIRE(llt.info() == Eigen::Success);  // a covariance, positive definite
  const Eigen::Matrix<double, 8, 8> l = llt.matrixL();
  RandomStream random(7);
  const int draws = 4000;
  Eigen::Matrix<double, 2, Eigen::Dynamic> samples(2, draws);
  for (int k = 0; k < draws; ++k) {
    Eigen::Matrix<double, 8, 1> z;
    for (int i = 0; i < 8; ++i) z(i) = random.normal();
    const Eigen::Matrix<double, 8, 1> delta = l * z;
    Camera<FraserAffine>::Intrinsics in = c.intrinsics();
    for (int i = 0; i < 8; ++i) in[static_cast<std::size_t>(i)] += delta(i);
    samples.col(k) = distortion(Camera<FraserAffine>::from_intrinsics(in, c.width(), c.height()), predicted.worst_pixel);
  }
  const Vec2 mean = samples.rowwise().mean();
  const Eigen::Matrix<double, 2, Eigen::Dynamic> centred = samples.colwise() - mean;
  const Mat2 sample_cov = centred * centred.transpose() / (draws - 1);
  const double measured = std::sqrt(Eigen::SelfAdjointEigenSolver<Mat2>(sample_cov).eigenvalues().maxCoeff());
  // 4000 draws: the standard deviation is measured to about 1.1 % (1 / sqrt(2 n)); 5 % allows the
  // first order's own error.
  CHECK(predicted.max_sigma_px == Approx(measured).epsilon(0.05));
  CHECK(predicted.max_sigma_px > 0.3);  // a spread that matters, not rounding
}

TEST_CASE("distortion_precision: bad input", "[eval]") {
  const Camera<FraserAffine> c = camera();
  CHECK_THROWS_AS(distortion_precision(c, std::vector<double>(5, 0.0)), Error);     // not square
  CHECK_THROWS_AS(distortion_precision(c, std::vector<double>(121, 0.0)), Error);   // 11 > 10 intrinsics
  CHECK_THROWS_AS(distortion_precision(c, std::vector<double>{}), Error);
  std::vector<double> asymmetric(4, 0.0);
  asymmetric[1] = 1.0;
  CHECK_THROWS_AS(distortion_precision(c, asymmetric), Error);
  std::vector<double> nan(4, 0.0);
  nan[0] = std::nan("");
  CHECK_THROWS_AS(distortion_precision(c, nan), Error);
  DistortionPrecisionOptions o;
  o.samples = 1;
  CHECK_THROWS_AS(distortion_precision(c, std::vector<double>(4, 0.0), o), Error);
}
