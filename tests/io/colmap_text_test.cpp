// COLMAP text models: round trips, pixel and pose conventions against COLMAP's own formulas, errors
// that name the file and line, and (when the binary is installed) COLMAP itself reading our files.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include <diachron/camera/frame.hpp>
#include <diachron/core/random.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/io/colmap_text.hpp>

#include "support/colmap_binary.hpp"
#include "support/colmap_projection.hpp"
#include "support/temp_folder.hpp"

using namespace diachron;

namespace {

std::string colmap_folder(const std::string& name) { return diachron::test::fresh_temp_folder("colmap_" + name); }

bool test_file_exists(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0;
}

void write_file(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// One draw per statement, the last argument first (z, y, x, then the rotation): the order of a
// call's arguments is unspecified (core/random.hpp, "Order of draws"); the model was made so.
Pose random_pose(RandomStream& random) {
  const double z = random.uniform(100, 900), y = random.uniform(-500, 500);
  const Vec3 centre(random.uniform(-500, 500), y, z);
  return Pose(random_rotation(random), centre);
}

// A small model with every supported camera model, an image without 2D points, 2D points with and
// without 3D points, and tracks of length 2 and 3.
ColmapModel sample_model() {
  RandomStream random(5);
  ColmapModel m;
  const std::vector<std::pair<std::string, std::vector<double>>> cameras = {
      {"SIMPLE_PINHOLE", {500.25, 200.5, 150.5}},
      {"PINHOLE", {500.25, 498.75, 201.5, 149.0}},
      {"SIMPLE_RADIAL", {400.0, 200.0, 150.0, -0.03}},
      {"RADIAL", {400.0, 200.0, 150.0, -0.03, 0.004}},
      {"OPENCV", {420.5, 421.25, 201.0, 148.5, -0.02, 0.003, 1.5e-4, -2e-4}},
      {"FULL_OPENCV", {420.5, 421.25, 201.0, 148.5, -0.02, 0.003, 1.5e-4, -2e-4, 1e-4, 0.0, 0.0, 0.0}}};
  std::uint32_t id = 1;
  for (const auto& [model, params] : cameras) {
    m.cameras[id] = ColmapCamera{id, model, 400, 300, params};
    ++id;
  }
  for (std::uint32_t i = 1; i <= 4; ++i) {
    ColmapImage image;
    image.id = 10 + i;
    image.name = "folder/image_" + std::to_string(i) + ".png";
    image.camera_id = 1 + (i % 6);
    image.pose = random_pose(random);
    m.images[image.id] = image;
  }
  // Image 14 keeps no 2D points (an empty POINTS2D line).
  const std::vector<std::vector<std::uint32_t>> tracks = {{11, 12}, {11, 12, 13}, {12, 13}, {11, 13}};
  std::uint64_t point_id = 7;
  for (const auto& images : tracks) {
    ColmapPoint3D p;
    p.id = point_id;
    const double z = random.uniform(0, 50), y = random.uniform(-100, 100);
    p.xyz = Vec3(random.uniform(-100, 100), y, z);
    p.rgb = {static_cast<std::uint8_t>(point_id), 20, 255};
    p.error = 0.125 * static_cast<double>(point_id);
    for (std::uint32_t image_id : images) {
      ColmapImage& image = m.images.at(image_id);
      // A 2D point without a 3D point first, so indices are not the point order.
      const double free_y = random.uniform(0, 300);
      image.points2d.push_back({Vec2(random.uniform(0, 400), free_y), kColmapNoPoint3D});
      p.track.push_back({image_id, static_cast<std::uint32_t>(image.points2d.size())});
      const double tied_y = random.uniform(0, 300);
      image.points2d.push_back({Vec2(random.uniform(0, 400), tied_y), static_cast<std::int64_t>(point_id)});
    }
    m.points3d[p.id] = p;
    point_id += 3;
  }
  return m;
}

void check_same_model(const ColmapModel& a, const ColmapModel& b, double pose_tolerance) {
  REQUIRE(a.cameras.size() == b.cameras.size());
  for (const auto& [id, camera] : a.cameras) {
    const ColmapCamera& other = b.cameras.at(id);
    CHECK(other.id == id);
    CHECK(other.model == camera.model);
    CHECK(other.width == camera.width);
    CHECK(other.height == camera.height);
    CHECK(other.params == camera.params);
  }
  REQUIRE(a.images.size() == b.images.size());
  for (const auto& [id, image] : a.images) {
    const ColmapImage& other = b.images.at(id);
    CHECK(other.name == image.name);
    CHECK(other.camera_id == image.camera_id);
    CHECK((other.pose.cam_from_world_rotation() - image.pose.cam_from_world_rotation()).cwiseAbs().maxCoeff() <=
          pose_tolerance);
    CHECK((other.pose.centre() - image.pose.centre()).norm() <= pose_tolerance * (1.0 + image.pose.centre().norm()));
    REQUIRE(other.points2d.size() == image.points2d.size());
    for (std::size_t k = 0; k < image.points2d.size(); ++k) {
      CHECK(other.points2d[k].xy == image.points2d[k].xy);
      CHECK(other.points2d[k].point3d_id == image.points2d[k].point3d_id);
    }
  }
  REQUIRE(a.points3d.size() == b.points3d.size());
  for (const auto& [id, p] : a.points3d) {
    const ColmapPoint3D& other = b.points3d.at(id);
    CHECK(other.xyz == p.xyz);
    CHECK(other.rgb == p.rgb);
    CHECK(other.error == p.error);
    CHECK(other.track == p.track);
  }
}

// The raw QW QX QY QZ TX TY TZ of an image as written in images.txt (not through our reader).
void raw_pose(const std::string& images_txt, std::uint32_t image_id, Eigen::Vector4d& q, Vec3& t) {
  std::istringstream in(read_file(images_txt));
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::uint32_t id = 0;
    fields >> id >> q[0] >> q[1] >> q[2] >> q[3] >> t[0] >> t[1] >> t[2];
    if (id == image_id) return;
    std::getline(in, line);  // its POINTS2D
  }
  FAIL("image " << image_id << " not in " << images_txt);
}

}  // namespace

