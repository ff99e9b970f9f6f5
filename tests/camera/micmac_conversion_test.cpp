// MicMac pixel-space Fraser <-> Camera<FraserAffine>: exact case, round trips, and fitted
// conversions (affinity on ideal offsets, CDist != PP) whose reported error is checked against an
// independent measurement.

#include <algorithm>
#include <cmath>
#include <optional>

#include <catch2/catch.hpp>

#include <Eigen/Core>

#include <diachron/camera/micmac_conversion.hpp>
#include <diachron/core/error.hpp>

using namespace diachron;

namespace {

constexpr double kF = 15300.0;
constexpr int kMicmacSize = 23000;

// A FraserBasic calibration (CDist = PP) equivalent to K1 = -0.08, K2 = 0.02, K3 = -0.005,
// P1 = 1e-4, P2 = -8e-5 in normalised units.
MicmacFraser fraser_basic() {
  MicmacFraser m;
  m.focal = kF;
  m.principal_point = Vec2(11511.8, 11492.4);
  m.distortion_centre = m.principal_point;
  m.r3 = -0.08 / (kF * kF);
  m.r5 = 0.02 / std::pow(kF, 4);
  m.r7 = -0.005 / std::pow(kF, 6);
  m.p1 = 1e-4 / kF;
  m.p2 = -8e-5 / kF;
  m.width = kMicmacSize;
  m.height = kMicmacSize;
  return m;
}

// MicMac's Direct distortion written out from the reference notes, independently of the library.
Vec2 micmac_project(const MicmacFraser& m, const Vec2& xy) {
  const double ux = m.principal_point.x() + m.focal * xy.x() - m.distortion_centre.x();
  const double uy = m.principal_point.y() + m.focal * xy.y() - m.distortion_centre.y();
  const double r2 = ux * ux + uy * uy;
  const double radial = 1 + m.r3 * r2 + m.r5 * r2 * r2 + m.r7 * r2 * r2 * r2;
  return Vec2(m.distortion_centre.x() + ux * radial + m.p1 * (2 * ux * ux + r2) +
                  2 * m.p2 * ux * uy + m.b1 * ux + m.b2 * uy,
              m.distortion_centre.y() + uy * radial + m.p2 * (2 * uy * uy + r2) +
                  2 * m.p1 * ux * uy);
}

double max_distance(const Camera<FraserAffine>& camera, const MicmacFraser& micmac) {
  double worst = 0.0;
  for (int i = 0; i <= 30; ++i) {
    for (int k = 0; k <= 30; ++k) {
      const Vec2 pixel(-0.5 + kMicmacSize * k / 30.0, -0.5 + kMicmacSize * i / 30.0);
      const std::optional<Vec2> xy = camera.normalized_from_pixel(pixel);
      REQUIRE(xy);
      worst = std::max(worst, (micmac_project(micmac, *xy) - pixel).norm());
    }
  }
  return worst;
}

}  // namespace

TEST_CASE("micmac_conversion: FraserBasic without affinity is exact", "[camera]") {
  const MicmacFraser micmac = fraser_basic();
  const auto result = camera_from_micmac(micmac);
  CHECK(result.exact);
  CHECK(result.max_error_px <= 1e-9);
  const Camera<FraserAffine>& c = result.model;
  CHECK(c.focal() == kF);
  CHECK(c.cx() == 11511.8);
  CHECK(c.cy() == 11492.4);
  CHECK(c.params()[0] == Approx(-0.08).epsilon(1e-14));
  CHECK(c.params()[1] == Approx(0.02).epsilon(1e-14));
  CHECK(c.params()[2] == Approx(-0.005).epsilon(1e-14));
  CHECK(c.params()[3] == Approx(1e-4).epsilon(1e-14));
  CHECK(c.params()[4] == Approx(-8e-5).epsilon(1e-14));
  CHECK(c.params()[5] == 0.0);
  CHECK(c.params()[6] == 0.0);
  CHECK(max_distance(c, micmac) <= 1e-9);
  // The pixel-origin shift moves only the principal point.
  const auto shifted = camera_from_micmac(micmac, {}, 0.5);
  CHECK(shifted.model.cx() == Approx(11511.3).epsilon(1e-15));
  CHECK(shifted.max_error_px <= 1e-9);
}

