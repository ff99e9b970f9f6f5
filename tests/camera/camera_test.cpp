// Camera<Distortion>: projection, iterative unprojection, scalar templating (double, float,
// ceres::Jet) and argument checks, for every built-in distortion policy.

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <catch2/catch.hpp>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/core/error.hpp>

#if __has_include(<ceres/jet.h>)
#include <ceres/jet.h>
#define DIACHRON_TEST_HAVE_JET 1
#endif

using namespace diachron;

namespace {

// A wide-angle 153 mm film camera (23 cm format) scanned at 10 um: f ~ 15300 px, about
// 23000 x 23000 px, image corners at r ~ 1.06 in normalised units.
constexpr double kFocal = 15300.0;
constexpr int kSize = 23000;
constexpr double kCx = 0.5 * (kSize - 1) + 12.3;
constexpr double kCy = 0.5 * (kSize - 1) - 7.1;

// Realistic aerial distortion with the sign of K1 chosen by the caller (K1 = +-0.1).
template <class D>
typename Camera<D>::Params aerial_params(double k1) {
  typename Camera<D>::Params p{};
  const std::array<double, 7> all = {k1, 0.02, -0.005, 1e-4, -8e-5, 1e-4 * kFocal, -5e-5 * kFocal};
  for (int i = 0; i < D::kNumParams; ++i) p[i] = all[i];
  return p;
}

template <class D>
Camera<D> aerial_camera(double k1) {
  return Camera<D>(/*focal_px=*/kFocal, /*cx_px=*/kCx, /*cy_px=*/kCy, /*width_px=*/kSize,
                   /*height_px=*/kSize, aerial_params<D>(k1));
}

// A grid of n x n pixels covering the whole image, edges and corners included.
std::vector<Vec2> image_grid(int width, int height, int n) {
  std::vector<Vec2> out;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      out.emplace_back(-0.5 + width * double(j) / (n - 1), -0.5 + height * double(i) / (n - 1));
    }
  }
  return out;
}

}  // namespace

TEMPLATE_TEST_CASE("Camera: unproject then project returns the pixel over the whole image",
                   "[camera]", NoDistortion, RadialK3, Fraser, FraserAffine) {
  for (const double k1 : {-0.1, 0.1}) {
    const Camera<TestType> camera = aerial_camera<TestType>(k1);
    double worst_px = 0.0;
    int worst_iterations = 0;
    for (const Vec2& pixel : image_grid(kSize, kSize, 41)) {
      const UnprojectResult r = camera.unproject_detailed(pixel);
      REQUIRE(r.converged);
      const double back = (camera.pixel_from_normalized(r.normalized) - pixel).norm();
      worst_px = std::max(worst_px, back);
      worst_iterations = std::max(worst_iterations, r.iterations);
      CHECK(r.residual_px <= 1e-10);
      const std::optional<Vec3> d = camera.unproject(pixel);
      REQUIRE(d);
      CHECK(d->norm() == Approx(1.0).epsilon(1e-15));
      const std::optional<Vec2> again = camera.project(Vec3(*d * 1234.5));
      REQUIRE(again);
      CHECK((*again - pixel).norm() <= 1e-9);  // scaling the direction costs a few ulps
    }
    CAPTURE(k1, worst_px, worst_iterations);
    CHECK(worst_px <= 1e-10);
    CHECK(worst_iterations <= 10);
  }
}

TEMPLATE_TEST_CASE("Camera: project then unproject returns the normalised point", "[camera]",
                   NoDistortion, RadialK3, Fraser, FraserAffine) {
  const Camera<TestType> camera = aerial_camera<TestType>(-0.1);
  for (double x = -0.8; x <= 0.8; x += 0.1) {
    for (double y = -0.8; y <= 0.8; y += 0.1) {
      const Vec2 xy(x, y);
      const std::optional<Vec2> back = camera.normalized_from_pixel(camera.pixel_from_normalized(xy));
      REQUIRE(back);
      CHECK((*back - xy).norm() <= 1e-13);
    }
  }
}

TEMPLATE_TEST_CASE("Camera: undistort inverts distort in normalised coordinates", "[camera]",
                   NoDistortion, RadialK3, Fraser, FraserAffine) {
  const auto params = aerial_params<TestType>(0.1);
  for (double x = -0.75; x <= 0.75; x += 0.05) {
    for (double y = -0.75; y <= 0.75; y += 0.05) {
      const Vec2 xy(x, y);
      Vec2 xd;
      TestType::distort(params.data(), xy.data(), xd.data());
      const UndistortResult r = undistort<TestType>(params.data(), xd);
      REQUIRE(r.converged);
      CHECK((r.xy - xy).norm() <= 1e-14);
    }
  }
}