TEST_CASE("colmap_text: write then read gives the same model", "[io][colmap]") {
  const ColmapModel model = sample_model();
  const std::string dir = colmap_folder("roundtrip");
  write_colmap_text(model, dir);
  const ColmapModel back = read_colmap_text(dir);
  check_same_model(model, back, 1e-15);
  // Image 14 has no 2D points: its POINTS2D line is empty and must not swallow the next image.
  CHECK(back.images.at(14).points2d.empty());
  CHECK(back.find_image("folder/image_3.png") == std::optional<std::uint32_t>(13));
  CHECK_FALSE(back.find_image("image_3.png"));
  // Written again, cameras and points are the same bytes (poses go through a rotation matrix, so
  // their last digit may move).
  const std::string again = colmap_folder("roundtrip_again");
  write_colmap_text(back, again);
  for (const char* file : {"/cameras.txt", "/points3D.txt"}) CHECK(read_file(dir + file) == read_file(again + file));
}

TEST_CASE("colmap_text: comments, blank lines and CRLF as COLMAP writes and accepts them", "[io][colmap]") {
  const std::string dir = colmap_folder("comments");
  write_file(dir + "/cameras.txt",
             "# Camera list with one line of data per camera:\r\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\r\n"
             "\r\n3 PINHOLE 640 480 500 510 320.5 240.5\r\n  # indented comment\n");
  write_file(dir + "/images.txt",
             "# Image list with two lines of data per image:\n\n"
             "1 1 0 0 0 1 2 3 3 a.png\n"
             "10.5 20.5 -1 30.5 40.5 5\n"
             "# between images\n"
             "2 0 1 0 0 0 0 0 3 b.png\n"
             "\n"
             "5 0 0 1 0 4 5 6 3 c.png\n"
             "1.5 2.5 5\n");
  write_file(dir + "/points3D.txt", "# 3D point list\n5 1 2 3 255 128 0 0.5 1 1 5 0\n");
  const ColmapModel m = read_colmap_text(dir);
  REQUIRE(m.cameras.size() == 1);
  CHECK(m.cameras.at(3).params == std::vector<double>{500, 510, 320.5, 240.5});
  REQUIRE(m.images.size() == 3);
  CHECK(m.images.at(1).points2d.size() == 2);
  CHECK(m.images.at(1).points2d[1].xy == Vec2(30.5, 40.5));
  CHECK(m.images.at(2).points2d.empty());
  CHECK(m.images.at(5).points2d.size() == 1);
  CHECK(m.images.at(1).pose.centre().isApprox(Vec3(-1, -2, -3), 1e-15));
  // q = (0, 1, 0, 0): 180 degrees about x; C = -R^T t.
  CHECK(m.images.at(2).pose.cam_from_world_rotation().isApprox(Vec3(1, -1, -1).asDiagonal().toDenseMatrix(), 1e-15));
  CHECK(m.points3d.at(5).rgb == std::array<std::uint8_t, 3>{{255, 128, 0}});
  CHECK(m.points3d.at(5).track == std::vector<ColmapTrackElement>{{1, 1}, {5, 0}});
}

