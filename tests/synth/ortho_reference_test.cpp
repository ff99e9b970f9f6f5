// An epoch delivered as a true orthophoto and its true surface (synth/ortho_reference.hpp): the
// renderer on an OrthoFrame against exact and camera oracles, the epoch replaced in the scene, and
// the folder write_scene and make_scene --ortho-reference write for it.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include <catch2/catch.hpp>
#include <Eigen/Geometry>

#include <diachron/camera/ortho_frame.hpp>
#include <diachron/synth/ortho_reference.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>
#ifdef DIACHRON_HAVE_GDAL
#include <diachron/eval/scene_check_points.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/synth/scene_io.hpp>

#include "support/temp_folder.hpp"
#endif

#include "support/rasters.hpp"
#include "support/scenes.hpp"
#include "support/test_paths.hpp"

using namespace diachron;

namespace {

const SceneOptions& ortho_scene_options() {
  static const SceneOptions options = diachron::test::small_scene_options(31, 60, 30);
  return options;
}

// The small scene as generate_scene makes it, and with its last epoch an orthophoto.
const Scene& ortho_source_scene() {
  static const Scene scene = generate_scene(ortho_scene_options());
  return scene;
}

const Scene& ortho_scene() {
  static const Scene scene = [] {
    Scene s = ortho_source_scene();
    make_ortho_reference(s, ortho_scene_options(), 1);
    return s;
  }();
  return scene;
}

// Pearson correlation of two equally long samples.
double ortho_correlation(const std::vector<double>& a, const std::vector<double>& b) {
  double ma = 0.0, mb = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= static_cast<double>(a.size());
  mb /= static_cast<double>(b.size());
  double sab = 0.0, saa = 0.0, sbb = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return sab / std::sqrt(saa * sbb);
}

// A Helmert with every kind of term: a frame turned 40 degrees, tilted 2 degrees, scaled and shifted.
Helmert3 ortho_tilted_world_from_frame() {
  Helmert3 h;
  h.scale = 1.7;
  const Eigen::AngleAxisd yaw(0.7, Vec3::UnitZ()), tilt(0.035, Vec3(1.0, 0.4, 0.0).normalized());
  h.rotation = (tilt * yaw).toRotationMatrix();
  h.translation = Vec3(120.0, -80.0, 15.0);
  return h;
}

}  // namespace

TEST_CASE("render_radiance: an OrthoFrame in the world sees each pixel's X, Y straight down", "[synth]") {
  const Scene& scene = ortho_source_scene();
  const SyntheticEpoch& epoch = scene.epochs[1];
  const LookOptions& look = ortho_scene_options().epochs[1].look;
  const detail::SurfaceTracer tracer(epoch.true_surface);
  const AlbedoMap shading = shading_map(epoch.true_surface, look, 1);
  const Vec2 centre(0.5 * (scene.bounds.min_x + scene.bounds.max_x), 0.5 * (scene.bounds.min_y + scene.bounds.max_y));
  const OrthoFrame frame(GeoTransform::north_up(centre.x() - 60.0, centre.y() + 50.0, 0.7), 171, 143);
  const Raster<float> radiance = render_radiance(frame, Helmert3::identity(), tracer, epoch.albedo, shading, look, 2);
  REQUIRE(radiance.width() == 171);
  REQUIRE(radiance.height() == 143);
  int exact = 0;
  for (int y = 0; y < frame.height(); ++y)
    for (int x = 0; x < frame.width(); ++x) {
      const Vec2 xy = frame.geo_transform().pixel_to_world(Vec2(x, y));
      // The world point on the surface at this X, Y is this pixel, whatever its height.
      const Vec3 world(xy.x(), xy.y(), epoch.true_surface.height_at(xy));
      const std::optional<Vec2> px = frame.project(world);
      REQUIRE(px);
      CHECK((*px - Vec2(x, y)).norm() < 1e-9);
      // The vertical ray keeps X, Y exactly: the radiance is the albedo times the shading there.
      const float expected = static_cast<float>(epoch.albedo.sample(xy) * shading.sample(xy));
      exact += radiance(x, y) == expected;
    }
  CHECK(exact == frame.width() * frame.height());
  // Threads do not change the image.
  const Raster<float> one_thread =
      render_radiance(frame, Helmert3::identity(), tracer, epoch.albedo, shading, look, 1);
  CHECK(test::same_values(radiance, one_thread));
}