TEST_CASE("micmac_conversion: camera -> MicMac -> camera round trip is exact", "[camera]") {
  const Camera<Fraser> camera(kF, 11511.8, 11492.4, kMicmacSize, kMicmacSize,
                              {-0.08, 0.02, -0.005, 1e-4, -8e-5});
  const auto to = micmac_from_camera(camera);
  CHECK(to.exact);
  CHECK(to.max_error_px <= 1e-9);
  CHECK(to.model.distortion_centre == to.model.principal_point);
  CHECK(to.model.r3 == Approx(-0.08 / (kF * kF)).epsilon(1e-14));
  CHECK(to.model.p1 == Approx(1e-4 / kF).epsilon(1e-14));
  CHECK(max_distance(as_fraser_affine(camera), to.model) <= 1e-9);
  const auto back = camera_from_micmac(to.model);
  CHECK(back.exact);
  for (int i = 0; i < 5; ++i) {
    CHECK(back.model.params()[i] == Approx(camera.params()[i]).epsilon(1e-13));
  }
}

TEST_CASE("micmac_conversion: affinity on ideal offsets is fitted and its error reported",
          "[camera]") {
  MicmacFraser micmac = fraser_basic();
  micmac.b1 = 1e-4;
  micmac.b2 = -5e-5;
  const auto result = camera_from_micmac(micmac);
  CHECK_FALSE(result.exact);
  CAPTURE(result.max_error_px, result.rms_error_px);
  // The forms differ by B1 (x' - x) (1.5 px x ~0.1 at the corners); the fit leaves ~0.06 px.
  CHECK(result.max_error_px < 0.1);
  CHECK(max_distance(result.model, micmac) == Approx(result.max_error_px).epsilon(0.25));
  CHECK(result.model.params()[5] == Approx(1e-4 * kF).epsilon(0.05));

  // And back: a camera with B1, B2 becomes MicMac by a fit.
  const auto back = micmac_from_camera(result.model);
  CHECK_FALSE(back.exact);
  CAPTURE(back.max_error_px);
  CHECK(back.max_error_px < 0.1);
  CHECK(max_distance(result.model, back.model) == Approx(back.max_error_px).epsilon(0.25));
  CHECK(back.model.b1 == Approx(micmac.b1).epsilon(0.05));
}

TEST_CASE("micmac_conversion: a distortion centre off the principal point is fitted",
          "[camera]") {
  MicmacFraser micmac = fraser_basic();
  micmac.distortion_centre += Vec2(40.0, -25.0);
  const auto result = camera_from_micmac(micmac);
  CHECK_FALSE(result.exact);
  CAPTURE(result.max_error_px, result.rms_error_px);
  CHECK(std::isfinite(result.max_error_px));
  CHECK(max_distance(result.model, micmac) == Approx(result.max_error_px).epsilon(0.25));
}

TEST_CASE("micmac_conversion: bad arguments throw diachron::Error", "[camera]") {
  MicmacFraser micmac = fraser_basic();
  micmac.focal = 0.0;
  CHECK_THROWS_AS(camera_from_micmac(micmac), Error);
  micmac = fraser_basic();
  micmac.r5 = std::nan("");
  CHECK_THROWS_AS(camera_from_micmac(micmac), Error);
  micmac = fraser_basic();
  micmac.height = 0;
  CHECK_THROWS_AS(camera_from_micmac(micmac), Error);
  CHECK_THROWS_AS(camera_from_micmac(fraser_basic(), {}, std::nan("")), Error);
}