TEST_CASE("colmap_text: a diachron camera and pose project where COLMAP's formulas put the pixel, minus 0.5",
          "[io][colmap]") {
  RandomStream random(11);
  // Every COLMAP model read from a file, converted to a diachron camera.
  const ColmapModel model = sample_model();
  const std::string dir = colmap_folder("projection");
  write_colmap_text(model, dir);
  const ColmapModel back = read_colmap_text(dir);
  int compared = 0;
  for (const auto& [camera_id, camera] : back.cameras) {
    const ConversionResult<Camera<FraserAffine>> converted = camera_from_colmap(camera);
    CHECK(converted.exact);
    for (const auto& [image_id, image] : back.images) {
      Eigen::Vector4d q;
      Vec3 t;
      raw_pose(dir + "/images.txt", image_id, q, t);
      const Frame<FraserAffine> frame(converted.model, image.pose);
      for (int k = 0; k < 20; ++k) {
        // Points in front of the camera, spread over the image.
        // One draw per statement, y before x (core/random.hpp, "Order of draws").
        const double y = random.uniform(-0.45, 0.45);
        const Vec3 cam(random.uniform(-0.6, 0.6), y, 1.0);
        const Vec3 world = image.pose.world_from_cam(cam * random.uniform(50, 500));
        const std::optional<Vec2> px = frame.project(world);
        REQUIRE(px);
        const Vec2 colmap = test::colmap_projection(camera.model, camera.params, q, t, world);
        CHECK((*px - (colmap - Vec2(0.5, 0.5))).norm() < 1e-8);
        ++compared;
      }
    }
  }
  CHECK(compared == 6 * 4 * 20);
}

TEST_CASE("colmap_text: Fraser P1 (r^2 + 2x^2 in x) is OpenCV's p2; B1 is fx - fy", "[io][colmap]") {
  // P1 only: OpenCV must carry it as p2.
  const Camera<FraserAffine> p1_only(300.0, 199.5, 149.5, 400, 300, {0.0, 0.0, 0.0, 1e-3, 0.0, 0.0, 0.0});
  const ConversionResult<ColmapCamera> a = colmap_camera_from_camera(p1_only, 4);
  CHECK(a.exact);
  CHECK(a.model.id == 4);
  CHECK(a.model.model == "OPENCV");
  CHECK(a.model.params == std::vector<double>{300.0, 300.0, 200.0, 150.0, 0.0, 0.0, 0.0, 1e-3});
  // P2 and B1: p1 and fx = f + B1.
  const Camera<FraserAffine> p2_b1(300.0, 199.5, 149.5, 400, 300, {0.0, 0.0, 0.0, 0.0, -2e-3, 0.75, 0.0});
  CHECK(colmap_camera_from_camera(p2_b1, 1).model.params ==
        std::vector<double>{300.75, 300.0, 200.0, 150.0, 0.0, 0.0, -2e-3, 0.0});
  // K3 needs FULL_OPENCV (exact); the shear B2 has no COLMAP model: fitted, and the error is said.
  const Camera<FraserAffine> k3(300.0, 199.5, 149.5, 400, 300, {-0.01, 0.001, 2e-4, 0.0, 0.0, 0.0, 0.0});
  const ConversionResult<ColmapCamera> full = colmap_camera_from_camera(k3, 1);
  CHECK(full.model.model == "FULL_OPENCV");
  CHECK(full.exact);
  CHECK(full.model.params[8] == 2e-4);
  const Camera<FraserAffine> shear(300.0, 199.5, 149.5, 400, 300, {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5});
  const ConversionResult<ColmapCamera> fitted = colmap_camera_from_camera(shear, 1);
  CHECK_FALSE(fitted.exact);
  CHECK(fitted.max_error_px > 0.01);
  // And back: the diachron camera of the OPENCV camera is the original.
  const Camera<FraserAffine> back = camera_from_colmap(a.model).model;
  CHECK(back.params() == p1_only.params());
  CHECK(back.cx() == p1_only.cx());
  CHECK(back.focal() == p1_only.focal());
}

