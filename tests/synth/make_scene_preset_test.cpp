// make_scene --preset decades writes exactly the scene generate_scene() makes from
// SceneOptions::decades_apart() with the same seed, the other flags applied on top: any program can
// regenerate the truth of a written scene from its seed. Runs the example program of this build;
// skipped (with a message) where examples are not built, as in the sanitizer build.

#include <cstdlib>
#include <string>

#include <unistd.h>

#include <catch2/catch.hpp>

#include <diachron/synth/scene.hpp>
#ifdef DIACHRON_HAVE_GDAL
#include <diachron/synth/scene_io.hpp>
#endif

#include "support/test_paths.hpp"

using namespace diachron;

namespace {

// The build's make_scene: tests live in <build>/tests, examples in <build>/examples.
std::string make_scene_path() {
  char buffer[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buffer, sizeof(buffer) - 1);
  if (n <= 0) return {};
  const std::string self(buffer, static_cast<std::size_t>(n));
  const std::string tests_dir = self.substr(0, self.rfind('/'));
  return tests_dir.substr(0, tests_dir.rfind('/')) + "/examples/make_scene";
}

}  // namespace

#ifdef DIACHRON_HAVE_GDAL
TEST_CASE("make_scene --preset decades --seed N writes the scene of decades_apart() with seed N", "[synth][decades]") {
  const std::string program = make_scene_path();
  REQUIRE(program.size() > std::string("/examples/make_scene").size());  // found this test's own path
  if (!test::file_exists(program)) {
    WARN("skipped: " << program << " is not built (examples off)");
    return;
  }
  const std::string out = "make_scene_preset_test_out";
  // Small images keep the test quick; the flag scales the focal length with the width, so the
  // expected options below do the same on top of the preset.
  const std::string command = program + " " + out + " --preset decades --seed 5 --image-size 400x300 --check-points 20 > /dev/null";
  REQUIRE(std::system(command.c_str()) == 0);
  const Scene written = read_scene(out);

  SceneOptions options = SceneOptions::decades_apart();
  options.seed = 5;
  options.check_points = 20;
  for (EpochOptions& e : options.epochs) {
    e.focal_px *= 400.0 / e.image_width_px;
    e.image_width_px = 400;
    e.image_height_px = 300;
  }
  const Scene expected = generate_scene(options);

  REQUIRE(written.seed == 5);
  REQUIRE(written.epochs.size() == expected.epochs.size());
  for (std::size_t e = 0; e < expected.epochs.size(); ++e) {
    const SyntheticEpoch& a = written.epochs[e];
    const SyntheticEpoch& b = expected.epochs[e];
    CHECK(a.name == b.name);
    CHECK(a.camera.focal() == Approx(b.camera.focal()).epsilon(1e-12));
    REQUIRE(a.images.size() == b.images.size());
    for (std::size_t i = 0; i < b.images.size(); ++i) {
      CHECK(a.images[i].name == b.images[i].name);
      CHECK(std::equal(a.images[i].pixels.begin(), a.images[i].pixels.end(), b.images[i].pixels.begin()));
      CHECK((a.images[i].pose_world.centre() - b.images[i].pose_world.centre()).norm() < 1e-9);
    }
    CHECK(a.tie_points.size() == b.tie_points.size());
    CHECK(a.dsm.width() == b.dsm.width());
    CHECK(a.dsm.height() == b.dsm.height());
  }
  CHECK(written.check_points.size() == expected.check_points.size());
  const Helmert3 h1 = written.epoch2_from_epoch1(), h2 = expected.epoch2_from_epoch1();
  CHECK(h1.scale == Approx(h2.scale).epsilon(1e-12));
  CHECK((h1.translation - h2.translation).norm() < 1e-6);

  // A value the preset does not allow is refused with the usage (exit 1): it has 2 to 5 epochs.
  CHECK(std::system((program + " " + out + " --preset decades --epochs 6 2> /dev/null").c_str()) != 0);
}
#else
TEST_CASE("make_scene preset test needs GDAL", "[synth][decades]") { WARN("skipped: built without GDAL"); }
#endif
