// Tests of the Transfer concept, DsmTransfer (two pinhole frames over a plane and a slope, a
// Helmert in between: analytic answers to 1e-6 px), DsmLift and MapTransfer.
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>

#include <catch2/catch.hpp>
#include <Eigen/Geometry>

#include <diachron/core/types.hpp>
#include <diachron/terrain/transfer.hpp>

#include "terrain/pinhole_test_frame.hpp"

using diachron::Dsm;
using diachron::GeoTransform;
using diachron::Raster;
using diachron::test::make_frame;
using diachron::test::PinholeFrame;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {

// Plane Z = z0 + gx X + gy Y with dyadic coefficients on a grid of odd-metre pixel centres, so that
// every float sample is exact and the bilinear DSM *is* the plane.
struct Plane {
  double z0, gx, gy;
  double operator()(double X, double Y) const { return z0 + gx * X + gy * Y; }
};

Dsm plane_dsm(const Plane& p) {
  const GeoTransform gt = GeoTransform::north_up(-1000.0, 2000.0, 2.0);
  Raster<float> z(1500, 1500);
  for (int y = 0; y < z.height(); ++y)
    for (int x = 0; x < z.width(); ++x) {
      const Vector2d w = gt.pixel_to_world({x, y});
      z(x, y) = static_cast<float>(p(w.x(), w.y()));
    }
  return Dsm(std::move(z), gt);
}

struct TestHelmert {
  double scale = 1.03;
  Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.07, Vector3d(0.1, -0.2, 1.0).normalized()).toRotationMatrix();
  Vector3d translation = Vector3d(12.0, -7.5, 4.0);
  Vector3d operator()(const Vector3d& p) const { return scale * rotation * p + translation; }
};

// Analytic: master ray meets the plane, then the Helmert, then the secondary projection.
std::optional<Vector2d> analytic(const PinholeFrame& m, const PinholeFrame& s, const Plane& p,
                                 const TestHelmert& h, const Vector2d& px) {
  const auto ray = m.ray(px);
  const Vector3d n(-p.gx, -p.gy, 1.0);
  const double t = -(ray->origin.z() - p(ray->origin.x(), ray->origin.y())) / n.dot(ray->direction);
  return s.project(h(ray->at(t)));
}

struct NotConst {
  std::optional<Vector2d> operator()(const Vector2d& p) { return p; }
};
struct WrongResult {
  Vector2d operator()(const Vector2d& p) const { return p; }
};

}  // namespace

TEST_CASE("Transfer: concept detection", "[terrain]") {
  using DsmT = diachron::DsmTransfer<PinholeFrame, PinholeFrame, TestHelmert>;
  STATIC_REQUIRE(diachron::is_transfer_v<DsmT>);
  STATIC_REQUIRE(diachron::check_transfer<DsmT>());
  const auto map = diachron::make_map_transfer([](const Vector2d& p) { return Vector2d(2.0 * p); });
  STATIC_REQUIRE(diachron::is_transfer_v<decltype(map)>);
  STATIC_REQUIRE_FALSE(diachron::is_transfer_v<NotConst>);
  STATIC_REQUIRE_FALSE(diachron::is_transfer_v<WrongResult>);
  STATIC_REQUIRE_FALSE(diachron::is_transfer_v<int>);
  STATIC_REQUIRE(diachron::has_frame_ray_v<PinholeFrame>);
  STATIC_REQUIRE(diachron::has_frame_project_v<PinholeFrame>);
  STATIC_REQUIRE_FALSE(diachron::has_frame_ray_v<int>);
  STATIC_REQUIRE(diachron::is_point_transform_v<TestHelmert>);
  STATIC_REQUIRE(diachron::is_point_transform_v<diachron::IdentityPointTransform>);
}

