// cameras.json: a round trip to the last bit, the layout the docs promise, and a precise message
// for every kind of bad file.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <diachron/core/random.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/json.hpp>

#include "support/temp_folder.hpp"

using namespace diachron;
using Catch::Matchers::Contains;

namespace {

namespace fs = std::filesystem;

std::string cameras_json_folder(const std::string& name) { return diachron::test::fresh_temp_folder("cameras_json_" + name); }

// Images with random (ugly) doubles everywhere, so that any loss of digits shows.
std::vector<CamerasJsonImage> random_images() {
  RandomStream rng(21, 0);
  std::vector<CamerasJsonImage> out;
  for (int i = 0; i < 5; ++i) {
    // One draw per statement, the last argument first (the parameters, cy, cx, f; then roll, pitch,
    // yaw, y, x): the order of a call's arguments is unspecified (core/random.hpp, "Order of draws").
    const Camera<FraserAffine>::Params params = {rng.uniform(-0.1, 0.1),   rng.uniform(-0.01, 0.01),
                                                 rng.uniform(-1e-3, 1e-3), rng.uniform(-1e-3, 1e-3),
                                                 rng.uniform(-1e-3, 1e-3), rng.uniform(-2.0, 2.0),
                                                 rng.uniform(-1.0, 1.0)};
    const double cy = rng.uniform(590.0, 610.0), cx = rng.uniform(790.0, 810.0);
    const Camera<FraserAffine> camera(rng.uniform(900.0, 1100.0), cx, cy, 1600, 1200, params);
    const double roll = rng.uniform(-0.05, 0.05), pitch = rng.uniform(-0.05, 0.05), yaw = rng.uniform(-3.0, 3.0);
    const double y = rng.uniform(4e6, 5e6);
    const Pose pose = Pose::from_yaw_pitch_roll(Vec3(rng.uniform(-1e5, 1e5), y, 1500.0 + i), yaw, pitch, roll);
    out.push_back(CamerasJsonImage::from_frame("e" + std::to_string(i % 2 + 1) + "_img \"" + std::to_string(i) + "\"",
                                               "e" + std::to_string(i % 2 + 1), Frame<FraserAffine>(camera, pose)));
  }
  return out;
}

std::string valid_text() {
  return R"({"images": [{"name": "a", "epoch": "e1",
    "camera": {"model": "fraser_affine", "width": 400, "height": 300, "f": 280, "cx": 199.5, "cy": 149.5,
               "k1": 0, "k2": 0, "k3": 0, "p1": 0, "p2": 0, "b1": 0, "b2": 0},
    "pose": {"R": [[1, 0, 0], [0, -1, 0], [0, 0, -1]], "C": [1, 2, 3]}}]})";
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

}  // namespace

TEST_CASE("cameras.json: written and read back to the last bit", "[io]") {
  const std::vector<CamerasJsonImage> images = random_images();
  const std::string path = cameras_json_folder("roundtrip") + "/cameras.json";
  write_cameras_json(images, path);
  const std::vector<CamerasJsonImage> back = read_cameras_json(path);
  REQUIRE(back.size() == images.size());
  for (std::size_t i = 0; i < images.size(); ++i) {
    CHECK(back[i].name == images[i].name);
    CHECK(back[i].epoch == images[i].epoch);
    CHECK(back[i].camera.focal() == images[i].camera.focal());
    CHECK(back[i].camera.cx() == images[i].camera.cx());
    CHECK(back[i].camera.cy() == images[i].camera.cy());
    CHECK(back[i].camera.width() == 1600);
    CHECK(back[i].camera.height() == 1200);
    CHECK(back[i].camera.params() == images[i].camera.params());
    CHECK(back[i].rotation == images[i].rotation);
    CHECK(back[i].centre == images[i].centre);
    // The frame projects as the source.
    const Vec3 ground = images[i].centre + images[i].rotation.transpose() * Vec3(30.0, -20.0, 1400.0);
    CHECK((*back[i].frame().project(ground) - *images[i].frame().project(ground)).norm() < 1e-9);
  }
  // Writing what was read gives the same text.
  CHECK(cameras_json(back) == cameras_json(images));
}