TEST_CASE("Camera<Fraser>: the formulas of docs/conventions.md, checked by hand", "[camera]") {
  const Camera<FraserAffine> camera(1000.0, 500.0, 400.0, 1000, 800,
                                    {0.1, 0.01, 0.001, 0.002, -0.003, 2.0, -1.0});
  const double x = 0.3;
  const double y = -0.2;
  const double r2 = x * x + y * y;
  const double radial = 1.0 + 0.1 * r2 + 0.01 * r2 * r2 + 0.001 * r2 * r2 * r2;
  const double xd = x * radial + 0.002 * (r2 + 2 * x * x) + 2 * -0.003 * x * y;
  const double yd = y * radial + -0.003 * (r2 + 2 * y * y) + 2 * 0.002 * x * y;
  const Vec2 expected(500.0 + 1000.0 * xd + 2.0 * xd - 1.0 * yd, 400.0 + 1000.0 * yd);
  const Vec2 got = camera.pixel_from_normalized(Vec2(x, y));
  CHECK((got - expected).norm() <= 1e-12);
  const std::optional<Vec2> projected = camera.project(Vec3(3 * x, 3 * y, 3.0));
  REQUIRE(projected);
  CHECK((*projected - expected).norm() <= 1e-12);
  // The static one-block form used by cost functors gives the same pixel.
  const auto intrinsics = camera.intrinsics();
  const double point[3] = {x, y, 1.0};
  double pixel[2];
  Camera<FraserAffine>::project(intrinsics.data(), point, pixel);
  CHECK((Vec2(pixel[0], pixel[1]) - expected).norm() <= 1e-12);
  CHECK(FraserAffine::param_names()[5] == "B1");
}

TEST_CASE("Camera<FraserAffine>: absurd distortion is reported, never silently wrong",
          "[camera]") {
  // K1 = -1.5 folds the radial polynomial at r = 0.47: distorted radii above ~0.31 have no
  // preimage on the branch that contains the principal point.
  const Camera<FraserAffine> camera(kFocal, kCx, kCy, kSize, kSize,
                                    {-1.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0});
  const Vec2 corner(-0.5, -0.5);
  const UnprojectResult r = camera.unproject_detailed(corner);
  // Newton may find a mirrored preimage beyond the fold (residual ~0): it must still be refused.
  CHECK_FALSE(r.converged);
  CHECK_FALSE(camera.unproject(corner));
  CHECK_FALSE(camera.normalized_from_pixel(corner));
  // The centre still unprojects.
  CHECK(camera.unproject(Vec2(kCx, kCy)));
  // A point beyond the fold would land back inside the image: project refuses it.
  CHECK_FALSE(camera.distortion_valid_at(Vec2(0.6, 0.0)));
  CHECK_FALSE(camera.project(Vec3(0.6, 0.0, 1.0)));
  CHECK(camera.project(Vec3(0.3, 0.0, 1.0)));
  // Non-finite input is a data failure, not an exception.
  CHECK_FALSE(camera.unproject(Vec2(std::numeric_limits<double>::quiet_NaN(), 0.0)));
}

TEST_CASE("Camera<Fraser>: points behind or on the centre plane do not project", "[camera]") {
  const Camera<Fraser> camera = aerial_camera<Fraser>(0.1);
  CHECK_FALSE(camera.project(Vec3(0.1, 0.1, -1.0)));
  CHECK_FALSE(camera.project(Vec3(0.1, 0.1, 0.0)));
  CHECK_FALSE(camera.project(Vec3(std::numeric_limits<double>::infinity(), 0.0, 1.0)));
  CHECK(camera.project(Vec3(0.1, 0.1, 1.0)));
}

TEST_CASE("Camera: bad arguments throw diachron::Error", "[camera]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(Camera<NoDistortion>(0.0, 0.0, 0.0, 10, 10), Error);
  CHECK_THROWS_AS(Camera<NoDistortion>(-5.0, 0.0, 0.0, 10, 10), Error);
  CHECK_THROWS_AS(Camera<NoDistortion>(nan, 0.0, 0.0, 10, 10), Error);
  CHECK_THROWS_AS(Camera<NoDistortion>(std::numeric_limits<double>::infinity(), 0, 0, 10, 10),
                  Error);
  CHECK_THROWS_AS(Camera<NoDistortion>(100.0, nan, 0.0, 10, 10), Error);
  CHECK_THROWS_AS(Camera<NoDistortion>(100.0, 0.0, 0.0, 0, 10), Error);
  CHECK_THROWS_AS(Camera<NoDistortion>(100.0, 0.0, 0.0, 10, -1), Error);
  CHECK_THROWS_AS(Camera<Fraser>(100.0, 0.0, 0.0, 10, 10, {nan, 0, 0, 0, 0}), Error);
  // B1 = -2 f mirrors the x axis: not a camera.
  CHECK_THROWS_AS(Camera<FraserAffine>(100.0, 0.0, 0.0, 10, 10, {0, 0, 0, 0, 0, -200.0, 0}),
                  Error);
  Camera<Fraser> camera(100.0, 5.0, 5.0, 10, 10);
  CHECK_THROWS_AS(camera.set_focal(0.0), Error);
  CHECK(camera.focal() == 100.0);  // a refused setter leaves the camera unchanged
  CHECK_THROWS_AS(camera.set_params({0, nan, 0, 0, 0}), Error);
  CHECK(camera.params()[1] == 0.0);
  CHECK_THROWS_AS(camera.set_principal_point(nan, 1.0), Error);
  UnprojectOptions bad;
  bad.tolerance_px = 0.0;
  CHECK_THROWS_AS(camera.unproject_detailed(Vec2(1.0, 1.0), bad), Error);
}

