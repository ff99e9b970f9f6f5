// The adjusted export: cameras.json and per-epoch COLMAP models that COLMAP's own projection
// (written from its documentation) reproduces within the reported conversion error; the input
// model is never written into.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include <diachron/core/random.hpp>
#include <diachron/io/adjusted_export.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/colmap_text.hpp>

#include "support/colmap_projection.hpp"
#include "support/temp_folder.hpp"

using namespace diachron;
using Catch::Matchers::Contains;

namespace {

namespace fs = std::filesystem;

std::string export_folder(const std::string& name) { return diachron::test::fresh_temp_folder("adjusted_" + name); }

// Epoch e1: two images sharing a camera with shear (B2 != 0: FULL_OPENCV, fitted) and one with its
// own camera; epoch e2: two images of a camera OPENCV holds exactly (K3 = B2 = 0).
std::vector<CamerasJsonImage> adjusted_images() {
  const Camera<FraserAffine> sheared(1000.0, 801.3, 598.2, 1600, 1200, {-0.08, 0.02, -0.004, 2e-4, -1e-4, 1.5, -0.8});
  const Camera<FraserAffine> other(1010.0, 799.0, 601.0, 1600, 1200, {-0.05, 0.01, 0.0, 1e-4, 1e-4, 0.5, 0.3});
  const Camera<FraserAffine> exact(700.0, 399.0, 301.0, 800, 600, {0.03, -0.01, 0.0, -3e-4, 2e-4, -0.7, 0.0});
  std::vector<CamerasJsonImage> out;
  const auto add = [&out](const std::string& name, const std::string& epoch, const Camera<FraserAffine>& c, double x) {
    const Pose pose = Pose::from_yaw_pitch_roll(Vec3(x, 50.0, 1500.0), 0.1 * x / 100.0, 0.02, -0.01);
    out.push_back(CamerasJsonImage::from_frame(name, epoch, Frame<FraserAffine>(c, pose)));
  };
  add("e1_a", "e1", sheared, 0.0);
  add("e2_a", "e2", exact, 20.0);
  add("e1_b", "e1", sheared, 400.0);
  add("e1_c", "e1", other, 800.0);
  add("e2_b", "e2", exact, 420.0);
  return out;
}

}  // namespace