TEST_CASE("Transfer: DsmTransfer over a plane and a slope matches the analytic answer", "[terrain]") {
  const PinholeFrame master = make_frame(Vector3d(480.0, 520.0, 1500.0), 1000.0, 0.0, 0.0);
  // Epoch 2: oblique, turned, lower, somewhere else; its frame is the Helmert image of epoch 1.
  const PinholeFrame secondary = make_frame(Vector3d(700.0, 300.0, 1300.0), 1200.0, 0.6, 0.25);
  const TestHelmert helmert;
  for (const Plane& plane : {Plane{120.0, 0.0, 0.0}, Plane{100.0, 0.25, -0.125}, Plane{-50.0, 0.75, 0.5}}) {
    const Dsm dsm = plane_dsm(plane);
    const auto transfer = diachron::make_dsm_transfer(master, dsm, secondary, helmert);
    double worst = 0.0;
    int count = 0;
    for (double v = 0.0; v <= 1000.0; v += 83.3)
      for (double u = 0.0; u <= 1000.0; u += 71.9) {
        const Vector2d px(u, v);
        const auto expected = analytic(master, secondary, plane, helmert, px);
        const auto got = transfer(px);
        REQUIRE(expected);
        REQUIRE(got);
        worst = std::max(worst, (*got - *expected).norm());
        ++count;
        // The lift and the moved point agree with the analytic ones too.
        const auto p1 = transfer.master_point(px);
        REQUIRE(p1);
        CHECK(p1->z() == Approx(plane(p1->x(), p1->y())).margin(1e-6));
        CHECK((*transfer.secondary_point(px) - helmert(*p1)).norm() < 1e-9);
      }
    INFO("plane gx " << plane.gx);
    CHECK(worst < 1e-6);
    WARN("DsmTransfer, plane gx=" << plane.gx << ": worst error " << worst << " px over " << count << " pixels");
  }
}

TEST_CASE("Transfer: identity transform, misses and the separate lift", "[terrain]") {
  const Plane plane{10.0, 0.0, 0.0};
  const Dsm dsm = plane_dsm(plane);
  const PinholeFrame master = make_frame(Vector3d(500.0, 500.0, 1010.0));
  const PinholeFrame secondary = make_frame(Vector3d(500.0, 500.0, 510.0));
  // Same frame for both epochs: nadir over flat ground at 1000 m and 500 m, same centre: the
  // secondary sees the ground twice as large around the principal point.
  const diachron::DsmTransfer<PinholeFrame, PinholeFrame> transfer(master, dsm, secondary);
  const auto p = transfer(Vector2d(600.0, 450.0));
  REQUIRE(p);
  CHECK(p->x() == Approx(700.0).epsilon(1e-12));
  CHECK(p->y() == Approx(400.0).epsilon(1e-12));

  // A pixel whose ray leaves the DSM (an extreme off-axis pixel), and a non-finite pixel.
  CHECK_FALSE(transfer(Vector2d(-5000.0, 500.0)));
  CHECK_FALSE(transfer(Vector2d(std::nan(""), 500.0)));
  // A ground point behind the secondary camera.
  const PinholeFrame looking_up = [] {
    PinholeFrame f = make_frame(Vector3d(500.0, 500.0, 50.0));
    f.R = Eigen::Matrix3d(Eigen::AngleAxisd(diachron::kPi, Vector3d::UnitX())) * f.R;
    return f;
  }();
  CHECK_FALSE(diachron::make_dsm_transfer(master, dsm, looking_up)(Vector2d(500.0, 500.0)));

  // The lift on its own, with its reason on failure.
  const diachron::DsmLift<PinholeFrame> lift(master, dsm);
  const auto ground = lift(Vector2d(500.0, 500.0));
  REQUIRE(ground);
  CHECK((*ground - Vector3d(500.0, 500.0, 10.0)).norm() < 1e-9);
  CHECK(lift.intersect(Vector2d(-5000.0, 500.0)).outcome == diachron::RayDsmOutcome::above_surface);
  CHECK(lift.intersect(Vector2d(std::nan(""), 500.0)).outcome == diachron::RayDsmOutcome::no_ray);
}

namespace {

// A frame that cannot unproject some pixels (x < 0), as a camera whose distortion inversion fails.
struct PartialFrame {
  PinholeFrame inner;
  std::optional<diachron::Ray3> ray(const Vector2d& px) const {
    if (px.x() < 0.0) return std::nullopt;
    return inner.ray(px);
  }
};

// Detection: is `make_dsm_transfer(frame, dsm-expression, frame)` well-formed?
template <class DsmExpr, class = void>
struct can_make_transfer : std::false_type {};
template <class DsmExpr>
struct can_make_transfer<DsmExpr, std::void_t<decltype(diachron::make_dsm_transfer(
                                      std::declval<PinholeFrame>(), std::declval<DsmExpr>(),
                                      std::declval<PinholeFrame>()))>> : std::true_type {};

}  // namespace