TEST_CASE("colmap_text: every malformed file is an error naming the file and line", "[io][colmap]") {
  const std::string dir = colmap_folder("malformed");
  const ColmapModel model = sample_model();
  write_colmap_text(model, dir);
  const std::string cameras = read_file(dir + "/cameras.txt");
  const std::string images = read_file(dir + "/images.txt");
  const std::string points = read_file(dir + "/points3D.txt");
  const auto restore = [&] {
    write_file(dir + "/cameras.txt", cameras);
    write_file(dir + "/images.txt", images);
    write_file(dir + "/points3D.txt", points);
  };
  struct Case {
    const char* file;
    std::string text;
    std::string where;
    std::string what;
  };
  const std::string image_11 = "11 1 0 0 0 0 0 0 2 a.png\n";
  const std::vector<Case> cases = {
      {"cameras.txt", "# c\n1 PINHOLE 4 3 1 1 1 1\n2 FISHEYE 4 3 1 1 1\n", "cameras.txt' line 3", "unknown camera model 'FISHEYE'"},
      {"cameras.txt", "1 PINHOLE 4 3 1 1 1\n", "cameras.txt' line 1", "needs 4 params, found 3"},
      {"cameras.txt", "\n1 OPENCV 4 3 1 1 1 1 0 0 0 abc\n", "cameras.txt' line 2", "'abc' is not a finite number"},
      {"cameras.txt", "1 PINHOLE 4 3 1 1 1 1\n1 PINHOLE 4 3 1 1 1 1\n", "cameras.txt' line 2", "camera id 1 appears twice"},
      {"cameras.txt", "1 PINHOLE 0 3 1 1 1 1\n", "cameras.txt' line 1", "the width 0 is outside"},
      {"cameras.txt", "1 PINHOLE 4 3 1 1 1 nan\n", "cameras.txt' line 1", "not a finite number"},
      {"images.txt", "# i\n11 1 0 0 0 0 0 0 2\n\n", "images.txt' line 2", "needs 10 fields"},
      {"images.txt", "11 0 0 0 0 0 0 0 2 a.png\n\n", "images.txt' line 1", "quaternion"},
      {"images.txt", image_11 + "1 2 -1 3\n", "images.txt' line 2", "needs triples"},
      {"images.txt", image_11 + "1 2 x\n", "images.txt' line 2", "'x' is not an integer"},
      {"images.txt", image_11 + "1 2 -2\n", "images.txt' line 2", "POINT3D_ID -2 is outside"},
      {"images.txt", "# i\n" + image_11 + "\n" + image_11 + "\n", "images.txt' line 4", "image id 11 appears twice"},
      {"images.txt", "11 1 0 0 0 0 0 0 99 a.png\n\n", "images.txt' line 1", "camera 99"},
      {"points3D.txt", "7 1 2 3 0 0 0 0.5 11\n", "points3D.txt' line 1", "pairs"},
      {"points3D.txt", "7 1 2 3 300 0 0 0.5\n", "points3D.txt' line 1", "colour component 300 is outside"},
      {"points3D.txt", "# p\n7 1 2 3 0 0 0 0.5 99 0\n", "points3D.txt' line 2", "no image 99"},
      {"points3D.txt", "7 1 2 3 0 0 0 0.5 11 0\n", "points3D.txt' line 1", "that 2D point observes point3D -1"},
      {"points3D.txt", "7 1 2 3 0 0 0 0.5 11 50\n", "points3D.txt' line 1", "has 6 2D points"},
  };
  for (const Case& c : cases) {
    INFO(c.file << ":\n" << c.text);
    restore();
    write_file(dir + "/" + c.file, c.text);
    CHECK_THROWS_WITH(read_colmap_text(dir), Catch::Contains(c.where) && Catch::Contains(c.what));
  }
  // The 2D point says point 10, whose track (in points3D.txt) does not list it: images.txt names
  // the POINTS2D line.
  restore();
  std::string broken = images;
  const auto line = broken.find("\n11 ");
  REQUIRE(line != std::string::npos);
  const auto points_line = broken.find('\n', line + 1) + 1;
  const auto first_minus_one = broken.find(" -1", points_line);
  broken.replace(first_minus_one, 3, " 10");
  write_file(dir + "/images.txt", broken);
  const int expected_line = 1 + static_cast<int>(std::count(broken.begin(), broken.begin() + points_line, '\n'));
  CHECK_THROWS_WITH(read_colmap_text(dir), Catch::Contains("images.txt' line " + std::to_string(expected_line)) &&
                                               Catch::Contains("whose track does not contain it"));
  // A missing file names itself.
  restore();
  std::remove((dir + "/points3D.txt").c_str());
  CHECK_THROWS_WITH(read_colmap_text(dir), Catch::Contains("points3D.txt") && Catch::Contains("cannot be opened"));
}

