#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/terrain/surface_alignment.hpp>

namespace {

using diachron::Dsm;
using diachron::GeoTransform;
using diachron::Helmert3;
using diachron::Raster;

// Hills of many sizes and directions (metres): the slopes fix every parameter of a Helmert.
double hills(double x, double y) {
  double z = 800.0;
  const double k[][4] = {{0.011, 0.004, 0.3, 40.0}, {-0.006, 0.013, 1.1, 30.0}, {0.021, -0.017, 2.0, 12.0},
                         {0.031, 0.027, 0.7, 6.0},  {-0.043, 0.019, 2.9, 4.0},  {0.003, -0.002, 0.1, 90.0}};
  for (const auto& t : k) z += t[3] * std::sin(t[0] * x + t[1] * y + t[2]);
  return z;
}

// A north-up DSM of `surface` over [x0, x0 + w cell] x [y0 - h cell, y0].
Dsm sample(const std::function<double(double, double)>& surface, double x0, double y0, double cell, int w, int h) {
  const GeoTransform t = GeoTransform::north_up(x0, y0, cell);
  Raster<float> z(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector2d p = t.pixel_to_world(Eigen::Vector2d(x, y));
      z(x, y) = static_cast<float>(surface(p.x(), p.y()));
    }
  return Dsm(std::move(z), t);
}

// The master: the world surface seen in a frame X1 = truth^-1(X2), sampled on that frame's grid,
// with `change` added in world coordinates (ground that moved between the epochs).
Dsm master_of(const Helmert3& epoch2_from_epoch1, const std::function<double(double, double)>& world,
              const std::function<double(double, double)>& change, double x0, double y0, double cell, int w, int h) {
  // Each master cell (x1, y1) gets the height z1 at which its moved point lies on the surface:
  // H(x1, y1, z1).z = surface(H(x1, y1, z1).xy), solved by fixed-point steps on z1 (the frame's
  // tilt moves X/Y a little with z1).
  const Helmert3& H = epoch2_from_epoch1;
  const auto height = [&](double x1, double y1) {
    double z1 = 0.0;
    for (int i = 0; i < 50; ++i) {
      const Eigen::Vector3d x2 = H(Eigen::Vector3d(x1, y1, z1));
      const double z2 = world(x2.x(), x2.y()) + change(x2.x(), x2.y());
      z1 = ((z2 - H.translation.z()) / H.scale - H.rotation(2, 0) * x1 - H.rotation(2, 1) * y1) / H.rotation(2, 2);
    }
    return z1;
  };
  return sample(height, x0, y0, cell, w, h);
}

// Largest planimetric distance between two Helmerts over a grid of master points at height z.
double largest_gap(const Helmert3& a, const Helmert3& b, const Dsm& master) {
  double worst = 0.0;
  for (int y = 0; y < master.height(); y += 8)
    for (int x = 0; x < master.width(); x += 8) {
      if (!master.valid(x, y)) continue;
      const Eigen::Vector2d p = master.pixel_to_world(Eigen::Vector2d(x, y));
      const Eigen::Vector3d p3(p.x(), p.y(), master.heights()(x, y));
      worst = std::max(worst, (a(p3) - b(p3)).head<2>().norm());
    }
  return worst;
}

Helmert3 truth_helmert() {
  Helmert3 h;
  h.scale = 1.25;
  h.rotation = diachron::rotation_from_axis_angle<double>(Eigen::Vector3d(0.004, -0.003, 0.6));
  h.translation = Eigen::Vector3d(1000.0, 2000.0, 50.0);
  return h;
}

// The truth moved by a few cells: what a rough co-registration hands over.
Helmert3 perturbed(const Helmert3& h) {
  Helmert3 p = h;
  p.scale *= 1.004;
  p.rotation = diachron::rotation_from_axis_angle<double>(Eigen::Vector3d(0.001, 0.0, 0.006)) * h.rotation;
  p.translation += Eigen::Vector3d(5.0, -4.0, 3.0);
  return p;
}

// The master of the tests: 240 x 240 cells of 1.6 m (2 m on the ground after the truth's scale
// 1.25) whose frame's origin the truth maps near the secondary's middle, so that it falls inside.
Dsm master_window(const std::function<double(double, double)>& world,
                  const std::function<double(double, double)>& change) {
  const Helmert3 truth = truth_helmert();
  const Eigen::Vector3d corner = truth.inverse()(Eigen::Vector3d(500.0, 3500.0, 800.0));
  return master_of(truth, world, change, corner.x() - 150.0, corner.y() + 150.0, 1.6, 240, 240);
}

double no_change(double, double) { return 0.0; }

}  // namespace

