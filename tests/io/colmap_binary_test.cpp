// COLMAP binary models: COLMAP 3.8's own bytes read field by field and written back the same,
// text -> binary -> text round trips, truncated and corrupt files named with their byte offset,
// read_colmap_model's choice of form, and (when the binary is installed) COLMAP converting ours.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/random.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/io/colmap_binary.hpp>
#include <diachron/io/colmap_model.hpp>
#include <diachron/io/colmap_text.hpp>

#include "support/colmap_binary.hpp"
#include "support/temp_folder.hpp"

using namespace diachron;

namespace {

std::string colmapbin_folder(const std::string& name) { return diachron::test::fresh_temp_folder("colmapbin_" + name); }

std::string colmapbin_read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void colmapbin_write(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

std::string colmapbin_unhex(const std::string& hex) {
  std::string out;
  for (std::size_t k = 0; k + 1 < hex.size(); k += 2)
    out.push_back(static_cast<char>(std::stoi(hex.substr(k, 2), nullptr, 16)));
  return out;
}

// The tiny model below as COLMAP 3.8 wrote it (`colmap model_converter --output_type BIN` of
//   cameras.txt   3 PINHOLE 640 480 500 510 320.5 240.5
//   images.txt    1 1 0 0 0 1 2 3 3 a.png / 1.5 2.5 -1 3.5 4.5 7
//                 2 0 1 0 0 4 5 6 3 b/c.png / 10.25 20.75 7
//   points3D.txt  7 1 2 3 10 20 30 0.5 1 1 2 0),
// an oracle independent of our writer. COLMAP wrote image 2 first (its hash map's order); ours
// writes ids in order, so the images are kept record by record.
const std::string kColmapbinCameras =
    "0100000000000000" "03000000" "01000000" "8002000000000000" "e001000000000000"
    "0000000000407f40" "0000000000e07f40" "0000000000087440" "0000000000106e40";
const std::string kColmapbinImageCount = "0200000000000000";
const std::string kColmapbinImage2 =
    "020000000000000000000000000000000000f03f00000000000000000000000000000000000000000000104000000000"
    "00001440000000000000184003000000622f632e706e6700010000000000000000000000008024400000000000c03440"
    "0700000000000000";
const std::string kColmapbinImage1 =
    "01000000000000000000f03f000000000000000000000000000000000000000000000000000000000000f03f00000000"
    "00000040000000000000084003000000612e706e67000200000000000000000000000000f83f0000000000000440ffff"
    "ffffffffffff0000000000000c4000000000000012400700000000000000";
const std::string kColmapbinPoints =
    "0100000000000000" "0700000000000000" "000000000000f03f" "0000000000000040" "0000000000000840" "0a141e"
    "000000000000e03f" "0200000000000000" "01000000" "01000000" "02000000" "00000000";

// Writes the COLMAP-made tiny model into `dir` (images in COLMAP's order).
void colmapbin_write_oracle(const std::string& dir) {
  colmapbin_write(dir + "/cameras.bin", colmapbin_unhex(kColmapbinCameras));
  colmapbin_write(dir + "/images.bin", colmapbin_unhex(kColmapbinImageCount + kColmapbinImage2 + kColmapbinImage1));
  colmapbin_write(dir + "/points3D.bin", colmapbin_unhex(kColmapbinPoints));
}

// One draw per statement, the last argument first (docs/conventions.md, "Order of draws").
Pose colmapbin_pose(RandomStream& random) {
  const double z = random.uniform(100, 900), y = random.uniform(-500, 500);
  const Vec3 centre(random.uniform(-500, 500), y, z);
  return Pose(random_rotation(random), centre);
}

// Every camera model COLMAP 3.8 has (fisheyes too: the files hold them even where diachron has no
// counterpart), an image without 2D points, 2D points with and without 3D points, a point with
// an empty track and a large point id.
ColmapModel colmapbin_model() {
  RandomStream random(17);
  ColmapModel m;
  const std::vector<std::pair<std::string, std::vector<double>>> cameras = {
      {"SIMPLE_PINHOLE", {500.25, 200.5, 150.5}},
      {"PINHOLE", {500.25, 498.75, 201.5, 149.0}},
      {"SIMPLE_RADIAL", {400.0, 200.0, 150.0, -0.03}},
      {"RADIAL", {400.0, 200.0, 150.0, -0.03, 0.004}},
      {"OPENCV", {420.5, 421.25, 201.0, 148.5, -0.02, 0.003, 1.5e-4, -2e-4}},
      {"OPENCV_FISHEYE", {420.5, 421.25, 201.0, 148.5, -0.02, 0.003, 1e-4, -1e-5}},
      {"FULL_OPENCV", {420.5, 421.25, 201.0, 148.5, -0.02, 0.003, 1.5e-4, -2e-4, 1e-4, 1e-5, 0.0, -1e-6}},
      {"FOV", {420.5, 421.25, 201.0, 148.5, 0.9}},
      {"SIMPLE_RADIAL_FISHEYE", {400.0, 200.0, 150.0, -0.03}},
      {"RADIAL_FISHEYE", {400.0, 200.0, 150.0, -0.03, 0.004}},
      {"THIN_PRISM_FISHEYE", {420.5, 421.25, 201.0, 148.5, -0.02, 0.003, 1e-4, -1e-5, 2e-3, 1e-4, -3e-4, 2e-5}}};
  std::uint32_t id = 1;
  for (const auto& [model, params] : cameras) {
    m.cameras[id] = ColmapCamera{id, model, 400 + static_cast<int>(id), 300, params};
    ++id;
  }
  for (std::uint32_t i = 1; i <= 5; ++i) {
    ColmapImage image;
    image.id = 20 + 3 * i;
    image.name = (i == 2 ? "sub/folder/image_" : "image_") + std::to_string(i) + ".tif";
    image.camera_id = 1 + (2 * i) % 11;
    image.pose = colmapbin_pose(random);
    m.images[image.id] = image;
  }
  // Image 35 keeps no 2D points.
  const std::vector<std::vector<std::uint32_t>> tracks = {{23, 26}, {23, 26, 29}, {26, 29, 32}, {23, 32}, {}};
  std::uint64_t point_id = 5;
  for (const auto& images : tracks) {
    ColmapPoint3D p;
    p.id = point_id;
    const double z = random.uniform(0, 50), y = random.uniform(-100, 100);
    p.xyz = Vec3(random.uniform(-100, 100), y, z);
    p.rgb = {static_cast<std::uint8_t>(point_id), 200, 7};
    p.error = 0.1 * static_cast<double>(point_id % 13);
    for (std::uint32_t image_id : images) {
      ColmapImage& image = m.images.at(image_id);
      const double free_y = random.uniform(0, 300);
      image.points2d.push_back({Vec2(random.uniform(0, 400), free_y), kColmapNoPoint3D});
      p.track.push_back({image_id, static_cast<std::uint32_t>(image.points2d.size())});
      const double tied_y = random.uniform(0, 300);
      image.points2d.push_back({Vec2(random.uniform(0, 400), tied_y), static_cast<std::int64_t>(point_id)});
    }
    m.points3d[p.id] = p;
    point_id = point_id * 1000 + 1;  // up to 5e12: beyond 32 bits
  }
  return m;
}

// The first difference between two models, "none" when they are the same (a string Catch prints).
std::string colmapbin_difference(const ColmapModel& a, const ColmapModel& b) {
  return colmap_model_difference(a, b).value_or("none");
}

}  // namespace

TEST_CASE("colmap_binary: camera model ids are COLMAP's", "[io][colmap]") {
  const std::vector<std::string> names = {"SIMPLE_PINHOLE", "PINHOLE",        "SIMPLE_RADIAL",        "RADIAL",
                                          "OPENCV",         "OPENCV_FISHEYE", "FULL_OPENCV",          "FOV",
                                          "SIMPLE_RADIAL_FISHEYE", "RADIAL_FISHEYE", "THIN_PRISM_FISHEYE"};
  for (std::size_t k = 0; k < names.size(); ++k) {
    CHECK(colmap_camera_model_id(names[k]) == std::optional<int>(static_cast<int>(k)));
    CHECK(colmap_camera_model_name(static_cast<int>(k)) == std::optional<std::string_view>(names[k]));
    CHECK(colmap_camera_model_num_params(names[k]));  // the text reader knows it too
  }
  CHECK_FALSE(colmap_camera_model_id("FISHEYE"));
  CHECK_FALSE(colmap_camera_model_name(11));
  CHECK_FALSE(colmap_camera_model_name(-1));
}

TEST_CASE("colmap_binary: COLMAP 3.8's own files read field by field, and written back byte for byte",
          "[io][colmap]") {
  const std::string dir = colmapbin_folder("oracle");
  colmapbin_write_oracle(dir);
  const ColmapModel m = read_colmap_binary(dir);
  REQUIRE(m.cameras.size() == 1);
  const ColmapCamera& camera = m.cameras.at(3);
  CHECK(camera.id == 3);
  CHECK(camera.model == "PINHOLE");
  CHECK(camera.width == 640);
  CHECK(camera.height == 480);
  CHECK(camera.params == std::vector<double>{500, 510, 320.5, 240.5});
  REQUIRE(m.images.size() == 2);
  const ColmapImage& a = m.images.at(1);
  CHECK(a.name == "a.png");
  CHECK(a.camera_id == 3);
  CHECK(a.pose.cam_from_world_rotation() == Mat3::Identity());
  CHECK(a.pose.cam_from_world_translation() == Vec3(1, 2, 3));
  REQUIRE(a.points2d.size() == 2);
  CHECK(a.points2d[0].xy == Vec2(1.5, 2.5));
  CHECK(a.points2d[0].point3d_id == kColmapNoPoint3D);  // 2^64 - 1 in the file
  CHECK(a.points2d[1].xy == Vec2(3.5, 4.5));
  CHECK(a.points2d[1].point3d_id == 7);
  const ColmapImage& b = m.images.at(2);
  CHECK(b.name == "b/c.png");
  // q = (0, 1, 0, 0): 180 degrees about x; t = (4, 5, 6), so C = -R^T t = (-4, 5, 6).
  CHECK(b.pose.cam_from_world_rotation() == Vec3(1, -1, -1).asDiagonal().toDenseMatrix());
  CHECK(b.pose.centre() == Vec3(-4, 5, 6));
  REQUIRE(b.points2d.size() == 1);
  CHECK(b.points2d[0].xy == Vec2(10.25, 20.75));
  CHECK(b.points2d[0].point3d_id == 7);
  REQUIRE(m.points3d.size() == 1);
  const ColmapPoint3D& p = m.points3d.at(7);
  CHECK(p.xyz == Vec3(1, 2, 3));
  CHECK(p.rgb == std::array<std::uint8_t, 3>{{10, 20, 30}});
  CHECK(p.error == 0.5);
  CHECK(p.track == std::vector<ColmapTrackElement>{{1, 1}, {2, 0}});

  // Our writer gives COLMAP's bytes (images in id order).
  const std::string out = colmapbin_folder("oracle_out");
  write_colmap_binary(m, out);
  CHECK(colmapbin_read(out + "/cameras.bin") == colmapbin_unhex(kColmapbinCameras));
  CHECK(colmapbin_read(out + "/images.bin") == colmapbin_unhex(kColmapbinImageCount + kColmapbinImage1 + kColmapbinImage2));
  CHECK(colmapbin_read(out + "/points3D.bin") == colmapbin_unhex(kColmapbinPoints));
}

TEST_CASE("colmap_binary: text -> binary -> text gives the same model and the same text", "[io][colmap]") {
  const ColmapModel model = colmapbin_model();
  const std::string text = colmapbin_folder("rt_text"), binary = colmapbin_folder("rt_binary"),
                    from_text = colmapbin_folder("rt_from_text"), from_binary = colmapbin_folder("rt_from_binary");
  write_colmap_text(model, text);
  const ColmapModel read_text = read_colmap_text(text);
  write_colmap_binary(read_text, binary);
  const ColmapModel read_binary = read_colmap_binary(binary);
  CHECK(colmapbin_difference(read_text, read_binary) == "none");
  CHECK(colmapbin_difference(model, read_binary) == "none");
  CHECK(read_binary.points3d.at(5001001001).track.size() == 2);
  CHECK(read_binary.points3d.at(5001001001001).track.empty());
  CHECK(read_binary.images.at(35).points2d.empty());
  // Both read models written as text: the same cameras and points, byte for byte; images.txt the
  // same but for the poses' last digit (each goes through a rotation matrix and back to a quaternion).
  write_colmap_text(read_text, from_text);
  write_colmap_text(read_binary, from_binary);
  for (const char* file : {"/cameras.txt", "/points3D.txt"})
    CHECK(colmapbin_read(from_text + file) == colmapbin_read(from_binary + file));
  std::istringstream lines_text(colmapbin_read(from_text + "/images.txt")),
      lines_binary(colmapbin_read(from_binary + "/images.txt"));
  std::string a, b;
  int image_lines = 0;
  while (std::getline(lines_text, a) && std::getline(lines_binary, b)) {
    if (!a.empty() && a[0] == '#') {
      CHECK(a == b);
      continue;
    }
    if (image_lines++ % 2 == 1) {
      CHECK(a == b);  // POINTS2D (empty for image 35)
      continue;
    }
    // IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME: ids and name the same, numbers to rounding.
    std::istringstream fa(a), fb(b);
    std::vector<std::string> ta, tb;
    for (std::string f; fa >> f;) ta.push_back(f);
    for (std::string f; fb >> f;) tb.push_back(f);
    REQUIRE(ta.size() == 10);
    REQUIRE(tb.size() == 10);
    CHECK(ta[0] == tb[0]);
    CHECK(ta[8] == tb[8]);
    CHECK(ta[9] == tb[9]);
    // Quaternions to 1e-14; translations (hundreds of units here) to 1e-11, their rounding.
    for (std::size_t k = 1; k < 8; ++k) CHECK(std::abs(std::stod(ta[k]) - std::stod(tb[k])) <= (k < 5 ? 1e-14 : 1e-11));
  }
  CHECK(image_lines == 10);
  CHECK_FALSE(std::getline(lines_binary, b));
  // And binary again: cameras and points the same bytes, images the same model.
  const std::string again = colmapbin_folder("rt_again");
  write_colmap_binary(read_binary, again);
  for (const char* file : {"/cameras.bin", "/points3D.bin"})
    CHECK(colmapbin_read(binary + file) == colmapbin_read(again + file));
  CHECK(colmapbin_difference(read_colmap_binary(again), read_binary) == "none");
}

TEST_CASE("colmap_binary: every truncated file is an error naming the file and the byte", "[io][colmap]") {
  const std::string dir = colmapbin_folder("truncated");
  write_colmap_binary(colmapbin_model(), dir);
  int cases = 0;
  for (const char* name : {"cameras.bin", "images.bin", "points3D.bin"}) {
    const std::string path = dir + "/" + name;
    const std::string whole = colmapbin_read(path);
    // Lengths short of the whole file (the counts say more records, or a record is cut): every one
    // over the first 60 bytes and the last 60, every 11th in between (a second for all of them).
    for (std::size_t length = 0; length < whole.size(); length += (length < 60 || length + 60 > whole.size()) ? 1 : 11) {
      colmapbin_write(path, whole.substr(0, length));
      INFO(name << " cut to " << length << " of " << whole.size() << " bytes");
      CHECK_THROWS_WITH(read_colmap_binary(dir), Catch::Contains(std::string(name) + "' byte "));
      ++cases;
    }
    colmapbin_write(path, whole + std::string(1, '\0'));
    CHECK_THROWS_WITH(read_colmap_binary(dir), Catch::Contains(std::string(name) + "' byte " + std::to_string(whole.size())) &&
                                                   Catch::Contains("1 bytes follow the last record"));
    colmapbin_write(path, whole);
  }
  CHECK(cases > 400);
  CHECK_NOTHROW(read_colmap_binary(dir));
  std::remove((dir + "/images.bin").c_str());
  CHECK_THROWS_WITH(read_colmap_binary(dir), Catch::Contains("images.bin") && Catch::Contains("cannot be opened"));
}

TEST_CASE("colmap_binary: corrupt values and broken references name the file, byte and record", "[io][colmap]") {
  const std::string dir = colmapbin_folder("corrupt");
  struct Case {
    const char* file;
    std::size_t offset;  // where to patch the oracle's bytes (images in COLMAP's order: 2, then 1)
    std::string hex;     // the new bytes
    std::string where;
    std::string what;
  };
  // Offsets in the oracle: cameras.bin: count 0, id 8, model 12, width 16, height 24, params 32.
  // images.bin: count 0, image 2 at 8 (q 12, t 44, camera 68, name 72, num_points2D 80, points 88),
  // image 1 at 112 (num_points2D 182, first point's id at 206). points3D.bin: count 0, id 8, xyz 16,
  // rgb 40, error 43, track length 51, elements 59.
  const std::vector<Case> cases = {
      {"cameras.bin", 12, "2a000000", "cameras.bin' byte 12, camera record 1 of 1 (id 3)", "unknown camera model id 42"},
      {"cameras.bin", 12, "ffffffff", "cameras.bin' byte 12", "unknown camera model id -1"},
      {"cameras.bin", 16, "0000000000000000", "cameras.bin' byte 16", "the width 0 is outside"},
      {"cameras.bin", 24, "0000000001000000", "cameras.bin' byte 24", "the height 4294967296 is outside"},
      {"cameras.bin", 40, "000000000000f87f", "cameras.bin' byte 40", "a camera param is not a finite number"},
      {"cameras.bin", 0, "0200000000000000", "cameras.bin' byte 0", "needs at least 48 bytes each"},
      {"cameras.bin", 8, "ffffffff", "cameras.bin' byte 8, camera record 1 of 1", "COLMAP's invalid id"},
      {"images.bin", 0, "ffffffffffffffff", "images.bin' byte 0", "the number of images 18446744073709551615"},
      {"images.bin", 12, std::string(64, '0'), "images.bin' byte 12, image record 1 of 2 (id 2)", "quaternion"},
      {"images.bin", 44, "000000000000f0ff", "images.bin' byte 44", "TX is not a finite number"},
      {"images.bin", 68, "63000000", "images.bin' byte 8", "refers to camera 99, which cameras.bin does not have"},
      {"images.bin", 72, "00", "images.bin' byte 72, image record 1 of 2 (id 2)", "the image name is empty"},
      {"images.bin", 112, "02000000", "images.bin' byte 112, image record 2 of 2 (id 2)", "image id 2 appears twice"},
      {"images.bin", 182, "0300000000000000", "images.bin' byte 182", "num_points2D 3 needs at least 24 bytes each"},
      {"images.bin", 206, "0900000000000000", "images.bin' byte 182", "observes point3D 9, whose track does not contain it"},
      {"images.bin", 206, "feffffffffffffff", "images.bin' byte 206", "point3D id 18446744073709551614 is out of range"},
      {"points3D.bin", 16, "000000000000f87f", "points3D.bin' byte 16, point3D record 1 of 1 (id 7)", "X is not a finite number"},
      {"points3D.bin", 51, "0300000000000000", "points3D.bin' byte 51", "the track length 3 needs at least 8 bytes each"},
      {"points3D.bin", 59, "05000000", "points3D.bin' byte 8", "track element (5, 1) of point3D 7: no image 5"},
      {"points3D.bin", 63, "09000000", "points3D.bin' byte 8", "image 1 has 2 2D points"},
      {"points3D.bin", 63, "00000000", "points3D.bin' byte 8", "that 2D point observes point3D -1"},
      {"points3D.bin", 8, "0800000000000000", "points3D.bin' byte 8", "observes point3D 7"},
  };
  for (const Case& c : cases) {
    INFO(c.file << " at " << c.offset << ": " << c.hex);
    colmapbin_write_oracle(dir);
    const std::string path = dir + "/" + c.file;
    std::string bytes = colmapbin_read(path);
    const std::string patch = colmapbin_unhex(c.hex);
    REQUIRE(c.offset + patch.size() <= bytes.size());
    bytes.replace(c.offset, patch.size(), patch);
    colmapbin_write(path, bytes);
    CHECK_THROWS_WITH(read_colmap_binary(dir), Catch::Contains(c.where) && Catch::Contains(c.what));
  }
  // An unterminated name: image 1's file cut inside "a.png".
  colmapbin_write_oracle(dir);
  colmapbin_write(dir + "/images.bin",
                  colmapbin_unhex(kColmapbinImageCount + kColmapbinImage2 + kColmapbinImage1.substr(0, 2 * 67)));
  CHECK_THROWS_WITH(read_colmap_binary(dir), Catch::Contains("images.bin' byte 176, image record 2 of 2 (id 1)") &&
                                                 Catch::Contains("no terminating"));
}

TEST_CASE("colmap_binary: the writer refuses what the files cannot hold", "[io][colmap]") {
  ColmapModel model = colmapbin_model();
  model.images.at(23).points2d.at(1).point3d_id = 99;
  CHECK_THROWS_WITH(write_colmap_binary(model, colmapbin_folder("refused")), Catch::Contains("point3D 99"));
  model = colmapbin_model();
  model.cameras.at(1).params[0] = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(write_colmap_binary(model, colmapbin_folder("refused")), Catch::Contains("non-finite param"));
  model = colmapbin_model();
  model.images.at(23).name = std::string("a\0b", 3);
  CHECK_THROWS_WITH(write_colmap_binary(model, colmapbin_folder("refused")), Catch::Contains("'\\0'"));
  model = colmapbin_model();
  model.cameras.at(1).model = "FISHEYE";
  CHECK_THROWS_AS(write_colmap_binary(model, colmapbin_folder("refused")), Error);
  // White space is fine in a binary name (COLMAP's text reader would cut it; ours refuses it).
  model = colmapbin_model();
  model.images.at(23).name = "with space.png";
  const std::string spaced = colmapbin_folder("spaced");
  write_colmap_binary(model, spaced);
  CHECK(read_colmap_binary(spaced).images.at(23).name == "with space.png");
}

TEST_CASE("read_colmap_model: the form the folder holds; both only when they agree", "[io][colmap]") {
  const ColmapModel model = colmapbin_model();
  ColmapFormat format = ColmapFormat::binary;
  const std::string text = colmapbin_folder("model_text");
  write_colmap_model(model, text);  // text by default
  CHECK(has_colmap_model(text, ColmapFormat::text));
  CHECK_FALSE(has_colmap_model(text, ColmapFormat::binary));
  CHECK(colmapbin_difference(read_colmap_model(text, &format), model) == "none");
  CHECK(format == ColmapFormat::text);

  const std::string binary = colmapbin_folder("model_binary");
  write_colmap_model(model, binary, ColmapFormat::binary);
  CHECK(colmapbin_difference(read_colmap_model(binary, &format), model) == "none");
  CHECK(format == ColmapFormat::binary);
  CHECK_FALSE(has_colmap_model(binary, ColmapFormat::text));

  // Both forms of one model: read (the binary one).
  write_colmap_model(model, binary, ColmapFormat::text);
  format = ColmapFormat::text;
  CHECK_NOTHROW(read_colmap_model(binary, &format));
  CHECK(format == ColmapFormat::binary);
  // The text one edited since: refused, saying where.
  ColmapModel edited = model;
  edited.images.at(26).name = "renamed.tif";
  write_colmap_text(edited, binary);
  CHECK_THROWS_WITH(read_colmap_model(binary),
                    Catch::Contains("differ") &&
                        Catch::Contains("image 26: name 'sub/folder/image_2.tif' against 'renamed.tif'") &&
                        Catch::Contains("remove the stale one"));
  edited = model;
  edited.points3d.at(5).error = 9.0;
  write_colmap_text(edited, binary);
  CHECK_THROWS_WITH(read_colmap_model(binary), Catch::Contains("point3D 5: position, colour or error differ"));
  // A partial model names the missing file; no model at all says so.
  std::remove((binary + "/points3D.txt").c_str());
  CHECK_THROWS_WITH(read_colmap_model(binary), Catch::Contains("points3D.txt") && Catch::Contains("cannot be opened"));
  CHECK_THROWS_WITH(read_colmap_model(colmapbin_folder("empty")), Catch::Contains("holds no COLMAP model"));
  CHECK(std::string(colmap_format_name(ColmapFormat::binary)) == "binary");
  CHECK(colmap_file_name("images", ColmapFormat::text) == "images.txt");
}

TEST_CASE("colmap_binary: COLMAP 3.8 converts our binary model to the text we write, and reads its own back",
          "[io][colmap]") {
  const std::optional<std::string> colmap = test::colmap_binary();
  if (!colmap) {
    WARN("skipped: the colmap binary is not installed (scripts/install_deps.sh installs it; DIACHRON_COLMAP names it)");
    return;
  }
  const ColmapModel model = colmapbin_model();
  const std::string ours = colmapbin_folder("colmap_ours"), to_text = colmapbin_folder("colmap_to_text"),
                    our_text = colmapbin_folder("colmap_our_text"), to_binary = colmapbin_folder("colmap_to_binary");
  write_colmap_binary(model, ours);
  write_colmap_text(model, our_text);
  const std::string log = ours + "/../colmapbin_colmap.log";
  const auto run = [&](const std::string& arguments) {
    const std::string command = "'" + *colmap + "' " + arguments + " > '" + log + "' 2>&1";
    const int status = std::system(command.c_str());
    INFO(command << "\n" << colmapbin_read(log));
    return status;
  };
  REQUIRE(run("model_converter --input_path '" + ours + "' --output_path '" + to_text + "' --output_type TXT") == 0);
  const ColmapModel colmap_text = read_colmap_text(to_text);
  CHECK(colmapbin_difference(colmap_text, read_colmap_text(our_text)) == "none");
  CHECK(colmapbin_difference(colmap_text, model) == "none");
  // COLMAP's own binary of our text (its hash-map order, its quaternions) reads as the same model.
  REQUIRE(run("model_converter --input_path '" + our_text + "' --output_path '" + to_binary + "' --output_type BIN") == 0);
  CHECK(colmapbin_difference(read_colmap_binary(to_binary), model) == "none");

  REQUIRE(run("model_analyzer --path '" + ours + "'") == 0);
  const std::string report = colmapbin_read(log);
  INFO(report);
  CHECK_THAT(report, Catch::Contains("Cameras: 11"));
  CHECK_THAT(report, Catch::Contains("Images: 5"));
  CHECK_THAT(report, Catch::Contains("Registered images: 5"));
  CHECK_THAT(report, Catch::Contains("Points: 5"));
  CHECK_THAT(report, Catch::Contains("Observations: 10"));
}