TEST_CASE("colmap_text: inconsistent models and unsupported cameras are refused", "[io][colmap]") {
  ColmapModel model = sample_model();
  model.images.at(11).points2d.at(1).point3d_id = 99;
  CHECK_THROWS_WITH(write_colmap_text(model, colmap_folder("inconsistent")), Catch::Contains("point3D 99"));
  model = sample_model();
  model.images.at(11).name = "with space.png";
  CHECK_THROWS_WITH(write_colmap_text(model, colmap_folder("inconsistent")), Catch::Contains("white space"));
  const ColmapCamera fisheye{1, "OPENCV_FISHEYE", 10, 10, {1, 1, 5, 5, 0, 0, 0, 0}};
  CHECK_THROWS_WITH(camera_from_colmap(fisheye), Catch::Contains("OPENCV_FISHEYE"));
  const ColmapCamera short_params{1, "OPENCV", 10, 10, {1, 1, 5, 5}};
  CHECK_THROWS_AS(camera_from_colmap(short_params), Error);
}

TEST_CASE("colmap_text: COLMAP 3.8 reads our model, converts it to binary and back unchanged", "[io][colmap]") {
  const std::optional<std::string> colmap = test::colmap_binary();
  if (!colmap) {
    WARN("skipped: the colmap binary is not installed (scripts/install_deps.sh installs it; DIACHRON_COLMAP names it)");
    return;
  }
  const ColmapModel model = sample_model();
  const std::string text = colmap_folder("colmap_text"), binary = colmap_folder("colmap_bin"),
                    back = colmap_folder("colmap_back");
  write_colmap_text(model, text);
  const std::string log = text + "/colmap.log";
  const auto run = [&](const std::string& arguments) {
    const std::string command = "'" + *colmap + "' " + arguments + " > '" + log + "' 2>&1";
    INFO(command << "\n" << read_file(log));
    return std::system(command.c_str());
  };
  REQUIRE(run("model_converter --input_path '" + text + "' --output_path '" + binary + "' --output_type BIN") == 0);
  CHECK(test_file_exists(binary + "/images.bin"));
  REQUIRE(run("model_converter --input_path '" + binary + "' --output_path '" + back + "' --output_type TXT") == 0);
  const ColmapModel again = read_colmap_text(back);
  // COLMAP keeps doubles; the pose goes through its quaternion, so rounding only.
  check_same_model(model, again, 1e-14);

  REQUIRE(run("model_analyzer --path '" + text + "'") == 0);
  const std::string report = read_file(log);
  INFO(report);
  CHECK_THAT(report, Catch::Contains("Cameras: 6"));
  CHECK_THAT(report, Catch::Contains("Images: 4"));
  CHECK_THAT(report, Catch::Contains("Registered images: 4"));
  CHECK_THAT(report, Catch::Contains("Points: 4"));
  CHECK_THAT(report, Catch::Contains("Observations: 9"));
}