TEST_CASE("write_adjusted_export: COLMAP models that project as the adjusted frames, within the reported error",
          "[io]") {
  const std::string dir = export_folder("models");
  const std::vector<CamerasJsonImage> images = adjusted_images();
  const AdjustedExportReport report = write_adjusted_export(images, dir);
  CHECK(report.cameras_json_path == dir + "/adjusted/cameras.json");
  REQUIRE(report.model_folders.size() == 2);
  CHECK(report.model_folders.at("e1") == dir + "/adjusted/e1");
  REQUIRE(report.cameras.size() == 3);
  CHECK(report.cameras[0].epoch == "e1");
  CHECK(report.cameras[0].model == "FULL_OPENCV");
  CHECK_FALSE(report.cameras[0].exact);
  CHECK(report.cameras[0].images == std::vector<std::string>{"e1_a", "e1_b"});
  CHECK(report.cameras[1].images == std::vector<std::string>{"e1_c"});
  CHECK(report.cameras[2].epoch == "e2");
  CHECK(report.cameras[2].model == "OPENCV");
  CHECK(report.cameras[2].exact);
  CHECK(report.cameras[2].max_error_px < 1e-6);
  CHECK(report.max_conversion_error_px == std::max(report.cameras[0].max_error_px, report.cameras[1].max_error_px));
  // Shear cannot be held by OpenCV's models: a real, measured, sub-pixel error.
  CHECK(report.max_conversion_error_px > 1e-3);
  CHECK(report.max_conversion_error_px < 1.0);

  // cameras.json holds the exact cameras.
  const std::vector<CamerasJsonImage> json = read_cameras_json(report.cameras_json_path);
  REQUIRE(json.size() == images.size());
  CHECK(json[3].camera.params() == images[3].camera.params());

  RandomStream rng(5, 0);
  // Named references, not structured bindings: C++17 lambdas cannot capture a binding (clang refuses).
  for (const auto& epoch_folder : report.model_folders) {
    const std::string& epoch = epoch_folder.first;
    const ColmapModel model = read_colmap_text(epoch_folder.second);
    for (const auto& id_image : model.images) {
      const auto& image = id_image.second;
      const CamerasJsonImage& source = *std::find_if(images.begin(), images.end(),
                                                     [&](const CamerasJsonImage& i) { return i.name == image.name; });
      CHECK(source.epoch == epoch);
      const ColmapCamera& camera = model.cameras.at(image.camera_id);
      const AdjustedCameraConversion& conversion =
          *std::find_if(report.cameras.begin(), report.cameras.end(), [&](const AdjustedCameraConversion& c) {
            return c.epoch == epoch && c.camera_id == image.camera_id;
          });
      const Frame<FraserAffine> frame = source.frame();
      const Eigen::Vector4d q = detail::colmap_qvec(image.pose);
      const Vec3 t = image.pose.cam_from_world_translation();
      int tested = 0;
      for (int k = 0; k < 200; ++k) {
        // A ground point seen inside the image.
        // One draw per statement, y before x (core/random.hpp, "Order of draws").
        const double y = rng.uniform(0.0, camera.height - 1.0);
        const Vec2 pixel(rng.uniform(0.0, camera.width - 1.0), y);
        const std::optional<Ray3> ray = frame.ray(pixel);
        REQUIRE(ray);
        const Vec3 world = ray->origin + rng.uniform(1300.0, 1600.0) * ray->direction;
        const Vec2 colmap = diachron_pixel_from_colmap(test::colmap_projection(camera.model, camera.params, q, t, world));
        CHECK((colmap - *frame.project(world)).norm() <= 1.5 * conversion.max_error_px + 1e-6);
        ++tested;
      }
      CHECK(tested == 200);
    }
  }
}

TEST_CASE("write_adjusted_export: never writes into the input model, checks before writing", "[io]") {
  const std::string dir = export_folder("refuse");
  const std::vector<CamerasJsonImage> images = adjusted_images();
  // The input model is DIR/adjusted/e1 itself, reached through a symbolic link.
  fs::create_directories(dir + "/adjusted/e1");
  fs::create_directory_symlink(dir + "/adjusted/e1", dir + "/input_e1");
  AdjustedExportOptions options;
  options.protected_folders = {dir + "/input_e1"};
  CHECK_THROWS_WITH(write_adjusted_export(images, dir, options), Contains("never overwritten"));
  CHECK_FALSE(fs::exists(dir + "/adjusted/cameras.json"));
  CHECK(fs::is_empty(dir + "/adjusted/e1"));
  // Another input folder is fine.
  fs::create_directories(dir + "/e1");
  options.protected_folders = {dir + "/e1"};
  CHECK_NOTHROW(write_adjusted_export(images, dir, options));
  CHECK(fs::is_empty(dir + "/e1"));

  std::vector<CamerasJsonImage> bad = images;
  bad[2].name = bad[0].name;
  const std::string dir2 = export_folder("bad");
  CHECK_THROWS_WITH(write_adjusted_export(bad, dir2), Contains("two images named 'e1_a'"));
  bad = images;
  bad[1].epoch = "..";
  CHECK_THROWS_WITH(write_adjusted_export(bad, dir2), Contains("not a plain folder name"));
  bad = images;
  bad[1].name = "with space";
  CHECK_THROWS_AS(write_adjusted_export(bad, dir2), Error);
  CHECK_FALSE(fs::exists(dir2 + "/adjusted"));
  CHECK_THROWS_AS(write_adjusted_export(images, ""), Error);
}