TEST_CASE("Camera: in_image includes the outer edges of the border pixels", "[camera]") {
  const Camera<NoDistortion> camera(100.0, 4.5, 2.5, 10, 6);
  CHECK(camera.in_image(Vec2(-0.5, -0.5)));
  CHECK(camera.in_image(Vec2(9.5, 5.5)));
  CHECK_FALSE(camera.in_image(Vec2(9.51, 3.0)));
  CHECK_FALSE(camera.in_image(Vec2(3.0, -0.51)));
}

TEST_CASE("Camera: intrinsics block round trip", "[camera]") {
  const Camera<FraserAffine> camera = aerial_camera<FraserAffine>(0.1);
  const auto block = camera.intrinsics();
  const Camera<FraserAffine> again = Camera<FraserAffine>::from_intrinsics(block, kSize, kSize);
  CHECK(again.intrinsics() == block);
  const Camera<FraserAffine> widened = as_fraser_affine(aerial_camera<Fraser>(0.1));
  const Vec2 xy(0.31, -0.44);
  CHECK((widened.pixel_from_normalized(xy) -
         aerial_camera<Fraser>(0.1).pixel_from_normalized(xy))
            .norm() == 0.0);
}

TEMPLATE_TEST_CASE("Camera: float instantiation agrees with double", "[camera]", NoDistortion,
                   RadialK3, Fraser, FraserAffine) {
  const Camera<TestType> camera = aerial_camera<TestType>(0.1);
  const auto block = camera.intrinsics();
  std::array<float, Camera<TestType>::kNumIntrinsics> block_f{};
  for (std::size_t i = 0; i < block.size(); ++i) block_f[i] = static_cast<float>(block[i]);
  const double point[3] = {120.0, -80.0, 250.0};
  const float point_f[3] = {120.0f, -80.0f, 250.0f};
  double pixel[2];
  float pixel_f[2];
  Camera<TestType>::project(block.data(), point, pixel);
  Camera<TestType>::project(block_f.data(), point_f, pixel_f);
  CHECK(pixel_f[0] == Approx(pixel[0]).epsilon(1e-5));
  CHECK(pixel_f[1] == Approx(pixel[1]).epsilon(1e-5));
}

#ifdef DIACHRON_TEST_HAVE_JET
TEMPLATE_TEST_CASE("Camera: Jet derivatives match central differences", "[camera]", NoDistortion,
                   RadialK3, Fraser, FraserAffine) {
  using Cam = Camera<TestType>;
  constexpr int kN = 3 + Cam::kNumIntrinsics;  // point, then intrinsics
  using Jet = ceres::Jet<double, kN>;
  const Cam camera = aerial_camera<TestType>(-0.1);
  const auto block = camera.intrinsics();
  const std::array<double, 3> point = {310.0, -270.0, 560.0};

  std::array<Jet, 3> point_j;
  std::array<Jet, Cam::kNumIntrinsics> block_j;
  for (int i = 0; i < 3; ++i) point_j[i] = Jet(point[i], i);
  for (int i = 0; i < Cam::kNumIntrinsics; ++i) block_j[i] = Jet(block[i], 3 + i);
  Jet pixel_j[2];
  Cam::project(block_j.data(), point_j.data(), pixel_j);

  const auto evaluate = [&](int k, double delta) {
    std::array<double, 3> p = point;
    auto b = block;
    if (k < 3) {
      p[k] += delta;
    } else {
      b[k - 3] += delta;
    }
    double pixel[2];
    Cam::project(b.data(), p.data(), pixel);
    return Vec2(pixel[0], pixel[1]);
  };
  CHECK(pixel_j[0].a == evaluate(0, 0.0).x());
  CHECK(pixel_j[1].a == evaluate(0, 0.0).y());
  for (int k = 0; k < kN; ++k) {
    // Steps proportional to each variable's scale: px for f, cx, cy, B; 1 for K, P; the point.
    const double value = k < 3 ? point[k] : block[k - 3];
    const double h = 1e-6 * std::max(1.0, std::abs(value));
    const Vec2 numeric = (evaluate(k, h) - evaluate(k, -h)) / (2.0 * h);
    for (int c = 0; c < 2; ++c) {
      const double analytic = pixel_j[c].v[k];
      CAPTURE(k, c, analytic, numeric[c]);
      CHECK(analytic == Approx(numeric[c]).epsilon(1e-6).margin(1e-6));
    }
  }
}
#endif
