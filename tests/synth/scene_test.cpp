// Tests of the synthetic scene generator: determinism, self-consistency of the ground truth
// (check points, renderer, epoch DSMs and Helmerts, tie points, estimated orientations), image
// texture, epoch changes, real DEMs, option checks.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/synth/scene.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>
#ifdef DIACHRON_HAVE_GDAL
#include <diachron/io/geotiff.hpp>
#endif

#include "support/rasters.hpp"
#include "support/test_paths.hpp"

using namespace diachron;

namespace {

// A smaller scene than the default (2 x 2 images per epoch), for the tests that run several.
SceneOptions small_options(std::uint64_t seed) {
  SceneOptions o;
  o.seed = seed;
  for (EpochOptions& e : o.epochs) {
    e.columns = 2;
    e.tie_points = 200;
  }
  o.check_points = 60;
  return o;
}

// Smaller still, for tests that generate several scenes: one flight line of two images at half
// the size (same field of view). Keeps the sanitizer run of this file short.
SceneOptions tiny_options(std::uint64_t seed) {
  SceneOptions o = small_options(seed);
  for (EpochOptions& e : o.epochs) {
    e.rows = 1;
    e.image_width_px /= 2;
    e.image_height_px /= 2;
    e.focal_px /= 2.0;
    e.tie_points = 100;
  }
  o.check_points = 30;
  return o;
}

const Scene& small_scene() {
  static const Scene scene = generate_scene(small_options(3));
  return scene;
}

bool same_pose(const Pose& a, const Pose& b) {
  return a.cam_from_world_rotation() == b.cam_from_world_rotation() && a.centre() == b.centre();
}

void require_same_scene(const Scene& a, const Scene& b) {
  REQUIRE(a.epochs.size() == b.epochs.size());
  for (std::size_t e = 0; e < a.epochs.size(); ++e) {
    const SyntheticEpoch& x = a.epochs[e];
    const SyntheticEpoch& y = b.epochs[e];
    REQUIRE(x.images.size() == y.images.size());
    for (std::size_t i = 0; i < x.images.size(); ++i) {
      CHECK(std::equal(x.images[i].pixels.begin(), x.images[i].pixels.end(), y.images[i].pixels.begin()));
      CHECK(same_pose(x.images[i].pose_world, y.images[i].pose_world));
      CHECK(same_pose(x.images[i].estimated_pose, y.images[i].estimated_pose));
    }
    CHECK(diachron::test::same_values(x.dsm.heights(), y.dsm.heights()));
    CHECK(diachron::test::same_values(x.true_surface.heights(), y.true_surface.heights()));
    CHECK(x.world_from_epoch.matrix() == y.world_from_epoch.matrix());
    REQUIRE(x.tie_points.size() == y.tie_points.size());
    for (std::size_t k = 0; k < x.tie_points.size(); ++k) {
      CHECK(x.tie_points[k].world == y.tie_points[k].world);
      REQUIRE(x.tie_points[k].observations.size() == y.tie_points[k].observations.size());
      for (std::size_t o = 0; o < x.tie_points[k].observations.size(); ++o)
        CHECK(x.tie_points[k].observations[o].pixel == y.tie_points[k].observations[o].pixel);
    }
  }
  REQUIRE(a.check_points.size() == b.check_points.size());
  for (std::size_t k = 0; k < a.check_points.size(); ++k) CHECK(a.check_points[k].world == b.check_points[k].world);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

TEST_CASE("the default scene: two epochs of 2 x 3 images with truth", "[synth]") {
  SceneOptions options;
  options.threads = 1;
  const auto t0 = std::chrono::steady_clock::now();
  const Scene scene = generate_scene(options);
  WARN("default scene (2 epochs x 6 images of 400 x 300 px) generated in " << seconds_since(t0)
                                                                           << " s on one thread");
  REQUIRE(scene.epochs.size() == 2);
  for (const SyntheticEpoch& epoch : scene.epochs) {
    CHECK(epoch.images.size() == 6);
    CHECK(epoch.tie_points.size() > 150);
    CHECK(epoch.dsm.statistics().count > 1000);
  }
  CHECK(scene.check_points.size() == 100);
  // The epochs' frames are arbitrary: a real rotation, scale and shift between them.
  const Helmert3 h = scene.epoch2_from_epoch1();
  CHECK(std::abs(h.scale - 1.0) > 1e-3);
  CHECK(rotation_angle(h.rotation) > 1e-2);
}

TEST_CASE("generate_scene is deterministic in the seed, whatever the threads", "[synth]") {
  SceneOptions one = tiny_options(11);
  one.threads = 1;
  SceneOptions two = tiny_options(11);
  two.threads = 2;
  const Scene a = generate_scene(one);
  const Scene b = generate_scene(two);
  require_same_scene(a, b);

  const Scene c = generate_scene(tiny_options(12));
  CHECK_FALSE(std::equal(a.epochs[0].images[0].pixels.begin(), a.epochs[0].images[0].pixels.end(),
                         c.epochs[0].images[0].pixels.begin()));
  CHECK(a.epochs[0].world_from_epoch.matrix() != c.epochs[0].world_from_epoch.matrix());
  CHECK(a.check_points.front().world != c.check_points.front().world);
}

TEST_CASE("check points: the ray of each true pixel meets the true surface at the point", "[synth]") {
  const Scene& scene = small_scene();
  REQUIRE(scene.check_points.size() >= 30);
  double worst_3d = 0.0, worst_px = 0.0;
  for (const CheckPoint& cp : scene.check_points) {
    std::vector<bool> seen(scene.epochs.size(), false);
    for (const CheckPoint::Observation& ob : cp.observations) {
      const SyntheticEpoch& epoch = scene.epochs[static_cast<std::size_t>(ob.epoch)];
      const Frame<FraserAffine> frame = epoch.world_frame(static_cast<std::size_t>(ob.image));
      seen[static_cast<std::size_t>(ob.epoch)] = true;
      REQUIRE(frame.in_image(ob.pixel));
      const std::optional<Ray3> ray = frame.ray(ob.pixel);
      REQUIRE(ray);
      const RayDsmResult hit = intersect_ray_dsm(epoch.true_surface, *ray);
      REQUIRE(hit.success);
      worst_3d = std::max(worst_3d, (hit.point - cp.world).norm());
      worst_px = std::max(worst_px, (*frame.project(cp.world) - ob.pixel).norm());
      // The same observation through the epoch frame and the true Helmert.
      const Vec3 in_epoch = epoch.epoch_from_world()(cp.world);
      CHECK((*epoch.epoch_frame(static_cast<std::size_t>(ob.image)).project(in_epoch) - ob.pixel).norm() < 1e-6);
    }
    for (bool s : seen) CHECK(s);  // seen in every epoch
  }
  INFO("worst 3D distance " << worst_3d << " m, worst reprojection " << worst_px << " px");
  CHECK(worst_3d < 1e-3);
  CHECK(worst_px < 1e-6);
}

TEST_CASE("the renderer puts the texture of a point where the camera projects it", "[synth]") {
  const Scene& scene = small_scene();
  const SyntheticEpoch& epoch = scene.epochs[0];
  const detail::SurfaceTracer tracer(epoch.true_surface);
  LookOptions flat;
  flat.shading = 0.0;
  int tested = 0;
  double worst = 0.0;
  for (std::size_t k = 0; k < scene.check_points.size() && tested < 8; ++k) {
    const CheckPoint& cp = scene.check_points[k];
    // Only where the surface is a plane around the point: texture painted on a roof next to it
    // would show displaced by the roof's parallax and bias the centroid.
    {
      const Dsm& s = epoch.true_surface;
      const Vec2 c = cp.world.head<2>();
      const double gx = (s.height_at(c.x() + 1.0, c.y()) - s.height_at(c.x() - 1.0, c.y())) / 2.0;
      const double gy = (s.height_at(c.x(), c.y() + 1.0) - s.height_at(c.x(), c.y() - 1.0)) / 2.0;
      double off_plane = 0.0;
      for (double dy = -10.0; dy <= 10.0; dy += 1.0)
        for (double dx = -10.0; dx <= 10.0; dx += 1.0) {
          const double z = s.height_at(c.x() + dx, c.y() + dy);
          off_plane = std::max(off_plane, std::abs(z - (cp.world.z() + gx * dx + gy * dy)));
        }
      if (!(off_plane < 0.3)) continue;
    }
    // A smooth bright spot (Gaussian, sigma 2 m, about 1 px) on black ground around the
    // check point: smooth so that the centroid of its pixel samples is not biased by aliasing.
    AlbedoMap mark;
    mark.transform = GeoTransform::north_up(cp.world.x() - 40.0, cp.world.y() + 40.0, 0.25);
    mark.values.resize(320, 320, 0.0f);
    for (int y = 0; y < 320; ++y)
      for (int x = 0; x < 320; ++x) {
        const double r2 = (mark.transform.pixel_to_world(Vec2(x, y)) - cp.world.head<2>()).squaredNorm();
        mark.values(x, y) = static_cast<float>(std::exp(-r2 / (2.0 * 2.0 * 2.0)));
      }
    for (const CheckPoint::Observation& ob : cp.observations) {
      if (ob.epoch != 0) continue;
      const Frame<FraserAffine> frame = epoch.world_frame(static_cast<std::size_t>(ob.image));
      if (ob.pixel.x() < 12 || ob.pixel.y() < 12 || ob.pixel.x() > frame.camera().width() - 13 ||
          ob.pixel.y() > frame.camera().height() - 13)
        continue;
      const Raster<float> radiance = render_radiance(frame, tracer, mark, flat, 1);
      double sum = 0.0;
      Vec2 centroid = Vec2::Zero();
      const int cx = static_cast<int>(std::lround(ob.pixel.x())), cy = static_cast<int>(std::lround(ob.pixel.y()));
      for (int y = cy - 7; y <= cy + 7; ++y)
        for (int x = cx - 7; x <= cx + 7; ++x) {
          sum += radiance(x, y);
          centroid += radiance(x, y) * Vec2(x, y);
        }
      REQUIRE(sum > 0.5);
      centroid /= sum;
      worst = std::max(worst, (centroid - ob.pixel).norm());
      ++tested;
      break;
    }
  }
  INFO("worst centroid offset " << worst << " px over " << tested << " marks");
  CHECK(tested >= 4);
  CHECK(worst < 0.05);
}

TEST_CASE("epoch DSMs map back onto the true surface through the true Helmert", "[synth]") {
  SceneOptions options = small_options(5);
  options.check_points = 0;
  for (EpochOptions& e : options.epochs) {
    e.tie_points = 0;
    e.dsm.ripple_m = 0.0;
    e.dsm.dome_m = 0.0;
  }
  options.epochs[0].dsm.noise_sigma_m = 0.0;
  options.epochs[0].dsm.hole_fraction = 0.0;
  options.epochs[1].dsm.noise_sigma_m = 0.5;
  const Scene scene = generate_scene(options);

  for (std::size_t e = 0; e < 2; ++e) {
    const SyntheticEpoch& epoch = scene.epochs[e];
    const Dsm& dsm = epoch.dsm;
    std::vector<double> residuals;
    for (int y = 0; y < dsm.height(); y += 2)
      for (int x = 0; x < dsm.width(); x += 2) {
        if (!dsm.valid(x, y)) continue;
        const Vec2 xy = dsm.pixel_to_world(Vec2(x, y));
        const Vec3 world = epoch.world_from_epoch(Vec3(xy.x(), xy.y(), dsm.heights()(x, y)));
        const double truth = epoch.true_surface.height_at(world.head<2>());
        if (std::isfinite(truth)) residuals.push_back(world.z() - truth);
      }
    REQUIRE(residuals.size() > 500);
    const double sigma = options.epochs[e].dsm.noise_sigma_m;
    // Float storage of the heights (epoch units up to ~1e3) limits exactness to ~1e-4 m.
    const double bound = sigma == 0.0 ? 2e-3 : 4.0 * sigma;
    std::size_t within = 0;
    double sum_sq = 0.0;
    for (double r : residuals)
      if (std::abs(r) <= bound) {
        ++within;
        sum_sq += r * r;
      }
    const double fraction = static_cast<double>(within) / static_cast<double>(residuals.size());
    const double rms = std::sqrt(sum_sq / static_cast<double>(std::max<std::size_t>(within, 1)));
    INFO("epoch " << e << ": " << residuals.size() << " cells, " << fraction << " within " << bound << " m, rms "
                  << rms << " m");
    // Only cells on building walls (steep one-cell slopes) move off the bound with a noisy tilt.
    CHECK(fraction > (sigma == 0.0 ? 0.999 : 0.97));
    if (sigma > 0.0) {
      CHECK(rms > 0.8 * sigma);
      CHECK(rms < 1.2 * sigma);
    }
  }
}

TEST_CASE("tie points reproject within their noise, in the world and epoch frames", "[synth]") {
  const Scene& scene = small_scene();
  for (std::size_t e = 0; e < scene.epochs.size(); ++e) {
    const SyntheticEpoch& epoch = scene.epochs[e];
    const double sigma = small_options(3).epochs[e].tie_noise_px;
    double sum_sq = 0.0, worst = 0.0, frame_gap = 0.0;
    std::size_t n = 0;
    for (const TiePoint& tie : epoch.tie_points) {
      REQUIRE(tie.observations.size() >= 2);
      CHECK((epoch.epoch_from_world()(tie.world) - tie.epoch).norm() < 1e-6 * (1.0 + tie.epoch.norm()));
      for (const ImageObservation& ob : tie.observations) {
        const auto i = static_cast<std::size_t>(ob.image);
        const Vec2 world_px = *epoch.world_frame(i).project(tie.world);
        const Vec2 epoch_px = *epoch.epoch_frame(i).project(tie.epoch);
        frame_gap = std::max(frame_gap, (world_px - epoch_px).norm());
        const Vec2 r = epoch_px - ob.pixel;
        sum_sq += r.squaredNorm();
        worst = std::max(worst, r.norm());
        n += 2;
      }
    }
    const double rms = std::sqrt(sum_sq / static_cast<double>(n));
    INFO("epoch " << e << ": " << epoch.tie_points.size() << " tracks, rms per coordinate " << rms << " px, worst "
                  << worst << " px, world/epoch frame gap " << frame_gap << " px");
    CHECK(rms > 0.8 * sigma);
    CHECK(rms < 1.2 * sigma);
    CHECK(worst < 6.0 * sigma);
    CHECK(frame_gap < 1e-6);
  }
}

TEST_CASE("estimated cameras differ from the truth and their poses fit the observations", "[synth]") {
  const Scene& scene = small_scene();
  for (const SyntheticEpoch& epoch : scene.epochs) {
    CHECK(epoch.estimated_camera.focal() != epoch.camera.focal());
    CHECK(epoch.estimated_camera.principal_point() != epoch.camera.principal_point());
    double sum_sq_est = 0.0, sum_sq_naive = 0.0;
    std::size_t n = 0;
    for (const TiePoint& tie : epoch.tie_points)
      for (const ImageObservation& ob : tie.observations) {
        const auto i = static_cast<std::size_t>(ob.image);
        const Vec2 truth = *epoch.epoch_frame(i).project(tie.epoch);
        const Vec2 fitted = *epoch.estimated_frame(i).project(tie.epoch);
        const Vec2 naive = *Frame<FraserAffine>(epoch.estimated_camera, epoch.images[i].pose_epoch).project(tie.epoch);
        sum_sq_est += (fitted - truth).squaredNorm();
        sum_sq_naive += (naive - truth).squaredNorm();
        ++n;
      }
    const double rms_est = std::sqrt(sum_sq_est / n), rms_naive = std::sqrt(sum_sq_naive / n);
    INFO(epoch.name << ": reprojection rms with the fitted poses " << rms_est << " px, with the true poses "
                    << rms_naive << " px");
    // The fitted pose absorbs what a pose can (focal length, principal point); the distortion
    // error that remains is what a bundle adjustment with self-calibration must remove.
    CHECK(rms_est < 0.5 * rms_naive);
    CHECK(rms_est < 3.0);
  }
}

TEST_CASE("images carry texture everywhere", "[synth]") {
  const Scene& scene = small_scene();
  for (const SyntheticEpoch& epoch : scene.epochs)
    for (const SyntheticImage& image : epoch.images) {
      const Raster<std::uint8_t>& p = image.pixels;
      double sum = 0.0, sum_sq = 0.0, gradient = 0.0;
      std::size_t black = 0;
      for (int y = 0; y + 1 < p.height(); ++y)
        for (int x = 0; x + 1 < p.width(); ++x) {
          const double v = p(x, y);
          sum += v;
          sum_sq += v * v;
          const double gx = p(x + 1, y) - v, gy = p(x, y + 1) - v;
          gradient += gx * gx + gy * gy;
          if (v == 0) ++black;
        }
      const double n = (p.width() - 1.0) * (p.height() - 1.0);
      const double mean = sum / n, sd = std::sqrt(sum_sq / n - mean * mean);
      INFO(image.name << ": mean " << mean << ", sd " << sd << ", mean squared gradient " << gradient / n
                      << ", black " << black);
      CHECK(sd > 15.0);
      CHECK(gradient / n > 40.0);
      CHECK(static_cast<double>(black) / n < 0.01);
    }
}

TEST_CASE("epochs differ: buildings, crops and radiometry change", "[synth]") {
  const Scene& scene = small_scene();
  std::size_t only_first = 0, only_second = 0;
  for (const Building& b : scene.landscape.buildings) {
    if (b.exists_in(0) && !b.exists_in(1)) ++only_first;
    if (!b.exists_in(0) && b.exists_in(1)) ++only_second;
  }
  CHECK(only_first > 0);
  CHECK(only_second > 0);
  const Raster<float>& s0 = scene.epochs[0].true_surface.heights();
  const Raster<float>& s1 = scene.epochs[1].true_surface.heights();
  std::size_t changed_cells = 0;
  for (std::size_t i = 0; i < s0.size(); ++i)
    if (std::abs(s0.data()[i] - s1.data()[i]) > 2.0f) ++changed_cells;
  CHECK(changed_cells > 100);
  const Raster<float>& a0 = scene.epochs[0].albedo.values;
  const Raster<float>& a1 = scene.epochs[1].albedo.values;
  std::size_t changed_texels = 0;
  for (std::size_t i = 0; i < a0.size(); ++i)
    if (std::abs(a0.data()[i] - a1.data()[i]) > 0.05f) ++changed_texels;
  CHECK(changed_texels > a0.size() / 20);
}

TEST_CASE("large world offsets keep the truth exact", "[synth]") {
  SceneOptions options = small_options(8);
  options.terrain.centre_x_m = 500000.0;
  options.terrain.centre_y_m = 5000000.0;
  options.check_points = 20;
  for (EpochOptions& e : options.epochs) e.tie_points = 60;
  const Scene scene = generate_scene(options);
  REQUIRE(scene.check_points.size() >= 10);
  for (const CheckPoint& cp : scene.check_points) {
    CHECK(cp.world.x() > 4e5);
    for (const CheckPoint::Observation& ob : cp.observations) {
      const SyntheticEpoch& epoch = scene.epochs[static_cast<std::size_t>(ob.epoch)];
      const Frame<FraserAffine> frame = epoch.world_frame(static_cast<std::size_t>(ob.image));
      const RayDsmResult hit = intersect_ray_dsm(epoch.true_surface, *frame.ray(ob.pixel));
      REQUIRE(hit.success);
      CHECK((hit.point - cp.world).norm() < 1e-3);
    }
  }
}

TEST_CASE("a real DEM as terrain", "[synth]") {
#ifndef DIACHRON_HAVE_GDAL
  WARN("skipped: built without GDAL, cannot read the DEM");
#else
  const auto path = test::data_file("mount-st-helens/1_msh00_83.tif");
  DIACHRON_REQUIRE_FILE_OR_SKIP(path, "mount-st-helens/1_msh00_83.tif");
  GeoTiffReadOptions read;
  read.assume_untagged_nodata = true;
  SceneOptions options;
  options.seed = 2;
  options.real_dem = read_geotiff_dsm(*path, read);
  options.terrain.cell_m = 2.0;
  options.texture.texel_m = 1.5;
  options.check_points = 20;
  for (EpochOptions& e : options.epochs) {
    e.rows = 1;
    e.columns = 2;
    e.focal_px = 900.0;
    e.flying_height_m = 2600.0;
    e.tie_points = 60;
    e.block_offset_m = Eigen::Vector2d::Zero();
  }
  const Scene scene = generate_scene(options);
  const Dsm& dem = *options.real_dem;
  CHECK(scene.landscape.ground.crs() == dem.crs());
  // The ground is the DEM, resampled: compare at scattered ground cells away from buildings.
  double worst = 0.0;
  const Dsm& ground = scene.landscape.ground;
  for (int y = 5; y < ground.height(); y += 97)
    for (int x = 5; x < ground.width(); x += 89) {
      const Vec2 xy = ground.pixel_to_world(Vec2(x, y));
      const double z = dem.height_at(xy);
      if (std::isfinite(z)) worst = std::max(worst, std::abs(z - ground.heights()(x, y)));
    }
  CHECK(worst < 1e-3);
  REQUIRE(scene.check_points.size() >= 5);
  for (const CheckPoint& cp : scene.check_points)
    for (const CheckPoint::Observation& ob : cp.observations) {
      const SyntheticEpoch& epoch = scene.epochs[static_cast<std::size_t>(ob.epoch)];
      const RayDsmResult hit =
          intersect_ray_dsm(epoch.true_surface, *epoch.world_frame(static_cast<std::size_t>(ob.image)).ray(ob.pixel));
      REQUIRE(hit.success);
      CHECK((hit.point - cp.world).norm() < 1e-3);
    }

  // A flight longer than the DEM is refused, and the message gives both extents to compare.
  for (EpochOptions& e : options.epochs) e.columns = 12;
  try {
    generate_scene(options);
    FAIL("a scene beyond the DEM was generated");
  } catch (const Error& error) {
    const std::string what = error.what();
    CHECK(what.find("does not cover the scene") != std::string::npos);
    CHECK(what.find("the DEM has X [") != std::string::npos);
    CHECK(what.find("the scene needs X [") != std::string::npos);
  }
#endif
}

TEST_CASE("invalid options are rejected with a message", "[synth]") {
  SceneOptions options = small_options(1);
  options.epochs[0].rows = 0;
  CHECK_THROWS_AS(generate_scene(options), Error);
  options = small_options(1);
  options.epochs[1].name = options.epochs[0].name;
  CHECK_THROWS_WITH(generate_scene(options), Catch::Contains("two epochs"));
  options = small_options(1);
  options.terrain.cell_m = -1.0;
  CHECK_THROWS_AS(generate_scene(options), Error);
  options = small_options(1);
  options.epochs.clear();
  CHECK_THROWS_AS(generate_scene(options), Error);
  // A camera below the hills.
  options = small_options(1);
  options.epochs[0].flying_height_m = 5.0;
  options.epochs[0].focal_px = 5.0;
  CHECK_THROWS_AS(generate_scene(options), Error);
  // A flying height that is not a height.
  CHECK_THROWS_AS(options.epochs[0].set_flying_height_keeping_gsd(0.0), Error);
  CHECK_THROWS_AS(options.epochs[0].set_flying_height_keeping_gsd(std::nan("")), Error);
}

TEST_CASE("set_flying_height_keeping_gsd: the focal length follows the height", "[synth]") {
  EpochOptions e = EpochOptions::historical();
  const double gsd = e.gsd_m();
  const int width = e.image_width_px;
  e.set_flying_height_keeping_gsd(3 * e.flying_height_m);
  CHECK(e.flying_height_m == Approx(3 * EpochOptions::historical().flying_height_m));
  CHECK(e.focal_px == Approx(3 * EpochOptions::historical().focal_px));
  CHECK(e.gsd_m() == Approx(gsd));
  CHECK(e.image_width_px == width);
}