TEST_CASE("render_radiance: an orthophoto is what a long-focal camera far above sees near its nadir", "[synth]") {
  const Scene& scene = ortho_source_scene();
  const SyntheticEpoch& epoch = scene.epochs[1];
  const LookOptions& look = ortho_scene_options().epochs[1].look;
  const detail::SurfaceTracer tracer(epoch.true_surface);
  const AlbedoMap shading = shading_map(epoch.true_surface, look, 1);
  const double gsd = 0.8, height = 2e5, ground = scene.reference_height_m;
  const int n = 81;
  const Vec2 nadir(0.5 * (scene.bounds.min_x + scene.bounds.max_x) + 13.3,
                   0.5 * (scene.bounds.min_y + scene.bounds.max_y) - 7.9);
  // Camera x along world X, camera y along world -Y (north-up), looking down; its pixel size on
  // the mean ground is the orthophoto's GSD, and its centre pixel sees the nadir.
  Mat3 cam_from_world;
  cam_from_world << 1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0;
  const Camera<NoDistortion> camera((height - ground) / gsd, 0.5 * (n - 1), 0.5 * (n - 1), n, n);
  const Frame<NoDistortion> down(camera, Pose(cam_from_world, Vec3(nadir.x(), nadir.y(), height)));
  const Raster<float> seen = render_radiance(down, tracer, epoch.albedo, look, 2);
  const double half = 0.5 * n * gsd;
  const OrthoFrame frame(GeoTransform::north_up(nadir.x() - half, nadir.y() + half, gsd), n, n);
  const Raster<float> ortho = render_radiance(frame, Helmert3::identity(), tracer, epoch.albedo, shading, look, 2);
  // The camera's rays lean by at most 45 px * 0.8 m / 2e5 m = 2e-4 rad: relief of tens of metres
  // moves their hit by millimetres, a hundredth of a pixel.
  double sum = 0.0, worst = 0.0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double d = std::abs(static_cast<double>(seen(x, y)) - ortho(x, y));
      sum += d;
      worst = std::max(worst, d);
    }
  const double mean = sum / (n * n);
  INFO("mean " << mean << ", worst " << worst);
  CHECK(mean < 1e-3);
  CHECK(worst < 0.02);
  // The comparison can fail: one pixel of shift makes them differ.
  double shifted = 0.0;
  for (int y = 0; y < n; ++y)
    for (int x = 1; x < n; ++x) shifted += std::abs(static_cast<double>(seen(x, y)) - ortho(x - 1, y));
  CHECK(shifted / (n * (n - 1)) > 5.0 * mean);
}

