// Epoch folders with a binary COLMAP model (as COLMAP writes it): read as the text ones are, with
// the messages naming the .bin files; a text model beside it only when the two agree.

#include <cstdio>
#include <string>

#include <unistd.h>

#include <catch2/catch.hpp>

#include <diachron/core/raster.hpp>
#include <diachron/io/colmap_binary.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/geotiff.hpp>

#include "support/temp_folder.hpp"

using namespace diachron;

namespace {

// One 40 x 30 px PINHOLE image "sub/a.png" (id 4) looking down from 100 units over a flat DSM at 0.
ColmapModel epochbin_model() {
  ColmapModel m;
  m.cameras[2] = ColmapCamera{2, "PINHOLE", 40, 30, {50.0, 52.0, 20.5, 15.0}};
  ColmapImage image;
  image.id = 4;
  image.name = "sub/a.png";
  image.camera_id = 2;
  image.pose = Pose::look_at(Vec3(10, 20, 100), Vec3(10, 20, 0));
  m.images[4] = image;
  return m;
}

// The epoch folder `name` with `model` in binary, its image and a flat DSM.
std::string epochbin_folder(const std::string& name, const ColmapModel& model) {
  const std::string dir = diachron::test::fresh_temp_folder("epochbin_" + name);
  write_colmap_binary(model, dir);
  make_folders(dir + "/images/sub", "epochbin_folder");
  Raster<std::uint8_t> pixels(40, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) pixels(x, y) = static_cast<std::uint8_t>(3 * x + 5 * y);
  write_image_u8(pixels, dir + "/images/sub/a.png");
  Raster<float> z(20, 20);
  for (float& v : z) v = 0.0f;
  write_geotiff_dsm(Dsm(z, GeoTransform::north_up(-40.0, 70.0, 5.0)), dir + "/dsm.tif");
  return dir;
}

}  // namespace

TEST_CASE("read_epoch_folder: a binary COLMAP model reads as the text one", "[io]") {
  const ColmapModel model = epochbin_model();
  const std::string dir = epochbin_folder("binary", model);
  const EpochFolder folder = read_epoch_folder(dir);
  CHECK(folder.model_format == ColmapFormat::binary);
  REQUIRE(folder.images.size() == 1);
  const EpochImage& image = folder.images[0];
  CHECK(image.id == 4);
  CHECK(image.name == "sub/a.png");
  CHECK(image.path == dir + "/images/sub/a.png");
  // PINHOLE: f = fy, B1 = fx - fy, principal point - 0.5 (diachron pixels).
  CHECK(image.frame.camera().focal() == 52.0);
  CHECK(image.frame.camera().cx() == 20.0);
  CHECK(image.frame.camera().cy() == 14.5);
  CHECK((image.frame.pose().centre() - Vec3(10, 20, 100)).norm() < 1e-12);
  CHECK(folder.load_image(0)(3, 2) == 3 * 3 + 5 * 2);

  // The same model as text beside it: read; a text model that differs: refused, naming both.
  write_colmap_text(model, dir);
  CHECK(read_epoch_folder(dir).model_format == ColmapFormat::binary);
  ColmapModel moved = model;
  moved.images.at(4).pose = Pose::look_at(Vec3(10, 20, 90), Vec3(10, 20, 0));
  write_colmap_text(moved, dir);
  CHECK_THROWS_WITH(read_epoch_folder(dir), Catch::Contains("holds a binary and a text COLMAP model that differ") &&
                                                Catch::Contains("image 4: pose"));
  for (const char* file : {"/cameras.txt", "/images.txt", "/points3D.txt"}) std::remove((dir + file).c_str());

  // Messages name the binary files.
  const std::string image_file = dir + "/images/sub/a.png";
  REQUIRE(std::rename(image_file.c_str(), (image_file + ".away").c_str()) == 0);
  CHECK_THROWS_WITH(read_epoch_folder(dir), Catch::Contains("image 'sub/a.png' (id 4 in images.bin) is missing from images/"));
  write_image_u8(Raster<std::uint8_t>(20, 30), image_file);
  const EpochFolder wrong = read_epoch_folder(dir);
  CHECK_THROWS_WITH(wrong.load_image(0), Catch::Contains("is 20 x 30 px but its camera in " + dir + "/cameras.bin is 40 x 30"));
  ColmapModel empty = model;
  empty.images.clear();
  write_colmap_binary(empty, dir);
  CHECK_THROWS_WITH(read_epoch_folder(dir), Catch::Contains("images.bin lists no image"));
  // A broken binary file stops the read with its name and byte.
  const std::string cut = epochbin_folder("cut", model);
  REQUIRE(::truncate((cut + "/images.bin").c_str(), 30) == 0);
  CHECK_THROWS_WITH(read_epoch_folder(cut), Catch::Contains("images.bin' byte 0: the number of images 1 needs at least"));
}
