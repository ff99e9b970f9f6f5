// COLMAP OPENCV / FULL_OPENCV <-> Camera<FraserAffine>: exact cases, round trips, and fitted
// conversions whose reported error is checked against an independent measurement.

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <catch2/catch.hpp>

#include <Eigen/Core>

#include <diachron/camera/colmap_conversion.hpp>
#include <diachron/core/error.hpp>

using namespace diachron;

namespace {

constexpr double kColmapFocal = 15300.0;
constexpr int kColmapSize = 23000;

Camera<FraserAffine> aerial(double k3, double b1, double b2) {
  return Camera<FraserAffine>(kColmapFocal, 11511.8, 11492.4, kColmapSize, kColmapSize,
                              {-0.08, 0.02, k3, 1e-4, -8e-5, b1, b2});
}

// OpenCV's projection written from its documentation, independently of the library: COLMAP pixel
// convention (top-left pixel centre at 0.5).
Vec2 opencv_project(const ColmapFullOpenCv& c, const Vec2& xy) {
  const double x = xy.x();
  const double y = xy.y();
  const double r2 = x * x + y * y;
  const double r4 = r2 * r2;
  const double r6 = r4 * r2;
  const double radial = (1 + c.k1 * r2 + c.k2 * r4 + c.k3 * r6) / (1 + c.k4 * r2 + c.k5 * r4 + c.k6 * r6);
  const double xd = x * radial + 2 * c.p1 * x * y + c.p2 * (r2 + 2 * x * x);
  const double yd = y * radial + c.p1 * (r2 + 2 * y * y) + 2 * c.p2 * x * y;
  return Vec2(c.fx * xd + c.cx, c.fy * yd + c.cy);
}

ColmapFullOpenCv as_full(const ColmapOpenCv& c) {
  std::vector<double> p = c.params();
  p.insert(p.end(), {0.0, 0.0, 0.0, 0.0});
  return ColmapFullOpenCv::from_params(c.width, c.height, p);
}

// Largest pixel distance between a camera and a COLMAP model over a 31 x 31 grid of the image,
// measured through the camera's rays.
double max_distance(const Camera<FraserAffine>& camera, const ColmapFullOpenCv& colmap) {
  double worst = 0.0;
  for (int i = 0; i <= 30; ++i) {
    for (int k = 0; k <= 30; ++k) {
      const Vec2 pixel(-0.5 + kColmapSize * k / 30.0, -0.5 + kColmapSize * i / 30.0);
      const std::optional<Vec2> xy = camera.normalized_from_pixel(pixel);
      REQUIRE(xy);
      const Vec2 colmap_pixel = opencv_project(colmap, *xy) - Vec2(0.5, 0.5);
      worst = std::max(worst, (colmap_pixel - pixel).norm());
    }
  }
  return worst;
}

}  // namespace

TEST_CASE("colmap_conversion: OPENCV to camera is exact, with P swapped and the half pixel",
          "[camera]") {
  ColmapOpenCv colmap;
  colmap.width = kColmapSize;
  colmap.height = kColmapSize;
  colmap.fx = 15301.53;
  colmap.fy = 15300.0;
  colmap.cx = 11512.3;
  colmap.cy = 11492.9;
  colmap.k1 = -0.08;
  colmap.k2 = 0.02;
  colmap.p1 = -8e-5;
  colmap.p2 = 1e-4;
  const auto result = camera_from_colmap(colmap);
  CHECK(result.exact);
  const Camera<FraserAffine>& c = result.model;
  CHECK(c.focal() == 15300.0);
  CHECK(c.cx() == 11511.8);
  CHECK(c.cy() == 11492.4);
  CHECK(c.params()[0] == -0.08);
  CHECK(c.params()[1] == 0.02);
  CHECK(c.params()[2] == 0.0);
  CHECK(c.params()[3] == 1e-4);   // P1 = p2
  CHECK(c.params()[4] == -8e-5);  // P2 = p1
  CHECK(c.params()[5] == Approx(1.53).epsilon(1e-12));
  CHECK(c.params()[6] == 0.0);
  CHECK(result.num_samples == 21 * 21);
  CHECK(result.max_error_px <= 1e-9);
  CHECK(result.rms_error_px <= result.max_error_px);
  CHECK(max_distance(c, as_full(colmap)) <= 1e-9);
}

TEST_CASE("colmap_conversion: camera -> OPENCV -> camera round trip is exact", "[camera]") {
  const Camera<FraserAffine> camera = aerial(/*k3=*/0.0, /*b1=*/1.53, /*b2=*/0.0);
  const auto to = colmap_opencv_from_camera(camera);
  CHECK(to.exact);
  CHECK(to.max_error_px <= 1e-9);
  CHECK(to.model.cx == Approx(11512.3).epsilon(1e-15));
  CHECK(to.model.p2 == 1e-4);
  CHECK(max_distance(camera, as_full(to.model)) <= 1e-9);
  const auto back = camera_from_colmap(to.model);
  CHECK(back.exact);
  for (int i = 0; i < 7; ++i) {
    CHECK(back.model.params()[i] == Approx(camera.params()[i]).margin(1e-11));
  }
  CHECK(back.model.focal() == camera.focal());
  CHECK(back.model.cx() == Approx(camera.cx()).epsilon(1e-15));
  // Any built-in policy converts through its FraserAffine form.
  const Camera<Fraser> fraser(kColmapFocal, 11511.8, 11492.4, kColmapSize, kColmapSize, {-0.08, 0.02, 0.0, 1e-4, 0});
  CHECK(colmap_opencv_from_camera(fraser).exact);
}