TEST_CASE("render_radiance: an orthophoto in a tilted frame looks along that frame's vertical", "[synth]") {
  const Scene& scene = ortho_source_scene();
  const SyntheticEpoch& epoch = scene.epochs[1];
  const LookOptions& look = ortho_scene_options().epochs[1].look;
  const detail::SurfaceTracer tracer(epoch.true_surface);
  const AlbedoMap shading = shading_map(epoch.true_surface, look, 1);
  const Helmert3 world_from_frame = ortho_tilted_world_from_frame();
  const Helmert3 frame_from_world = world_from_frame.inverse();
  const Vec3 centre = frame_from_world(Vec3(0.5 * (scene.bounds.min_x + scene.bounds.max_x),
                                            0.5 * (scene.bounds.min_y + scene.bounds.max_y), scene.reference_height_m));
  const double cell = 1.3 / world_from_frame.scale;  // 1.3 m
  const OrthoFrame frame(GeoTransform::north_up(centre.x() - 40.0 * cell, centre.y() + 30.0 * cell, cell), 80, 60);
  const Raster<float> radiance = render_radiance(frame, world_from_frame, tracer, epoch.albedo, shading, look, 2);
  // Oracle: the exact ray-DSM search on the frame's vertical through each pixel, from 2 km above.
  const Vec3 down = world_from_frame.rotation * Vec3(0.0, 0.0, -1.0);
  double worst = 0.0;
  int hits = 0;
  for (int y = 0; y < frame.height(); ++y)
    for (int x = 0; x < frame.width(); ++x) {
      const Vec2 xy = frame.geo_transform().pixel_to_world(Vec2(x, y));
      const Vec3 start = world_from_frame(Vec3(xy.x(), xy.y(), centre.z() + 2000.0 / world_from_frame.scale));
      const RayDsmResult hit = intersect_ray_dsm(epoch.true_surface, Ray3{start, down});
      REQUIRE(hit.success);
      ++hits;
      const Vec2 w = hit.point.head<2>();
      worst = std::max(worst, std::abs(epoch.albedo.sample(w) * shading.sample(w) - radiance(x, y)));
      // The world point there projects back to the pixel through the frame.
      CHECK((frame.project(frame_from_world(hit.point)).value() - Vec2(x, y)).norm() < 1e-6);
    }
  CHECK(hits == 80 * 60);
  CHECK(worst < 1e-5);
}

