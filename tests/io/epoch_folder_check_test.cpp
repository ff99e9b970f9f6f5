#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/raster.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/epoch_folder_check.hpp>
#include <diachron/io/geotiff.hpp>

#include "support/temp_folder.hpp"

namespace {

// The terrain of the check's epoch folders: rolling relief, so that a horizontal offset of the
// model shows in its heights.
double efcheck_height(double x, double y) { return 100.0 + 15.0 * std::sin(x / 23.0) * std::cos(y / 31.0); }

// Writes an epoch folder: a 1 unit DSM over [0, 1000]^2, one PINHOLE camera (f 500 px, 400 x 300)
// looking straight down from 400 units above (GSD 0.6), `images` images along x, 300 model points
// on the terrain seen by each image, every point moved by `offset`; images of `image_size`.
std::string efcheck_folder(const std::string& name, const Eigen::Vector3d& offset, int images = 2,
                           Eigen::Vector2i image_size = Eigen::Vector2i(400, 300),
                           const Eigen::Vector3d& camera_shift = Eigen::Vector3d::Zero()) {
  const std::string dir = diachron::test::fresh_temp_folder(name);
  diachron::Raster<float> z(1000, 1000);
  const diachron::GeoTransform geo = diachron::GeoTransform::north_up(0.0, 1000.0, 1.0);
  for (int y = 0; y < 1000; ++y)
    for (int x = 0; x < 1000; ++x) {
      const Eigen::Vector2d p = geo.pixel_to_world({x, y});
      z(x, y) = static_cast<float>(efcheck_height(p.x(), p.y()));
    }
  diachron::write_geotiff_dsm(diachron::Dsm(z, geo), dir + "/dsm.tif");
  std::filesystem::create_directories(dir + "/images");
  diachron::ColmapModel model;
  model.cameras[1] = diachron::ColmapCamera{1, "PINHOLE", 400, 300, {500.0, 500.0, 200.0, 150.0}};
  const Eigen::Matrix3d down = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();  // world -> camera, nadir
  for (int i = 0; i < images; ++i) {
    diachron::ColmapImage image;
    image.id = static_cast<std::uint32_t>(i + 1);
    image.name = "im" + std::to_string(i) + ".png";
    image.camera_id = 1;
    image.pose = diachron::Pose(down, Eigen::Vector3d(400.0 + 100.0 * i, 500.0, 500.0) + camera_shift);
    model.images[image.id] = image;
    diachron::Raster<std::uint8_t> pixels(image_size.x(), image_size.y(), 128);
    diachron::write_image_u8(pixels, dir + "/images/" + image.name);
  }
  // Points on the terrain within the first image's footprint (+- 100 x 75 units around its nadir).
  std::uint64_t id = 1;
  for (int k = 0; k < 300; ++k, ++id) {
    const double x = 320.0 + 160.0 * ((k * 37) % 300) / 300.0, y = 440.0 + 120.0 * ((k * 91) % 300) / 300.0;
    diachron::ColmapPoint3D point;
    point.id = id;
    point.xyz = Eigen::Vector3d(x, y, efcheck_height(x, y)) + offset;
    for (auto& [image_id, image] : model.images) {
      point.track.push_back({image_id, static_cast<std::uint32_t>(image.points2d.size())});
      image.points2d.push_back({Eigen::Vector2d(200.0, 150.0), static_cast<std::int64_t>(id)});
    }
    model.points3d[id] = point;
  }
  diachron::write_colmap_text(model, dir);
  return dir;
}

bool efcheck_has(const diachron::EpochFolderCheck& c, const std::string& check, diachron::EpochCheckSeverity s) {
  for (const diachron::EpochCheckIssue& i : c.issues)
    if (i.check == check && i.severity == s) return true;
  return false;
}

}  // namespace

TEST_CASE("check_epoch_folder: a model on its DSM passes without a finding", "[io][epoch_folder_check]") {
  const diachron::EpochFolder e = diachron::read_epoch_folder(efcheck_folder("efcheck_ok", Eigen::Vector3d::Zero()));
  const diachron::EpochFolderCheck c = diachron::check_epoch_folder(e);
  CHECK(c.issues.empty());
  CHECK_FALSE(c.refused());
  CHECK(c.agreement.verdict == diachron::ModelDsmVerdict::agree);
  CHECK(c.gsd == Approx(0.8).epsilon(0.05));  // 400 units above a ground at 100: 400 / 500 per px
  REQUIRE(c.footprint_share.size() == 2);
  CHECK(c.footprint_share[0] == 1.0);
  CHECK(c.unreadable_images == 0);
  CHECK(c.wrong_size_images == 0);
}

TEST_CASE("check_epoch_folder: a model far above its DSM is refused with the figures and a remedy",
          "[io][epoch_folder_check]") {
  const diachron::EpochFolder e =
      diachron::read_epoch_folder(efcheck_folder("efcheck_up", Eigen::Vector3d(0.0, 0.0, 130.0)));
  const diachron::EpochFolderCheck c = diachron::check_epoch_folder(e);
  CHECK(c.refused());
  CHECK(c.agreement.verdict == diachron::ModelDsmVerdict::gross);
  CHECK(c.agreement.median_dz == Approx(130.0).margin(0.5));
  REQUIRE(efcheck_has(c, "model_dsm", diachron::EpochCheckSeverity::refusal));
  for (const diachron::EpochCheckIssue& i : c.issues)
    if (i.check == "model_dsm") {
      CHECK(i.what.find("130") != std::string::npos);
      CHECK(i.remedy.find("DSM's frame") != std::string::npos);
    }
}

