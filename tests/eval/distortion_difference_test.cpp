// Tests of eval/distortion_difference.hpp: zero for equal distortions whatever the focal length and
// principal point, the radial displacement at the corner from an independent solve of the radial
// equation, symmetry, at given pixels, bad input; the part beyond a change of pose against a
// brute-force re-orientation over a plane.
#include <algorithm>
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/camera/camera.hpp>
#include <diachron/core/error.hpp>
#include <diachron/eval/distortion_difference.hpp>
#include <diachron/geometry/rotation.hpp>

using namespace diachron;

namespace {

// FraserAffine parameters: K1, K2, K3, P1, P2, B1, B2.
Camera<FraserAffine> camera(double f, double cx, double cy, double k1, double b1 = 0.0) {
  return Camera<FraserAffine>(f, cx, cy, 1000, 800, {k1, 0.0, 0.0, 0.0, 0.0, b1, 0.0});
}

// The oracle for beyond_pose_*: camera `a` looks straight down from `height` over the plane z = 0;
// camera `b`'s pose (3 rotation, 3 centre parameters) is fitted by Gauss-Newton with numerical
// derivatives so that b images the plane points of a's grid pixels where a does. Returns the RMS
// (first) and largest (second) pixel difference left: what no pose of b can absorb, without the
// first-order model the library fits.
std::pair<double, double> refit_pose_over_plane(const Camera<FraserAffine>& a, const Camera<FraserAffine>& b,
                                                double height, int samples) {
  const Mat3 down = Vec3(1.0, -1.0, -1.0).asDiagonal();  // camera z along world -z
  std::vector<Vec2> pixels;
  std::vector<Vec3> ground;
  for (int j = 0; j < samples; ++j)
    for (int i = 0; i < samples; ++i) {
      const Vec2 p((a.width() - 1) * double(i) / (samples - 1), (a.height() - 1) * double(j) / (samples - 1));
      const Vec3 ray = down.transpose() * *a.unproject(p);
      pixels.push_back(p);
      ground.push_back(Vec3(0.0, 0.0, height) + ray * (height / -ray.z()));
    }
  const auto residuals = [&](const Eigen::Matrix<double, 6, 1>& pose) {
    const Mat3 r = rotation_from_axis_angle<double>(Vec3(pose.head<3>())) * down;
    const Vec3 centre = Vec3(0.0, 0.0, height) + pose.tail<3>();
    Eigen::VectorXd out(2 * ground.size());
    for (std::size_t k = 0; k < ground.size(); ++k)
      out.segment<2>(2 * k) = *b.project(r * (ground[k] - centre)) - pixels[k];
    return out;
  };
  Eigen::Matrix<double, 6, 1> pose = Eigen::Matrix<double, 6, 1>::Zero();
  for (int iteration = 0; iteration < 20; ++iteration) {
    const Eigen::VectorXd r0 = residuals(pose);
    Eigen::MatrixXd jacobian(r0.size(), 6);
    for (int c = 0; c < 6; ++c) {
      Eigen::Matrix<double, 6, 1> step = pose;
      const double h = c < 3 ? 1e-7 : 1e-4;  // radians, metres
      step(c) += h;
      jacobian.col(c) = (residuals(step) - r0) / h;
    }
    pose -= jacobian.colPivHouseholderQr().solve(r0);
  }
  const Eigen::VectorXd r = residuals(pose);
  double worst = 0.0;
  for (Eigen::Index k = 0; k < r.size() / 2; ++k) worst = std::max(worst, r.segment<2>(2 * k).norm());
  return {std::sqrt(r.squaredNorm() / (r.size() / 2)), worst};
}

// The oracle for refit_*: b's focal length and principal point fitted by Gauss-Newton (numerical
// derivatives) so that b maps the rays of a's grid pixels onto those pixels. Returns the RMS and
// largest pixel difference left.
std::pair<double, double> refit_focal_and_principal_point(const Camera<FraserAffine>& a, const Camera<FraserAffine>& b,
                                                          int samples) {
  std::vector<Vec2> pixels, rays;
  for (int j = 0; j < samples; ++j)
    for (int i = 0; i < samples; ++i) {
      pixels.emplace_back((a.width() - 1) * double(i) / (samples - 1), (a.height() - 1) * double(j) / (samples - 1));
      rays.push_back(*a.normalized_from_pixel(pixels.back()));
    }
  const auto residuals = [&](const Vec3& fc) {
    const Camera<FraserAffine> c(fc(0), fc(1), fc(2), b.width(), b.height(), b.params());
    Eigen::VectorXd out(2 * rays.size());
    for (std::size_t k = 0; k < rays.size(); ++k) out.segment<2>(2 * k) = c.pixel_from_normalized(rays[k]) - pixels[k];
    return out;
  };
  Vec3 fc(b.focal(), b.cx(), b.cy());
  for (int iteration = 0; iteration < 10; ++iteration) {
    const Eigen::VectorXd r0 = residuals(fc);
    Eigen::MatrixXd jacobian(r0.size(), 3);
    for (int c = 0; c < 3; ++c) {
      Vec3 step = fc;
      step(c) += 1e-4;
      jacobian.col(c) = (residuals(step) - r0) / 1e-4;
    }
    fc -= jacobian.colPivHouseholderQr().solve(r0);
  }
  const Eigen::VectorXd r = residuals(fc);
  double worst = 0.0;
  for (Eigen::Index k = 0; k < r.size() / 2; ++k) worst = std::max(worst, r.segment<2>(2 * k).norm());
  return {std::sqrt(r.squaredNorm() / (r.size() / 2)), worst};
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

TEST_CASE("distortion_difference: beyond a change of pose, against a brute-force re-orientation", "[eval]") {
  const Camera<FraserAffine> truth = camera(1000, 499.5, 399.5, 0.0);
  // A focal length and principal point apart are a change of pose over a plane: nothing is left.
  const DistortionDifference focal_only = distortion_difference(truth, camera(1010, 494.0, 402.0, 0.0));
  CHECK(focal_only.beyond_pose_max_px < 1e-6);
  CHECK(focal_only.refit_max_px < 1e-6);

  // A radial K1 is partly a change of height (the focal length's trade), partly not: what is left is
  // smaller than the distortion difference itself, and it is what re-fitting b's pose over the plane
  // leaves (1000 m above it; the first-order model against the exact projection).
  const Camera<FraserAffine> radial = camera(1000, 499.5, 399.5, 0.03);
  const DistortionDifference d = distortion_difference(truth, radial);
  CHECK(d.beyond_pose_rms_px < 0.8 * d.rms_px);
  CHECK(d.beyond_pose_max_px > 1.0);
  const std::pair<double, double> refit = refit_pose_over_plane(truth, radial, 1000.0, 17);
  CHECK(d.beyond_pose_rms_px == Approx(refit.first).epsilon(0.005));
  CHECK(d.beyond_pose_max_px == Approx(refit.second).epsilon(0.01));
  // With the focal length and principal point re-fitted instead (the balanced comparison): no more
  // is absorbed than by a whole pose (radial symmetry leaves the tilt and turn nothing to take),
  // more than by the cameras' own values, and it is what re-fitting them does (the pixel is linear
  // in them, so this oracle is exact).
  CHECK(d.refit_rms_px < d.rms_px);
  CHECK(d.refit_rms_px >= d.beyond_pose_rms_px - 1e-6);
  const std::pair<double, double> refit_fc = refit_focal_and_principal_point(truth, radial, 17);
  CHECK(d.refit_rms_px == Approx(refit_fc.first).epsilon(1e-4));
  CHECK(d.refit_max_px == Approx(refit_fc.second).epsilon(1e-4));

  // Together with a focal length and principal point that differ too: the same oracle.
  const Camera<FraserAffine> shifted = camera(990, 505.0, 396.0, 0.03, 1.5);
  const DistortionDifference e = distortion_difference(truth, shifted);
  const std::pair<double, double> refit_shifted = refit_pose_over_plane(truth, shifted, 1000.0, 17);
  CHECK(e.beyond_pose_rms_px == Approx(refit_shifted.first).epsilon(0.005));
  CHECK(e.beyond_pose_max_px == Approx(refit_shifted.second).epsilon(0.01));
  const std::pair<double, double> refit_fc_shifted = refit_focal_and_principal_point(truth, shifted, 17);
  CHECK(e.refit_rms_px == Approx(refit_fc_shifted.first).epsilon(1e-4));
  CHECK(e.refit_max_px == Approx(refit_fc_shifted.second).epsilon(1e-4));

  // Decentring distortion is mostly a tilt (its terms are quadratic, as a tilt's image motion): a
  // fit without the tilt terms would leave most of it.
  const Camera<FraserAffine> decentred(1000, 499.5, 399.5, 1000, 800, {0.0, 0.0, 0.0, 4e-3, -3e-3, 0.0, 0.0});
  const DistortionDifference p = distortion_difference(truth, decentred);
  const std::pair<double, double> refit_decentred = refit_pose_over_plane(truth, decentred, 1000.0, 17);
  CHECK(p.beyond_pose_rms_px < 0.5 * p.rms_px);
  CHECK(p.beyond_pose_rms_px == Approx(refit_decentred.first).epsilon(0.005));
  CHECK(p.beyond_pose_max_px == Approx(refit_decentred.second).epsilon(0.01));

  // Fewer than 4 samples cannot determine the fit.
  const DistortionDifference two = distortion_difference_at(truth, radial, {Vec2(0.0, 0.0), Vec2(999.0, 799.0)});
  CHECK(std::isinf(two.beyond_pose_max_px));
  CHECK(std::isinf(two.refit_max_px));
}