TEST_CASE("cameras.json: the layout of the docs (keys, model, nested R)", "[io]") {
  const JsonValue root = parse_json(cameras_json(random_images()), "t");
  const JsonValue& image = root.find("images")->array.at(0);
  for (const char* key : {"name", "epoch", "camera", "pose"}) CHECK(image.find(key));
  const JsonValue& camera = *image.find("camera");
  CHECK(camera.find("model")->string == "fraser_affine");
  for (const char* key : {"width", "height", "f", "cx", "cy", "k1", "k2", "k3", "p1", "p2", "b1", "b2"})
    CHECK(camera.find(key)->type == JsonValue::Type::number);
  const JsonValue& r = *image.find("pose")->find("R");
  REQUIRE(r.array.size() == 3);
  CHECK(r.array[2].array.size() == 3);
  CHECK(image.find("pose")->find("C")->array.size() == 3);
  // The params are Fraser + affine's in the policy's order: k1 is params[0], b2 params[6].
  const CamerasJsonImage first = random_images()[0];
  CHECK(camera.find("k1")->number == first.camera.params()[0]);
  CHECK(camera.find("p1")->number == first.camera.params()[3]);
  CHECK(camera.find("b2")->number == first.camera.params()[6]);
  // An empty list is valid too.
  CHECK(parse_cameras_json(cameras_json({}), "t").empty());
}

TEST_CASE("cameras.json: bad files name the file and the key", "[io]") {
  REQUIRE(parse_cameras_json(valid_text(), "v").size() == 1);
  const auto error_of = [](const std::string& text) {
    try {
      parse_cameras_json(text, "'x/cameras.json'");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string t = valid_text();
  CHECK_THAT(error_of(replaced(t, "\"k2\": 0, ", "")), Contains("'x/cameras.json': images[0].camera.k2: missing"));
  CHECK_THAT(error_of(replaced(t, "\"f\": 280", "\"f\": \"280\"")), Contains("images[0].camera.f: is of type string, expected number"));
  CHECK_THAT(error_of(replaced(t, "\"k3\": 0", "\"k3\": 1e999")), Contains("images[0].camera.k3: is not a finite number"));
  CHECK_THAT(error_of(replaced(t, "\"C\": [1, 2, 3]", "\"C\": [1, 2]")), Contains("images[0].pose.C: needs 3 numbers"));
  CHECK_THAT(error_of(replaced(t, "[0, 0, -1]", "[0, 0, 1]")), Contains("images[0].pose.R: is not a rotation"));
  CHECK_THAT(error_of(replaced(t, "[0, -1, 0]", "[0, -1]")), Contains("images[0].pose.R[1]: needs 3 numbers"));
  CHECK_THAT(error_of(replaced(t, "fraser_affine", "OPENCV")), Contains("images[0].camera.model: is \"OPENCV\""));
  CHECK_THAT(error_of(replaced(t, "\"width\": 400", "\"width\": 400.5")), Contains("images[0].camera.width"));
  CHECK_THAT(error_of(replaced(t, "\"f\": 280", "\"f\": -280")), Contains("images[0].camera: is not a valid camera"));
  CHECK_THAT(error_of(replaced(t, "\"epoch\": \"e1\"", "\"epoch\": 1")), Contains("images[0].epoch: is of type number"));
  CHECK_THAT(error_of(replaced(t, "\"pose\"", "\"Pose\"")), Contains("images[0].pose: missing"));
  CHECK_THAT(error_of("{\"imgs\": []}"), Contains("images: missing"));
  CHECK_THAT(error_of("[1]"), Contains("the top level: is of type array"));
  CHECK_THAT(error_of("{\"images\": [1,]}"), Contains("'x/cameras.json': line 1"));
  CHECK_THROWS_WITH(read_cameras_json("/nonexistent/cameras.json"), Contains("/nonexistent/cameras.json"));
  // Writing checks first and leaves no file behind.
  std::vector<CamerasJsonImage> bad = random_images();
  bad[1].centre.x() = std::nan("");
  const std::string path = cameras_json_folder("bad") + "/cameras.json";
  CHECK_THROWS_WITH(write_cameras_json(bad, path), Contains("image 1"));
  CHECK_FALSE(fs::exists(path));
}