TEST_CASE("check_epoch_folder: a model shifted sideways is refused and the shift found", "[io][epoch_folder_check]") {
  const diachron::EpochFolder e =
      diachron::read_epoch_folder(efcheck_folder("efcheck_side", Eigen::Vector3d(12.0, -9.0, 0.0)));
  const diachron::EpochFolderCheck c = diachron::check_epoch_folder(e);
  CHECK(c.refused());
  CHECK(c.agreement.best_offset.x() == Approx(-12.0).margin(1.01));
  CHECK(c.agreement.best_offset.y() == Approx(9.0).margin(1.01));
}

TEST_CASE("check_epoch_folder: a small vertical offset warns and does not refuse", "[io][epoch_folder_check]") {
  // 1.5 tolerances (tolerance max(3 cells, 3 x 0.8 GSD) = 3 units): mild.
  const diachron::EpochFolder e =
      diachron::read_epoch_folder(efcheck_folder("efcheck_mild", Eigen::Vector3d(0.0, 0.0, 4.5)));
  const diachron::EpochFolderCheck c = diachron::check_epoch_folder(e);
  CHECK(c.agreement.verdict == diachron::ModelDsmVerdict::mild);
  CHECK_FALSE(c.refused());
  CHECK(efcheck_has(c, "model_dsm", diachron::EpochCheckSeverity::warning));
}

TEST_CASE("check_epoch_folder: images of another size than their camera, or unreadable, are refused",
          "[io][epoch_folder_check]") {
  {
    const diachron::EpochFolder e = diachron::read_epoch_folder(
        efcheck_folder("efcheck_size", Eigen::Vector3d::Zero(), 2, Eigen::Vector2i(800, 600)));
    const diachron::EpochFolderCheck c = diachron::check_epoch_folder(e);
    CHECK(c.wrong_size_images == 2);
    CHECK(c.refused());
    CHECK(efcheck_has(c, "image_file", diachron::EpochCheckSeverity::refusal));
  }
  {
    const std::string dir = efcheck_folder("efcheck_corrupt", Eigen::Vector3d::Zero());
    std::ofstream(dir + "/images/im1.png") << "not an image";
    const diachron::EpochFolder e = diachron::read_epoch_folder(dir);
    const diachron::EpochFolderCheck c = diachron::check_epoch_folder(e);
    CHECK(c.unreadable_images == 1);
    CHECK(c.refused());
    diachron::EpochFolderCheckOptions no_files;
    no_files.check_image_files = false;
    CHECK_FALSE(diachron::check_epoch_folder(e, no_files).refused());
  }
}

TEST_CASE("check_epoch_folder: images that miss the DSM", "[io][epoch_folder_check]") {
  // The cameras 5000 units east of the DSM, the points on it: no footprint meets it.
  const diachron::EpochFolder e = diachron::read_epoch_folder(
      efcheck_folder("efcheck_away", Eigen::Vector3d::Zero(), 2, Eigen::Vector2i(400, 300), Eigen::Vector3d(5000, 0, 0)));
  const diachron::EpochFolderCheck c = diachron::check_epoch_folder(e);
  CHECK(c.footprint_share == std::vector<double>{0.0, 0.0});
  CHECK_FALSE(efcheck_has(c, "footprint", diachron::EpochCheckSeverity::note));
  CHECK(efcheck_has(c, "footprint", diachron::EpochCheckSeverity::refusal));
  CHECK(c.refused());
  diachron::EpochFolderCheckOptions bad;
  bad.footprint_grid = 1;
  CHECK_THROWS_AS(diachron::check_epoch_folder(e, bad), diachron::Error);
  // A default-constructed check (not run) counts as refused: its default means failure.
  CHECK(diachron::EpochFolderCheck{}.refused());
}

TEST_CASE("check_epoch_folder: images partly beyond the DSM are a note, not a warning", "[io][epoch_folder_check]") {
  // Nadirs at x = 1000 and 1100 on a DSM that ends at 1000: about half and a fifth of the footprints.
  const diachron::EpochFolder e = diachron::read_epoch_folder(
      efcheck_folder("efcheck_edge", Eigen::Vector3d::Zero(), 2, Eigen::Vector2i(400, 300), Eigen::Vector3d(600, 0, 0)));
  const diachron::EpochFolderCheck c = diachron::check_epoch_folder(e);
  REQUIRE(c.footprint_share.size() == 2);
  CHECK(c.footprint_share[0] > 0.3);
  CHECK(c.footprint_share[0] < 0.7);
  CHECK(c.footprint_share[1] < c.footprint_share[0]);
  CHECK(efcheck_has(c, "footprint", diachron::EpochCheckSeverity::note));
  CHECK_FALSE(efcheck_has(c, "footprint", diachron::EpochCheckSeverity::warning));
  CHECK_FALSE(c.refused());
}