TEST_CASE("make_ortho_reference: the epoch becomes a north-up true orthophoto and true DSM in its frame", "[synth]") {
  const Scene& before = ortho_source_scene();
  const Scene& scene = ortho_scene();
  const SyntheticEpoch& source = before.epochs[1];
  const SyntheticEpoch& epoch = scene.epochs[1];
  REQUIRE(epoch.orthophoto);
  const OrthoFrame& frame = epoch.orthophoto->frame;
  const GeoTransform& geo = frame.geo_transform();
  const double s = epoch.epoch_from_world().scale;
  // North-up in the epoch frame, at the epoch's GSD (epoch units per pixel = metres * scale).
  CHECK(geo.c[2] == 0.0);
  CHECK(geo.c[4] == 0.0);
  CHECK(geo.c[1] == Approx(source.gsd_m * s).epsilon(1e-12));
  CHECK(geo.c[5] == -geo.c[1]);
  CHECK(epoch.gsd_m == source.gsd_m);
  CHECK(epoch.orthophoto->pixels.width() == frame.width());
  CHECK(epoch.orthophoto->pixels.height() == frame.height());
  CHECK((epoch.world_from_epoch.matrix() - source.world_from_epoch.matrix()).cwiseAbs().maxCoeff() == 0.0);
  // No images, no tie points; the check points keep their world position and epoch 0's pixels.
  CHECK(epoch.images.empty());
  CHECK(epoch.tie_points.empty());
  REQUIRE(scene.check_points.size() == before.check_points.size());
  REQUIRE(!scene.check_points.empty());
  for (std::size_t k = 0; k < scene.check_points.size(); ++k) {
    const CheckPoint& a = scene.check_points[k];
    const CheckPoint& b = before.check_points[k];
    CHECK(a.world == b.world);
    std::size_t in_epoch0 = 0;
    for (const CheckPoint::Observation& o : b.observations) in_epoch0 += o.epoch == 0;
    CHECK(a.observations.size() == in_epoch0);
    for (const CheckPoint::Observation& o : a.observations) CHECK(o.epoch == 0);
    // Every check point lies on the orthophoto.
    CHECK(frame.in_image(frame.project(epoch.epoch_from_world()(a.world)).value()));
  }
  // The older epoch is untouched.
  REQUIRE(scene.epochs[0].images.size() == before.epochs[0].images.size());
  for (std::size_t i = 0; i < before.epochs[0].images.size(); ++i)
    CHECK(test::same_values(scene.epochs[0].images[i].pixels, before.epochs[0].images[i].pixels));
  CHECK(test::same_values(scene.epochs[0].dsm.heights(), before.epochs[0].dsm.heights()));

  // It covers the epoch's images: the ground under every image's centre is on it.
  for (std::size_t i = 0; i < source.images.size(); ++i) {
    const Frame<FraserAffine> f = source.world_frame(i);
    const Vec2 middle(0.5 * f.camera().width(), 0.5 * f.camera().height());
    const RayDsmResult hit = intersect_ray_dsm(source.true_surface, f.ray(middle).value());
    REQUIRE(hit.success);
    CHECK(frame.in_image(frame.project(epoch.epoch_from_world()(hit.point)).value()));
  }

  // The DSM is the true surface in the epoch frame: each cell's point lies on it (float storage).
  const Dsm& dsm = epoch.dsm;
  CHECK(dsm.transform().c[2] == 0.0);
  CHECK(dsm.transform().c[4] == 0.0);
  CHECK(dsm.transform().c[1] == Approx(source.true_surface.min_cell_size() * s).epsilon(1e-12));
  std::size_t valid = 0;
  double worst = 0.0;
  for (int y = 0; y < dsm.height(); y += 3)
    for (int x = 0; x < dsm.width(); x += 3) {
      const float z = dsm.heights()(x, y);
      if (std::isnan(z)) continue;
      ++valid;
      const Vec2 xy = dsm.transform().pixel_to_world(Vec2(x, y));
      const Vec3 world = epoch.world_from_epoch(Vec3(xy.x(), xy.y(), z));
      worst = std::max(worst, std::abs(source.true_surface.height_at(world.head<2>()) - world.z()));
    }
  CHECK(valid > 1000);
  CHECK(worst < 1e-3);

  // Its grey values are the straight-down render: they follow the radiance at the same place, and
  // not the radiance two pixels off.
  const LookOptions& look = ortho_scene_options().epochs[1].look;
  const detail::SurfaceTracer tracer(source.true_surface);
  const AlbedoMap shading = shading_map(source.true_surface, look, 1);
  std::vector<double> grey, here, off;
  for (int y = 4; y < frame.height() - 4; y += 2)
    for (int x = 4; x < frame.width() - 4; x += 2) {
      const auto radiance_at = [&](int px, int py) {
        const Vec2 xy = geo.pixel_to_world(Vec2(px, py));
        const Vec3 start = epoch.world_from_epoch(Vec3(xy.x(), xy.y(), 1e4));
        const Vec3 down = epoch.world_from_epoch.rotation * Vec3(0.0, 0.0, -1.0);
        const std::optional<Vec3> hit = tracer.intersect(Ray3{start, down});
        if (!hit) return std::optional<double>();
        return std::optional<double>(source.albedo.sample(hit->head<2>()) * shading.sample(hit->head<2>()));
      };
      const std::optional<double> a = radiance_at(x, y), b = radiance_at(x + 2, y);
      if (!a || !b) continue;
      grey.push_back(epoch.orthophoto->pixels(x, y));
      here.push_back(*a);
      off.push_back(*b);
    }
  REQUIRE(grey.size() > 1000);
  const double r_here = ortho_correlation(grey, here), r_off = ortho_correlation(grey, off);
  INFO("correlation " << r_here << " in place, " << r_off << " two pixels off");
  CHECK(r_here > 0.95);
  CHECK(r_here > r_off + 0.1);
}

