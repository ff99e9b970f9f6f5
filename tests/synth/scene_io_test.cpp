// Round trip of a synthetic scene through its folder format, and the errors that name the file.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

#include <catch2/catch.hpp>

#ifdef DIACHRON_HAVE_GDAL
#include <diachron/synth/scene_io.hpp>

#include "support/rasters.hpp"
#endif

using namespace diachron;

#ifdef DIACHRON_HAVE_GDAL

namespace {

std::string temp_folder(const std::string& name) {
  const char* base = std::getenv("TMPDIR");
  return std::string(base ? base : "/tmp") + "/diachron_synth_" + name + "_" + std::to_string(::getpid());
}

void check_pose(const Pose& a, const Pose& b) {
  CHECK((a.cam_from_world_rotation() - b.cam_from_world_rotation()).cwiseAbs().maxCoeff() < 1e-14);
  CHECK((a.centre() - b.centre()).norm() == 0.0);
}

void check_camera(const Camera<FraserAffine>& a, const Camera<FraserAffine>& b) {
  CHECK(a.intrinsics() == b.intrinsics());
  CHECK(a.width() == b.width());
  CHECK(a.height() == b.height());
}

Scene small_scene() {
  SceneOptions o;
  o.seed = 21;
  for (EpochOptions& e : o.epochs) {
    e.rows = 1;
    e.columns = 2;
    e.tie_points = 80;
  }
  o.check_points = 20;
  return generate_scene(o);
}

}  // namespace

TEST_CASE("write_scene then read_scene gives the same scene", "[synth][io]") {
  const Scene scene = small_scene();
  const std::string dir = temp_folder("roundtrip");
  write_scene(scene, dir);
  const Scene back = read_scene(dir);

  CHECK(back.seed == scene.seed);
  CHECK(back.bounds.min_x == scene.bounds.min_x);
  CHECK(back.bounds.max_y == scene.bounds.max_y);
  CHECK(back.reference_height_m == scene.reference_height_m);
  REQUIRE(back.epochs.size() == scene.epochs.size());
  for (std::size_t e = 0; e < scene.epochs.size(); ++e) {
    const SyntheticEpoch& a = scene.epochs[e];
    const SyntheticEpoch& b = back.epochs[e];
    CHECK(a.name == b.name);
    CHECK(a.gsd_m == b.gsd_m);
    CHECK(a.world_from_epoch.matrix() == b.world_from_epoch.matrix());
    check_camera(a.camera, b.camera);
    check_camera(a.estimated_camera, b.estimated_camera);
    REQUIRE(a.images.size() == b.images.size());
    for (std::size_t i = 0; i < a.images.size(); ++i) {
      CHECK(a.images[i].name == b.images[i].name);
      CHECK(a.images[i].row == b.images[i].row);
      CHECK(a.images[i].column == b.images[i].column);
      CHECK(std::equal(a.images[i].pixels.begin(), a.images[i].pixels.end(), b.images[i].pixels.begin()));
      check_pose(a.images[i].pose_world, b.images[i].pose_world);
      check_pose(a.images[i].pose_epoch, b.images[i].pose_epoch);
      check_pose(a.images[i].estimated_pose, b.images[i].estimated_pose);
    }
    CHECK(diachron::test::same_values(a.dsm.heights(), b.dsm.heights()));
    CHECK(a.dsm.transform().c == b.dsm.transform().c);
    CHECK(diachron::test::same_values(a.true_surface.heights(), b.true_surface.heights()));
    CHECK(a.true_surface.transform().c == b.true_surface.transform().c);
    CHECK(diachron::test::same_values(a.albedo.values, b.albedo.values));
    REQUIRE(a.tie_points.size() == b.tie_points.size());
    for (std::size_t k = 0; k < a.tie_points.size(); ++k) {
      CHECK(a.tie_points[k].world == b.tie_points[k].world);
      CHECK(a.tie_points[k].epoch == b.tie_points[k].epoch);
      REQUIRE(a.tie_points[k].observations.size() == b.tie_points[k].observations.size());
      for (std::size_t o = 0; o < a.tie_points[k].observations.size(); ++o) {
        CHECK(a.tie_points[k].observations[o].image == b.tie_points[k].observations[o].image);
        CHECK(a.tie_points[k].observations[o].pixel == b.tie_points[k].observations[o].pixel);
      }
    }
  }
  REQUIRE(back.check_points.size() == scene.check_points.size());
  for (std::size_t k = 0; k < scene.check_points.size(); ++k) {
    CHECK(back.check_points[k].world == scene.check_points[k].world);
    REQUIRE(back.check_points[k].observations.size() == scene.check_points[k].observations.size());
    for (std::size_t o = 0; o < scene.check_points[k].observations.size(); ++o) {
      CHECK(back.check_points[k].observations[o].epoch == scene.check_points[k].observations[o].epoch);
      CHECK(back.check_points[k].observations[o].image == scene.check_points[k].observations[o].image);
      CHECK(back.check_points[k].observations[o].pixel == scene.check_points[k].observations[o].pixel);
    }
  }
  CHECK(back.epoch2_from_epoch1().matrix().isApprox(scene.epoch2_from_epoch1().matrix(), 1e-14));
}

TEST_CASE("read_scene names the file and line it cannot read", "[synth][io]") {
  CHECK_THROWS_WITH(read_scene(temp_folder("missing")), Catch::Contains("scene.txt"));

  const Scene scene = small_scene();
  const std::string dir = temp_folder("broken");
  write_scene(scene, dir);
  std::string text;
  {
    std::ifstream in(dir + "/scene.txt");
    std::stringstream buffer;
    buffer << in.rdbuf();
    text = buffer.str();
  }
  {
    // A camera line with a word where a number belongs.
    std::string broken = text;
    const auto at = broken.find("\ncamera ");
    REQUIRE(at != std::string::npos);
    broken.insert(at + 8, "oops ");
    std::ofstream(dir + "/scene.txt") << broken;
    CHECK_THROWS_WITH(read_scene(dir), Catch::Contains("scene.txt' line") && Catch::Contains("camera"));
  }
  {
    // A missing image file.
    std::ofstream(dir + "/scene.txt") << text;
    const std::string image = dir + "/images/" + scene.epochs[0].images[0].name + ".png";
    REQUIRE(std::remove(image.c_str()) == 0);
    CHECK_THROWS_WITH(read_scene(dir), Catch::Contains(scene.epochs[0].images[0].name + ".png"));
  }
  {
    // A truncated file.
    std::ofstream(dir + "/scene.txt") << text.substr(0, text.size() / 2);
    CHECK_THROWS_AS(read_scene(dir), Error);
  }
}

#else

TEST_CASE("scene_io needs GDAL", "[synth][io]") { WARN("skipped: built without GDAL"); }

#endif