TEST_CASE("colmap_conversion: K3 and shear make OPENCV a fit that reports its error",
          "[camera]") {
  const Camera<FraserAffine> camera = aerial(/*k3=*/-0.005, /*b1=*/1.53, /*b2=*/-0.77);
  const auto to = colmap_opencv_from_camera(camera);
  CHECK_FALSE(to.exact);
  CAPTURE(to.max_error_px, to.rms_error_px);
  CHECK(std::isfinite(to.max_error_px));
  CHECK(to.max_error_px > 1e-3);  // genuinely lossy
  CHECK(to.rms_error_px <= to.max_error_px);
  // The reported error is what an independent measurement on a finer grid finds (the grid
  // maximum can only grow slightly on a finer grid).
  const double measured = max_distance(camera, as_full(to.model));
  CHECK(measured == Approx(to.max_error_px).epsilon(0.25));
  // The fit beats the naive closed form (dropping K3 and B2).
  ColmapFullOpenCv naive = as_full(to.model);
  naive.fx = kColmapFocal + 1.53;
  naive.fy = kColmapFocal;
  naive.cx = 11512.3;
  naive.cy = 11492.9;
  naive.k1 = -0.08;
  naive.k2 = 0.02;
  naive.p1 = -8e-5;
  naive.p2 = 1e-4;
  CHECK(max_distance(camera, naive) > 10.0 * to.max_error_px);
}

TEST_CASE("colmap_conversion: FULL_OPENCV without k4..k6 is exact both ways", "[camera]") {
  const Camera<FraserAffine> camera = aerial(/*k3=*/-0.005, /*b1=*/1.53, /*b2=*/0.0);
  const auto to = colmap_full_opencv_from_camera(camera);
  CHECK(to.exact);
  CHECK(to.max_error_px <= 1e-9);
  CHECK(to.model.k3 == -0.005);
  CHECK(to.model.k4 == 0.0);
  CHECK(max_distance(camera, to.model) <= 1e-9);
  const auto back = camera_from_colmap(to.model);
  CHECK(back.exact);
  CHECK(back.max_error_px <= 1e-9);
  for (int i = 0; i < 7; ++i) {
    CHECK(back.model.params()[i] == Approx(camera.params()[i]).margin(1e-11));
  }
  const ColmapFullOpenCv parsed = ColmapFullOpenCv::from_params(kColmapSize, kColmapSize, to.model.params());
  CHECK(parsed.params() == to.model.params());
}

TEST_CASE("colmap_conversion: the rational FULL_OPENCV is fitted and its error reported",
          "[camera]") {
  ColmapFullOpenCv colmap;
  colmap.width = kColmapSize;
  colmap.height = kColmapSize;
  colmap.fx = 15301.53;
  colmap.fy = 15300.0;
  colmap.cx = 11512.3;
  colmap.cy = 11492.9;
  colmap.k1 = -0.08;
  colmap.k2 = 0.02;
  colmap.k3 = -0.005;
  colmap.k4 = 0.03;
  colmap.k5 = -0.01;
  colmap.k6 = 0.002;
  colmap.p1 = -8e-5;
  colmap.p2 = 1e-4;
  const auto result = camera_from_colmap(colmap);
  CHECK_FALSE(result.exact);
  CAPTURE(result.max_error_px, result.rms_error_px);
  CHECK(result.max_error_px > 1e-6);
  CHECK(result.max_error_px < 5.0);
  CHECK(max_distance(result.model, colmap) == Approx(result.max_error_px).epsilon(0.25));
}

TEST_CASE("colmap_conversion: shear cannot be FULL_OPENCV, the fit says by how much",
          "[camera]") {
  const Camera<FraserAffine> camera = aerial(/*k3=*/-0.005, /*b1=*/1.53, /*b2=*/-0.77);
  const auto to = colmap_full_opencv_from_camera(camera);
  CHECK_FALSE(to.exact);
  CAPTURE(to.max_error_px);
  CHECK(to.max_error_px > 1e-3);
  CHECK(to.max_error_px < 1.0);
  CHECK(max_distance(camera, to.model) == Approx(to.max_error_px).epsilon(0.25));
}

TEST_CASE("colmap_conversion: bad arguments throw diachron::Error", "[camera]") {
  CHECK_THROWS_AS(ColmapOpenCv::from_params(10, 10, {1.0, 2.0}), Error);
  CHECK_THROWS_AS(ColmapFullOpenCv::from_params(10, 10, std::vector<double>(8, 1.0)), Error);
  ColmapOpenCv c = ColmapOpenCv::from_params(100, 100, {100, 100, 50, 50, 0, 0, 0, 0});
  CHECK(camera_from_colmap(c).exact);
  c.fx = -100.0;
  CHECK_THROWS_AS(camera_from_colmap(c), Error);
  c.fx = 100.0;
  c.k1 = std::nan("");
  CHECK_THROWS_AS(camera_from_colmap(c), Error);
  c.k1 = 0.0;
  c.width = 0;
  CHECK_THROWS_AS(camera_from_colmap(c), Error);
  ConversionOptions options;
  options.grid_points_per_side = 1;
  CHECK_THROWS_AS(colmap_opencv_from_camera(aerial(0, 0, 0), options), Error);
}