TEST_CASE("make_ortho_reference: deterministic, whatever the threads", "[synth]") {
  Scene a = ortho_source_scene(), b = ortho_source_scene();
  OrthoReferenceOptions one, two;
  one.threads = 1;
  two.threads = 2;
  make_ortho_reference(a, ortho_scene_options(), 1, one);
  make_ortho_reference(b, ortho_scene_options(), 1, two);
  CHECK(test::same_values(a.epochs[1].orthophoto->pixels, b.epochs[1].orthophoto->pixels));
  CHECK(test::same_values(a.epochs[1].dsm.heights(), b.epochs[1].dsm.heights()));
  CHECK(test::same_values(a.epochs[1].orthophoto->pixels, ortho_scene().epochs[1].orthophoto->pixels));
}

TEST_CASE("make_ortho_reference: options set the GSD and the DSM cell", "[synth]") {
  Scene scene = ortho_source_scene();
  OrthoReferenceOptions options;
  options.gsd_m = 3.0;
  options.dsm_cell_m = 2.5;
  make_ortho_reference(scene, ortho_scene_options(), 1, options);
  const SyntheticEpoch& epoch = scene.epochs[1];
  const double s = epoch.epoch_from_world().scale;
  CHECK(epoch.gsd_m == 3.0);
  CHECK(epoch.orthophoto->frame.cell_size() == Approx(3.0 * s).epsilon(1e-12));
  CHECK(epoch.dsm.transform().c[1] == Approx(2.5 * s).epsilon(1e-12));
  // Both grids start at the same corner and cover the same box to within a cell.
  const OrthoFrame& f = epoch.orthophoto->frame;
  CHECK(epoch.dsm.transform().c[0] == f.geo_transform().c[0]);
  CHECK(epoch.dsm.transform().c[3] == f.geo_transform().c[3]);
  CHECK(std::abs(epoch.dsm.width() * 2.5 - f.width() * 3.0) <= 3.0);
}

TEST_CASE("make_ortho_reference: invalid input throws, naming the field or the epoch", "[synth]") {
  OrthoReferenceOptions bad;
  bad.gsd_m = -1.0;
  CHECK_THROWS_WITH(bad.check(), Catch::Contains("gsd_m"));
  bad = {};
  bad.dsm_cell_m = std::nan("");
  CHECK_THROWS_WITH(bad.check(), Catch::Contains("dsm_cell_m"));
  Scene scene = ortho_source_scene();
  CHECK_THROWS_WITH(make_ortho_reference(scene, ortho_scene_options(), 2), Catch::Contains("epoch 2"));
  SceneOptions other = ortho_scene_options();
  other.epochs[1].name = "other";
  CHECK_THROWS_WITH(make_ortho_reference(scene, other, 1), Catch::Contains("options"));
  Scene done = ortho_scene();
  CHECK_THROWS_WITH(make_ortho_reference(done, ortho_scene_options(), 1), Catch::Contains("already an orthophoto"));
}