TEST_CASE("surface alignment recovers a Helmert from a start a few cells off", "[terrain][surface_alignment]") {
  const Helmert3 truth = truth_helmert();
  const Dsm secondary = sample(hills, 0.0, 4000.0, 2.0, 800, 800);
  const Dsm master = master_window(hills, no_change);
  const Helmert3 start = perturbed(truth);
  REQUIRE(largest_gap(start, truth, master) > 5.0);

  const diachron::SurfaceAlignmentResult r = diachron::refine_surface_alignment(master, secondary, start);
  INFO(r.message);
  REQUIRE(r.accepted);
  CHECK(r.converged);
  CHECK(largest_gap(r.epoch2_from_epoch1, truth, master) < 0.05);  // metres: 0.025 cells
  CHECK(std::abs(r.epoch2_from_epoch1.translation.z() - truth.translation.z()) < 0.5);
  CHECK(r.sigma_after < r.sigma_before);
  CHECK(r.moved > 5.0);
  CHECK(r.points > 1000);
}

TEST_CASE("surface alignment leaves ground that changed out of the fit", "[terrain][surface_alignment]") {
  const Helmert3 truth = truth_helmert();
  const Dsm secondary = sample(hills, 0.0, 4000.0, 2.0, 800, 800);
  // A dome 40 m high (sigma 40 m: a tenth of the overlap within 2 sigma) grew between the epochs (master = before it).
  const auto dome = [](double x, double y) {
    const double d2 = (x - 560.0) * (x - 560.0) + (y - 3440.0) * (y - 3440.0);
    return -40.0 * std::exp(-d2 / (2.0 * 40.0 * 40.0));
  };
  const Dsm master = master_window(hills, dome);

  const diachron::SurfaceAlignmentResult r = diachron::refine_surface_alignment(master, secondary, perturbed(truth));
  INFO(r.message);
  REQUIRE(r.accepted);
  CHECK(largest_gap(r.epoch2_from_epoch1, truth, master) < 0.2);  // 0.1 cells
  CHECK(r.agreeing_after < 0.95);  // the dome does not agree, and is not made to

  // Plain least squares (a biweight bound so wide that nothing is left out) is pulled by the dome.
  diachron::SurfaceAlignmentOptions plain;
  plain.tukey_sigmas = 1e6;
  const diachron::SurfaceAlignmentResult p = diachron::refine_surface_alignment(master, secondary, perturbed(truth), plain);
  INFO(p.message << ", plain gap " << largest_gap(p.epoch2_from_epoch1, truth, master) << ", robust gap " << largest_gap(r.epoch2_from_epoch1, truth, master));
  CHECK(largest_gap(p.epoch2_from_epoch1, truth, master) > 4.0 * largest_gap(r.epoch2_from_epoch1, truth, master));
}

TEST_CASE("surface alignment refuses what the surfaces cannot fix", "[terrain][surface_alignment]") {
  const Helmert3 truth = truth_helmert();

  SECTION("flat ground") {
    const auto flat = [](double, double) { return 700.0; };
    const Dsm secondary = sample(flat, 0.0, 4000.0, 2.0, 800, 800);
    const Dsm master = master_window(flat, no_change);
    const diachron::SurfaceAlignmentResult r = diachron::refine_surface_alignment(master, secondary, perturbed(truth));
    CHECK_FALSE(r.accepted);
    CHECK(r.message.find("do not fix") != std::string::npos);
    CHECK(r.epoch2_from_epoch1.translation == perturbed(truth).translation);
  }
  SECTION("a move beyond the bound") {
    const Dsm secondary = sample(hills, 0.0, 4000.0, 2.0, 800, 800);
    const Dsm master = master_window(hills, no_change);
    diachron::SurfaceAlignmentOptions o;
    o.max_move_cells = 1.0;  // the start is 3 to 6 cells off
    const diachron::SurfaceAlignmentResult r =
        diachron::refine_surface_alignment(master, secondary, perturbed(truth), o);
    CHECK_FALSE(r.accepted);
    CHECK(r.message.find("moved the master by more than") != std::string::npos);
    CHECK(r.epoch2_from_epoch1.scale == perturbed(truth).scale);
  }
  SECTION("no overlap") {
    const Dsm secondary = sample(hills, 0.0, 4000.0, 2.0, 800, 800);
    const Dsm master = master_window(hills, no_change);
    Helmert3 away = truth;
    away.translation.x() += 1e5;
    const diachron::SurfaceAlignmentResult r = diachron::refine_surface_alignment(master, secondary, away);
    CHECK_FALSE(r.accepted);
    CHECK(r.message.find("land on the secondary") != std::string::npos);
  }
  SECTION("bad input") {
    const Dsm secondary = sample(hills, 0.0, 4000.0, 2.0, 100, 100);
    Helmert3 broken = truth;
    broken.scale = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_AS(diachron::refine_surface_alignment(secondary, secondary, broken), diachron::Error);
    diachron::SurfaceAlignmentOptions o;
    o.max_points = 10;
    CHECK_THROWS_AS(diachron::refine_surface_alignment(secondary, secondary, truth, o), diachron::Error);
    CHECK_THROWS_AS(diachron::refine_surface_alignment(Dsm(), secondary, truth), diachron::Error);
  }
}
