// Round trip of a synthetic scene through its folder layout (an SfM's COLMAP model per epoch, the
// truth apart), the COLMAP model's conventions, and the errors that name the file.

#include <algorithm>
#include <cmath>
#include <cstdint>
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
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#ifdef DIACHRON_HAVE_GDAL
#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/helmert_json.hpp>
#include <diachron/synth/full_size_scan.hpp>
#include <diachron/synth/scene_io.hpp>

#include "support/colmap_binary.hpp"
#include "support/colmap_projection.hpp"
#include "support/rasters.hpp"
#include "support/scenes.hpp"
#include "support/temp_folder.hpp"
#endif

using namespace diachron;

#ifdef DIACHRON_HAVE_GDAL

namespace {

std::string temp_folder(const std::string& name) { return diachron::test::temp_path("synth_" + name); }

void check_pose(const Pose& a, const Pose& b) {
  CHECK((a.cam_from_world_rotation() - b.cam_from_world_rotation()).cwiseAbs().maxCoeff() < 1e-14);
  CHECK((a.centre() - b.centre()).norm() == 0.0);
}

// A pose that went through COLMAP's quaternion and translation: rounding only.
void check_pose_via_colmap(const Pose& a, const Pose& b) {
  CHECK((a.cam_from_world_rotation() - b.cam_from_world_rotation()).cwiseAbs().maxCoeff() < 1e-15);
  CHECK((a.centre() - b.centre()).norm() < 1e-12 * (1.0 + a.centre().norm()));
}

void check_camera(const Camera<FraserAffine>& a, const Camera<FraserAffine>& b) {
  CHECK(a.intrinsics() == b.intrinsics());
  CHECK(a.width() == b.width());
  CHECK(a.height() == b.height());
}

// A camera that went through COLMAP's OPENCV parameters (f + B1, principal point + 0.5): rounding only.
void check_camera_via_colmap(const Camera<FraserAffine>& a, const Camera<FraserAffine>& b) {
  for (std::size_t k = 0; k < a.intrinsics().size(); ++k)
    CHECK(std::abs(a.intrinsics()[k] - b.intrinsics()[k]) <= 1e-13 * (1.0 + std::abs(a.intrinsics()[k])));
  CHECK(a.width() == b.width());
  CHECK(a.height() == b.height());
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// Generated once for all test cases (the sanitizer build runs them too).
const Scene& io_small_scene() {
  static const Scene scene = generate_scene(diachron::test::small_scene_options(21, 80, 20));
  return scene;
}

}  // namespace

TEST_CASE("write_scene then read_scene gives the same scene", "[synth][io]") {
  const Scene& scene = io_small_scene();
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
    check_camera_via_colmap(a.estimated_camera, b.estimated_camera);
    REQUIRE(a.images.size() == b.images.size());
    for (std::size_t i = 0; i < a.images.size(); ++i) {
      CHECK(a.images[i].name == b.images[i].name);
      CHECK(a.images[i].row == b.images[i].row);
      CHECK(a.images[i].column == b.images[i].column);
      CHECK(std::equal(a.images[i].pixels.begin(), a.images[i].pixels.end(), b.images[i].pixels.begin()));
      check_pose(a.images[i].pose_world, b.images[i].pose_world);
      check_pose(a.images[i].pose_epoch, b.images[i].pose_epoch);
      check_pose_via_colmap(a.images[i].estimated_pose, b.images[i].estimated_pose);
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
        CHECK((a.tie_points[k].observations[o].pixel - b.tie_points[k].observations[o].pixel).norm() < 1e-12);
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

TEST_CASE("write_scene: full-size scans come from the write_image callback and read back", "[synth][io]") {
  // The small scene delivered twice as large (make_scene --scan-px): images made by
  // FullSizeEpochRenderer one at a time, the scaled truth and models beside them.
  const SceneOptions options = diachron::test::small_scene_options(21, 80, 20);
  Scene scene = io_small_scene();
  scale_scene_images(scene, 2.0);
  FullSizeScanOptions scan;
  scan.scale = 2.0;
  std::vector<Raster<std::uint8_t>> written;
  SceneWriteOptions write;
  write.write_image = [&](std::size_t e, std::size_t i, const std::string& path) {
    const FullSizeEpochRenderer renderer(scene, e, options.epochs[e].look, scan);
    written.push_back(renderer.render(i));
    write_image_u8(written.back(), path);
  };
  const std::string dir = temp_folder("full_size");
  write_scene(scene, dir, write);
  REQUIRE(written.size() == 4);
  const Scene back = read_scene(dir);
  std::size_t k = 0;
  for (std::size_t e = 0; e < scene.epochs.size(); ++e) {
    check_camera(scene.epochs[e].camera, back.epochs[e].camera);
    CHECK(back.epochs[e].camera.width() == 2 * io_small_scene().epochs[e].camera.width());
    check_camera_via_colmap(scene.epochs[e].estimated_camera, back.epochs[e].estimated_camera);
    CHECK(back.epochs[e].gsd_m == scene.epochs[e].gsd_m);
    for (std::size_t i = 0; i < scene.epochs[e].images.size(); ++i, ++k) {
      const Raster<std::uint8_t>& b = back.epochs[e].images[i].pixels;
      REQUIRE(b.width() == written[k].width());
      CHECK(std::equal(b.begin(), b.end(), written[k].begin()));
    }
    for (std::size_t t = 0; t < scene.epochs[e].tie_points.size(); ++t)
      CHECK((back.epochs[e].tie_points[t].observations.front().pixel -
             scene.epochs[e].tie_points[t].observations.front().pixel).norm() < 1e-12);
  }
  REQUIRE(back.check_points.size() == scene.check_points.size());
  for (std::size_t c = 0; c < scene.check_points.size(); ++c)
    CHECK(back.check_points[c].observations.front().pixel == scene.check_points[c].observations.front().pixel);
}

TEST_CASE("write_scene: each epoch folder holds what its SfM delivers, the truth is apart", "[synth][io]") {
  const Scene& scene = io_small_scene();
  const std::string dir = temp_folder("layout");
  write_scene(scene, dir);
  CHECK(folder_entries(dir) == std::vector<std::string>{"e1", "e2", "truth"});
  CHECK(folder_entries(dir + "/truth") == std::vector<std::string>{"e1_albedo.tif", "e1_true_surface.tif", "e2_albedo.tif",
                                                                    "e2_true_surface.tif", "scene.txt"});
  for (const SyntheticEpoch& epoch : scene.epochs) {
    const std::string folder = dir + "/" + epoch.name;
    CHECK(folder_entries(folder) ==
          std::vector<std::string>{"cameras.txt", "dsm.tif", "images", "images.txt", "points3D.txt"});
    std::vector<std::string> pngs;
    for (const SyntheticImage& image : epoch.images) pngs.push_back(image.name + ".png");
    std::sort(pngs.begin(), pngs.end());
    CHECK(folder_entries(folder + "/images") == pngs);

    // The model holds the estimated camera and poses, the tie points as tracks: every observation
    // is where COLMAP's own formula puts the estimated projection (+0.5 px), up to the tie noise.
    const ColmapModel model = read_colmap_text(folder);
    REQUIRE(model.cameras.size() == 1);
    const ColmapCamera& camera = model.cameras.begin()->second;
    CHECK(camera.model == "OPENCV");
    CHECK(model.images.size() == epoch.images.size());
    CHECK(model.points3d.size() == epoch.tie_points.size());
    std::istringstream images_txt(read_text(folder + "/images.txt"));
    std::string line;
    int compared = 0;
    while (std::getline(images_txt, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream fields(line);
      std::uint32_t id = 0;
      Eigen::Vector4d q;
      Eigen::Vector3d t;
      fields >> id >> q[0] >> q[1] >> q[2] >> q[3] >> t[0] >> t[1] >> t[2];
      std::getline(images_txt, line);
      const ColmapImage& image = model.images.at(id);
      const std::size_t index = static_cast<std::size_t>(
          std::find_if(epoch.images.begin(), epoch.images.end(),
                       [&](const SyntheticImage& i) { return i.name + ".png" == image.name; }) -
          epoch.images.begin());
      REQUIRE(index < epoch.images.size());
      for (const ColmapPoint2D& p : image.points2d) {
        const Vec3 xyz = model.points3d.at(static_cast<std::uint64_t>(p.point3d_id)).xyz;
        const Vec2 colmap = test::colmap_projection(camera.model, camera.params, q, t, xyz);
        const std::optional<Vec2> ours = epoch.estimated_frame(index).project(xyz);
        REQUIRE(ours);
        CHECK((*ours - (colmap - Vec2(0.5, 0.5))).norm() < 1e-8);
        // The recorded observation is the true projection plus 0.3 px noise, off the estimated one
        // by the camera error (under 3 px here).
        CHECK((p.xy - colmap).norm() < 3.0);
        ++compared;
      }
    }
    std::size_t observations = 0;
    for (const TiePoint& tie : epoch.tie_points) observations += tie.observations.size();
    CHECK(static_cast<std::size_t>(compared) == observations);
  }
}

TEST_CASE("write_scene: COLMAP 3.8 opens each epoch folder as a model", "[synth][io]") {
  const std::optional<std::string> colmap = test::colmap_binary();
  if (!colmap) {
    WARN("skipped: the colmap binary is not installed (scripts/install_deps.sh --peers installs it)");
    return;
  }
  const Scene& scene = io_small_scene();
  const std::string dir = temp_folder("colmap");
  write_scene(scene, dir);
  for (const SyntheticEpoch& epoch : scene.epochs) {
    const std::string log = dir + "/" + epoch.name + "_analyzer.log";
    const std::string command = "'" + *colmap + "' model_analyzer --path '" + dir + "/" + epoch.name + "' > '" + log + "' 2>&1";
    REQUIRE(std::system(command.c_str()) == 0);
    const std::string report = read_text(log);
    INFO(report);
    std::size_t observations = 0;
    for (const TiePoint& tie : epoch.tie_points) observations += tie.observations.size();
    CHECK_THAT(report, Catch::Contains("Cameras: 1"));
    CHECK_THAT(report, Catch::Contains("Registered images: " + std::to_string(epoch.images.size())));
    CHECK_THAT(report, Catch::Contains("Points: " + std::to_string(epoch.tie_points.size())));
    CHECK_THAT(report, Catch::Contains("Observations: " + std::to_string(observations)));
  }
}

TEST_CASE("read_scene names the file and line it cannot read", "[synth][io]") {
  CHECK_THROWS_WITH(read_scene(temp_folder("missing")), Catch::Contains("truth/scene.txt"));

  const Scene& scene = io_small_scene();
  const std::string dir = temp_folder("broken");
  write_scene(scene, dir);
  const std::string truth = dir + "/truth/scene.txt";
  const std::string text = read_text(truth);
  {
    // A camera line with a word where a number belongs.
    std::string broken = text;
    const auto at = broken.find("\ncamera ");
    REQUIRE(at != std::string::npos);
    broken.insert(at + 8, "oops ");
    std::ofstream(truth) << broken;
    CHECK_THROWS_WITH(read_scene(dir), Catch::Contains("scene.txt' line") && Catch::Contains("camera"));
  }
  {
    // A missing image file.
    std::ofstream(truth) << text;
    const std::string image = dir + "/e1/images/" + scene.epochs[0].images[0].name + ".png";
    REQUIRE(std::remove(image.c_str()) == 0);
    CHECK_THROWS_WITH(read_scene(dir), Catch::Contains(scene.epochs[0].images[0].name + ".png"));
    write_scene(scene, dir);
  }
  {
    // A truncated file.
    std::ofstream(truth) << text.substr(0, text.size() / 2);
    CHECK_THROWS_AS(read_scene(dir), Error);
    std::ofstream(truth) << text;
  }
  {
    // A broken COLMAP model: its file and line.
    const std::string images = dir + "/e2/images.txt";
    const std::string original = read_text(images);
    std::string broken = original;
    const auto first_record = broken.find("\n1 ") + 1;
    broken.insert(first_record, "x");
    std::ofstream(images) << broken;
    CHECK_THROWS_WITH(read_scene(dir), Catch::Contains("e2/images.txt' line 5") && Catch::Contains("'x1'"));
    // An image of the truth that the model does not have.
    broken = original;
    const auto name = broken.find(scene.epochs[1].images[1].name);
    REQUIRE(name != std::string::npos);
    broken.replace(name, 2, "zz");
    std::ofstream(images) << broken;
    CHECK_THROWS_WITH(read_scene(dir), Catch::Contains("e2/images.txt' has no image '" + scene.epochs[1].images[1].name));
    std::ofstream(images) << original;
  }
  {
    // A folder of the old single-folder layout says so.
    const std::string old = temp_folder("old_layout");
    ::mkdir(old.c_str(), 0755);
    std::ofstream(old + "/scene.txt") << "diachron-synthetic-scene 1\n";
    CHECK_THROWS_WITH(read_scene(old), Catch::Contains("old single-folder layout"));
  }
  // An epoch may not take the truth folder's name.
  Scene renamed = scene;
  renamed.epochs[0].name = "truth";
  CHECK_THROWS_WITH(write_scene(renamed, temp_folder("renamed")), Catch::Contains("'truth'"));
  CHECK_NOTHROW(read_scene(dir));
}

TEST_CASE("read_epoch_folder reads what write_scene wrote, and names what is missing", "[synth][io]") {
  const Scene& scene = io_small_scene();
  const std::string dir = temp_folder("epoch_folder");
  write_scene(scene, dir);
  for (std::size_t e = 0; e < scene.epochs.size(); ++e) {
    const SyntheticEpoch& epoch = scene.epochs[e];
    const EpochFolder folder = read_epoch_folder(dir + "/" + epoch.name);
    REQUIRE(folder.images.size() == epoch.images.size());
    CHECK(diachron::test::same_values(folder.dsm.heights(), epoch.dsm.heights()));
    for (std::size_t i = 0; i < epoch.images.size(); ++i) {
      const EpochImage& image = folder.images[i];
      CHECK(image.name == epoch.images[i].name + ".png");
      CHECK(folder.find(image.name) == i);
      CHECK(image.conversion_error_px == 0.0);
      check_camera_via_colmap(image.frame.camera(), epoch.estimated_camera);
      check_pose_via_colmap(image.frame.pose(), epoch.images[i].estimated_pose);
      const Raster<std::uint8_t> pixels = folder.load_image(i);
      CHECK(std::equal(pixels.begin(), pixels.end(), epoch.images[i].pixels.begin()));
    }
    CHECK(folder.find("nothing.png") == folder.images.size());
  }
  const std::string e1 = dir + "/" + scene.epochs[0].name;
  const std::string missing = e1 + "/images/" + scene.epochs[0].images[1].name + ".png";
  REQUIRE(std::rename(missing.c_str(), (missing + ".away").c_str()) == 0);
  CHECK_THROWS_WITH(read_epoch_folder(e1), Catch::Contains("image '" + scene.epochs[0].images[1].name + ".png'") &&
                                               Catch::Contains("missing from images/"));
  REQUIRE(std::rename((missing + ".away").c_str(), missing.c_str()) == 0);
  CHECK_THROWS_WITH(read_epoch_folder(dir + "/nowhere"), Catch::Contains("does not exist"));
  {
    // A camera model diachron does not hold stops the read, naming it.
    const std::string cameras = e1 + "/cameras.txt";
    const std::string original = read_text(cameras);
    std::string broken = original;
    const auto at = broken.find("OPENCV");
    REQUIRE(at != std::string::npos);
    broken.replace(at, 6, "OPENCV_FISHEYE");
    std::ofstream(cameras) << broken;
    CHECK_THROWS_WITH(read_epoch_folder(e1), Catch::Contains("OPENCV_FISHEYE"));
    std::ofstream(cameras) << original;
  }
  CHECK_NOTHROW(read_epoch_folder(e1));
  {
    // A colour photo (the modern epoch's usual kind) is read as its grey: the image written again as
    // RGB with three equal bands loads as the same pixels.
    const EpochFolder folder = read_epoch_folder(e1);
    const Raster<std::uint8_t> grey = folder.load_image(0);
    const cv::Mat g(grey.height(), grey.width(), CV_8UC1, const_cast<std::uint8_t*>(grey.data()));
    cv::Mat bgr;
    cv::merge(std::vector<cv::Mat>{g, g, g}, bgr);
    REQUIRE(cv::imwrite(folder.images[0].path, bgr));
    const Raster<std::uint8_t> back = folder.load_image(0);
    CHECK(std::equal(back.begin(), back.end(), grey.begin()));
  }
  {
    // Masks, COLMAP's way: masks/<image name>.png for the images that have one, read as written;
    // one of another size than its camera is an error naming it.
    CHECK(read_epoch_folder(e1).masks() == 0);
    CHECK(read_epoch_folder(e1).load_mask(0).empty());
    const std::string name = scene.epochs[0].images[1].name + ".png";
    make_folder(e1 + "/masks", "test");
    const Raster<std::uint8_t> written = diachron::test::uniform_noise_image(
        scene.epochs[0].camera.width(), scene.epochs[0].camera.height(), 11);
    write_image_u8(written, e1 + "/masks/" + name + ".png");
    const EpochFolder folder = read_epoch_folder(e1);
    CHECK(folder.masks() == 1);
    CHECK(folder.images[0].mask_path.empty());
    CHECK(folder.images[1].mask_path == e1 + "/masks/" + name + ".png");
    const Raster<std::uint8_t> mask = folder.load_mask(1);
    CHECK(std::equal(mask.begin(), mask.end(), written.begin(), written.end()));
    write_image_u8(Raster<std::uint8_t>(7, 5, 255), e1 + "/masks/" + name + ".png");
    CHECK_THROWS_WITH(folder.load_mask(1), Catch::Contains("mask '" + e1 + "/masks/" + name + ".png' is 7 x 5 px"));
    // MicMac's name, beside the image, where COLMAP's is missing; COLMAP's first where both are.
    const std::string micmac = e1 + "/images/" + scene.epochs[0].images[0].name + "_Masq.tif";
    write_image_u8(written, micmac);
    const std::string micmac1 = e1 + "/images/" + scene.epochs[0].images[1].name + "_Masq.tif";
    write_image_u8(written, micmac1);
    const EpochFolder both = read_epoch_folder(e1);
    CHECK(both.masks() == 2);
    CHECK(both.images[0].mask_path == micmac);
    CHECK(both.images[1].mask_path == e1 + "/masks/" + name + ".png");
    const Raster<std::uint8_t> from_micmac = both.load_mask(0);
    CHECK(std::equal(from_micmac.begin(), from_micmac.end(), written.begin(), written.end()));
    REQUIRE(std::remove(micmac.c_str()) == 0);
    REQUIRE(std::remove(micmac1.c_str()) == 0);
    REQUIRE(std::remove((e1 + "/masks/" + name + ".png").c_str()) == 0);
  }

  // The Helmert file of the programs reads back to the same doubles, and rejects what is not one.
  const Helmert3 h = scene.epoch2_from_epoch1();
  const std::string json = dir + "/helmert.json";
  write_helmert_json(h, json);
  const Helmert3 back = read_helmert_json(json);
  CHECK(back.scale == h.scale);
  CHECK(back.rotation == h.rotation);
  CHECK(back.translation == h.translation);
  std::ofstream(json) << "{\"scale\": 2, \"rotation\": [[1, 0, 0], [0, 1, 0], [0, 0, 2]], \"translation\": [0, 0, 0]}";
  CHECK_THROWS_WITH(read_helmert_json(json), Catch::Contains("not a rotation matrix"));
  std::ofstream(json) << "{\"scale\": 1, \"rotation\": [[1, 0, 0], [0, 1, 0]], \"translation\": [0, 0, 0]}";
  CHECK_THROWS_WITH(read_helmert_json(json), Catch::Contains("9 rotation"));
  CHECK_THROWS_WITH(read_helmert_json(dir + "/none.json"), Catch::Contains("no such file"));
}

#else

TEST_CASE("scene_io needs GDAL", "[synth][io]") { WARN("skipped: built without GDAL"); }

#endif