#ifdef DIACHRON_HAVE_GDAL
TEST_CASE("write_scene: an orthophoto epoch's folder holds ortho.tif and dsm.tif, no images", "[synth][io]") {
  const Scene& scene = ortho_scene();
  const std::string dir = test::temp_path("synth_ortho_reference");
  write_scene(scene, dir);
  const SyntheticEpoch& epoch = scene.epochs[1];
  const std::string e2 = dir + "/" + epoch.name;
  CHECK(test::file_exists(e2 + "/ortho.tif"));
  CHECK(test::file_exists(e2 + "/dsm.tif"));
  CHECK_FALSE(test::file_exists(e2 + "/images"));
  CHECK_FALSE(test::file_exists(e2 + "/cameras.txt"));
  CHECK_FALSE(test::file_exists(e2 + "/images.txt"));
  CHECK_FALSE(test::file_exists(e2 + "/points3D.txt"));
  CHECK(test::file_exists(dir + "/" + scene.epochs[0].name + "/images.txt"));

  // An 8-bit grey GeoTIFF whose geotransform is the OrthoFrame's, north-up.
  const RasterGeoreference ref = read_raster_georeference(e2 + "/ortho.tif");
  REQUIRE(ref.has_geotransform);
  CHECK(ref.width == epoch.orthophoto->frame.width());
  CHECK(ref.height == epoch.orthophoto->frame.height());
  CHECK(ref.transform.c == epoch.orthophoto->frame.geo_transform().c);
  CHECK_NOTHROW(OrthoFrame::check_north_up(ref.transform));
  CHECK(test::same_values(read_image_u8(e2 + "/ortho.tif"), epoch.orthophoto->pixels));
  CHECK(test::same_values(read_geotiff_dsm(e2 + "/dsm.tif").heights(), epoch.dsm.heights()));

  // read_scene gives it back; the older epoch's check points still score against the truth.
  const Scene back = read_scene(dir);
  REQUIRE(back.epochs.size() == 2);
  REQUIRE(back.epochs[1].orthophoto);
  CHECK(back.epochs[1].images.empty());
  CHECK(back.epochs[1].gsd_m == epoch.gsd_m);
  CHECK(back.epochs[1].orthophoto->frame.geo_transform().c == epoch.orthophoto->frame.geo_transform().c);
  CHECK(test::same_values(back.epochs[1].orthophoto->pixels, epoch.orthophoto->pixels));
  CHECK(back.epochs[1].world_from_epoch.matrix() == epoch.world_from_epoch.matrix());
  CHECK(back.epochs[0].images.size() == scene.epochs[0].images.size());
  const std::vector<ObservedCheckPoint> written = scene_check_points(back, 0, 1);
  const std::vector<ObservedCheckPoint> truth = scene_check_points(scene, 0, 1);
  REQUIRE(written.size() == truth.size());
  for (std::size_t k = 0; k < truth.size(); ++k) {
    CHECK((written[k].truth - truth[k].truth).norm() < 1e-9);
    CHECK(written[k].observations.size() == truth[k].observations.size());
  }
}

TEST_CASE("make_scene --ortho-reference writes the last epoch as its orthophoto and true DSM", "[synth][io]") {
  char buffer[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buffer, sizeof(buffer) - 1);
  REQUIRE(n > 0);
  const std::string self(buffer, static_cast<std::size_t>(n));
  const std::string tests_dir = self.substr(0, self.rfind('/'));
  const std::string program = tests_dir.substr(0, tests_dir.rfind('/')) + "/examples/make_scene";
  if (!test::file_exists(program)) {
    WARN("skipped: " << program << " is not built (examples off)");
    return;
  }
  const std::string out = test::temp_path("synth_make_scene_ortho");
  const std::string command =
      program + " " + out + " --seed 31 --images-per-epoch 1x2 --check-points 30 --ortho-reference > /dev/null";
  REQUIRE(std::system(command.c_str()) == 0);
  const Scene written = read_scene(out);
  SceneOptions options;
  options.seed = 31;
  options.check_points = 30;
  for (EpochOptions& e : options.epochs) {
    e.rows = 1;
    e.columns = 2;
  }
  Scene expected = generate_scene(options);
  make_ortho_reference(expected, options, 1);
  REQUIRE(written.epochs.size() == 2);
  REQUIRE(written.epochs[1].orthophoto);
  CHECK(test::same_values(written.epochs[1].orthophoto->pixels, expected.epochs[1].orthophoto->pixels));
  const GeoTransform& written_geo = written.epochs[1].orthophoto->frame.geo_transform();
  CHECK(written_geo.c == expected.epochs[1].orthophoto->frame.geo_transform().c);
  REQUIRE(written.epochs[0].images.size() == expected.epochs[0].images.size());
  for (std::size_t i = 0; i < expected.epochs[0].images.size(); ++i)
    CHECK(test::same_values(written.epochs[0].images[i].pixels, expected.epochs[0].images[i].pixels));
  CHECK(written.check_points.size() == expected.check_points.size());
}
#endif
