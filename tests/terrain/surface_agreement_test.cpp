#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/eval/coregistration_case.hpp>
#include <diachron/terrain/surface_agreement.hpp>

namespace {

using diachron::Dsm;
using diachron::GeoTransform;
using diachron::Helmert3;
using diachron::Raster;

// Hills of several sizes on a 5 m grid, plus white noise of `sigma` metres (0: none).
Dsm noisy_hills(int w, int h, double sigma, std::uint64_t seed) {
  diachron::RandomStream rng(seed);
  Raster<float> z(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double v = 600.0 + 40.0 * std::sin(0.05 * x + 0.3) * std::cos(0.04 * y) + 12.0 * std::sin(0.13 * x - 0.09 * y) +
                       5.0 * std::cos(0.21 * y + 0.07 * x);
      z(x, y) = static_cast<float>(v + (sigma > 0.0 ? rng.normal(0.0, sigma) : 0.0));
    }
  return Dsm(std::move(z), GeoTransform::north_up(500000.0, 5100000.0, 5.0));
}

Dsm tilted_plane(int w, int h) {
  Raster<float> z(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) z(x, y) = static_cast<float>(100.0 + 0.2 * x - 0.1 * y);
  return Dsm(std::move(z), GeoTransform::north_up(0.0, 0.0, 1.0));
}

}  // namespace

TEST_CASE("dsm_cell_noise: 0 on a plane, the sigma of white noise on a smooth surface", "[terrain]") {
  CHECK(diachron::dsm_cell_noise(tilted_plane(120, 90)) < 1e-3);
  for (double sigma : {0.5, 2.0}) {
    const double noise = diachron::dsm_cell_noise(noisy_hills(300, 240, sigma, 3));
    INFO("sigma " << sigma << ", measured " << noise);
    // The smooth hills add their curvature (about 0.05 m here) to the noise.
    CHECK(noise == Approx(sigma).epsilon(0.08));
  }
  // Too few cells with four valid neighbours: NaN, not a figure from a handful.
  CHECK(std::isnan(diachron::dsm_cell_noise(tilted_plane(12, 12))));
  diachron::SurfaceAgreementOptions bad;
  bad.max_points = 10;
  CHECK_THROWS_AS(diachron::dsm_cell_noise(tilted_plane(50, 50), bad), diachron::Error);
}

TEST_CASE("surface_agreement: about the noise at the truth, the relief elsewhere, nothing without overlap",
          "[terrain]") {
  diachron::CoregistrationCaseOptions case_options;
  case_options.overlap_min = case_options.overlap_max = 0.7;
  case_options.hole_fraction = 0.05;
  case_options.noise_sigma_cells = 0.1;  // 0.5 m on the 5 m world grid, in each frame
  const Dsm world = noisy_hills(400, 320, 0.0, 1);
  const diachron::CoregistrationCase c = diachron::make_coregistration_case(world, world, case_options, 21);
  const Helmert3& truth = c.secondary_from_master;

  const diachron::SurfaceAgreement right = diachron::surface_agreement(c.master, c.secondary, truth);
  INFO("misfit " << right.misfit << ", noises " << right.master_noise << ", " << right.secondary_noise);
  REQUIRE(right.valid);
  CHECK(right.points > 1000);
  // Both noises are the case's 0.5 m (the master's brought to secondary units by the scale), and
  // the misfit is theirs combined, with what bilinear interpolation of the secondary adds.
  CHECK(right.secondary_noise == Approx(0.5).epsilon(0.15));
  CHECK(right.master_noise == Approx(0.5).epsilon(0.15));
  CHECK(right.noise_ratio > 0.7);
  CHECK(right.noise_ratio < 1.6);

  // The oracle: the same misfit from every master cell (no sampling grid), by brute force.
  std::vector<double> residuals;
  for (int y = 0; y < c.master.height(); ++y)
    for (int x = 0; x < c.master.width(); ++x) {
      if (!c.master.valid(x, y)) continue;
      const Eigen::Vector2d w = c.master.pixel_to_world(Eigen::Vector2d(x, y));
      const Eigen::Vector3d m = truth(Eigen::Vector3d(w.x(), w.y(), c.master.heights()(x, y)));
      const double z2 = c.secondary.height_at(m.x(), m.y());
      if (std::isfinite(z2)) residuals.push_back(z2 - m.z());
    }
  std::sort(residuals.begin(), residuals.end());
  const double median = residuals[residuals.size() / 2];
  for (double& r : residuals) r = std::abs(r - median);
  std::sort(residuals.begin(), residuals.end());
  CHECK(right.misfit == Approx(1.4826 * residuals[residuals.size() / 2]).epsilon(0.1));

  // Ten cells off: the misfit is the relief's, many times the noise.
  Helmert3 off = truth;
  off.translation += Eigen::Vector3d(50.0, -30.0, 0.0) * truth.scale;
  const diachron::SurfaceAgreement wrong = diachron::surface_agreement(c.master, c.secondary, off);
  REQUIRE(wrong.valid);
  CHECK(wrong.noise_ratio > 5.0);

  // Moved away from the secondary: not valid, and a ratio that passes no threshold.
  Helmert3 away = truth;
  away.translation.x() += 1e7;
  const diachron::SurfaceAgreement none = diachron::surface_agreement(c.master, c.secondary, away);
  CHECK_FALSE(none.valid);
  CHECK(none.points == 0);
  CHECK(std::isinf(none.noise_ratio));

  Helmert3 broken = truth;
  broken.scale = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(diachron::surface_agreement(c.master, c.secondary, broken), diachron::Error);
  CHECK_THROWS_AS(diachron::surface_agreement(Dsm(), c.secondary, truth), diachron::Error);
}