TEST_CASE("Transfer: a pixel that cannot be unprojected has its own reason", "[terrain]") {
  const Dsm dsm = plane_dsm(Plane{10.0, 0.0, 0.0});
  const diachron::DsmLift<PartialFrame> lift(PartialFrame{make_frame(Vector3d(500.0, 500.0, 1010.0))}, dsm);
  const diachron::RayDsmResult r = lift.intersect(Vector2d(-1.0, 500.0));
  CHECK_FALSE(r.success);
  CHECK(r.outcome == diachron::RayDsmOutcome::no_ray);
  CHECK(std::string(diachron::to_string(r.outcome)).find("unprojected") != std::string::npos);
  // A pixel with a ray that misses the grid is still `outside`-like, not no_ray.
  CHECK(lift.intersect(Vector2d(1.0e7, 500.0)).outcome != diachron::RayDsmOutcome::no_ray);
  CHECK(lift.intersect(Vector2d(500.0, 500.0)).success);
}

TEST_CASE("Transfer: a temporary DSM does not compile where the DSM is kept by pointer", "[terrain]") {
  // make_dsm_transfer(frame, read_geotiff_dsm("x.tif"), frame) used to compile and dangle.
  STATIC_REQUIRE(can_make_transfer<const Dsm&>::value);
  STATIC_REQUIRE(can_make_transfer<Dsm&>::value);
  STATIC_REQUIRE_FALSE(can_make_transfer<Dsm>::value);
  STATIC_REQUIRE_FALSE(can_make_transfer<Dsm&&>::value);
  STATIC_REQUIRE_FALSE(can_make_transfer<decltype(plane_dsm(Plane{10.0, 0.0, 0.0}))>::value);
  STATIC_REQUIRE(std::is_constructible_v<diachron::DsmLift<PinholeFrame>, PinholeFrame, const Dsm&>);
  STATIC_REQUIRE_FALSE(std::is_constructible_v<diachron::DsmLift<PinholeFrame>, PinholeFrame, Dsm>);
  STATIC_REQUIRE_FALSE(std::is_constructible_v<diachron::DsmLift<PinholeFrame>, PinholeFrame, const Dsm&&>);
  STATIC_REQUIRE(std::is_constructible_v<diachron::DsmTransfer<PinholeFrame, PinholeFrame>, PinholeFrame,
                                         const Dsm&, PinholeFrame>);
  STATIC_REQUIRE_FALSE(
      std::is_constructible_v<diachron::DsmTransfer<PinholeFrame, PinholeFrame>, PinholeFrame, Dsm, PinholeFrame>);
}

TEST_CASE("Transfer: MapTransfer wraps plain and optional 2D maps", "[terrain]") {
  const auto sim = diachron::make_map_transfer([](const Vector2d& p) {
    return Vector2d(Eigen::Rotation2Dd(0.3) * p * 1.5 + Vector2d(3.0, -4.0));
  });
  const auto q = sim(Vector2d(10.0, 0.0));
  REQUIRE(q);
  CHECK(q->x() == Approx(15.0 * std::cos(0.3) + 3.0));
  CHECK(q->y() == Approx(15.0 * std::sin(0.3) - 4.0));
  // A homography with its line at infinity at x = 2: non-finite images become nullopt.
  Eigen::Matrix3d H;
  H << 1, 0, 0, 0, 1, 0, -0.5, 0, 1;
  const auto homography = diachron::make_map_transfer([H](const Vector2d& p) {
    const Vector3d x = H * p.homogeneous();
    return Vector2d(x.head<2>() / x.z());
  });
  CHECK(homography(Vector2d(1.0, 1.0)));
  CHECK_FALSE(homography(Vector2d(2.0, 1.0)));
  // An optional-returning map passes its nullopt through.
  const auto partial = diachron::make_map_transfer([](const Vector2d& p) -> std::optional<Vector2d> {
    if (p.x() < 0.0) return std::nullopt;
    return p;
  });
  CHECK(partial(Vector2d(1.0, 2.0)));
  CHECK_FALSE(partial(Vector2d(-1.0, 2.0)));
}
